"""The monitor's work queue: the window being fitted and those waiting behind it.

One window is fitted at a time; windows that complete meanwhile wait, first in first out, up
to `depth` of them; `HealthMonitor` skips (and counts) one that completes with the queue
full.  No lock of its own: the monitor calls it under its lock.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from ..diagnosis.isolation_settings import IsolationSettings
from ..domain.window import Window
from ..limits import Limit, check
from ..telemetry.wire import StreamId

#: Allowed queue depths.  Unbounded here; monitor_node's parameter has LIMITS["queue_depth"].
DEPTH_LIMIT = Limit(0, math.inf, integer=True)


@dataclass(frozen=True, eq=False)  # a job is itself: compared by identity
class Job:
    """A window to fit, with the settings current when it completed."""

    window: Window
    t0: float
    t1: float
    settings: IsolationSettings
    started: float
    matrix: np.ndarray  # the window as received (telemetry layout), for /ema/window
    stream: StreamId | None = None  # the stream it came from (None: anonymous)
    cycle: int | None = None  # its operating cycle, when the stream numbers them


class JobQueue:
    """The running job, the queued ones (oldest first) and the queued ones dropped."""

    def __init__(self, depth: int) -> None:
        """`depth`: jobs that may wait behind the running one (a whole number >= 0)."""
        self.depth = int(check("queue_depth", depth, limit=DEPTH_LIMIT))
        self.running: Job | None = None
        self.pending: deque[Job] = deque()
        self._dropped: set[Job] = set()  # queued jobs `drop_pending` dropped, not yet run
        self.evaluations = 0  # of the running job's fit so far (its progress)

    @property
    def full(self) -> bool:
        """True when a job runs and `depth` jobs wait: a new one would be skipped."""
        return self.running is not None and len(self.pending) >= self.depth

    def add(self, job: Job) -> bool:
        """Run `job` now (True) or queue it behind the running one (False)."""
        if self.running is None:
            self.running, self.evaluations = job, 0
            return True
        self.pending.append(job)  # a tracked fit is shorter than a window: the queue drains
        return False

    def done(self, job: Job) -> bool:
        """`job` ended; True when it was the running one (the oldest queued one runs now)."""
        if self.running is job:
            self.running = self.pending.popleft() if self.pending else None
            self.evaluations = 0
            return True
        if job in self.pending:  # ended out of turn (e.g. cancelled): never wedge the queue
            self.pending.remove(job)
        return False

    def drop_pending(self) -> list[Job]:
        """Drop the queued jobs (they will not be run); the dropped ones, oldest first."""
        dropped = list(self.pending)
        self.pending.clear()
        self._dropped.update(dropped)
        return dropped

    def take_dropped(self, job: Job) -> bool:
        """True (once) when `job` was dropped: its run is to be skipped."""
        if job in self._dropped:
            self._dropped.discard(job)
            return True
        return False
