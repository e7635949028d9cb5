"""The simulated actuator as a stream of telemetry messages, free of rclpy.

`ActuatorStream` runs the HF model (`HFStream`) message by message, repeating
the command window; sample j is at t = j / sample_rate.  A new k requested at
any time takes effect exactly at the next window boundary, so no window mixes
two fault states.  With `max_windows` > 0 the stream ends after sample
max_windows * N (N samples per window): exactly that many aligned windows.

With a `degradation` (`physics.degradation`), each window is one operating cycle: window c
(samples cN .. (c+1)N) runs with ``degradation.k(c)``, held constant inside it and changed
at its boundary as a requested k is (`degradation.simulate_cycles` cuts the same windows);
k cannot be requested then.  An uncapped law that leaves [0, 1] stops the stream with the
FaultVectorError naming the fault and cycle (checked up front when `max_windows` > 0).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from .. import __version__
from ..domain.faults import validate
from ..domain.window import telemetry_rows
from ..errors import ConfigError
from ..physics.commands import CommandSpec, LoadSpec
from ..physics.parameters import ActuatorParameters
from .degradation import Degradation
from .real_ema import HFStream
from .unit import select_unit, unit_record


@dataclass(frozen=True)
class Message:
    """The rows of one telemetry message; `k_changed`: a new k took effect in (or before) them."""

    rows: np.ndarray
    k_changed: bool


class ActuatorStream:
    """The HF model cut into messages of `samples_per_message` samples; thread-safe `request_k`."""

    def __init__(
        self,
        k: Sequence[float],
        *,
        command: CommandSpec,
        load: LoadSpec,
        seed: int,
        noise: tuple[float, float, float],
        samples_per_message: int,
        max_windows: int,
        realtime_factor: float,
        unit: str = "",
        unit_seed: int | None = None,
        temperature_c: float | None = None,
        degradation: Degradation | None = None,
        cycle_hours: float | None = None,
        actuator: ActuatorParameters | None = None,
        command_at: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> None:
        """`unit` / `unit_seed`: the unit described or drawn (`physics.unit.select_unit`).

        `command_at(t)`: the position commands [rad] at sample times t [s] (a rig commanded
        from outside, `command_inbox.CommandInbox`); None: `command`'s window, repeated.

        `actuator`: the datasheet the unit is drawn around (None: the packaged thesis
        actuator, `ActuatorParameters.default()`; an actuator file: `load_actuator`).

        `degradation`: k per cycle instead of `k` from cycle 0 on; `cycle_hours`: its hours
        per cycle (None: `Degradation.hours_per_cycle`).
        """
        self.degradation = degradation
        self.cycle_hours = (
            None if degradation is None else degradation.hours_per_cycle(cycle_hours)
        )
        if degradation is not None and max_windows:
            degradation.check_cycles(max_windows)  # a law leaving [0, 1] refused up front
        self.command, self.load, self.seed, self.noise = command, load, seed, noise
        self.unit = select_unit(unit, unit_seed)
        self.unit_origin = unit_record(self.unit, spec=unit, seed=unit_seed)
        self.temperature_c = temperature_c
        self.samples_per_message = samples_per_message
        self.max_windows = max_windows
        self.realtime_factor = realtime_factor
        self.command_at = command_at
        self._model = self._hf_stream(k, actuator or ActuatorParameters.default())
        self.sample_rate = float(self._model.sample_rate)
        self.samples_per_window = int(self._model.samples_per_window)
        if self.samples_per_window < 2:
            raise ConfigError(
                f"duration {command.duration} s holds fewer than 2 samples at "
                f"{self.sample_rate:g} Hz"
            )
        self._end = max_windows * self.samples_per_window + 1 if max_windows else None
        self._lock = threading.Lock()
        self._pending_k: np.ndarray | None = None
        self._k_since_j = 0
        self.k_changes_applied = 0
        self._cycle_k = None if degradation is None else validate(k)  # the last cycle's k

    def _hf_stream(self, k: Sequence[float], datasheet: ActuatorParameters) -> HFStream:
        """The HF of this stream's unit built to `datasheet`, at its temperature."""
        noise = self.noise
        return HFStream(
            list(k),
            actuator=self.unit.actuator(datasheet, temperature_c=self.temperature_c),
            command=self.command,
            load=self.load,
            sensors=self.unit.sensors(
                noise_current=noise[0], noise_position=noise[1], noise_speed=noise[2]
            ),
            seed=self.seed,
            temperature_c=self.temperature_c,
        )

    @property
    def k(self) -> np.ndarray:
        """The fault vector the model currently runs with."""
        return self._model.k.copy()

    @property
    def k_since_t(self) -> float:
        """Time of the window boundary from which `k` holds."""
        return self._k_since_j / self.sample_rate

    @property
    def windows_complete(self) -> int:
        """Windows whose every sample has been emitted."""
        return self._model.j // self.samples_per_window

    def check_k_may_be_set(self) -> None:
        """ConfigError while a degradation gives k (it cannot be set then)."""
        if self.degradation is not None:
            raise ConfigError(
                f"k follows the degradation {self.degradation.source or '(given)'} cycle by "
                "cycle; it cannot be set while one is given"
            )

    def request_k(self, k: Sequence[float]) -> np.ndarray:
        """Validate a new k (FaultVectorError if bad) and apply it at the next window boundary.

        ConfigError while a degradation gives k (`check_k_may_be_set`).
        """
        self.check_k_may_be_set()
        checked = validate(k)
        with self._lock:
            self._pending_k = checked
        return checked

    def apply_pending_k(self) -> bool:
        """Apply a pending k now (at a window boundary or after the end); True if one was."""
        with self._lock:
            k, self._pending_k = self._pending_k, None
        if k is None:
            return False
        self._model.set_k(k)
        self._k_since_j = max(self._model.j, 0)
        self.k_changes_applied += 1
        return True

    def _next_count(self) -> int:
        """Samples in the next message (0: `max_windows` windows are out)."""
        first = self._model.j + 1
        if self._end is None:
            return self.samples_per_message
        return max(0, min(self.samples_per_message, self._end - first))

    def next_times(self) -> tuple[float, float] | None:
        """The times [s] of the next message's first and last samples (None: the end)."""
        n = self._next_count()
        if n == 0:
            return None
        first = self._model.j + 1
        return first / self.sample_rate, (first + n - 1) / self.sample_rate

    def next_message(self) -> Message | None:
        """The next message's rows, or None once `max_windows` windows are out."""
        n = self._next_count()
        if n == 0:
            return None
        parts, changed = [], False
        big_n = self.samples_per_window
        while n > 0:
            j = self._model.j
            if j < 0 or j % big_n == 0:
                self._follow_degradation(max(j, 0) // big_n)
                if self._pending_k is not None:
                    changed |= self.apply_pending_k()
            chunk = n
            if (self._pending_k is not None or self.degradation is not None) and j >= 0:
                chunk = min(chunk, big_n - j % big_n)  # stop on the boundary, change k there
            commands = None
            if self.command_at is not None:
                commands = self.command_at((j + 1 + np.arange(chunk)) / self.sample_rate)
            parts.append(self._model.advance(chunk, commands))
            n -= chunk
        rows = parts[0] if len(parts) == 1 else np.vstack(parts)
        # an HF that reports no temperature (7 columns) gets a NaN temperature column
        return Message(telemetry_rows(rows), changed)

    def _follow_degradation(self, cycle: int) -> None:
        """At the start of window `cycle`: request the degradation's k when it changed."""
        if self.degradation is None:
            return
        k = self.degradation.k(cycle)
        last = self._cycle_k  # set whenever a degradation is
        if last is None or not np.array_equal(k, last):  # both from validate(): same floats
            self._cycle_k = k
            with self._lock:
                self._pending_k = k

    def run_info(self) -> dict[str, Any]:
        """The JSON object published on /ema/run_info (with a degradation, as `simulate`'s)."""
        info = {
            "source": "ema_phm.ros.ema_node",
            "version": __version__,
            "sample_rate": self.sample_rate,
            "window_duration": self.samples_per_window / self.sample_rate,
            "samples_per_window": self.samples_per_window,
            "samples_per_message": self.samples_per_message,
            "command": self.command.as_dict(),
            "load": self.load.as_dict(),
            "seed": self.seed,
            "noise_current": self.noise[0],
            "noise_position": self.noise[1],
            "noise_speed": self.noise[2],
            "unit": self.unit_origin,
            "temperature_c": self.temperature_c,
            "realtime_factor": self.realtime_factor,
            "max_windows": self.max_windows,
            "k_true": [float(v) for v in self._model.k],
            "k_since_t": self.k_since_t,
        }
        if self.degradation is not None:
            info.update(
                cycle_hours=self.cycle_hours,
                degradation=self.degradation.as_dict(),
                degradation_file=self.degradation.source,
            )
        return info
