"""Healthy model-error level of an actuator's monitor (its file's `monitor` section).

Fits the datasheet unit's noise-free default chirp (seeds 0-2) with the monitor of the file
(fitness "thesis" and "recorded", unmeasured-load nuisances searched) and prints, per fit,
the fitness, what the window's own noise adds (`Fitness.noise_fitness`) and their
difference, the model-error part; a part below commissioning's HEALTHY_FLOOR is recorded
as that floor, as commissioning does.

    .venv/bin/python bench/healthy_level.py config/actuators/small_pi_ema.yaml
"""

from __future__ import annotations

import argparse

import numpy as np

from ema_phm.diagnosis.commissioning import HEALTHY_FLOOR
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NOMINAL
from ema_phm.physics import real_ema
from ema_phm.physics.actuator_file import load_actuator
from ema_phm.physics.parameters import MonitorBelief


def main() -> None:
    """Print the healthy model-error level of the actuator file given."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("actuator", help="actuator file")
    args = p.parse_args()
    actuator = load_actuator(args.actuator)
    belief = MonitorBelief.for_actuator(actuator)
    for name in ("thesis", "recorded"):
        parts = []
        for seed in (0, 1, 2):
            w = real_ema.simulate(NOMINAL, actuator=actuator, seed=seed).window
            r = isolate(w, belief=belief, seed=seed, weights=name, nuisance=True)
            noise = Fitness(w, belief=belief, nuisance=True, weights=name).noise_fitness
            parts.append(r.fitness - noise)
            print(f"{name} seed {seed}: fitness {r.fitness:.4f} noise {noise:.4f}")
        level = max(HEALTHY_FLOOR, float(np.mean(parts)))
        print(f"{name}: mean model part {np.mean(parts):.4f} -> healthy level {level:.4f}")


if __name__ == "__main__":
    main()
