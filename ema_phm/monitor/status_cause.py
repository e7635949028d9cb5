"""Why the monitor's status is what it is, as data, rendered with the current counters."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..diagnosis import health
from . import status_texts


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

    def render(self, ctx: status_texts.StatusContext) -> status_texts.HealthStatus:
        """The HealthStatus this cause gives with the counters, settings and prognosis of `ctx`.

        The prognosis may raise the level (`status_texts.with_prognosis`).
        """
        return status_texts.with_prognosis(self._render(ctx), ctx.prognostics)

    def _render(self, ctx: status_texts.StatusContext) -> status_texts.HealthStatus:
        if self.kind == "result" and self.assessment is not None:
            return status_texts.result_status(self.assessment, ctx)
        if self.kind == "failure":
            return status_texts.failure_status(
                self.reason, ctx, self.assessment, self.window_t0, self.window_t1
            )
        if self.kind == "not_excited":
            return status_texts.not_excited_status(
                self.reason, ctx, self.window_t0, self.window_t1
            )
        if self.kind == "commissioning":
            return status_texts.commissioning_status(self.reason, ctx)
        if self.kind in ("commissioning_refused", "commissioning_warning"):
            return status_texts.commissioning_status(self.reason, ctx, level=health.WARN)
        if self.kind == "fault":
            return status_texts.fault_status(self.where, self.reason, ctx, self.assessment)
        if self.kind == "warming_up":
            return status_texts.warming_up_status(ctx)
        if self.reason:
            return status_texts.waiting_status(ctx, self.reason)
        return status_texts.waiting_status(ctx)
