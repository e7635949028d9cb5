"""`ema-phm import --stream`: a bag read once, in time order, in memory bounded by the window.

The whole-log import (`importer.source_windows`) holds every mapped series of a recording
and the stretch on the grid while it cuts the windows, so its memory grows with the log
(docs/benchmarks_import_memory.md).  Here the bag's messages go, in log-time order, through
the same channels monitor_node reads a rig's topics with (`live.LiveChannels`: the same
derivations, units, delays, gaps and anti-aliasing, with a bounded history), and the grid
rows through the assembler monitor_node cuts its windows with: `WindowAssembler` for
``windows: {by: length}``, `SpanAssembler` for ``{by: excitation}`` (segments at most
`live.LONGEST_SEGMENT_S` long), `ListedAssembler` for ``{by: times}`` and ``{by: marker}``
(the marker's runs found by `live.MarkerRuns`).  Each window is given as soon as it is
complete, and nothing else is held but the assembler's rows and a short history per series.

So the windows are those monitor_node would have fitted had the bag been played to it.
They differ from the whole-log import's in what a stream cannot know ahead:

- an excitation segment longer than `live.LONGEST_SEGMENT_S` is dropped (counted in
  ``discarded``), and the command's range that scales "it moves" is the stretch's so far,
  not the whole stretch's;
- a current logged slower than the grid is not marked (run_info ``current_logged``): its
  residual is weighed at every grid sample, as live;
- the default gap of a series (`resample.GAP_STEPS` median steps) is measured on the
  samples `live.LiveChannels` holds (the last second or so, at least `live.KEEP`), not
  the whole log;
- a stretch that ends because one topic falls silent for more than `live.MAX_BUFFER_S`
  while the others go on loses its last `live.HOLD_S` of rows (the others' samples there
  are forgotten before the silent one comes back);
- where a series is low-passed (logged faster than the grid) the samples can differ from
  the whole-log import's in their last bits (each block of rows is computed from its own
  margin), and a folder imported one way then refuses the other's windows as other
  content;
- a listed or marked window longer than the limits' longest window (60 s at 2 kHz) is
  dropped and counted (offline it is written);
- tables are read whole: refused here with the reason.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..domain.window import MIN_SAMPLES, TIME_COLUMN, Window
from ..errors import BagError, ConfigError, WindowError
from ..physics.parameters import ActuatorParameters
from ..telemetry.listed_assembler import ListedAssembler
from ..telemetry.span_assembler import SpanAssembler
from ..telemetry.window_assembler import Completed, Discarded, WindowAssembler
from .channel_map import ChannelMap
from .live import (
    LiveChannels,
    Mark,
    MarkerRuns,
    listed_rule,
    longest_listed,
    longest_segment,
    marker_runs,
    span_rule,
    window_samples,
)
from .sources import bag_messages, first_times, kind_of

#: Log time between two calls for grid rows [s]: each call recomputes its block's edges.
BLOCK_S = 0.5
#: Log time with no message of any mapped topic after which the rows held are given [s]
#: (a paused rig): a series keeps `live.MAX_BUFFER_S` of history at most.
PAUSE_S = 1.0


@dataclass
class StreamCounts:
    """What a streamed source gave, beside its windows."""

    first_s: float | None = None  # the first and last grid row [s]
    last_s: float | None = None
    rows: int = 0  # grid rows made
    stretches: int = 0  # runs of consecutive grid rows
    longest_rows: int = 0  # rows of the longest run
    discarded: int = 0  # excitation segments (or marked windows) too long to stream
    dropped: int = 0  # listed windows (times) not wholly recorded
    too_short: int = 0  # windows of fewer than MIN_SAMPLES samples
    first_msg_s: float | None = None  # the first and last message [s from the bag's start]
    last_msg_s: float | None = None
    next_block_ns: int = 0  # log time of the next call for grid rows [ns from the first]
    _run: int = 0
    _next: int | None = None

    def span(self, t: float) -> None:
        """Count a message at `t` [s from the bag's start]."""
        if self.first_msg_s is None or t < self.first_msg_s:
            self.first_msg_s = t
        if self.last_msg_s is None or t > self.last_msg_s:
            self.last_msg_s = t

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


class Cutter:
    """The assembler a map's windows rule asks for, and a marker's runs: rows in, windows out."""

    def __init__(self, cmap: ChannelMap, actuator: ActuatorParameters) -> None:
        rate = float(actuator.acquisition.sample_rate)
        span, listed = span_rule(cmap), listed_rule(cmap)
        self.assembler: ByLength | SpanAssembler | ListedAssembler
        self.runs: MarkerRuns | None = None
        if span is not None:
            self.assembler = SpanAssembler(rate, longest_segment(actuator), span)
        elif listed is not None:
            self.assembler = ListedAssembler(rate, longest_listed(actuator, listed), listed)
            self.runs = marker_runs(cmap, rate)
        else:
            self.assembler = ByLength(rate, window_samples(actuator, cmap.windows.seconds))

    def feed(self, rows: np.ndarray, marker: np.ndarray) -> list[Completed | Discarded]:
        """A block of grid rows (the marker at each): the windows they completed or broke."""
        if self.runs is None:
            return self.assembler.feed(rows)
        events: list[Completed | Discarded] = []
        for piece in self.runs.split(rows, marker):
            events += self._piece(piece)
        return events

    def _piece(self, piece: np.ndarray | Mark) -> list[Completed | Discarded]:
        if isinstance(piece, Mark):
            assert isinstance(self.assembler, ListedAssembler)
            return self.assembler.mark(piece.t0, piece.t1)
        return self.assembler.feed(piece)

    def end(self) -> list[Completed | Discarded]:
        """No row is to come: the segments or marked runs as they stand."""
        if isinstance(self.assembler, SpanAssembler):  # a tail of windows by length is left
            return self.assembler.reset()  # out, as offline
        if self.runs is not None:
            return [e for m in self.runs.end() for e in self._piece(m)]
        return []


def check_streamable(path: Path, cmap: ChannelMap) -> None:
    """ConfigError naming why `path` cannot be imported as a stream with `cmap`."""
    if kind_of(path) != "bag":
        raise ConfigError(f"--stream reads ROS 2 bags; {path} is a table: import without --stream")


def stream_windows(
    path: Path, cmap: ChannelMap, actuator: ActuatorParameters, counts: StreamCounts
) -> Iterator[tuple[Window, float]]:
    """The windows of the bag at `path`, each with its start in the source [s], as they complete.

    `counts` is filled as the bag is read.  ConfigError or BagError naming the bag and the
    problem.
    """
    check_streamable(path, cmap)
    try:
        yield from _streamed(path, cmap, actuator, counts)
    except (BagError, ConfigError, WindowError) as exc:
        if str(path) in str(exc):
            raise
        raise type(exc)(f"bag {path}: {exc}") from None


def _streamed(
    path: Path, cmap: ChannelMap, actuator: ActuatorParameters, counts: StreamCounts
) -> Iterator[tuple[Window, float]]:
    rate = float(actuator.acquisition.sample_rate)
    cutter = Cutter(cmap, actuator)
    refs = cmap.refs()
    # time 0 where the whole-log import puts it: the earliest sample, its delay taken off
    first = first_times(path, refs, cmap)
    origin = min(first[r.topic] - round(r.delay_s * 1e9) for r in refs if r.topic is not None)
    live = LiveChannels(cmap, actuator, origin_ns=origin)
    start_log: int | None = None
    last_log = 0
    for m in bag_messages(path, refs, cmap):
        if start_log is None:
            start_log = m.log_ns
        if last_log and m.log_ns - last_log > PAUSE_S * 1e9:  # all paused: give what is held
            yield from _given(live, cutter, counts, rate, final=True)
        last_log = m.log_ns
        live.add(m.topic, m.msg, m.log_ns)  # timed as the map says, as live
        counts.span(m.ns * 1e-9)
        if live.out_of_order or live.restarts:  # the whole-log import refuses it too
            raise ConfigError(
                f"{m.topic}: time does not increase at {m.ns * 1e-9:.9g} s from the bag's "
                "start (a message older than the one before it)"
            )
        if m.log_ns - start_log >= counts.next_block_ns:  # by log time: it only increases
            counts.next_block_ns = m.log_ns - start_log + int(BLOCK_S * 1e9)
            yield from _given(live, cutter, counts, rate, final=False)
    yield from _given(live, cutter, counts, rate, final=True)
    yield from _windows(cutter.end(), counts)
    if isinstance(cutter.assembler, ListedAssembler):  # listed after the bag's end
        counts.dropped += cutter.assembler.waiting


def _given(
    live: LiveChannels, cutter: Cutter, counts: StreamCounts, rate: float, *, final: bool
) -> Iterator[tuple[Window, float]]:
    """The windows the rows ready now complete (`final`: every row held, as at the end)."""
    rows, marker = live.rows_and_marker(final=final)
    yield from _windows(cutter.feed(_counted(rows, counts, rate), marker), counts)


def _counted(rows: np.ndarray, counts: StreamCounts, rate: float) -> np.ndarray:
    counts.add(rows, rate)
    return rows


def _windows(
    events: list[Completed | Discarded], counts: StreamCounts
) -> Iterator[tuple[Window, float]]:
    """The completed windows of `events` (times from their start), the others counted."""
    for e in events:
        if isinstance(e, Discarded):  # a listed time not wholly recorded, or too long
            if e.unrecorded:
                counts.dropped += 1
            else:
                counts.discarded += 1
            continue
        if e.data.shape[0] < MIN_SAMPLES:
            counts.too_short += 1
            continue
        start = e.t0
        data = e.data.copy()
        data[:, TIME_COLUMN] -= start
        yield Window.from_matrix(data).validated(), start
