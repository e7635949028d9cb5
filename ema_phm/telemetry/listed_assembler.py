"""Cut a live stream at given times: a channel map's ``times`` and ``marker`` rules, live.

rclpy-free, with `window_assembler.WindowAssembler`'s interface (`feed`, `reset`,
`pending_samples`) and one more call, `mark`.  The monitor uses it when its run_info asks for
windows by ``times`` or by ``marker`` (`ListedRule`).  A window is a [start, end] on the
stream's clock (seconds from its first row, as a row's time column says), listed up front
(``times``: the run_info's list) or marked as the stream goes (``marker``:
`importing.live.MarkerRuns` finds where the marker is non-zero and calls `mark` once a run
has ended).

A time becomes a grid index by `grid_index` (the offline cut uses it too).  A window is
given once the rows through its end have arrived, if every row of it did; otherwise it is
discarded with the reason, as offline a listed window not wholly recorded is dropped
(`importing.segments.by_times`).  Whatever breaks the stream (missing samples, a row off
the grid, a `reset`) breaks the windows across it.  At most 2 (`n` + 1) rows are held (`n`:
the longest window given; a longer one is discarded), so memory is bounded.  A stream whose
time steps back by more than `RESTART_S` (a restarted rig) is cut by the same list again, as
offline each log is; a window marked before the step is discarded.  Windows are numbered
in the order they end (offline too), from ``first_cycle``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..limits import check
from .window_assembler import Completed, Discarded, grid_runs

#: The rules this assembler cuts by.
LISTED_RULES = ("times", "marker")
#: How the reason of a window whose rows did not all arrive ends.
NOT_RECORDED = "was not wholly recorded"
#: Time stepping back this far [s] starts the stream anew (as `importing.live` says).
RESTART_S = 1.0
#: The latest listed time [s] (about 32 years): its grid index must be a machine integer.
LATEST_S = 1.0e9


def grid_index(t: float, rate: float) -> int:
    """The grid index nearest time `t` [s]; half-way goes down (offline's nearest sample)."""
    return math.ceil(t * rate - 0.5)


def listed_order(times: tuple[tuple[float, float], ...]) -> list[tuple[float, float]]:
    """Listed windows in the order they end (then start): the order they are numbered in."""
    return sorted(times, key=lambda w: (w[1], w[0]))


@dataclass(frozen=True)
class ListedRule:
    """A run_info's ``windows`` by ``times`` or ``marker`` (the channel map's `WindowRule`)."""

    by: str
    times: tuple[tuple[float, float], ...] = ()  # times: [start, end] from the stream's start
    min_duration_s: float = 0.0  # marker: a shorter run is not marked (`MarkerRuns`)
    first_cycle: int = 0

    @classmethod
    def from_info(cls, windows: Mapping[str, Any]) -> ListedRule:
        """The rule of a run_info ``windows`` object by times or marker; ConfigError naming it."""
        by = windows.get("by")
        first = windows.get("first_cycle", 0)
        if not isinstance(first, int) or isinstance(first, bool) or first < 0:
            raise ConfigError(
                f"run_info windows first_cycle must be a whole number >= 0, got {first!r}"
            )
        if by == "marker":
            low = windows.get("min_duration_s", 0.0)
            if not isinstance(low, (int, float)) or isinstance(low, bool) or not 0 <= low < 1e9:
                raise ConfigError(
                    f"run_info windows min_duration_s must be in [0, 1e9) s, got {low!r}"
                )
            return cls("marker", min_duration_s=float(low), first_cycle=first)
        listed = windows.get("times", ())
        try:
            times = tuple((float(a), float(b)) for a, b in listed)
        except (TypeError, ValueError, OverflowError):
            raise ConfigError(
                f"run_info windows times must be a list of [start, end], got {listed!r}"
            ) from None
        if not all(0 <= a < b <= LATEST_S for a, b in times):
            raise ConfigError(
                f"run_info windows times need 0 <= start < end <= {LATEST_S:g} s, got {listed!r}"
            )
        return cls("times", times=times, first_cycle=first)

    def as_info(self) -> dict[str, Any]:
        """The run_info ``windows`` value of this rule."""
        if self.by == "marker":
            return {
                "by": "marker",
                "min_duration_s": self.min_duration_s,
                "first_cycle": self.first_cycle,
            }
        return {
            "by": "times",
            "times": [list(w) for w in self.times],
            "first_cycle": self.first_cycle,
        }


class ListedAssembler:
    """Feed rows with `feed(rows)`, mark windows with `mark`; get back windows (module doc)."""

    def __init__(self, sample_rate: float, longest: int, rule: ListedRule) -> None:
        """`longest`: samples a window may span at most (a longer one is discarded)."""
        self.sample_rate = float(check("sample_rate", sample_rate))
        self.n = int(check("samples_per_window", longest))
        self.rule = rule
        self.cycle = rule.first_cycle  # the next window's
        self._blocks: list[np.ndarray] = []  # consecutive rows held, grid index _j0 onwards
        self._held = 0
        self._j0 = 0
        self._next: int | None = None  # grid index expected next (None: after a break)
        self._last: int | None = None  # grid index of the last row fed, kept across a break
        self._listed = self._armed()

    def _armed(self) -> list[tuple[int, int]]:
        """The rule's listed windows as grid indices (first, last), in order of their end."""
        rate = self.sample_rate
        return [
            (grid_index(a, rate), grid_index(b, rate)) for a, b in listed_order(self.rule.times)
        ]

    @property
    def pending_samples(self) -> int:
        """Rows held towards the windows to come."""
        return self._held

    @property
    def waiting(self) -> int:
        """Windows listed or marked, not yet given or discarded."""
        return len(self._listed)

    def reset(self, reason: str | None = None) -> list[Completed | Discarded]:
        """The stream breaks here: the rows held are forgotten (a window across it is lost)."""
        self._blocks, self._held, self._next = [], 0, None
        return []

    def feed(self, rows: np.ndarray) -> list[Completed | Discarded]:
        """Add one batch of rows; return the windows it completed or broke."""
        events: list[Completed | Discarded] = []
        for first, run in grid_runs(rows, self.sample_rate):
            if first < 0:  # off the grid: the stretch ends, the row is not used
                self.reset()
                continue
            if self._last is not None and first < self._last - RESTART_S * self.sample_rate:
                self._listed = self._armed()  # a new stream (a repeated message is not)
            if self._next is None or first != self._next:
                self._blocks, self._held, self._j0 = [], 0, first
            self._blocks.append(run)
            self._held += run.shape[0]
            self._next = first + run.shape[0]
            self._last = self._next - 1
            events += self._give()
            self._trim()
        return events

    def mark(self, start_s: float, end_s: float) -> list[Completed | Discarded]:
        """A window [start_s, end_s] of rows already fed (or to come); what it completed."""
        rate = self.sample_rate
        window = (grid_index(start_s, rate), grid_index(end_s, rate))
        self._listed = sorted([*self._listed, window], key=lambda w: (w[1], w[0]))
        return self._give()

    def _give(self) -> list[Completed | Discarded]:
        """Each listed window whose end has arrived: given whole, or discarded with why."""
        events: list[Completed | Discarded] = []
        while self._listed and self._last is not None and self._listed[0][1] <= self._last:
            a, b = self._listed.pop(0)
            events.append(self._window(a, b))
        return events

    def _window(self, a: int, b: int) -> Completed | Discarded:
        rate = self.sample_rate
        what = f"the window {a / rate:g}-{b / rate:g} s"
        if b - a > self.n:
            longest = f"{self.n / rate:g} s"
            why = f"{what} is {(b - a) / rate:g} s long, longer than the longest fitted, {longest}"
            return Discarded(j0=a, t0=a / rate, samples=b - a + 1, reason=why)
        if a < self._j0 or not self._held or b >= self._j0 + self._held:
            held = (
                f"rows from {self._j0 / rate:g} s on only: a gap, or before them"
                if self._held
                else "no rows held: the stream broke"
            )
            why = f"{what} ({held}) {NOT_RECORDED}"
            samples = max(0, b - self._j0 + 1)
            return Discarded(j0=a, t0=a / rate, samples=samples, reason=why, unrecorded=True)
        self.cycle += 1
        return Completed(j0=a, data=self._rows(a, b), cycle=self.cycle - 1)

    def _rows(self, a: int, b: int) -> np.ndarray:
        """A copy of the held rows of grid indices a..b."""
        pieces, j = [], self._j0
        for block in self._blocks:
            lo, hi = max(a - j, 0), min(b - j + 1, block.shape[0])
            if lo < hi:
                pieces.append(block[lo:hi])
            j += block.shape[0]
        return np.ascontiguousarray(np.concatenate(pieces))

    def _trim(self) -> None:
        """Keep the last `n` + 1 rows (any window ending at the newest), 2 (`n` + 1) at most."""
        keep = self.n + 1
        while len(self._blocks) > 1 and self._held - self._blocks[0].shape[0] >= keep:
            first = self._blocks.pop(0)
            self._held -= first.shape[0]
            self._j0 += first.shape[0]
        if self._held > 2 * keep:  # one block of a long batch: a copy of its tail, not a view
            tail = self._rows(self._j0 + self._held - keep, self._j0 + self._held - 1)
            self._blocks, self._j0, self._held = [tail], self._j0 + self._held - keep, keep
