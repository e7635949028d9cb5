"""What one input made the monitor decide to send: `Outputs` and its `LogLine`s."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..diagnosis.health import Assessment
from .job_queue import Job
from .status_texts import HealthStatus


@dataclass(frozen=True)
class LogLine:
    """One line for the node to log at `severity`."""

    severity: str  # debug, info, warning or error
    text: str


@dataclass
class Outputs:
    """What one input made the monitor decide to send."""

    # windows scheduled to be fitted, oldest first: each is published (/ema/window) and
    # submitted to the worker; one message can complete several windows
    jobs: list[Job] = field(default_factory=list)
    health: np.ndarray | None = None  # /ema/health vector
    assessment: Assessment | None = None  # ... the fit behind it (/ema/actuator_health)
    status: HealthStatus | None = None  # /diagnostics
    logs: list[LogLine] = field(default_factory=list)

    def log(self, severity: str, text: str) -> None:
        """Queue a log line."""
        self.logs.append(LogLine(severity, text))
