"""The monitor's `/diagnostics` status: what decided it, and how it renders on a heartbeat.

A status is the rendering of its cause (`StatusCause`) with the monitor's context (counters,
settings, prognosis, stream).  A fault of the monitor itself (a callback raised, an input
refused) shows until a good input clears it (`clear_fault`: the cause before it returns) or
a window ends.  No lock of its own: `HealthMonitor` calls it under its lock.
"""

from __future__ import annotations

from typing import Callable

from ..diagnosis import health
from . import status_texts
from .job_queue import Job
from .outputs import Outputs
from .status_cause import StatusCause


class StatusBoard:
    """The current cause, the one a fault hides, the last fit shown and the last status."""

    def __init__(self, context: Callable[[], status_texts.StatusContext]) -> None:
        """`context`: the monitor's counters, settings, prognosis and stream, now."""
        self._context = context
        self.cause = StatusCause()
        self._before_fault: StatusCause | None = None
        self.last_assessment: health.Assessment | None = None
        self.last_status: status_texts.HealthStatus | None = None

    def decide(self, cause: StatusCause, out: Outputs) -> None:
        """Make `cause` the status and send it; any cause but a fault replaces a fault for good."""
        if cause.kind != "fault":
            self._before_fault = None  # a later clear_fault must not bring back an older cause
        self.cause = cause
        out.status = self.last_status = cause.render(self._context())

    def fault(self, where: str, reason: str, out: Outputs) -> None:
        """A fault of the monitor itself: ERROR, over the cause before it."""
        if self._before_fault is None:
            self._before_fault = self.cause
        self.decide(StatusCause("fault", self.last_assessment, reason, where), out)

    def clear_fault(self) -> None:
        """A good input: the cause before the fault is the status again (on the next send)."""
        if self._before_fault is not None:
            self.cause, self._before_fault = self._before_fault, None

    def window_ended(self, cause: StatusCause, out: Outputs) -> None:
        """A window was fitted, failed or not assessed: `cause` replaces any fault."""
        if cause.kind == "result":
            self.last_assessment = cause.assessment
        self._before_fault = None
        self.decide(cause, out)

    def heartbeat(
        self, out: Outputs, running: Job | None, evaluations: int, age: float, stale_timeout: float
    ) -> None:
        """The current status, 'isolating…' while `running`, STALE after `stale_timeout` s.

        `age`: seconds since the last telemetry; `evaluations`: of the running fit.
        """
        ctx = self._context()
        current = self.cause.render(ctx)
        if self.cause.kind == "warming_up":  # no telemetry is expected yet: not stale
            out.status = self.last_status = current
        elif running is not None:
            out.status = status_texts.busy_status(
                current,
                self.last_assessment,
                ctx,
                window_t0=running.t0,
                window_t1=running.t1,
                evaluations=evaluations,
            )
        else:
            out.status = self.last_status = status_texts.current_status(
                current,
                telemetry_age_s=age,
                stale_timeout_s=stale_timeout,
                ctx=ctx,
                last=self.last_assessment,
            )
