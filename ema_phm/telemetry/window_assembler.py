"""Cut a stream of telemetry batches into complete, boundary-aligned windows.

rclpy-free: the monitor node feeds it the rows of each `/ema/telemetry`
message; tests and replays feed it arrays.

Alignment.  Sample j of the stream is at t = j / sample_rate.  With N samples
per window (N = window duration * sample_rate), a window starts at a sample
whose index is a multiple of N (t a multiple of the window duration) and holds
the N + 1 samples j0 .. j0 + N, so consecutive windows share their boundary
sample.  A stream joined mid-way is skipped up to the next boundary.

Continuity.  Consecutive samples must have consecutive indices.  A missing
stretch (a dropped message, a time gap) or a step back in time (an
out-of-order or repeated message) discards the window being assembled, with a
reason; assembly resumes at the next boundary after the break.

`parse_run_info` turns the `/ema/run_info` JSON into the assembler's two
numbers, checked against `ema_phm.limits` (anything else -> ConfigError).

`read_fitted_windows` reads back the windows a monitor node recorded on
`/ema/window` (see README, "ROS 2").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..domain.window import TIME_COLUMN, Window, telemetry_rows
from ..errors import BagError, ConfigError, WindowError
from ..limits import check
from .wire import GROUND_TRUTH_TOPIC, RUN_INFO_TOPIC, WINDOW_TOPIC, cycle_of_label

#: A sample time may sit this far (in sample periods) off the grid and still count as on it.
GRID_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Completed:
    """A complete window: rows j0 .. j0 + N (N + 1 samples, CHANNELS order)."""

    j0: int
    data: np.ndarray
    #: the operating cycle the window is (None: numbered by its time, `tracker.cycle_of`)
    cycle: int | None = None

    @property
    def t0(self) -> float:
        """Time of the first sample [s]."""
        return float(self.data[0, TIME_COLUMN])

    @property
    def t1(self) -> float:
        """Time of the last sample [s]."""
        return float(self.data[-1, TIME_COLUMN])


@dataclass(frozen=True)
class Discarded:
    """A window given up before it was complete, and why."""

    j0: int
    t0: float
    samples: int  # how many of its N + 1 samples had arrived
    reason: str
    #: a listed window some of whose rows never came (not one cut short by its length)
    unrecorded: bool = False


@dataclass(frozen=True)
class RunInfo:
    """A checked `/ema/run_info`: the window geometry and the whole JSON object."""

    sample_rate: float
    samples_per_window: int
    info: dict[str, Any]


def parse_run_info(text: str) -> RunInfo:
    """`/ema/run_info` JSON -> RunInfo.

    ConfigError naming the problem for anything malformed (not JSON, nested too deeply, not an
    object, sample_rate / samples_per_window missing, of the wrong type, NaN, infinite or outside
    `ema_phm.limits.LIMITS`).
    """
    try:
        info = json.loads(text)
    except RecursionError:
        raise ConfigError(f"run_info JSON is nested too deeply ({len(text)} characters)") from None
    except ValueError as exc:
        raise ConfigError(f"run_info is not JSON: {exc}") from None
    if not isinstance(info, dict):
        raise ConfigError(f"run_info must be a JSON object, got {type(info).__name__}") from None
    for key in ("sample_rate", "samples_per_window"):
        if key not in info:
            raise ConfigError(f"run_info has no {key!r}") from None
    fs = float(check("sample_rate", info["sample_rate"], label="run_info sample_rate"))
    n = int(
        check(
            "samples_per_window", info["samples_per_window"], label="run_info samples_per_window"
        )
    )
    return RunInfo(fs, n, info)


def grid_indices(t: np.ndarray, sample_rate: float) -> np.ndarray:
    """Sample indices of times t; -1 where a time is off the grid or not finite."""
    x = np.asarray(t, dtype=np.float64) * sample_rate
    with np.errstate(invalid="ignore"):
        j = np.where(np.isfinite(x), np.rint(x), -1.0)
        bad = ~np.isfinite(x) | (np.abs(x - j) > GRID_TOLERANCE) | (j < 0)
    return np.where(bad, -1, j).astype(np.int64)


def grid_runs(rows: np.ndarray, sample_rate: float) -> list[tuple[int, np.ndarray]]:
    """A batch's runs of consecutive grid samples: (first grid index, rows), -1 off the grid.

    `rows` are n x 8 in CHANNELS order, or legacy n x 7 (given a NaN temperature); any other
    shape is a WindowError.
    """
    rows = telemetry_rows(rows)
    if rows.shape[0] == 0:
        return []
    j = grid_indices(rows[:, TIME_COLUMN], sample_rate)
    breaks = np.flatnonzero((np.diff(j) != 1) | (j[1:] < 0)) + 1
    edges = [0, *breaks.tolist(), rows.shape[0]]
    return [(int(j[a]), rows[a:b]) for a, b in zip(edges[:-1], edges[1:], strict=True)]


class WindowAssembler:
    """Feed batches with `feed(rows)`; get back `Completed` and `Discarded` events."""

    def __init__(self, sample_rate: float, samples_per_window: int) -> None:
        if not (math.isfinite(sample_rate) and sample_rate > 0):
            raise WindowError(f"sample_rate must be > 0, got {sample_rate}")
        if int(samples_per_window) != samples_per_window or samples_per_window < 2:
            raise WindowError(
                f"samples_per_window must be an integer >= 2, got {samples_per_window}"
            )
        self.sample_rate = float(sample_rate)
        self.n = int(samples_per_window)
        self._parts: list[np.ndarray] = []
        self._count = 0
        self._j0: int | None = None  # first index of the window being assembled
        self._next: int | None = None  # index expected next (None: nothing seen yet)
        self.samples_skipped = 0  # samples seen outside any window (before a boundary)

    @property
    def pending_samples(self) -> int:
        """Samples collected towards the window being assembled."""
        return self._count

    def reset(self, reason: str | None = None) -> list[Discarded]:
        """Forget everything; returns the discarded partial window, if any (with `reason`)."""
        out = self._give_up(reason or "assembler reset") if self._j0 is not None else []
        self._next = None
        return out

    def _give_up(self, reason: str) -> list[Discarded]:
        j0 = self._j0
        ev = (
            [Discarded(j0=int(j0), t0=j0 / self.sample_rate, samples=self._count, reason=reason)]
            if j0 is not None
            else []
        )
        self._parts, self._count, self._j0 = [], 0, None
        return ev

    def indices(self, t: np.ndarray) -> np.ndarray:
        """Sample indices of times t; -1 where a time is off the grid or not finite."""
        return grid_indices(t, self.sample_rate)

    def feed(self, rows: np.ndarray) -> list[Completed | Discarded]:
        """Add one batch of samples; return what it completed or broke.

        `rows` are n x 8 in CHANNELS order, or legacy n x 7 (given a NaN temperature);
        any other shape is a WindowError.
        """
        events: list[Completed | Discarded] = []
        for first, run in grid_runs(rows, self.sample_rate):
            if first < 0:
                events += self._give_up(
                    f"sample time {run[0, TIME_COLUMN]!r} s is not on the "
                    f"{self.sample_rate:g} Hz grid"
                )
                self._next = None
                continue
            events += self._run(first, run)
        return events

    def _run(self, a: int, run: np.ndarray) -> list[Completed | Discarded]:
        events: list[Completed | Discarded] = []
        fs = self.sample_rate
        if self._next is not None and a != self._next:
            if a > self._next:
                gap = a - self._next
                reason = (
                    f"time gap: {gap} sample(s) ({gap / fs:.4g} s) missing before t = "
                    f"{a / fs:.6g} s "
                    f"(dropped message?)"
                )
            else:
                reason = (
                    f"out-of-order or repeated samples: got t = {a / fs:.6g} s, expected "
                    f"t = {self._next / fs:.6g} s"
                )
            events += self._give_up(reason)
        self._next = a + run.shape[0]
        if self._j0 is None:
            first_b = -(-a // self.n) * self.n  # first boundary index >= a
            if first_b > a + run.shape[0] - 1:
                self.samples_skipped += run.shape[0]
                return events
            self.samples_skipped += first_b - a
            run = run[first_b - a :]
            self._j0 = first_b
        self._parts.append(run)
        self._count += run.shape[0]
        while self._count >= self.n + 1:
            data = np.concatenate(self._parts) if len(self._parts) > 1 else self._parts[0]
            events.append(
                Completed(j0=int(self._j0), data=np.ascontiguousarray(data[: self.n + 1]))
            )
            rest = data[self.n :]  # the boundary sample starts the next window
            self._parts, self._count = [rest], rest.shape[0]
            self._j0 += self.n
        return events


def _labelled_cycle(path: Path, index: int, msg: Any) -> int | None:
    """The cycle a recorded window's label carries (`wire.cycle_of_label`); BagError."""
    dims = list(msg.layout.dim)
    try:
        return cycle_of_label(str(dims[0].label)) if dims else None
    except WindowError as exc:
        raise BagError(f"bag {path}: {WINDOW_TOPIC} message {index}: {exc}") from None


def read_fitted_windows(path: str | Path) -> list[Window]:
    """The windows a monitor node recorded on `/ema/window`, in log-time order.

    Each gets, as `k_true` / `meta`, the last `/ema/ground_truth` / `/ema/run_info`
    logged before it (when the bag has them); `meta` ``cycle`` is the one the window's
    label carries (`wire.samples_label`: a stream that numbers its windows), none otherwise.
    Raises BagError when the bag has no `/ema/window` messages, a malformed label or a
    ground truth that is not N_K finite numbers in [0, 1].
    """
    # rosbags is loaded only when a bag is read, not by a live monitor's assembler
    from .bag_reader import ground_truth, read_messages, telemetry_rows  # noqa: PLC0415

    out: list[Window] = []
    k_true: np.ndarray | None = None
    meta: dict[str, Any] = {}
    for topic, _type, t_ns, msg in read_messages(
        path, [WINDOW_TOPIC, GROUND_TRUTH_TOPIC, RUN_INFO_TOPIC]
    ):
        if topic == WINDOW_TOPIC:
            rows = telemetry_rows(Path(path), len(out), msg, topic=WINDOW_TOPIC)
            cycle = _labelled_cycle(Path(path), len(out), msg)
            own = {k: v for k, v in meta.items() if k != "cycle"}  # a run_info's is not this
            if cycle is not None:
                own["cycle"] = cycle
            out.append(Window.from_matrix(rows, k_true=k_true, meta=own))
        elif topic == GROUND_TRUTH_TOPIC:
            k_true = ground_truth(Path(path), msg, t_ns)
        else:
            try:
                info = json.loads(msg.data)
            except ValueError:
                info = None
            meta = info if isinstance(info, dict) else {}
    if not out:
        raise BagError(f"bag {path} has no {WINDOW_TOPIC} messages")
    return out
