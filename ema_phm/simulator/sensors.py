"""The simulated actuator's imperfect sensors (sec. 2.1.8).

- `SensorSpec`: what the simulated actuator's sensors get wrong (gains, offsets, white noise,
  quantization), taken by `real_ema.simulate` and `real_ema.HFStream` as `sensors=`.
- `quantize`: the reading of a sensor with a finite resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from numba import njit

from ..errors import ConfigError
from ..limits import check


@njit(cache=True, error_model="numpy")
def quantize(x: float, step: float) -> float:
    """The reading of a sensor of resolution `step` (nearest level; step 0 = exact)."""
    if step <= 0.0:
        return x
    return step * math.floor(x / step + 0.5)


#: Gains must lie in this range: a sensor off by more than a factor 2 is broken, not imperfect.
_GAIN_RANGE = (0.5, 2.0)
#: |offset| bounds: the drive's 22.5 A current limit, the +/-0.5 rad end-stop travel.
_OFFSET_BOUND = {"current_offset": 22.5, "position_offset": 0.5}


@dataclass(frozen=True)
class SensorSpec:
    """The sensor errors of one simulated actuator (the default: ideal sensors).

    Which signal reads which sensor (`real_ema` applies them so):

    - phase current sensors, gain `current_gain`: read by the hysteresis current comparators
      (in the loop) and by the Park acquisition of I_3eq (telemetry).  `current_offset` [A]
      and `noise_current` [A RMS] are those of the acquired I_3eq channel (telemetry only): a
      common offset on the three phase sensors cancels in the Park transform (eq. 2.2).
    - user position sensor: reading = quantize(theta_u + `position_offset`,
      high_fidelity.position_resolution) + `noise_position` [rad RMS] noise.  The position
      loop reads it (offset, quantization and noise enter the loop) and so does the telemetry.
    - motor speed: reading = `speed_gain` * omega_m + `noise_speed` [rad/s RMS] noise; the
      speed loop and the telemetry read it.
    - resolver (motor angle): reading = quantize(theta_m, high_fidelity.resolver_resolution),
      in the telemetry; the commutation uses the exact angle (a 16-bit resolver's error,
      1e-4 rad, changes the torque by a relative 1e-8).

    Noise is white and Gaussian, a new draw at every control interrupt for the loop readings
    (the telemetry records the reading taken at its sample instant) and at every telemetry
    sample for I_3eq.
    """

    current_gain: float = 1.0
    current_offset: float = 0.0  # A, on the acquired I_3eq
    position_offset: float = 0.0  # rad, user position sensor
    speed_gain: float = 1.0
    noise_current: float = 0.0  # A RMS
    noise_position: float = 0.0  # rad RMS
    noise_speed: float = 0.0  # rad/s RMS

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"sensor {f.name} must be a finite number, got {v!r}")
        for name in ("current_gain", "speed_gain"):
            v = getattr(self, name)
            if not _GAIN_RANGE[0] <= v <= _GAIN_RANGE[1]:
                raise ConfigError(
                    f"sensor {name} = {v:g} must be in [{_GAIN_RANGE[0]:g}, {_GAIN_RANGE[1]:g}]"
                )
        for name, bound in _OFFSET_BOUND.items():
            v = getattr(self, name)
            if abs(v) > bound:
                raise ConfigError(f"sensor {name} = {v:g} must be in [{-bound:g}, {bound:g}]")
        for name in ("noise_current", "noise_position", "noise_speed"):
            check(name, getattr(self, name), label=f"sensor {name}")

    @property
    def noisy(self) -> bool:
        """True when any channel has noise."""
        return bool(self.noise_current or self.noise_position or self.noise_speed)

    def as_dict(self) -> dict[str, float]:
        """The fields as a dict (for window metadata)."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}
