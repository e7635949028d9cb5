#!/usr/bin/env python3
"""Excitation benchmark: where a window stops identifying k.

Usage (repo root): .venv/bin/python -m bench.studies.bench_excitation [--seeds 2] [--evals 4000]

For chirp amplitudes 0 .. 0.03 rad (default chirp otherwise), healthy and faulty
k, without noise and with 1 % current noise (0.225 A RMS), it simulates the HF
window and reports the excitation measures (probe separation of
ema_phm/diagnosis/excitation.py, command / current / position RMS about the mean) and the
isolation %err (default preset, its global stage stopped after --evals
evaluations, excitation check off), next to the %err of a random k.  Then the
all-zero window, the separation of the other windows the tests and the CLI use,
and the cost of the check.  Prints markdown tables (pasted into docs/excitation.md).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from bench.harness import cli, machine
from bench.harness.scenarios import MULTI, NOISE_RMS
from ema_phm.diagnosis import excitation
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import N_K, NOMINAL, k_with, percent_err
from ema_phm.domain.window import CHANNELS, Window
from ema_phm.physics.commands import CommandSpec, calibration_spec
from ema_phm.simulator import real_ema

AMPLITUDES = (0.0, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2)


CASES = {
    "healthy": NOMINAL.copy(),
    "friction k1=0.5": k_with(friction=0.5),
    "short B k4=0.4": k_with(short_circuit_b=0.4),
    "gain k8=0.7": k_with(gain_drift=0.7),
}


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


def random_k_err(k_true: np.ndarray, *, draws: int = 2000) -> float:
    """Mean %err of a uniformly random k: what an arbitrary answer scores."""
    rng = np.random.default_rng(0)
    return float(np.mean([percent_err(rng.random(N_K), k_true) for _ in range(draws)]))


def sweep(seeds: int, evals: int) -> list[str]:
    lines = [
        "| amplitude [rad] | k | noise [A] | separation (min..max over seeds) | weakest probe | "
        "cmd RMS [rad] | I RMS [A] | theta_u RMS [rad] | %err per seed | random-k %err |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for amp in AMPLITUDES:
        for name, k in CASES.items():
            for noise in (0.0, NOISE_RMS):
                seps, errs, weakest = [], [], set()
                for seed in range(seeds):
                    w = real_ema.simulate(
                        k, command=CommandSpec(amplitude=amp), seed=seed, noise_current=noise
                    ).window
                    ex = excitation.measure(w)
                    seps.append(ex.separation)
                    weakest.add(ex.weakest)
                    res = isolate(w, seed=seed, max_evaluations=evals, check_excitation=False)
                    errs.append(res.percent_err)
                lines.append(
                    f"| {amp:g} | {name} | {noise:g} | {min(seps):.3g} .. {max(seps):.3g} | "
                    f"{', '.join(sorted(weakest))} | {rms(w.command):.3g} | {rms(w.i3eq):.3g} | "
                    f"{rms(w.theta_u):.3g} | {' '.join(f'{e:.2f}' for e in errs)} | "
                    f"{random_k_err(k):.1f} |"
                )
                print(lines[-1], flush=True)
    return lines


def other_windows() -> list[str]:
    zeros = Window.from_matrix(
        np.column_stack([np.arange(4001) / 2000.0] + [np.zeros(4001)] * (len(CHANNELS) - 1))
    )
    windows = {
        "all-zero telemetry (2 s)": zeros,
        "default chirp 2 s": real_ema.simulate(NOMINAL).window,
        "default chirp 2 s, 1 % noise": real_ema.simulate(NOMINAL, noise_current=NOISE_RMS).window,
        "default chirp 1 s (test_isolation)": real_ema.simulate(
            NOMINAL, command=CommandSpec(duration=1.0)
        ).window,
        "default chirp 0.3 s (test_cli)": real_ema.simulate(
            NOMINAL, command=CommandSpec(duration=0.3)
        ).window,
        "calibration chirp 0.05 rad 1 s": real_ema.simulate(
            NOMINAL, command=calibration_spec()
        ).window,
        "multi-fault (Table 6.17), 2 s, 1 % noise": real_ema.simulate(
            MULTI.tolist(), noise_current=NOISE_RMS
        ).window,
    }
    lines = [
        "| window | separation | weakest probe | same with `current` weights (not used) |",
        "|---|---|---|---|",
    ]
    for name, w in windows.items():
        ex = excitation.measure(w)
        current_only = Fitness(w, weights="current").separation(
            np.vstack(list(excitation.PROBES.values())), NOMINAL
        )
        lines.append(f"| {name} | {ex.separation:.3g} | {ex.weakest} | {current_only.min():.3g} |")
        print(lines[-1], flush=True)
    return lines


def cost(repeats: int = 20) -> list[str]:
    w = real_ema.simulate(NOMINAL).window
    excitation.measure(w)  # JIT warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        excitation.measure(w)
        times.append(time.perf_counter() - t0)
    return [
        f"check on the 2 s default window: median {1e3 * statistics.median(times):.1f} ms, "
        f"max {1e3 * max(times):.1f} ms over {repeats} runs"
    ]


def main() -> int:
    ap = cli(__doc__.splitlines()[0], raw_description=False)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--evals", type=int, default=4000, help="isolation budget (global stage only)")
    args = ap.parse_args()
    t0, c0 = time.perf_counter(), time.process_time()
    m = machine()
    print(f"machine: {m['cpu']}, {m['cores']} cores; threshold {excitation.THRESHOLD:g}")
    out = cost() + [""] + other_windows() + [""] + sweep(args.seeds, args.evals)
    print("\n" + "\n".join(out))
    print(
        f"\nwall {time.perf_counter() - t0:.0f} s, CPU (this process) "
        f"{time.process_time() - c0:.0f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
