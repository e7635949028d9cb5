"""Following the recorded loop: what the monitor model reads besides the command.

Replaying the command open-loop (the thesis) cannot follow what the real closed loop does
with its own realisation: noise its loops read, a play's limit cycle, stacked faults.  So
the monitor's position loop may read the *recorded* user position, and its shafts may
restart from the recorded motor angle and speed every few tens of ms (multiple shooting;
twist, current and controller state carried over).  The kernel (monitor_model.lf_kernel)
takes the (n, 3) array `RecordedLoop.inputs` builds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import butter, sosfiltfilt

from ..domain.window import Window
from ..errors import ConfigError
from ..physics.signals import noise_variance

#: Columns of the recorded-loop input (n, 3): the position the drive's loop read
#: (prefiltered), the resolver's motor angle [rad] and the motor speed [rad/s].
REC_POSITION, REC_THETA_M, REC_OMEGA_M = 0, 1, 2


@dataclass(frozen=True)
class RecordedLoop:
    """How the monitor follows the recorded loop instead of replaying the command open-loop.

    `follow`: the position loop reads the recorded user position, low-passed at
    `feedback_hz` (2nd order, zero phase: the drive's loop read its sensor about ten times
    per telemetry sample, each with its own noise, so the recorded noise is not what it
    followed).  `segment_s` > 0: the motor angle and speed restart from
    the recorded ones every `segment_s` (multiple shooting); `anchor_hz` low-passes the
    recorded speed they restart from (0: raw).  `motor_side`: the fed-back position is the
    resolver's angle through the gear (clean, full bandwidth) plus the recorded deflection
    (user position less it: play, twist, offset) low-passed at `feedback_hz`, so that only
    the deflection carries the position sensor's noise into the loop; a clean deflection
    (`clean_below_rad`) goes in unfiltered.  The defaults were chosen on drawn units 0 and 1
    (docs/recorded_loop.md).
    """

    follow: bool = True
    feedback_hz: float = 40.0
    segment_s: float = 0.075
    anchor_hz: float = 0.0
    motor_side: bool = True
    #: `feedback_hz` of a window whose loop hunts (`at`): a limit cycle near 80 Hz must pass
    hunting_feedback_hz: float = 200.0
    #: a deflection whose white noise (`deflection_noise_rms`) is below this [rad] is fed
    #: back unfiltered: there is no noise to keep out, only the signal to distort.  Measured
    #: (seed 3): noise-free windows <= 8.4e-6 (a hunting play's leakage included), the
    #: benchmark's 5e-5 RMS reads >= 4.0e-5.
    clean_below_rad: float = 2.0e-5

    def __post_init__(self) -> None:
        for name in (
            "feedback_hz",
            "segment_s",
            "anchor_hz",
            "hunting_feedback_hz",
            "clean_below_rad",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ConfigError(f"recorded loop {name} must be finite and >= 0, got {v!r}")
        if self.follow and self.feedback_hz <= 0.0:
            raise ConfigError(
                f"recorded loop feedback_hz must be > 0 to follow the loop, got {self.feedback_hz}"
            )

    @property
    def follows(self) -> bool:
        """Whether anything recorded enters the model (else it is the open-loop replay)."""
        return self.follow or self.segment_s > 0.0

    def at(self, hunting: bool) -> RecordedLoop:
        """The loop for one window: `hunting_feedback_hz` when its loop hunts."""
        return replace(self, feedback_hz=self.hunting_feedback_hz) if hunting else self

    def clean(self, window: Window, gear: float) -> bool:
        """Whether `window`'s deflection goes in unfiltered (its noise below `clean_below_rad`)."""
        return self._is_clean(_motor_and_deflection(window, gear)[1])

    def _is_clean(self, deflection: np.ndarray) -> bool:
        return deflection_noise_rms(deflection) < self.clean_below_rad

    def inputs(
        self, window: Window, gear: float, *, clean: bool | None = None
    ) -> tuple[np.ndarray, int]:
        """The kernel's `rec` (n, 3) of `window` and the segment length in samples (0: none).

        `gear`: user angle per motor angle (the motor side of the fed-back position).
        `clean`: whether the deflection goes in unfiltered (None: `self.clean(window, gear)`);
        given, so that a window's noise re-drawn (fitness.py) is processed as the window was.
        """
        n = window.n
        rec = np.zeros((n, 3))
        if self.follow and self.motor_side:
            motor, deflection = _motor_and_deflection(window, gear)
            if clean is None:
                clean = self._is_clean(deflection)
            rec[:, REC_POSITION] = motor + (
                deflection if clean else low_pass(deflection, self.feedback_hz, window.dt)
            )
        elif self.follow:
            rec[:, REC_POSITION] = low_pass(window.theta_u, self.feedback_hz, window.dt)
        rec[:, REC_THETA_M] = window.theta_m
        rec[:, REC_OMEGA_M] = (
            low_pass(window.omega_m, self.anchor_hz, window.dt)
            if self.anchor_hz > 0.0
            else window.omega_m
        )
        seg = int(round(self.segment_s / window.dt)) if self.segment_s > 0.0 else 0
        if self.segment_s > 0.0 and seg < 1:
            raise ConfigError(
                f"recorded loop segment_s {self.segment_s:g} s is shorter than one sample "
                f"({window.dt:g} s)"
            )
        return np.ascontiguousarray(rec), seg


def _motor_and_deflection(window: Window, gear: float) -> tuple[np.ndarray, np.ndarray]:
    """The resolver's angle through the gear and the user position less it [rad, user]."""
    motor = gear * np.asarray(window.theta_m, dtype=np.float64)
    return motor, np.asarray(window.theta_u, dtype=np.float64) - motor


def low_pass(x: np.ndarray, hz: float, dt: float) -> np.ndarray:
    """The signal x low-passed at `hz` (2nd-order Butterworth, forward and back)."""
    x = np.asarray(x, dtype=np.float64)
    wn = min(hz * 2.0 * dt, 0.99)
    sos = butter(2, wn, btype="lowpass", output="sos")
    return sosfiltfilt(sos, x, padlen=min(x.size - 1, 12))


#: Length of the stretches `deflection_noise_rms` measures [samples]: 50 ms at 2 kHz.
NOISE_STRETCH = 100


def deflection_noise_rms(x: np.ndarray) -> float:
    """White-noise RMS of a recorded deflection: the 10th percentile over 50 ms stretches.

    A hunting play's limit cycle is not smooth at 2 kHz and reads as noise where it runs;
    the quietest stretches read the sensor alone.
    """
    x = np.asarray(x, dtype=np.float64)
    parts = [
        math.sqrt(noise_variance(x[i : i + NOISE_STRETCH]))
        for i in range(0, max(1, x.size - NOISE_STRETCH + 1), NOISE_STRETCH)
    ]
    return float(np.percentile(parts, 10.0))
