"""A rig's position commands as they arrive, read back at the simulated samples' times.

The simulated actuator commanded from outside (ema_node's `command_topic`) follows either a
joint trajectory controller (`TrajectoryInbox`: whole trajectories, interpolated by the
controller) or a stream of set-points (`CommandInbox`, a forward position controller's),
each taken from the moment it arrived, in one of two ways a servo drive does:

- ``hold``: the last set-point until the next one (zero-order hold).  A set-point stream
  at a few hundred Hz is then a staircase, and each stair drives a stiff position loop into
  its current limit (the packaged thesis drive, 1e5 1/s: +/-22.5 A on every stair);
- ``linear``: interpolated position, after CiA 402's interpolated position mode (which
  uses a fixed period; here the period is the interval between two arrivals): the command
  moves linearly from the previous set-point to the new one over that interval (one
  interval late), at most `MAX_SPAN_S`; a longer silence is a jump, not a slow ramp.  Set-
  points that arrive with jitter still make small jumps (a segment starts from the previous
  set-point, not from where the last segment had got).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ..errors import ConfigError

#: s of commands kept behind the latest time read (older ones are never asked for again).
KEEP_S = 30.0
#: The longest interval ``linear`` interpolates over [s].
MAX_SPAN_S = 0.1
#: How a commanded rig takes its set-points.
MODES: tuple[str, ...] = ("linear", "hold")


class CommandInbox:
    """Commands [rad] stamped with their arrival time [s, a monotonic clock]; thread-safe."""

    def __init__(self, start: float, mode: str = "linear") -> None:
        """`start`: the command held before the first one arrives (the rest position)."""
        if mode not in MODES:
            raise ConfigError(
                f"command interpolation must be one of {', '.join(MODES)}, got {mode!r}"
            )
        self.start, self.mode = float(start), mode
        self.received = 0
        self._times: list[float] = []
        self._values: list[float] = []
        self._lock = threading.Lock()

    def put(self, value: float, at: float) -> None:
        """The command `value` arrived at time `at`; ConfigError for a non-finite value."""
        if isinstance(value, bool) or not math.isfinite(float(value)):
            raise ConfigError(f"a position command must be a finite number, got {value!r}")
        with self._lock:
            if self._times and at < self._times[-1]:
                at = self._times[-1]  # arrivals are in order; a clock read late is not earlier
            self._times.append(float(at))
            self._values.append(float(value))
            self.received += 1

    def at(self, times: np.ndarray) -> np.ndarray:
        """The command held at each of `times` [s, the arrival clock]: the last one before it."""
        times = np.asarray(times, dtype=np.float64)
        with self._lock:
            if self._times and times.size:  # forget what no later time can ask for
                drop = int(np.searchsorted(self._times, float(times.min()) - KEEP_S))
                if drop > 0:  # the last forgotten one is the command held before the rest
                    self.start = self._values[drop - 1]
                    del self._times[:drop], self._values[:drop]
            stamps = np.asarray(self._times)
            values = np.asarray([self.start, *self._values])
        after = np.searchsorted(stamps, times, side="right")  # 0: before the first
        held = values[after]
        if self.mode == "hold" or stamps.size < 2:
            return held
        i = after - 1  # the last arrival at or before each time (-1: none)
        known = i >= 1  # the first arrival has no interval before it: it is held
        span = np.zeros(times.shape)
        span[known] = stamps[i[known]] - stamps[i[known] - 1]
        ramp = known & (span > 0) & (span <= MAX_SPAN_S)
        frac = np.ones(times.shape)
        frac[ramp] = np.minimum(1.0, (times[ramp] - stamps[i[ramp]]) / span[ramp])
        prev = values[np.maximum(after - 1, 0)]
        return np.where(ramp, prev + (held - prev) * frac, held)


class TrajectoryInbox:
    """A joint trajectory controller's set-points: each trajectory from its start on.

    A trajectory replaces what the last one commanded from its start time; between its
    points the command is interpolated linearly (a controller given positions only), from
    the position commanded at its start to its first point, and holds its last point.
    """

    def __init__(self, start: float) -> None:
        """`start`: the command held before the first trajectory (the rest position)."""
        self.start = float(start)
        self.received = 0
        self._t = np.empty(0)
        self._v = np.empty(0)
        self._lock = threading.Lock()

    def put(self, begins: float, offsets: np.ndarray, positions: np.ndarray) -> None:
        """A trajectory starting at `begins` [s]: points at begins + `offsets` [s], `positions`.

        ConfigError for no points, non-finite values or offsets that go back in time.
        """
        offsets = np.asarray(offsets, dtype=np.float64)
        positions = np.asarray(positions, dtype=np.float64)
        if offsets.size == 0 or offsets.shape != positions.shape:
            raise ConfigError(
                f"a trajectory needs one position per point, got {offsets.size} points and "
                f"{positions.size} positions"
            )
        if not (np.all(np.isfinite(offsets)) and np.all(np.isfinite(positions))):
            raise ConfigError("a trajectory's times and positions must be finite numbers")
        if offsets[0] < 0 or np.any(np.diff(offsets) <= 0):
            raise ConfigError(
                "a trajectory's points must have increasing times from its start, got "
                f"{offsets[:5].tolist()}..."
            )
        with self._lock:
            now = float(self._interp(np.array([begins]))[0])
            keep = self._t < begins
            # from what was commanded at its start (a first point at 0 is then a jump)
            self._t = np.concatenate([self._t[keep], [begins], begins + offsets])
            self._v = np.concatenate([self._v[keep], [now], positions])
            self.received += 1

    def _interp(self, times: np.ndarray) -> np.ndarray:
        if self._t.size == 0:
            return np.full(times.shape, self.start)
        return np.interp(times, self._t, self._v, left=self.start, right=self._v[-1])

    def at(self, times: np.ndarray) -> np.ndarray:
        """The command at each of `times` [s, the arrival clock]."""
        times = np.asarray(times, dtype=np.float64)
        with self._lock:
            if self._t.size and times.size:  # forget what no later time can ask for
                drop = int(np.searchsorted(self._t, float(times.min()) - KEEP_S))
                if drop > 1:  # keep one point before the rest, for the interpolation
                    self.start = float(self._v[drop - 2])
                    self._t, self._v = self._t[drop - 1 :], self._v[drop - 1 :]
            return self._interp(times)
