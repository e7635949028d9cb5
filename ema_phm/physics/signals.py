"""Signal helpers both sides use: the acquisition filter and a noise estimate.

- `filter_coefficients`: the 2nd-order Butterworth on I_3eq (sec. 2.1.8) that the drive
  applies before recording and that the monitor model applies to its own current.
- `noise_variance`: the white-noise variance of a recorded signal, as the monitor measures it.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError


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
