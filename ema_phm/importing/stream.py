"""`ema-phm import --stream`: a bag read once, in time order, in memory bounded by the window.

The whole-log import (`importer.source_windows`) holds every mapped series of a recording
and the stretch on the grid while it cuts the windows, so its memory grows with the log
(docs/benchmarks_import_memory.md).  Here the bag's messages go, in log-time order, through
the same channels monitor_node reads a rig's topics with (`live.LiveChannels`: the same
derivations, units, delays, gaps and anti-aliasing, with a bounded history), and the grid
rows through the assembler monitor_node cuts its windows with: `WindowAssembler` for
``windows: {by: length}``, `SpanAssembler` for ``{by: excitation}`` (segments at most
`live.LONGEST_SEGMENT_S` long).  Each window is given as soon as it is complete, and
nothing else is held but the assembler's rows and a short history per series.

So the windows are those monitor_node would have fitted had the bag been played to it.
They differ from the whole-log import's in what a stream cannot know ahead:

- an excitation segment longer than `live.LONGEST_SEGMENT_S` is dropped (counted in
  ``discarded``), and the command's range that scales "it moves" is the stretch's so far,
  not the whole stretch's;
- a current logged slower than the grid is not marked (run_info ``current_logged``): its
  residual is weighed at every grid sample, as live;
- the default gap of a series (`resample.GAP_STEPS` median steps) is measured on the
  samples `live.LiveChannels` holds (the last second or so), not the whole log;
- windows by a time list or a marker need the whole log, and tables are read whole: both
  are refused here with the reason.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..domain.window import TIME_COLUMN, Window
from ..errors import ConfigError
from ..physics.parameters import ActuatorParameters
from ..telemetry.span_assembler import SpanAssembler
from ..telemetry.window_assembler import Completed, Discarded, WindowAssembler
from .channel_map import ChannelMap
from .live import LiveChannels, longest_segment, span_rule, window_samples
from .sources import bag_messages, kind_of

#: Log time between two calls for grid rows [s]: each call recomputes its block's edges.
BLOCK_S = 0.5
#: The rules a stream can cut by.
STREAMED_RULES = ("length", "excitation")


@dataclass
class StreamCounts:
    """What a streamed source gave, beside its windows."""

    first_s: float | None = None  # the first and last grid row [s]
    last_s: float | None = None
    rows: int = 0  # grid rows made
    stretches: int = 0  # runs of consecutive grid rows
    longest_rows: int = 0  # rows of the longest run
    discarded: int = 0  # windows given up: a gap inside one, a segment too long
    _run: int = 0
    _next: int | None = None

    def add(self, rows: np.ndarray, rate: float) -> None:
        """Count a block of grid rows."""
        if rows.shape[0] == 0:
            return
        j = np.rint(rows[:, TIME_COLUMN] * rate).astype(np.int64)
        breaks = np.flatnonzero(np.diff(j) != 1) + 1
        starts = np.concatenate([[0], breaks])
        ends = np.concatenate([breaks, [j.size]])
        for a, b in zip(starts, ends, strict=True):
            if self._next is None or int(j[a]) != self._next:
                self.stretches += 1
                self._run = 0
            self._run += int(b - a)
            self.longest_rows = max(self.longest_rows, self._run)
            self._next = int(j[b - 1]) + 1
        self.rows += int(j.size)
        if self.first_s is None:
            self.first_s = float(rows[0, TIME_COLUMN])
        self.last_s = float(rows[-1, TIME_COLUMN])


class ByLength:
    """Windows of n steps from each stretch's first row, as ``windows: {by: length}`` cuts them.

    A `WindowAssembler` on the stretch's own grid index (it starts windows at multiples of
    n): a stretch's tail shorter than a window is left out and not counted, as offline.
    """

    def __init__(self, rate: float, n: int) -> None:
        self.rate = rate
        self.windows = WindowAssembler(rate, n)
        self._origin = 0  # grid index of the stretch's first row
        self._next: int | None = None  # grid index expected next

    def feed(self, rows: np.ndarray) -> list[Completed | Discarded]:
        """Add a block of grid rows; the windows it completed."""
        out: list[Completed | Discarded] = []
        j = np.rint(rows[:, TIME_COLUMN] * self.rate).astype(np.int64)
        breaks = np.flatnonzero(np.diff(j) != 1) + 1
        for run, jr in zip(np.split(rows, breaks), np.split(j, breaks), strict=True):
            if jr.size == 0:
                continue
            if self._next is None or int(jr[0]) != self._next:  # a new stretch
                self.windows.reset()
                self._origin = int(jr[0])
            self._next = int(jr[-1]) + 1
            shifted = run.copy()
            shifted[:, TIME_COLUMN] = (jr - self._origin) / self.rate
            for e in self.windows.feed(shifted):
                if isinstance(e, Completed):
                    data = e.data.copy()
                    data[:, TIME_COLUMN] = (e.j0 + self._origin + np.arange(len(data))) / self.rate
                    out.append(Completed(j0=e.j0 + self._origin, data=data))
        return out


def check_streamable(path: Path, cmap: ChannelMap) -> None:
    """ConfigError naming why `path` cannot be imported as a stream with `cmap`."""
    if cmap.windows.by not in STREAMED_RULES:
        raise ConfigError(
            f"--stream cuts windows by {' or '.join(STREAMED_RULES)}, as monitor_node does; "
            f"the map's windows: by {cmap.windows.by} needs the whole log: import without "
            "--stream"
        )
    if kind_of(path) != "bag":
        raise ConfigError(f"--stream reads ROS 2 bags; {path} is a table: import without --stream")


def stream_windows(
    path: Path, cmap: ChannelMap, actuator: ActuatorParameters, counts: StreamCounts
) -> Iterator[tuple[Window, float]]:
    """The windows of the bag at `path`, each with its start in the source [s], as they complete.

    `counts` is filled as the bag is read.  ConfigError or BagError naming the problem.
    """
    check_streamable(path, cmap)
    rate = float(actuator.acquisition.sample_rate)
    rule = span_rule(cmap)
    assembler: ByLength | SpanAssembler
    if rule is None:
        assembler = ByLength(rate, window_samples(actuator, cmap.windows.seconds))
    else:
        assembler = SpanAssembler(rate, longest_segment(actuator), rule)
    live = LiveChannels(cmap, actuator)
    refs = cmap.refs()
    next_block = BLOCK_S
    for m in bag_messages(path, refs, cmap):
        live.add(m.topic, m.msg, m.log_ns)  # timed as the map says, as live
        t = m.ns * 1e-9
        if live.out_of_order or live.restarts:  # the whole-log import refuses it too
            raise ConfigError(
                f"{path}: {m.topic}: time does not increase at {t:.9g} s (a message older "
                "than the one before it)"
            )
        if t >= next_block:
            next_block = t + BLOCK_S
            yield from _windows(assembler.feed(_counted(live.rows(), counts, rate)), counts)
    events = assembler.feed(_counted(live.rows(final=True), counts, rate))
    if isinstance(assembler, SpanAssembler):  # the segments as they stand (a tail of
        events += assembler.reset()  # windows by length is left out, as offline)
    yield from _windows(events, counts)


def _counted(rows: np.ndarray, counts: StreamCounts, rate: float) -> np.ndarray:
    counts.add(rows, rate)
    return rows


def _windows(
    events: list[Completed | Discarded], counts: StreamCounts
) -> Iterator[tuple[Window, float]]:
    """The completed windows of `events` (times from their start), the others counted."""
    for e in events:
        if isinstance(e, Discarded):
            counts.discarded += 1
            continue
        start = e.t0
        data = e.data.copy()
        data[:, TIME_COLUMN] -= start
        yield Window.from_matrix(data).validated(), start
