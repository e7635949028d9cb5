"""Cut a live stream at given times: a channel map's ``times`` and ``marker`` rules, live.

rclpy-free, with `window_assembler.WindowAssembler`'s interface (`feed`, `reset`,
`pending_samples`) and one more call, `mark`.  The monitor uses it when its run_info asks for
windows by ``times`` or by ``marker`` (`ListedRule`).  A window is a [start, end] on the
stream's clock (seconds from its first row, as a row's time column says), listed up front
(``times``: the run_info's list) or marked as the stream goes (``marker``:
`importing.live.MarkerRuns` finds where the marker is non-zero and calls `mark` once a run
has ended).

A window is given once the rows through its end have arrived, if every row of it did;
otherwise it is discarded with the reason, as offline a listed window not wholly recorded
is dropped (`importing.segments.by_times`).  Whatever breaks the stream (missing samples, a
row off the grid, a `reset`) breaks the windows across it.  At most `n` samples are held
(the longest window given; a longer one is discarded), in the blocks they came in, so
memory is bounded and a row is copied once more only when its window is given.  A stream
whose time steps back (a restarted rig) is cut by the same list again, as offline each log
is.  Windows are numbered in the order they are given, from ``first_cycle``.
"""

from __future__ import annotations

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
            if not isinstance(low, (int, float)) or isinstance(low, bool) or not low >= 0:
                raise ConfigError(f"run_info windows min_duration_s must be >= 0, got {low!r}")
            return cls("marker", min_duration_s=float(low), first_cycle=first)
        listed = windows.get("times", ())
        try:
            times = tuple((float(a), float(b)) for a, b in listed)
        except (TypeError, ValueError):
            raise ConfigError(
                f"run_info windows times must be a list of [start, end], got {listed!r}"
            ) from None
        if not all(0 <= a < b < np.inf for a, b in times):
            raise ConfigError(f"run_info windows times need 0 <= start < end, got {listed!r}")
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
        self._next: int | None = None  # grid index expected next
        self._listed = self._armed()

    def _armed(self) -> list[tuple[int, int]]:
        """The rule's listed windows as grid indices (first, last), in order of their end."""
        rate = self.sample_rate
        return sorted(((round(a * rate), round(b * rate)) for a, b in self.rule.times), key=_end)

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
            if self._next is not None and first < self._next:  # time stepped back: a new stream
                self._listed = self._armed()
            if self._next is None or first != self._next:
                self._blocks, self._held, self._j0 = [], 0, first
            self._blocks.append(run)
            self._held += run.shape[0]
            self._next = first + run.shape[0]
            events += self._give()
            self._trim()
        return events

    def mark(self, start_s: float, end_s: float) -> list[Completed | Discarded]:
        """A window [start_s, end_s] of rows already fed (or to come); what it completed."""
        window = (round(start_s * self.sample_rate), round(end_s * self.sample_rate))
        self._listed = sorted([*self._listed, window], key=_end)
        return self._give()

    def _give(self) -> list[Completed | Discarded]:
        """Each listed window whose end has arrived: given whole, or discarded with why."""
        events: list[Completed | Discarded] = []
        while self._listed and self._next is not None and _end(self._listed[0]) < self._next:
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
        if a < self._j0:
            since = f"{self._j0 / rate:g} s"
            why = f"{what} (rows from {since} on only: a gap, or before them) {NOT_RECORDED}"
            return Discarded(j0=a, t0=a / rate, samples=max(0, b - self._j0 + 1), reason=why)
        held = self._blocks[0] if len(self._blocks) == 1 else np.concatenate(self._blocks)
        self._blocks = [held]
        data = np.ascontiguousarray(held[a - self._j0 : b - self._j0 + 1])
        self.cycle += 1
        return Completed(j0=a, data=data, cycle=self.cycle - 1)

    def _trim(self) -> None:
        """Keep the last `n` rows, at least: enough for any window ending at the newest."""
        while len(self._blocks) > 1 and self._held - self._blocks[0].shape[0] >= self.n + 1:
            first = self._blocks.pop(0)
            self._held -= first.shape[0]
            self._j0 += first.shape[0]


def _end(window: tuple[int, int]) -> int:
    return window[1]
