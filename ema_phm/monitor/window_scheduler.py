"""Telemetry in, windows to fit out: the monitor's intake and work queue.

Windows are assembled from one stream (`WindowIntake`); each completed window is fitted
now, queued behind the running fit (`job_queue.JobQueue`) or skipped with the queue full;
a broken one is discarded with its reason.  No lock of its own: `HealthMonitor` calls it
under its lock.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

import numpy as np

from ..diagnosis.isolation_settings import IsolationSettings
from ..domain.window import Window
from ..errors import WindowError
from ..telemetry.window_assembler import Completed, Discarded
from ..telemetry.window_intake import Event, WindowIntake
from ..telemetry.wire import StreamId, describe_stream
from .job_queue import Job, JobQueue
from .outputs import Outputs


class WindowScheduler:
    """The intake, the work queue and when telemetry was last heard."""

    def __init__(
        self,
        queue_depth: int,
        counters: dict[str, int],
        discard_reasons: deque[str],
        clock: Callable[[], float],
    ) -> None:
        """Count in `counters`, keep discard reasons in `discard_reasons` (the monitor's)."""
        self.jobs = JobQueue(queue_depth)
        self.intake = WindowIntake()
        self.counters = counters
        self.discard_reasons = discard_reasons
        self._clock = clock
        self.last_telemetry = clock()  # start-up counts as "last heard" for staleness

    def heard(self) -> None:
        """Telemetry (or the end of the warm-up) arrived now: staleness counts from here."""
        self.last_telemetry = self._clock()

    def take_rows(self, rows: np.ndarray, stream: StreamId | None) -> tuple[list[Event], str]:
        """Add `rows` of `stream`: the events, and why the window broke on a stream change."""
        self.heard()
        changes, before = self.intake.stream_changes, self.intake.stream
        events = self.intake.add_rows(rows, stream)
        if self.intake.stream_changes == changes:
            return events, ""
        self.counters["stream_changes"] += 1
        return events, (
            f"telemetry of {describe_stream(stream)} after {describe_stream(before)}: "
            "two publishers on the topic, or a restarted source; the window being "
            "assembled is discarded"
        )

    def handle(self, events: list[Event], settings: IsolationSettings, out: Outputs) -> None:
        """Schedule each completed window (fitted with `settings`), discard each broken one."""
        for event in events:
            if isinstance(event, Discarded):
                self.discard(
                    f"window t0 = {event.t0:g} s discarded after {event.samples} samples: "
                    f"{event.reason}",
                    out,
                )
            else:
                self._schedule(event, settings, out)

    def discard(self, reason: str, out: Outputs) -> None:
        """Count and log a discarded window."""
        self.counters["windows_discarded"] += 1
        self.discard_reasons.append(reason)
        out.log("warning", reason)

    def _schedule(self, event: Completed, settings: IsolationSettings, out: Outputs) -> None:
        """Fit the window now, or queue it behind the running fit, or skip it (queue full)."""
        running = self.jobs.running
        if running is not None and self.jobs.full:
            self.counters["windows_skipped_busy"] += 1
            out.log(
                "info",
                f"window t = {event.t0:g}..{event.t1:g} s skipped: still isolating "
                f"t = {running.t0:g}..{running.t1:g} s with {len(self.jobs.pending)} "
                f"window(s) queued (queue_depth {self.jobs.depth})",
            )
            return
        try:
            window = Window.from_matrix(event.data, meta=dict(self.intake.run_info)).validated()
        except WindowError as exc:
            self.discard(f"window t = {event.t0:g}..{event.t1:g} s discarded: {exc}", out)
            return
        stream = self.intake.stream
        job = Job(
            window, event.t0, event.t1, settings, self._clock(), event.data, stream, event.cycle
        )
        self.jobs.add(job)
        out.jobs.append(job)
