"""Calibration of the monitor model in nominal conditions (section 6.2).

The belief's back-EMF constant ke and torque gain gt are fitted so that the
nominal LF current matches the current recorded on a healthy calibration window (MSE of
eq. 6.1, taken as a mean so it does not depend on the sample count).  The window is the
caller's: a recording of the actuator on the calibration command, or, for the packaged
calibration, the simulated actuator's (`ema_phm.simulator.real_ema.calibration_window`,
run by `ema-phm calibrate`).  The result is written to a file the caller names; the packaged
config/calibration.yaml is only read (it is part of `MonitorBelief.default()`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import optimize

from ..domain.faults import NOMINAL
from ..domain.window import Window
from ..model.belief import MonitorBelief
from ..model.calibration_file import write_calibration_file
from ..model.monitor_model import OUT_I3EQ, MonitorModel


@dataclass(frozen=True)
class CalibrationResult:
    """Fitted ke [V*s/rad] and gt [N*m/A], the MSEs [A^2] before and after, the start values."""

    ke: float
    gt: float
    mse_before: float
    mse_after: float
    ke_before: float
    gt_before: float
    evaluations: int


def calibrate(window: Window, *, belief: MonitorBelief) -> CalibrationResult:
    """Fit (ke, gt) of `belief` to the current of a healthy calibration `window`.

    Starts from the belief's ke and gt (for an actuator, `MonitorBelief.uncalibrated_for`:
    its physical sections and the thesis values of the packaged ema.yaml's monitor section).
    """
    ke0, gt0 = belief.value("monitor.ke"), belief.value("monitor.gt")

    def mse(x: np.ndarray) -> float:
        if not (x[0] > 0 and x[1] > 0):  # a belief refuses ke, gt <= 0: treat as the worst fit
            return float("inf")
        trial = belief.with_values(
            {"monitor.ke": float(x[0]) * ke0, "monitor.gt": float(x[1]) * gt0}
        )
        out = MonitorModel(window, belief=trial).simulate(NOMINAL)
        return float(np.mean((out[:, OUT_I3EQ] - window.i3eq) ** 2))

    before = mse(np.array([1.0, 1.0]))
    # coarse scan over ke first: the MSE is flat in ke until the voltage limit bites
    grid = np.linspace(1.0, 4.0, 31)
    best = min(grid, key=lambda g: mse(np.array([g, 1.0])))
    res = optimize.minimize(
        mse,
        np.array([best, 1.0]),
        method="Nelder-Mead",
        options={"xatol": 1e-5, "fatol": 1e-9, "maxiter": 400},
    )
    return CalibrationResult(
        ke=float(res.x[0] * ke0),
        gt=float(res.x[1] * gt0),
        mse_before=before,
        mse_after=float(res.fun),
        ke_before=ke0,
        gt_before=gt0,
        evaluations=int(res.nfev) + len(grid) + 1,
    )


def user_calibration_file() -> Path:
    """Where `ema-phm calibrate` writes by default.

    That is ``${XDG_CONFIG_HOME:-~/.config}/ema_phm/calibration.yaml``.
    """
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "ema_phm" / "calibration.yaml"


def write_calibration(result: CalibrationResult, path: Path) -> Path:
    """Write `result` as a calibration file (`model.calibration_file`), creating its folder."""
    documentation = {
        "before": {"ke": result.ke_before, "gt": result.gt_before, "mse_a2": result.mse_before},
        "after": {"mse_a2": result.mse_after},
        "evaluations": result.evaluations,
    }
    return write_calibration_file(path, result.ke, result.gt, documentation)
