"""Self-commissioning of the live monitor from its first windows, and its guard.

Without a unit file the monitor keeps its first `windows` fitted windows as healthy
baselines and commissions itself from them (`diagnosis.commissioning.commission`) against
the belief it was given (an actuator file's, else the packaged one).  Not silently:

- when `commissioning.review` speaks against the baselines, or the commissioned fit does
  not explain the unit (`CommissioningResult.unexplained`: its model error far above the
  belief's expected healthy level), nothing is adopted: the uncommissioned belief judges
  the later windows and the reasons stand as warnings (a WARN status, ``unit_warnings``);
- a factor that ran to a search bound is adopted at 1 or at the bound as commissioning
  leaves it, and named the same way (WARN).

No lock of its own: `HealthMonitor` runs `keep` from its worker and `restart` under its lock.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

from ..diagnosis.commissioning import CommissioningResult, StartCheck, commission, review
from ..diagnosis.isolation_settings import IsolationSettings
from ..domain.window import Window
from ..model.belief import MonitorBelief


@dataclass(frozen=True)
class Kept:
    """What keeping one baseline decided: a status kind, its detail and the log severity."""

    kind: str  # commissioning, commissioning_warning or commissioning_refused
    detail: str
    severity: str = "info"


class CommissioningGuard:
    """The baselines kept so far, and the belief commissioned from them (or refused)."""

    def __init__(self, windows: int) -> None:
        """Commission from the first `windows` windows (0: use the belief as given)."""
        self.windows = windows
        self.commissioned: MonitorBelief | None = None
        self.report: dict[str, Any] | None = None
        #: why the monitor did not commission itself, or what speaks against its commissioning
        self.warnings: list[str] = []
        self._baselines: list[Window] = []

    @property
    def active(self) -> bool:
        """True while windows are kept as baselines instead of being assessed."""
        return self.commissioned is None and len(self._baselines) < self.windows

    def belief(self, settings: IsolationSettings) -> MonitorBelief | None:
        """The belief to fit with: the unit file's, else the commissioned one, else the given.

        None: the packaged one.
        """
        if settings.unit_file or self.commissioned is None:
            return settings.belief
        return self.commissioned

    def restart(self, windows: int) -> None:
        """Commission again from the next `windows` windows (what spoke against the last goes)."""
        self.windows, self.commissioned, self.report = windows, None, None
        self.warnings = []
        self._baselines.clear()

    def keep(
        self, window: Window, t0: float, t1: float, base: MonitorBelief | None = None
    ) -> Kept:
        """Keep `window` (t0..t1 s) as a healthy baseline; commission once there are enough.

        `base`: the belief to commission against (None: the packaged one).
        """
        self._baselines.append(window)
        n, need = len(self._baselines), self.windows
        if n < need:
            return Kept(
                "commissioning",
                f"window t = {t0:g}..{t1:g} s kept as healthy baseline {n} of {need} "
                f"(the first windows are assumed healthy; give unit_file to skip this)",
            )
        base = base or MonitorBelief.default()
        spans = [f"window t = {w.t[0]:g}..{w.t[-1]:g} s" for w in self._baselines]
        checks, problems = review(self._baselines, spans, belief=base)  # against them?
        kept = self._refuse(problems, base) if problems else self._commission(checks, base)
        self._baselines.clear()
        return kept

    def _refuse(
        self, problems: list[str], base: MonitorBelief, result: CommissioningResult | None = None
    ) -> Kept:
        """Not silently: the uncommissioned `base` judges the windows instead."""
        self.commissioned = base
        self.report = {"refused": problems, **_figures(result)}
        self.warnings = [f"not commissioned: {p}" for p in problems]
        return Kept(
            "commissioning_refused",
            f"WARN: not commissioned, later windows are judged against the uncommissioned "
            f"belief ({base.source}; give unit_file to use a commissioned unit): "
            f"{'; '.join(problems)}",
            "warning",
        )

    def _commission(self, checks: Sequence[StartCheck], base: MonitorBelief) -> Kept:
        res = commission(self._baselines, belief=base, checks=checks)
        unexplained = res.unexplained()
        if unexplained:  # never a widened healthy reference
            return self._refuse(unexplained + res.warnings, base, res)
        unit = {k: ok for k, ok in res.identifiable.items() if k not in res.unknowns}
        factors = {k: round(res.factors[k], 4) for k, ok in unit.items() if ok}
        fixed = sorted(k for k, ok in unit.items() if not ok)
        self.commissioned = base.commissioned_with(res.values)
        self.report = _figures(res)
        self.warnings = [f"commissioned despite: {w}" for w in res.warnings]
        detail = (
            f"commissioned from {self.windows} window(s) in {res.wall_s:.1f} s: factors "
            f"{factors}; left at the datasheet (not pinned by these windows): "
            f"{', '.join(fixed) or 'none'}"
        )
        detail += "".join(
            f"; {name} {u['value']:.4g} ({'identified' if u['identified'] else u['warning']})"
            for name, u in res.unknowns.items()
        )
        if res.warnings:  # what spoke against it (`CommissioningResult.warnings`)
            return Kept(
                "commissioning_warning", f"WARN: {detail}; {'; '.join(res.warnings)}", "warning"
            )
        return Kept("commissioning", detail)


def _figures(res: CommissioningResult | None) -> dict[str, Any]:
    """What a commissioning's report holds of its result (nothing without one)."""
    if res is None:
        return {}
    return {
        "factors": res.factors,
        "identifiable": res.identifiable,
        "at_bound": res.at_bound,
        "unknowns": res.unknowns,
        "healthy_references": [ref.as_dict() for ref in res.references],
    }
