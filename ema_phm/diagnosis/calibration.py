"""Calibration of the monitor model in nominal conditions (section 6.2).

The LF back-EMF constant ke and torque gain gt are fitted so that the nominal
LF current matches the nominal HF current on the default window (MSE of eq. 6.1,
taken as a mean so it does not depend on the sample count).
"""
from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy import optimize

from ..physics import real_ema
from ..physics.commands import calibration_spec
from ..physics.fault_vector import NOMINAL
from ..physics.monitor_model import MonitorModel
from ..physics.parameters import config_dir, load_params


@dataclass(frozen=True)
class CalibrationResult:
    ke: float
    gt: float
    mse_before: float
    mse_after: float
    ke_before: float
    gt_before: float
    evaluations: int


def calibrate(*, params: dict[str, Any] | None = None) -> CalibrationResult:
    """Fit (ke, gt) of the LF to the nominal HF on the calibration window; starts from the thesis values."""
    base = params or load_params(calibrated=False)
    window = real_ema.simulate(NOMINAL, params=base, command=calibration_spec()).window
    ke0, gt0 = base["monitor"]["ke"], base["monitor"]["gt"]

    def mse(x: np.ndarray) -> float:
        p = {s: dict(v) for s, v in base.items()}
        p["monitor"]["ke"], p["monitor"]["gt"] = float(x[0]) * ke0, float(x[1]) * gt0
        out = MonitorModel(window, params=p).simulate(NOMINAL)
        return float(np.mean((out[:, 0] - window.i3eq) ** 2))

    before = mse(np.array([1.0, 1.0]))
    # coarse scan over ke first: the MSE is flat in ke until the voltage limit bites
    grid = np.linspace(1.0, 4.0, 31)
    best = min(grid, key=lambda g: mse(np.array([g, 1.0])))
    res = optimize.minimize(mse, np.array([best, 1.0]), method="Nelder-Mead",
                            options={"xatol": 1e-5, "fatol": 1e-9, "maxiter": 400})
    return CalibrationResult(ke=float(res.x[0] * ke0), gt=float(res.x[1] * gt0), mse_before=before,
                             mse_after=float(res.fun), ke_before=ke0, gt_before=gt0,
                             evaluations=int(res.nfev) + len(grid) + 1)


def write_calibration(result: CalibrationResult, path: Path | None = None) -> Path:
    path = path or config_dir() / "calibration.yaml"
    header = (
        "# Monitor-model calibration in nominal conditions (thesis section 6.2).\n"
        "# Written by `ema-phm calibrate --write`: ke and gt of the LF are fitted\n"
        "# (coarse scan of ke, then Nelder-Mead on both) so that the nominal LF current\n"
        "# matches the nominal HF I_3eq on the calibration window of config/commands.yaml\n"
        "# (a chirp that reaches the voltage limit, where ke matters).\n"
        "# mse_* are means of (I_HF - I_LF)^2 over the window's samples, in A^2\n"
        "# (thesis: 0.1292 -> 0.0644 A^2 with ke = 0.085897, gt = 0.080072).\n"
    )
    body = {
        "monitor": {"ke": result.ke, "gt": result.gt},
        "before": {"ke": result.ke_before, "gt": result.gt_before, "mse_a2": result.mse_before},
        "after": {"mse_a2": result.mse_after},
        "evaluations": result.evaluations,
        "date": _dt.date.today().isoformat(),
    }
    path.write_text(header + yaml.safe_dump(body, sort_keys=False), encoding="utf-8")
    return path
