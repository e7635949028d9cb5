"""Signal acquisition (sec. 2.1.8) and the HF's imperfect sensors.

- `filter_coefficients`: the 2nd-order Butterworth on I_3eq both models share (the monitor
  model imports it from here, so it never imports the HF model).
- `SensorSpec`: what the simulated actuator's sensors get wrong (gains, offsets, white noise,
  quantization), taken by `real_ema.simulate` and `real_ema.HFStream` as `sensors=`.
- `quantize`: the reading of a sensor with a finite resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from ..errors import ConfigError
from ..limits import check


def noise_variance(x: np.ndarray) -> float:
    """White-noise variance of a recorded signal from the MAD of its second differences.

    Robust to a smooth signal under the noise (a second difference of white noise has
    variance 6 sigma^2; the signal's is small at 2 kHz).
    """
    d2 = np.diff(np.asarray(x, dtype=np.float64), 2)
    if d2.size < 3:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return (1.4826 * mad) ** 2 / 6.0


def filter_coefficients(cutoff_hz: float, dt: float) -> tuple[float, float, float, float, float]:
    """2nd-order Butterworth low-pass (bilinear, pre-warped) as b0, b1, b2, a1, a2."""
    fs = 1.0 / dt
    if not 0 < cutoff_hz < 0.5 * fs:
        raise ConfigError(f"current filter cutoff {cutoff_hz} Hz must be in (0, {0.5 * fs:g}) Hz")
    # closed form of scipy.signal.butter(2, fc, fs=fs): importing scipy.signal costs ~1 s
    warped = math.tan(math.pi * cutoff_hz / fs)
    norm = 1.0 / (1.0 + math.sqrt(2.0) * warped + warped * warped)
    b0 = warped * warped * norm
    return (
        b0,
        2.0 * b0,
        b0,
        2.0 * (warped * warped - 1.0) * norm,
        (1.0 - math.sqrt(2.0) * warped + warped * warped) * norm,
    )


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
