"""Why the monitor's status is what it is, as data, rendered with the current counters."""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import health


@dataclass(frozen=True)
class StatusCause:
    """The event that decided the status.

    One of waiting, warming_up, commissioning, commissioning_warning (commissioned, with
    warnings), commissioning_refused, result, failure, not_excited or fault.
    """

    kind: str = "waiting"
    assessment: health.Assessment | None = (
        None  # the fit shown (the last good one for failure / fault)
    )
    reason: str = ""
    where: str = ""
    window_t0: float = math.nan
    window_t1: float = math.nan

    def render(self, ctx: health.StatusContext) -> health.HealthStatus:
        """The HealthStatus this cause gives with the counters, settings and prognosis of `ctx`.

        The prognosis may raise the level (`health.with_prognosis`).
        """
        return health.with_prognosis(self._render(ctx), ctx.prognostics)

    def _render(self, ctx: health.StatusContext) -> health.HealthStatus:
        if self.kind == "result" and self.assessment is not None:
            return health.result_status(self.assessment, ctx)
        if self.kind == "failure":
            return health.failure_status(
                self.reason, ctx, self.assessment, self.window_t0, self.window_t1
            )
        if self.kind == "not_excited":
            return health.not_excited_status(self.reason, ctx, self.window_t0, self.window_t1)
        if self.kind == "commissioning":
            return health.commissioning_status(self.reason, ctx)
        if self.kind in ("commissioning_refused", "commissioning_warning"):
            return health.commissioning_status(self.reason, ctx, level=health.WARN)
        if self.kind == "fault":
            return health.fault_status(self.where, self.reason, ctx, self.assessment)
        if self.kind == "warming_up":
            return health.warming_up_status(ctx)
        if self.reason:
            return health.waiting_status(ctx, self.reason)
        return health.waiting_status(ctx)
