#!/usr/bin/env python3
"""How far the nominal HF ("real EMA") is from the nominal LF monitor on the default window.

Usage (repo root):  .venv/bin/python -m bench.studies.hf_lf_residual [--isolate]

Prints the RMS of the differences (I_3eq [A], theta_u [rad], omega_m [rad/s]) between the
nominal HF window and the nominal LF prediction with the packaged belief (docs/models.md
records the figures before and after issue 9), and with --isolate the %err (eq. 6.4) of the
default preset (seed 0) on a few default-window scenarios.  A truthful HF is not a twin: the
residual is what the monitor cannot explain even when nothing is wrong.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NOMINAL, k_with
from ema_phm.model.monitor_model import OUT_I3EQ, OUT_OMEGA_M, OUT_THETA_U, MonitorModel
from ema_phm.simulator import real_ema

SCENARIOS = {
    "nominal": NOMINAL,
    "friction k1=0.5": k_with(friction=0.5),
    "backlash k2=0.6": k_with(backlash=0.6),
    "short circuit B k4=0.4": k_with(short_circuit_b=0.4),
    "eccentricity k6=0.6": k_with(eccentricity=0.6, eccentricity_phase=0.3),
    "multi": k_with(
        friction=0.3,
        backlash=0.2,
        short_circuit_a=0.2,
        eccentricity=0.3,
        eccentricity_phase=0.7,
        gain_drift=0.6,
    ),
}


def rms(x: np.ndarray) -> float:
    """Root mean square, ignoring NaN."""
    return float(np.sqrt(np.nanmean(x**2)))


def residual() -> dict[str, float]:
    """RMS differences between the nominal HF window and the nominal LF prediction."""
    window = real_ema.simulate(NOMINAL).window
    lf = MonitorModel(window).simulate(NOMINAL)
    return {
        "rms_i3eq_A": rms(window.i3eq - lf[:, OUT_I3EQ]),
        "rms_theta_u_rad": rms(window.theta_u - lf[:, OUT_THETA_U]),
        "rms_omega_m_rad_s": rms(window.omega_m - lf[:, OUT_OMEGA_M]),
    }


def main() -> int:
    """Print the residual, and the isolation %err per scenario with --isolate."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isolate", action="store_true", help="also isolate a few scenarios")
    args = ap.parse_args()
    print(json.dumps(residual()))
    if args.isolate:
        for name, k in SCENARIOS.items():
            t0 = time.perf_counter()
            res = isolate(real_ema.simulate(k).window, seed=0)
            print(
                f"{name}: %err {res.percent_err:.2f}, k = {np.round(res.k, 3).tolist()} "
                f"({time.perf_counter() - t0:.1f} s)",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
