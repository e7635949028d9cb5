"""Speed and accuracy measurements of the two models (used by `ema-phm bench` and bench/)."""

from __future__ import annotations

import os
import platform
import statistics
import subprocess
import sys
import time
from typing import Any

import numba
import numpy as np

from ..domain.faults import N_K, NOMINAL, fault, k_with
from ..domain.window import Window
from ..model.monitor_model import OUT_I3EQ, MonitorModel
from ..simulator import real_ema


def machine() -> dict[str, Any]:
    """CPU, core count and library versions of this machine."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "numpy": np.__version__,
    }


def hf_cold_start_s() -> float:
    """Wall time of a fresh interpreter importing the HF and running a tiny window.

    (Compilation comes from numba's on-disk cache after the first ever run).
    """
    code = (
        "import time;t=time.perf_counter();from ema_phm.physics import real_ema as h;"
        "from ema_phm.physics.commands import CommandSpec;"
        "from ema_phm.domain.faults import NOMINAL;"
        "h.simulate(NOMINAL,command=CommandSpec(duration=0.05));"
        "print(time.perf_counter()-t)"
    )
    subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True
    )  # fills the cache
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


#: The faulty k the speeds are measured on (also the reference bags' multi_fault state).
K_FAULT = k_with(
    friction=0.3,
    backlash=0.2,
    short_circuit_a=0.2,
    eccentricity=0.3,
    eccentricity_phase=0.4,
    gain_drift=0.6,
)


def measure_models(
    *,
    repeats: int = 5,
    population: int = 64,
    batches: int = 10,
    seed: int = 0,
    cold_start: bool = True,
) -> dict[str, Any]:
    """Medians on the default window of three speeds.

    HF wall time per simulated second (one core), LF window evaluations per second (all cores), LF
    step error vs a 10x finer step.
    """
    rng = np.random.default_rng(seed)
    window = real_ema.simulate(K_FAULT).window  # also the warm-up (JIT)
    hf_per_s = _hf_wall_per_sim_s(window, repeats)
    model = MonitorModel(window)
    rate = _lf_evals_per_s(model, rng.random((population, N_K)), batches)
    errs, hunting = _lf_step_errors(model, rng)
    out = {
        "hf_wall_per_sim_s": hf_per_s,
        "hf_realtime_factor": 1.0 / hf_per_s,
        "lf_evals_per_s": rate,
        "lf_fine_step_rel_rms": max(errs),
        "lf_fine_step_rel_rms_hunting": hunting,
        "lf_step_s": model.step_s,
        "window_s": window.duration,
        "window_samples": window.n,
        "machine": machine(),
    }
    if cold_start:
        out["hf_cold_start_s"] = hf_cold_start_s()
    return out


def _hf_wall_per_sim_s(window: Window, repeats: int) -> float:
    """Median HF wall time per simulated second of `window` (`K_FAULT`, one core)."""
    hf_times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        real_ema.simulate(K_FAULT)
        hf_times.append(time.perf_counter() - t0)
    return statistics.median(hf_times) / window.duration


def _lf_evals_per_s(model: MonitorModel, pop: np.ndarray, batches: int) -> float:
    """Median LF window evaluations per second of a batch of `pop` (all cores)."""
    model.simulate_batch(pop)  # warm-up
    rates = []
    for _ in range(batches):
        t0 = time.perf_counter()
        model.simulate_batch(pop)
        rates.append(pop.shape[0] / (time.perf_counter() - t0))
    return statistics.median(rates)


def _lf_step_errors(model: MonitorModel, rng: np.random.Generator) -> tuple[list[float], float]:
    """Relative RMS current error vs a 10x finer step: without play, and with a hunting play."""
    fine = MonitorModel(model.window, steps_per_sample=model.steps_per_sample * 10)

    def step_error(k: np.ndarray) -> float:
        a, b = model.simulate(k)[:, OUT_I3EQ], fine.simulate(k)[:, OUT_I3EQ]
        return float(np.sqrt(np.mean((a - b) ** 2)) / max(np.sqrt(np.mean(b**2)), 1e-12))

    # a play past ~0.05 of the backlash entry makes the loop hunt (a limit cycle, in the HF
    # too): its phase depends on the step, so step convergence is measured without it, and
    # reported apart
    no_play = [NOMINAL.copy(), K_FAULT.copy(), *rng.random((3, N_K))]
    for k in no_play:
        k[fault("backlash").index] = 0.0
    return [step_error(k) for k in no_play], step_error(k_with(backlash=0.2))
