"""Cut a live stream into its excitation segments, as `ema-phm import` cuts a log offline.

rclpy-free, with `window_assembler.WindowAssembler`'s interface (`feed`, `reset`,
`pending_samples`): the monitor uses it when its run_info asks for windows by excitation
(`SpanRule`).  A window is where the command moves (`domain.excitation_spans`: pauses shorter
than ``max_pause_s`` joined, ``settle_s`` kept on each side, at least ``min_duration_s``).

A segment is given once nothing to come can change it: once the command has been still for
``max_pause_s`` + 2 x ``settle_s`` after the segment's end, no later move can join it, widen
it or take half of its settle time.  Whatever breaks the stream ends the stretch, as a gap
ends one offline, and every segment in it is given as it stands: missing samples, a step
back in time, a sample off the grid, a `reset` (another stream, a malformed message, a new
geometry).  Segments are numbered in order from ``first_cycle`` (`Completed.cycle`), as the
import numbers the windows of a log without cycle numbers.

Differences from offline, by construction:

- a change counts as a move when it is above `excitation_spans.STILL_SHARE` of the
  command's range in the stretch *so far* (offline: the whole stretch), and of at least
  `MIN_RANGE_RAD` (offline: no floor), so rest that only drifts by rounding is not a move;
- a segment longer than the run_info's ``samples_per_window`` is not fitted (offline it
  would be one long window): it is discarded with its reason, and the rest of that motion is
  dropped until the command has rested longer than ``max_pause_s``; a segment after it starts
  after that rest (offline: half-way when their settle times meet).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..domain.excitation_spans import STILL_SHARE, excitation_spans
from ..errors import ConfigError
from ..limits import check
from .window_assembler import Completed, Discarded, grid_runs

#: Command column of the telemetry rows.
COMMAND_COLUMN = 1
#: Smallest command range a move is a share of [rad]: chirps of <= 3e-4 rad excite nothing
#: a fit can read (diagnosis/excitation.py, docs/excitation.md), so rest that drifts by less
#: is no move.
MIN_RANGE_RAD = 3e-4


@dataclass(frozen=True)
class SpanRule:
    """The excitation rule of a run_info's ``windows`` (the channel map's `WindowRule`)."""

    max_pause_s: float = 0.25
    settle_s: float = 0.1
    min_duration_s: float = 0.5
    first_cycle: int = 0

    @classmethod
    def from_info(cls, windows: Any) -> SpanRule | None:
        """The rule of a run_info's ``windows`` value; None for windows by length (or none).

        ConfigError naming the value for anything else.
        """
        if windows is None:
            return None
        if not isinstance(windows, Mapping):
            raise ConfigError(f"run_info windows must be an object, got {windows!r}")
        by = windows.get("by", "length")
        if by == "length":
            return None
        if by != "excitation":
            raise ConfigError(
                f"run_info windows by {by!r}: live windows are by length, excitation, times "
                "or marker"
            )
        out = {}
        for key in ("max_pause_s", "settle_s", "min_duration_s"):
            value = windows.get(key, getattr(cls, key))
            try:
                out[key] = float(value)
            except (TypeError, ValueError):
                raise ConfigError(
                    f"run_info windows {key} must be a number, got {value!r}"
                ) from None
            if not (out[key] >= 0 and np.isfinite(out[key])):
                raise ConfigError(f"run_info windows {key} must be >= 0, got {value!r}")
        first = windows.get("first_cycle", 0)
        if not isinstance(first, int) or isinstance(first, bool) or first < 0:
            raise ConfigError(
                f"run_info windows first_cycle must be a whole number >= 0, got {first!r}"
            )
        return cls(**out, first_cycle=first)

    def as_info(self) -> dict[str, Any]:
        """The run_info ``windows`` value of this rule."""
        return {
            "by": "excitation",
            "max_pause_s": self.max_pause_s,
            "settle_s": self.settle_s,
            "min_duration_s": self.min_duration_s,
            "first_cycle": self.first_cycle,
        }


class SpanAssembler:
    """Feed rows with `feed(rows)`; get back excitation segments as `Completed` (module doc)."""

    def __init__(self, sample_rate: float, longest: int, rule: SpanRule) -> None:
        """`longest`: samples a segment may span at most (a longer one is discarded)."""
        self.sample_rate = float(check("sample_rate", sample_rate))
        self.n = int(check("samples_per_window", longest))
        self.rule = rule
        self.cycle = rule.first_cycle  # the next segment's
        self._pause = round(rule.max_pause_s * self.sample_rate)
        self._pad = round(rule.settle_s * self.sample_rate)
        self._rows = np.empty((0, 0))
        self._j0 = 0  # grid index of the first row held
        self._next: int | None = None  # grid index expected next
        self._range: tuple[float, float] | None = None  # the command's, in the stretch so far
        self._dropping = False  # the rest of a segment too long to fit
        self._last_move = -1  # grid index of its last move seen

    @property
    def pending_samples(self) -> int:
        """Rows held towards the segments to come."""
        return int(self._rows.shape[0])

    def reset(self, reason: str | None = None) -> list[Completed | Discarded]:
        """The stretch ends here (`reason`: why; module docstring): its segments as they stand."""
        out = self._end_stretch()
        self._next = None
        return out

    def feed(self, rows: np.ndarray) -> list[Completed | Discarded]:
        """Add one batch of rows; return the segments it completed or broke."""
        events: list[Completed | Discarded] = []
        for first, run in grid_runs(rows, self.sample_rate):
            if first < 0:  # off the grid: the stretch ends, the row is not used
                events += self.reset()
                continue
            events += self._run(first, run)
        return events

    def _run(self, a: int, run: np.ndarray) -> list[Completed | Discarded]:
        events: list[Completed | Discarded] = []
        if self._next is not None and a != self._next:  # a gap or a step back
            events += self._end_stretch()
        if self._rows.size == 0:
            self._rows, self._j0 = run, a
        else:
            self._rows = np.concatenate([self._rows, run])
        self._next = a + run.shape[0]
        command = run[:, COMMAND_COLUMN]
        low, high = float(np.min(command)), float(np.max(command))
        if self._range is not None:
            low, high = min(low, self._range[0]), max(high, self._range[1])
        self._range = (low, high)
        return events + self._give(final=False)

    def _end_stretch(self) -> list[Completed | Discarded]:
        events = self._give(final=True)
        self._rows, self._range, self._dropping = np.empty((0, 0)), None, False
        return events

    @property
    def _scale(self) -> float:
        low, high = self._range or (0.0, 0.0)
        return max(high - low, MIN_RANGE_RAD)

    def _give(self, final: bool) -> list[Completed | Discarded]:
        """The segments nothing to come can change (`final`: the stretch ended, all of them)."""
        if self._dropping:
            self._drop_the_rest()
        rows = self._rows
        if self._dropping or rows.shape[0] < 2:
            return []
        spans = excitation_spans(
            rows[:, COMMAND_COLUMN],
            self.sample_rate,
            max_pause_s=self.rule.max_pause_s,
            settle_s=self.rule.settle_s,
            min_duration_s=0.0,
            scale=self._scale,
        )
        events: list[Completed | Discarded] = []
        last, cut = rows.shape[0] - 1, 0
        for a, b in spans:
            if not final and last - b <= self._pause + 2 * self._pad:
                break
            cut = b + 1
            if b - a > self.n:
                events.append(self._too_long(a, b, ended=True))
            elif (b - a) / self.sample_rate >= self.rule.min_duration_s:
                data = np.ascontiguousarray(rows[a : b + 1])
                events.append(Completed(j0=self._j0 + a, data=data, cycle=self.cycle))
                self.cycle += 1
        open_span = next(((a, b) for a, b in spans if b + 1 > cut), None)
        if open_span is None:  # nothing moving is held: keep what a next segment may widen onto
            cut = max(cut, last - self._pad)
        elif open_span[1] - open_span[0] > self.n:
            events.append(self._too_long(*open_span, ended=False))
            self._dropping, self._last_move = True, self._j0 + last
            cut = last  # one row: the next change is measured from it
        self._rows = rows[cut:]
        self._j0 += cut
        return events

    def _drop_the_rest(self) -> None:
        """Drop the motion of a segment too long to fit, until it has rested (module doc)."""
        command = self._rows[:, COMMAND_COLUMN]
        moved = np.flatnonzero(np.abs(np.diff(command)) > STILL_SHARE * self._scale) + 1
        # the rows it last moved to: the last one known before these rows, then each in them
        moves = np.concatenate([[self._last_move - self._j0], moved])
        rests = np.flatnonzero(np.diff(moves) > self._pause)
        if rests.size:  # rested between two moves: the second starts another segment
            end = int(moves[rests[0]])
        elif command.size - 1 - int(moves[-1]) > self._pause:  # resting since its last move
            end = int(moves[-1])
        else:  # still moving, or not rested long enough yet: one row kept to measure from
            self._last_move = self._j0 + int(moves[-1])
            self._rows, self._j0 = self._rows[-1:], self._j0 + command.size - 1
            return
        self._dropping = False
        self._rows, self._j0 = self._rows[end + 1 :], self._j0 + end + 1

    def _too_long(self, a: int, b: int, *, ended: bool) -> Discarded:
        """The segment of held rows a..b, longer than `n` samples, given up."""
        j0 = self._j0 + a
        longest = f"{self.n / self.sample_rate:g} s"
        why = (
            f"an excitation segment of {(b - a) / self.sample_rate:g} s, longer than {longest}"
            if ended
            else f"an excitation segment longer than {longest} (the longest fitted) without a "
            f"pause of {self.rule.max_pause_s:g} s; the rest of its motion is dropped"
        )
        return Discarded(j0=j0, t0=j0 / self.sample_rate, samples=b - a + 1, reason=why)
