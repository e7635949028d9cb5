"""Helpers shared by the physics tests (a plain module, not collected)."""

from __future__ import annotations

import numpy as np

from ema_phm.physics.fault_vector import NOMINAL

GEAR = 0.002


def k_with(**faults: float) -> np.ndarray:
    k = NOMINAL.copy()
    idx = {
        "friction": 0,
        "backlash": 1,
        "sc_a": 2,
        "sc_b": 3,
        "sc_c": 4,
        "ecc": 5,
        "phase": 6,
        "gain": 7,
    }
    for name, val in faults.items():
        k[idx[name]] = val
    return k


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))
