"""A channel map fed message by message: the monitor's telemetry rows from a rig's live topics.

`LiveChannels` is what `monitor_node` does with ``channel_map_file``, free of rclpy: each
message of a mapped topic is added as it arrives (`add`), and `rows` returns the new rows on
the actuator's acquisition grid, in `domain.window.CHANNELS` order, by the same rules as
`ema-phm import` (`importer.channel_series`, `resample.stretches`, `importer.on_grid_columns`):
the same derivations, units, delays, gaps and anti-aliasing.  Rows are held back `HOLD_S`
behind the newest sample every series has (the interpolation and the zero-phase filter
need samples on both sides) and computed over `LEAD_S` before them and `HOLD_S` after, so
the filter's edges fall outside the rows given; a stretch that a gap closed is given whole.
A message older than its series' newest sample is dropped and counted (`out_of_order`);
one more than `RESTART_S` older starts the stream over (a restarted rig, a looped bag:
`restarts`).  A series keeps at most `MAX_BUFFER_S` of history, whatever the others do.
Windows are cut from these rows by the node's own window length, as its native telemetry is:
at grid indices that are multiples of the window's samples.  Given ``window_samples``, each
stretch's first row is moved forward onto such a multiple (`shift_samples`, which grows
until the stream starts over), so windows start where the stretch starts, as
``windows: {by: length}`` cuts them offline, and not up to a window later (a stream whose
slowest topic starts after the first, or a stream after a gap).  The rows' times, and so
the window times the monitor reports, are the stream's plus that shift.

A map whose windows are by ``times`` or ``marker`` is cut live by
`telemetry.listed_assembler.ListedAssembler` (`listed_rule`): the times are seconds from the
stream's first row.  For a marker, `rows_and_marker` also gives the marker's value at each row
(held, as offline: its last sample by then, 0 before its first; rows do not wait for it, so
a marker sent only when it changes is no gap), and `MarkerRuns` finds its runs as
`segments.by_marker` does: each run of non-zero rows at least ``min_duration_s`` long,
marked once it has ended (a zero, a gap, a step back in time, or `MarkerRuns.end`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..domain.window import CHANNELS, TIME_COLUMN
from ..limits import LIMITS
from ..physics.parameters import ActuatorParameters
from ..telemetry.listed_assembler import LISTED_RULES, ListedRule, grid_index
from ..telemetry.listed_assembler import RESTART_S as LISTED_RESTART_S
from ..telemetry.span_assembler import SpanRule
from . import resample
from .channel_map import ChannelMap, SourceRef
from .importer import channel_series, on_grid_columns
from .sources import Series, converted, header_stamp_ns, value_of

#: The longest excitation segment cut from a stream [s] (at most the longest window the
#: limits allow); a longer one is discarded (`telemetry.span_assembler`; offline it would
#: be one long window).
LONGEST_SEGMENT_S = 20.0
#: Rows wait this long behind the newest sample of every series [s].
HOLD_S = 0.05
#: Samples kept before the next row to compute it from [s].
LEAD_S = 0.1
#: A series keeps at most this much history while others lag [s].
MAX_BUFFER_S = 10.0
#: `rows` works only once this much more could be given [s] (a call per message is cheap).
MIN_BLOCK_S = 0.02
#: Samples a series always keeps: enough steps for its median (`resample.GAP_STEPS` of it
#: make its default gap), so that a slow series' own gap is not taken for its step.
KEEP = 2 * int(resample.GAP_STEPS) + 1
#: A message this much older than its series' newest starts the stream over [s] (the
#: listed windows' assembler starts over at the same step back).
RESTART_S = LISTED_RESTART_S


def window_samples(actuator: ActuatorParameters, window_duration: float) -> int:
    """Grid steps per window of `window_duration` s at the actuator's sample rate."""
    return max(2, round(window_duration * float(actuator.acquisition.sample_rate)))


def longest_segment(actuator: ActuatorParameters) -> int:
    """Grid steps of the longest excitation segment cut from a stream (`LONGEST_SEGMENT_S`)."""
    return min(window_samples(actuator, LONGEST_SEGMENT_S), int(LIMITS["samples_per_window"].high))


def span_rule(cmap: ChannelMap) -> SpanRule | None:
    """The map's excitation rule for a stream's windows (None: the map cuts them otherwise)."""
    rule = cmap.windows
    if rule.by != "excitation":
        return None
    return SpanRule(
        rule.max_pause_s, rule.settle_s, rule.min_duration_s, cmap.identity.first_cycle
    )


def listed_rule(cmap: ChannelMap) -> ListedRule | None:
    """The map's ``times`` or ``marker`` rule for a stream's windows (None: cut otherwise)."""
    rule = cmap.windows
    if rule.by not in LISTED_RULES:
        return None
    return ListedRule(rule.by, rule.times, rule.min_duration_s, cmap.identity.first_cycle)


def longest_listed(actuator: ActuatorParameters, rule: ListedRule) -> int:
    """Grid steps of the longest window a ``times`` or ``marker`` rule gives a stream.

    The longest listed (at least 2 s), or any the limits allow for a marker's runs.
    """
    limit = int(LIMITS["samples_per_window"].high)
    if rule.by == "marker":
        return limit
    rate = float(actuator.acquisition.sample_rate)
    steps = [grid_index(b, rate) - grid_index(a, rate) for a, b in rule.times]
    return min(limit, max([window_samples(actuator, 2.0), *steps]))


def marker_runs(cmap: ChannelMap, rate: float) -> MarkerRuns | None:
    """The runs finder of a map whose windows are by marker (None: cut otherwise)."""
    rule = cmap.windows
    return MarkerRuns(rate, rule.min_duration_s) if rule.by == "marker" else None


@dataclass(frozen=True)
class Mark:
    """A marked window [t0, t1], the times of its first and last rows [s]."""

    t0: float
    t1: float


class MarkerRuns:
    """A live marker's runs, as `segments.by_marker` finds them offline (module docstring)."""

    def __init__(self, rate: float, min_duration_s: float) -> None:
        self.rate, self.min_duration_s = rate, min_duration_s
        self._start: int | None = None  # grid index of the open run's first row
        self._last: int | None = None  # grid index of the last row seen

    def split(self, rows: np.ndarray, marker: np.ndarray) -> list[np.ndarray | Mark]:
        """`rows` (with the `marker` at each), in pieces, a run's `Mark` after its last row."""
        if rows.shape[0] == 0:
            return []
        j = np.rint(rows[:, TIME_COLUMN] * self.rate).astype(np.int64)
        on = np.asarray(marker) != 0
        before = j[0] - 2 if self._last is None else self._last
        prev_j = np.concatenate([[before], j[:-1]])
        broken = j != prev_j + 1  # a gap, or time stepping back
        prev_on = np.concatenate([[self._start is not None], on[:-1]])
        out: list[np.ndarray | Mark] = []
        done = 0
        for k in np.flatnonzero(broken | (on != prev_on)).tolist():
            if self._start is not None and (broken[k] or not on[k]):
                if k > done:
                    out.append(rows[done:k])
                    done = k
                out += self._close(int(prev_j[k]))
            if on[k] and self._start is None:
                self._start = int(j[k])
        out.append(rows[done:])
        self._last = int(j[-1])
        return out

    def end(self) -> list[Mark]:
        """No row is to come: the open run ends at the last row."""
        return [] if self._last is None else self._close(self._last)

    def _close(self, last: int) -> list[Mark]:
        start, self._start = self._start, None
        if start is None or (last - start) / self.rate < self.min_duration_s:
            return []
        return [Mark(start / self.rate, last / self.rate)]


class LiveChannels:
    """Mapped topics in, grid rows out (module docstring)."""

    def __init__(
        self,
        cmap: ChannelMap,
        actuator: ActuatorParameters,
        window_samples: int | None = None,
        origin_ns: int | None = None,
    ) -> None:
        """`origin_ns`: the stream's time 0 [ns, the messages' clock] (None: its first message)."""
        self.cmap = cmap
        self.window_samples = window_samples
        #: grid samples added to every row's time since the stream began (see the module)
        self.shift_samples = 0
        self.actuator = actuator
        self.rate = float(actuator.acquisition.sample_rate)
        self.refs = cmap.refs()
        #: the series rows wait for: the channels', not a marker's (held: one sent only on
        #: change is no gap, and its value at a row is its last sample by then)
        self._gating = cmap.channel_refs()
        self.by_topic: dict[str, list[SourceRef]] = {}
        for r in self.refs:
            if r.topic is None:
                raise ValueError(f"{cmap.source}: {r.label} is a table column, not a topic")
            self.by_topic.setdefault(r.topic, []).append(r)
        self._t: dict[SourceRef, list[float]] = {r: [] for r in self.refs}
        self._v: dict[SourceRef, list[float]] = {r: [] for r in self.refs}
        # per topic, each series it feeds: (ref, its times, its values, where, for errors)
        self._slots = {
            topic: [(r, self._t[r], self._v[r], f"topic {topic}: {r.label}") for r in refs]
            for topic, refs in self.by_topic.items()
        }
        self._by_header = cmap.stamps == "header"
        self._origin_ns: int | None = origin_ns
        self.emitted_until = -math.inf
        self._next_trim = -math.inf
        self.out_of_order = 0
        self.restarts = 0

    @property
    def topics(self) -> list[str]:
        """The topics the map reads."""
        return list(self.by_topic)

    def add(self, topic: str, msg: Any, receive_ns: int) -> None:
        """One message of `topic`, received at `receive_ns` (its header stamp if the map says).

        BagError naming the topic and field when the message lacks what the map names.
        """
        stamp = header_stamp_ns(msg) if self._by_header else None
        ns = stamp or int(receive_ns)
        if self._origin_ns is None:
            self._origin_ns = ns
        t = (ns - self._origin_ns) * 1e-9
        slots = self._slots.get(topic, ())
        if any(times and t < times[-1] - RESTART_S for _r, times, _v, _w in slots):
            self._restart(ns)
            t = 0.0
        for r, times, values, where in slots:
            value = value_of(msg, r, where)
            if times and t <= times[-1]:
                self.out_of_order += 1
                continue
            times.append(t)
            values.append(value)
        if t >= self._next_trim:  # once a second: a bound, not an exact length
            self._trim_history(t)
            self._next_trim = t + 1.0

    def _restart(self, origin_ns: int) -> None:
        """Forget every sample: the stream starts over at `origin_ns`."""
        for r in self.refs:
            self._t[r].clear()
            self._v[r].clear()
        self._origin_ns = origin_ns
        self.emitted_until = -math.inf
        self._next_trim = -math.inf
        self.shift_samples = 0
        self.restarts += 1

    def _trim_history(self, newest: float) -> None:
        """At most MAX_BUFFER_S per series, even while another series is silent."""
        for r in self.refs:
            times = self._t[r]
            if len(times) > KEEP and times[0] < newest - 2 * MAX_BUFFER_S:
                cut = min(int(np.searchsorted(times, newest - MAX_BUFFER_S)), len(times) - KEEP)
                del times[:cut]
                del self._v[r][:cut]

    def rows(self, *, final: bool = False) -> np.ndarray:
        """The rows ready since the last call, (m, len(CHANNELS)), time increasing.

        `final`: no sample is to come (the end of a recording), so the rows are given up
        to the last time every series covers, without waiting `HOLD_S` for more.
        """
        return self.rows_and_marker(final=final)[0]

    def rows_and_marker(self, *, final: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """`rows`, and the map's marker at each row (held; zeros for a map without one)."""
        none = np.empty((0, len(CHANNELS))), np.empty(0)
        if any(len(self._t[r]) < 2 for r in self._gating):
            return none
        common = min(self._t[r][-1] - r.delay_s for r in self._gating)
        if not final and common - HOLD_S - self.emitted_until < MIN_BLOCK_S:
            return none
        series = {
            r: converted(r, np.asarray(self._t[r]), np.asarray(self._v[r]))
            for r in self.refs
            if self._t[r]
        }
        chans = channel_series(series, self.cmap, self.actuator)
        present = [s for s in chans.values() if s is not None]
        spans = resample.stretches(
            [*(series[r] for r in self._gating), *present], self.cmap.max_gap_s
        )
        marker = series.get(self.cmap.windows.marker) if self.cmap.windows.marker else None
        out = []
        for i, (lo, hi) in enumerate(spans):
            end = hi - HOLD_S if i == len(spans) - 1 and not final else hi
            start = max(lo, self.emitted_until + 0.5 / self.rate)
            block = self._block(chans, (lo, hi), start, end)
            if block.size:
                if lo > self.emitted_until:  # a stretch's first rows
                    self._align(round(block[0, 0] * self.rate))
                self.emitted_until = float(block[-1, 0])
                held = (  # no marker sample yet: off
                    np.zeros(len(block)) if marker is None else resample.held(marker, block[:, 0])
                )
                block[:, 0] += self.shift_samples / self.rate
                out.append(np.column_stack([block, held]))
        self._trim(max(s.t[-1] for s in present))
        if not out:
            return none
        both = np.vstack(out)
        return both[:, :-1], both[:, -1]

    def _align(self, first: int) -> None:
        """Shift the rows so that grid index `first` starts a window (module docstring)."""
        if self.window_samples:
            self.shift_samples += -(first + self.shift_samples) % self.window_samples

    def _block(
        self, chans: dict[str, Series | None], span: tuple[float, float], start: float, end: float
    ) -> np.ndarray:
        """Grid rows from `start` to `end` in `span`, computed from LEAD_S before, HOLD_S after."""
        if end < start:
            return np.empty((0, len(CHANNELS)))
        t = resample.grid((max(span[0], start - LEAD_S), min(span[1], end + HOLD_S)), self.rate)
        keep = (t >= start - 1e-12) & (t <= end + 1e-12)
        if t.size < 3 or not keep.any():
            return np.empty((0, len(CHANNELS)))
        cols = on_grid_columns(chans, t, self.rate)
        return np.column_stack([t[keep]] + [cols[c][keep] for c in CHANNELS[1:]])

    def _trim(self, newest: float) -> None:
        """Forget samples no further row needs."""
        keep_from = max(self.emitted_until - 2 * LEAD_S, newest - MAX_BUFFER_S)
        for r in self.refs:
            times = self._t[r]
            # raw times (delay on); the last sample at or before it stays (a slow series
            # needs the one before its next grid time)
            cut = int(np.searchsorted(times, keep_from + r.delay_s, side="right")) - 1
            cut = min(max(cut, 0), max(0, len(times) - KEEP))  # a series' step stays known
            if cut:
                del times[:cut]
                del self._v[r][:cut]
