"""The acquisition chain both models share: the 2nd-order Butterworth on I_3eq (sec. 2.1.8).

Its own module so that the monitor model never imports the HF model.
"""

from __future__ import annotations

import math

from ..errors import ConfigError


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
