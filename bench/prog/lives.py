"""The tuning half's fault lives, as a fleet would hold them: estimates up to each failure.

Each even-numbered degrading trajectory gives, per fault it grows, the estimate history the
live monitor would have kept (`monitor.policy.FitPolicy.count`: explained windows only) over
the cycles before the fault's true end of life.  `ema_phm.prognostics.learn` learns the
growth priors from them; the odd-numbered (held-out) trajectories are never read.
"""

from __future__ import annotations

from bench.prog.compare import fitted_row, windows_by_trajectory
from ema_phm.domain.faults import NAMES
from ema_phm.monitor.policy import FitPolicy
from ema_phm.prognostics.rul import History

#: Fewest counted estimates a life needs to be learned from.
MIN_ESTIMATES = 5


def counted_history(windows: list[dict]) -> History | None:
    """The history the monitor's policy keeps of `windows` (None: nothing counted)."""
    policy = FitPolicy()
    for w in sorted(windows, key=lambda w: w["cycle"]):
        if "k" in w:
            policy.count(int(w["cycle"]), fitted_row(w), prognose=False)
    return policy.estimates.history() if len(policy.estimates) else None


def lives_by_trajectory(data: dict) -> dict[int, list[tuple[str, History, int]]]:
    """Per trajectory index, the lives of the faults it grows to failure.

    Each life: (fault name, estimate history before its true end of life, k index).
    """
    by_t = windows_by_trajectory(data)
    out: dict[int, list[tuple[str, History, int]]] = {}
    for tr in data["plan"]:
        if tr["index"] not in by_t:
            continue
        for name, eol in tr["true_eol"].items():
            if eol is None:
                continue
            hist = counted_history([w for w in by_t[tr["index"]] if w["cycle"] < eol])
            if hist is not None and hist.n >= MIN_ESTIMATES:
                out.setdefault(tr["index"], []).append((name, hist, NAMES.index(name)))
    return out


def tuning_lives(data: dict, parity: int = 0) -> list[tuple[str, History, int]]:
    """(fault name, estimate history before its true end of life, k index) of one half."""
    return [life for t, ls in lives_by_trajectory(data).items() if t % 2 == parity for life in ls]
