"""Self-commissioning of the live monitor from its first windows, and its guard.

Without a unit file the monitor keeps its first `windows` fitted windows as healthy
baselines and commissions itself from them (`diagnosis.commissioning.commission`), unless
`commissioning.review` speaks against them: then the packaged belief judges the later
windows and the reasons stand as warnings (a WARN status, ``unit_warnings``).  No lock of its
own: `HealthMonitor` runs `keep` from its worker and `restart` under its lock.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..diagnosis.commissioning import commission, review
from ..diagnosis.isolation_settings import IsolationSettings
from ..domain.window import Window
from ..physics.parameters import MonitorBelief


@dataclass(frozen=True)
class Kept:
    """What keeping one baseline decided: a status kind, its detail and the log severity."""

    kind: str  # commissioning or commissioning_refused
    detail: str
    severity: str = "info"


class CommissioningGuard:
    """The baselines kept so far, and the belief commissioned from them (or refused)."""

    def __init__(self, windows: int) -> None:
        """Commission from the first `windows` windows (0: use the packaged belief)."""
        self.windows = windows
        self.commissioned: MonitorBelief | None = None
        self.report: dict[str, Any] | None = None
        #: why the monitor did not commission itself from its first windows
        self.warnings: list[str] = []
        self._baselines: list[Window] = []

    @property
    def active(self) -> bool:
        """True while windows are kept as baselines instead of being assessed."""
        return self.commissioned is None and len(self._baselines) < self.windows

    def belief(self, settings: IsolationSettings) -> MonitorBelief | None:
        """The belief to fit with: the unit file's, else the commissioned one (or None)."""
        return settings.belief if settings.belief is not None else self.commissioned

    def restart(self, windows: int) -> None:
        """Commission again from the next `windows` windows."""
        self.windows, self.commissioned, self.report = windows, None, None
        self._baselines.clear()

    def keep(self, window: Window, t0: float, t1: float) -> Kept:
        """Keep `window` (t0..t1 s) as a healthy baseline; commission once there are enough."""
        self._baselines.append(window)
        n, need = len(self._baselines), self.windows
        if n < need:
            return Kept(
                "commissioning",
                f"window t = {t0:g}..{t1:g} s kept as healthy baseline {n} of {need} "
                f"(the first windows are assumed healthy; give unit_file to skip this)",
            )
        spans = [f"window t = {w.t[0]:g}..{w.t[-1]:g} s" for w in self._baselines]
        checks, problems = review(self._baselines, spans)  # what speaks against them
        kept = self._refuse(problems) if problems else self._commission(checks)
        self._baselines.clear()
        return kept

    def _refuse(self, problems: list[str]) -> Kept:
        """Not silently: the packaged belief judges the windows instead."""
        self.commissioned = MonitorBelief.default()
        self.report = {"refused": problems}
        self.warnings = [f"not commissioned: {p}" for p in problems]
        return Kept(
            "commissioning_refused",
            f"WARN: not commissioned, later windows are judged against the packaged "
            f"belief (give unit_file to use a commissioned unit): {'; '.join(problems)}",
            "warning",
        )

    def _commission(self, checks: Any) -> Kept:
        res = commission(self._baselines, checks=checks)
        factors = {k: round(v, 4) for k, v in res.factors.items() if res.identifiable[k]}
        fixed = sorted(k for k, ok in res.identifiable.items() if not ok)
        self.commissioned = MonitorBelief.default().with_values(res.values)
        self.report = {"factors": res.factors, "identifiable": res.identifiable}
        return Kept(
            "commissioning",
            f"commissioned from {self.windows} window(s) in {res.wall_s:.1f} s: factors "
            f"{factors}; left at the datasheet (not pinned by these windows): "
            f"{', '.join(fixed) or 'none'}",
        )
