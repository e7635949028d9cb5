"""Healthy model-error level of an actuator's monitor (its file's `monitor` section).

Two measures, printed side by side:
- the datasheet unit: its noise-free default chirp (seeds 0-2) fitted by the monitor of the
  file (fitness "thesis" and "recorded", nuisances searched); per fit the fitness, what the
  window's own noise adds (`Fitness.noise_fitness`, and what the followed channels' noise
  adds through the loop, `Fitness.fed_noise_fitness`) and their difference, the model error
  (an ideal figure: the monitor's parameters are the datasheet's);
- `--units N`: drawn units (`Unit.draw(s)`, s = first .. first + N - 1) in the benchmarks'
  hangar (two healthy baselines each, own temperature, small unmeasured load, the
  benchmarks' noise with the current noise at 1 % of the actuator's current range),
  commissioned against the file's belief; per unit the model error each healthy reference
  keeps (`commissioning.HealthyReference.model_error`), then their median.
A level below commissioning's HEALTHY_FLOOR is recorded as that floor, as commissioning does.

    .venv/bin/python -m bench.healthy_level config/actuators/small_pi_ema.yaml --units 8 \
        --first 10
"""

from __future__ import annotations

import argparse

import numpy as np

from bench.harness.scenarios import NOISE, hangar_windows
from ema_phm.diagnosis.commissioning import HEALTHY_FLOOR, commission
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NOMINAL
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator_file import load_actuator
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit


def datasheet(actuator: ActuatorParameters, belief: MonitorBelief) -> None:
    """Print the datasheet unit's model error per fitness."""
    for name in ("thesis", "recorded"):
        parts = []
        for seed in (0, 1, 2):
            w = real_ema.simulate(NOMINAL, actuator=actuator, seed=seed).window
            r = isolate(w, belief=belief, seed=seed, weights=name, nuisance=True)
            fit = Fitness(w, belief=belief, nuisance=True, weights=name)
            assert r.row is not None  # a nuisance search returns its row
            noise = fit.noise_fitness + fit.fed_noise_fitness(r.row)
            parts.append(r.fitness - noise)
            print(f"datasheet {name} seed {seed}: fitness {r.fitness:.4f} noise {noise:.4f}")
        level = max(HEALTHY_FLOOR, float(np.mean(parts)))
        print(f"datasheet {name}: mean model error {np.mean(parts):.4f} -> level {level:.4f}")


def drawn(actuator: ActuatorParameters, belief: MonitorBelief, first: int, units: int) -> None:
    """Print the model error commissioned drawn units keep, per healthy reference."""
    scale = actuator.controller.max_current / ActuatorParameters.default().controller.max_current
    noise = {**NOISE, "noise_current": NOISE["noise_current"] * scale}
    command, _ = default_specs()
    errors = []
    for u in range(first, first + units):
        windows = hangar_windows(u, Unit.draw(u), actuator, command, noise=noise)
        res = commission(windows, belief=belief)
        errors.append([r.model_error for r in res.references])
        print(f"unit {u}: " + ", ".join(f"{r.name} {r.model_error:.4f}" for r in res.references))
    for i, ref in enumerate(res.references):
        med = float(np.median([e[i] for e in errors]))
        print(f"drawn units: {ref.name} median {med:.4f} -> level {max(HEALTHY_FLOOR, med):.4f}")


def main() -> None:
    """Print the healthy model-error levels of the actuator file given."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("actuator", help="actuator file")
    p.add_argument("--units", type=int, default=0, help="drawn units to commission (0: none)")
    p.add_argument("--first", type=int, default=10, help="first drawn unit's seed")
    args = p.parse_args()
    actuator = load_actuator(args.actuator)
    belief = MonitorBelief.for_actuator(actuator)
    datasheet(actuator, belief)
    if args.units:
        drawn(actuator, belief, args.first, args.units)


if __name__ == "__main__":
    main()
