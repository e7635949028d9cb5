"""Shared fixtures-as-functions of the typed message tests (test/telemetry, test/ros)."""

from __future__ import annotations

import numpy as np

from ema_phm.diagnosis.health import assess
from ema_phm.domain.window import CHANNELS
from ema_phm.telemetry import typed


def rows(n: int, rate: float = 2000.0, t0: float = 0.0) -> np.ndarray:
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, len(CHANNELS)))
    a[:, 0] = t0 + np.arange(n) / rate
    a[:, 2] = np.nan  # load not measured
    return a


def full_report() -> typed.HealthReport:
    a = assess(
        [0.3, 0.02, 0.0, 0.0, 0.0, 0.1, 0.25, 0.55],
        k_true=[0.3, 0.0, 0.0, 0.0, 0.0, 0.1, 0.25, 0.5],
        fitness=0.0123,
        evaluations=812,
        elapsed_s=3.25,
        window_t0=4.0,
        window_t1=6.0,
    )
    extras = typed.HealthExtras(
        k_low=np.linspace(0.0, 0.35, 8),
        k_high=np.linspace(0.1, 0.9, 8),
        identifiable=(True, False, True, True, True, False, False, True),
        reasons=("", "flat fitness", "", "", "", "too little speed", "zeta ~ 0", ""),
        adequacy=typed.AdequacyResult(statistic=1.7, threshold=3.0, ok=True, evaluated=True),
        nuisances=typed.nuisances_of(
            {"load_torque": -2.5, "current_offset": 0.04}, {"load_torque": "N*m"}
        ),
        rul=tuple(typed.RemainingLife(*(float(i * 10 + j) for j in range(8))) for i in range(8)),
        no_degradation_detected=True,
    )
    return typed.HealthReport(a.level, a.message, "ema_sim", True, a, extras)
