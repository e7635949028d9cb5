"""The acquisition filter both models apply (ema_phm.physics.signals)."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.errors import ConfigError
from ema_phm.physics import signals


@pytest.mark.parametrize("fc,dt", [(1000.0, 1e-6), (1000.0, 1e-4), (300.0, 5e-4)])
def test_acquisition_filter_is_the_scipy_butterworth(fc, dt):
    from scipy import signal

    b, a = signal.butter(2, fc, fs=1.0 / dt)
    np.testing.assert_allclose(
        signals.filter_coefficients(fc, dt), [b[0], b[1], b[2], a[1], a[2]], rtol=1e-9
    )


@pytest.mark.parametrize("fc", [0.0, 500.0, 1e9])
def test_a_cutoff_outside_zero_to_nyquist_is_named(fc):
    with pytest.raises(ConfigError, match=rf"cutoff {fc} Hz.*\(0, 500\) Hz"):
        signals.filter_coefficients(fc, 1e-3)
