"""Headline figures over several sampling seeds, with 95 % intervals and paired differences.

The isolation rows are fixed; what changes with the seed is the RUL sampling of the
methods that sample (`rul.prognose`'s posterior-predictive draws; the straight line has
none, so its seeds are one scoring).  Each figure is the mean over SEEDS of the figure of
one seed's scoring of the held-out trajectories.  Its 95 % interval is a percentile
bootstrap over trajectories (BOOT resamples of the held-out trajectories with
replacement, the same resample for every method and seed, so a paired difference keeps
its pairing): it holds the spread from which lives happened to be drawn, which is far
larger than the spread over seeds (shown as the range of the per-seed figures).

Coverage is given two ways: conditional on a RUL (the windows that gave one) and over
every counted window before the end of life (a window without a RUL counts as not
holding the truth), and the latter also from lambda 0.5 on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from bench.prog.compare import Scored, history_metrics, warned

#: Sampling seeds of the prognosis averaged over.
SEEDS = (0, 1, 2)
#: Bootstrap resamples of the trajectories.
BOOT = 2000
#: Seed of the bootstrap's resampling.
BOOT_SEED = 20261128


@dataclass(frozen=True)
class TrajectoryNumbers:
    """One trajectory's per-history numbers under one method and seed."""

    ph: list[float]
    ph_stays: list[float]
    al50: list[bool]
    al75: list[bool]
    covered: int
    with_rul: int
    windows: int
    covered_late: int
    windows_late: int
    still_warn: int
    still: int


def trajectory_numbers(s: Scored) -> TrajectoryNumbers:
    hist = [history_metrics(s.points[n], eol) for n, eol in s.eol.items()]
    hist = [h for h in hist if "ph" in h]
    late_cov = late_n = 0
    for name, eol in s.eol.items():
        before = [p for p in s.points[name] if p.cycle < eol]
        if not before:
            continue
        t_half = before[0].cycle + 0.5 * (eol - before[0].cycle)
        late = [p for p in before if p.cycle >= t_half]
        late_n += len(late)
        late_cov += sum(p.degrading and p.p5 <= eol - p.cycle <= p.p95 for p in late)
    still = [p for n, p in s.points.items() if n not in s.eol] if s.kind != "healthy" else []
    return TrajectoryNumbers(
        ph=[h["ph"] for h in hist],
        ph_stays=[h["ph_stays"] for h in hist],
        al50=[h.get("al50") is True for h in hist],
        al75=[h.get("al75") is True for h in hist],
        covered=sum(h["covered"][0] for h in hist),
        with_rul=sum(h["covered"][1] for h in hist),
        windows=sum(h["predictions"] for h in hist),
        covered_late=late_cov,
        windows_late=late_n,
        still_warn=sum(bool(warned(p)) for p in still),
        still=len(still),
    )


def _interval(draws: np.ndarray) -> tuple[float, float]:
    """The 95 % percentile interval of bootstrap `draws` (nan, nan when none is a number)."""
    if not np.isfinite(draws).any():
        return math.nan, math.nan
    lo, hi = np.nanpercentile(draws, [2.5, 97.5])
    return float(lo), float(hi)


def _median(xs: list[float]) -> float:
    return float(np.median(xs)) if xs else math.nan


def _ratio(n: int, d: int) -> float:
    return n / d if d else math.nan


#: (label, figure of a list of trajectories) of the headline figures.
FIGURES: tuple[tuple[str, Callable[[list[TrajectoryNumbers]], float]], ...] = (
    ("prognostic horizon, median share of life", lambda t: _median([x for a in t for x in a.ph])),
    ("PH (stays), median share of life", lambda t: _median([x for a in t for x in a.ph_stays])),
    (
        "alpha-lambda at lambda 0.5",
        lambda t: _ratio(sum(sum(a.al50) for a in t), sum(len(a.al50) for a in t)),
    ),
    (
        "alpha-lambda at lambda 0.75",
        lambda t: _ratio(sum(sum(a.al75) for a in t), sum(len(a.al75) for a in t)),
    ),
    (
        "90 % coverage, windows with a RUL",
        lambda t: _ratio(sum(a.covered for a in t), sum(a.with_rul for a in t)),
    ),
    (
        "90 % coverage, every window (no RUL = miss)",
        lambda t: _ratio(sum(a.covered for a in t), sum(a.windows for a in t)),
    ),
    (
        "90 % coverage, every window from lambda 0.5",
        lambda t: _ratio(sum(a.covered_late for a in t), sum(a.windows_late for a in t)),
    ),
    (
        "RUL WARN on faults that do not grow",
        lambda t: _ratio(sum(a.still_warn for a in t), sum(a.still for a in t)),
    ),
)


def table(
    by_method: dict[str, dict[int, list[Scored]]],
    labels: dict[str, str],
    pairs: list[tuple[str, str]],
    keep: Callable[[Scored], bool],
) -> list[str]:
    """Markdown lines: each method's mean over seeds [95 % CI], then each pair's difference.

    Per figure, each method's mean over its seeds [95 % CI] (range over seeds), then each
    pair's paired difference [95 % CI].

    `by_method[name][seed]`: that method's scoring at that seed (one entry: no sampling);
    `keep`: the trajectories reported (the held-out half).
    """
    names = list(by_method)
    ref = next(iter(next(iter(by_method.values())).values()))
    idx = [i for i, s in enumerate(ref) if keep(s)]
    per = {
        m: {seed: [trajectory_numbers(sc[i]) for i in idx] for seed, sc in by_method[m].items()}
        for m in names
    }
    rng = np.random.default_rng(BOOT_SEED)
    draws = rng.integers(0, len(idx), size=(BOOT, len(idx)))
    head = "| figure | " + " | ".join(labels[m] for m in names)
    head += " | " + " | ".join(f"{labels[a]} - {labels[b]}" for a, b in pairs) + " |"
    lines = [head, "|---|" + "---:|" * (len(names) + len(pairs))]
    for label, fig in FIGURES:
        mean: dict[str, float] = {}
        boot: dict[str, np.ndarray] = {}
        cells = []
        for m in names:
            seeds = per[m]
            vals = [fig(t) for t in seeds.values()]
            mean[m] = float(np.mean(vals))
            boot[m] = np.array(
                [np.mean([fig([t[j] for j in d]) for t in seeds.values()]) for d in draws]
            )
            lo, hi = _interval(boot[m])
            spread = f" (seeds {min(vals):.0%}-{max(vals):.0%})" if len(vals) > 1 else ""
            cells.append(f"{mean[m]:.0%} [{lo:.0%}, {hi:.0%}]{spread}")
        for a, b in pairs:
            d = boot[a] - boot[b]
            lo, hi = _interval(d)
            cells.append(f"{mean[a] - mean[b]:+.0%} [{lo:+.0%}, {hi:+.0%}]")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def section(
    by_method: dict[str, dict[int, list[Scored]]],
    labels: dict[str, str],
    pairs: list[tuple[str, str]],
) -> list[str]:
    """The report's section: what was averaged, how the intervals were made, the table."""
    used = sorted({seed for v in by_method.values() for seed in v})
    return [
        "",
        "## Headline figures over seeds, with 95 % intervals (held out)",
        "",
        f"Each figure is the mean over {len(used)} sampling seeds of the prognosis "
        f"({', '.join(str(s) for s in used)}; the isolation rows are the same, and the "
        "straight line does not sample), on the held-out (odd) trajectories.  In brackets "
        f"the 95 % interval: percentile bootstrap over trajectories ({BOOT} resamples, the "
        "same ones for every method, so the differences are paired); in parentheses the "
        "range of the per-seed figures.  'every window' coverage counts a window without a "
        "RUL as not holding the truth.  'no fleet history' is `rul.prognose` with "
        "`growth_priors={}` (`--growth-priors none`).",
        "",
        *table(by_method, labels, pairs, keep=lambda s: s.index % 2 == 1),
    ]


def as_dict(by_method: dict[str, dict[int, list[Scored]]]) -> dict[str, Any]:
    """How many scorings went in (for the record)."""
    return {m: sorted(v) for m, v in by_method.items()}
