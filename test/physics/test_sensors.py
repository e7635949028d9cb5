"""The acquisition chain (ema_phm.simulator.sensors); the monitor model never imports the HF."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from ema_phm.errors import ConfigError
from ema_phm.model import monitor_model
from ema_phm.simulator import sensors


@pytest.mark.parametrize("fc,dt", [(1000.0, 1e-6), (1000.0, 1e-4), (300.0, 5e-4)])
def test_acquisition_filter_is_the_scipy_butterworth(fc, dt):
    from scipy import signal

    b, a = signal.butter(2, fc, fs=1.0 / dt)
    np.testing.assert_allclose(
        sensors.filter_coefficients(fc, dt), [b[0], b[1], b[2], a[1], a[2]], rtol=1e-9
    )


@pytest.mark.parametrize("fc", [0.0, 500.0, 1e9])
def test_a_cutoff_outside_zero_to_nyquist_is_named(fc):
    with pytest.raises(ConfigError, match=rf"cutoff {fc} Hz.*\(0, 500\) Hz"):
        sensors.filter_coefficients(fc, 1e-3)


def _imported_modules(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name.rsplit(".", 1)[-1] for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            names.add((node.module or "").rsplit(".", 1)[-1])
            names.update(alias.name for alias in node.names)
    return names


def test_the_monitor_model_never_imports_the_hf_model():
    imported = _imported_modules(Path(monitor_model.__file__))
    assert "sensors" in imported  # the check sees the imports it should
    assert "real_ema" not in imported
