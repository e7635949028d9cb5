"""Telemetry and run_info in, window events out: the monitor's front end, free of rclpy.

Until the first good `/ema/run_info` there is no window geometry, so telemetry
waits in a bounded buffer (`PENDING_MESSAGES` messages, `PENDING_SAMPLES`
samples; the oldest go first).  A run_info that changes the geometry discards
the window being assembled and starts a new `WindowAssembler`; one with the
same geometry only updates `run_info`.  A run_info whose ``windows`` asks for windows by
excitation (`span_assembler.SpanRule`) gets a `span_assembler.SpanAssembler` instead: its
windows are the command's excitation segments, at most ``samples_per_window`` long, and
where a window would be discarded (below, and a new geometry) the segments it holds are
given as they stand, as a gap ends a stretch offline.  One whose ``windows`` are by
``times`` or ``marker`` (`listed_assembler.ListedRule`) gets a `listed_assembler.ListedAssembler`:
its windows are listed in the run_info, or marked as the stream goes (`mark`).

Every message may carry its stream's identity (`wire.StreamId`, None for an anonymous
stream).  A window is assembled from one stream only: a message of another identity
(a second publisher on the topic, a restarted source) discards the window being assembled,
with both identities in the reason, and assembly goes on with the new stream from its
next window boundary.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..limits import LIMITS
from .listed_assembler import LISTED_RULES, ListedAssembler, ListedRule
from .span_assembler import SpanAssembler, SpanRule
from .window_assembler import Completed, Discarded, RunInfo, WindowAssembler, parse_run_info
from .wire import StreamId, describe_stream

#: Telemetry messages kept while waiting for the first run_info.
PENDING_MESSAGES = 5000
#: ... and at most this many samples (two of the longest windows allowed).
PENDING_SAMPLES = 2 * int(LIMITS["samples_per_window"].high)

Event = Completed | Discarded
Assembler = WindowAssembler | SpanAssembler | ListedAssembler


@dataclass(frozen=True)
class RunInfoUpdate:
    """A good run_info: its content, whether it set a new geometry, the events that caused."""

    run_info: RunInfo
    new_geometry: bool
    events: list[Event] = field(default_factory=list)


class WindowIntake:
    """Feeds a WindowAssembler from telemetry rows, holding them until the geometry is known."""

    def __init__(self) -> None:
        self._assembler: Assembler | None = None
        self._pending: deque[tuple[np.ndarray, StreamId | None]] = deque()
        self._pending_samples = 0
        self.run_info: dict[str, Any] = {}
        self.stream: StreamId | None = None  # identity of the stream being assembled
        self.stream_changes = 0  # messages whose identity differed from the one before
        self._seen_stream = False  # a message was fed (so `stream` is a real one)

    @property
    def has_geometry(self) -> bool:
        """True once a good run_info gave the sample rate and window length."""
        return self._assembler is not None

    @property
    def samples_collected(self) -> int:
        """Samples of the window being assembled (0 before the geometry is known)."""
        return 0 if self._assembler is None else self._assembler.pending_samples

    def accept_run_info(self, text: str) -> RunInfoUpdate:
        """Apply a run_info JSON text; ConfigError / WindowError (nothing changed) if malformed."""
        parsed = parse_run_info(text)
        assembler = assembler_of(parsed)
        rule = getattr(assembler, "rule", None)
        self.run_info = parsed.info
        old = self._assembler
        if old is not None and _geometry(old) == _geometry(assembler):
            return RunInfoUpdate(parsed, new_geometry=False)
        events: list[Event] = []
        if old is not None:
            events += old.reset(
                f"run_info changed the window to {assembler.n} samples at "
                f"{assembler.sample_rate:g} Hz"
                + ("" if rule is None else f", by {rule.as_info()['by']} ({rule.as_info()})")
            )
        if isinstance(old, (SpanAssembler, ListedAssembler)) and not isinstance(
            assembler, WindowAssembler
        ):
            assembler.cycle = max(assembler.cycle, old.cycle)  # cycles never step back
        self._assembler = assembler
        pending, self._pending, self._pending_samples = list(self._pending), deque(), 0
        for rows, stream in pending:
            events += self._feed(assembler, rows, stream)
        return RunInfoUpdate(parsed, new_geometry=True, events=events)

    def add_rows(self, rows: np.ndarray, stream: StreamId | None = None) -> list[Event]:
        """One telemetry message's rows (of `stream`): the windows it completed or broke."""
        if self._assembler is None:
            self._hold(rows, stream)
            return []
        return self._feed(self._assembler, rows, stream)

    def _feed(
        self, assembler: Assembler, rows: np.ndarray, stream: StreamId | None
    ) -> list[Event]:
        events: list[Event] = []
        if stream != self.stream:
            if self._seen_stream:
                self.stream_changes += 1
                events += assembler.reset(
                    f"telemetry of another stream arrived mid-window: {describe_stream(stream)} "
                    f"after {describe_stream(self.stream)} (a second publisher on the topic, or a "
                    "restarted source)"
                )
            self.stream = stream
        self._seen_stream = True
        return events + assembler.feed(rows)

    def mark(self, start_s: float, end_s: float, stream: StreamId | None = None) -> list[Event]:
        """A window [start_s, end_s] marked on `stream` (`ListedAssembler.mark`): its events.

        Nothing for a stream other than the one being assembled, or windows cut otherwise.
        """
        if not isinstance(self._assembler, ListedAssembler) or stream != self.stream:
            return []
        return self._assembler.mark(start_s, end_s)

    def reject_message(self, reason: str) -> list[Event]:
        """A malformed telemetry message: the window being assembled is discarded."""
        if self._assembler is None:
            return []
        return list(self._assembler.reset(reason))

    def _hold(self, rows: np.ndarray, stream: StreamId | None) -> None:
        self._pending.append((rows, stream))
        self._pending_samples += rows.shape[0]
        while self._pending and (
            len(self._pending) > PENDING_MESSAGES or self._pending_samples > PENDING_SAMPLES
        ):
            self._pending_samples -= self._pending.popleft()[0].shape[0]


def rule_of(info: RunInfo) -> SpanRule | ListedRule | None:
    """A run_info's ``windows`` rule (None: by length); ConfigError naming a bad value."""
    windows = info.info.get("windows")
    if isinstance(windows, dict) and windows.get("by") in LISTED_RULES:
        return ListedRule.from_info(windows)
    return SpanRule.from_info(windows)


def assembler_of(parsed: RunInfo) -> Assembler:
    """The assembler a run_info asks for (its ``windows``); ConfigError naming a bad value."""
    rule = rule_of(parsed)
    if isinstance(rule, ListedRule):
        return ListedAssembler(parsed.sample_rate, parsed.samples_per_window, rule)
    if rule is None:
        return WindowAssembler(parsed.sample_rate, parsed.samples_per_window)
    return SpanAssembler(parsed.sample_rate, parsed.samples_per_window, rule)


def _geometry(assembler: Assembler) -> tuple[float, int, SpanRule | ListedRule | None]:
    """What makes two assemblers cut the same windows."""
    return (assembler.sample_rate, assembler.n, getattr(assembler, "rule", None))
