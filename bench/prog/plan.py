"""The prognostics benchmark's plan: trajectories, their degradation laws, environments, seeds.

Trajectory t runs on unit ``Unit.draw(seed + t)``; its laws are drawn from
``numpy.random.default_rng((seed, t, 23))`` and each cycle's environment from
``default_rng((seed, t, cycle, 7))`` (see bench_prognostics.py).
"""

from __future__ import annotations

import math

import numpy as np

from bench.harness.scenarios import (
    BASELINES,
    LOAD_NM,
    NOISE,
    SPRING_NM_PER_RAD,
    TEMPERATURE_C,
)
from ema_phm.domain.faults import ERROR_SEVERITY
from ema_phm.simulator.degradation import Degradation

#: Fault types, in the order trajectories cycle through them.
TYPES: tuple[str, ...] = ("friction", "backlash", "short_circuit_a", "eccentricity", "multi_fault")
#: The faults that grow in each type.
TYPE_FAULTS: dict[str, tuple[str, ...]] = {
    "friction": ("friction",),
    "backlash": ("backlash",),
    "short_circuit_a": ("short_circuit_a",),
    "eccentricity": ("eccentricity",),
    "multi_fault": ("friction", "eccentricity"),
    "healthy": (),
    "steady": (),
}
#: Faults a steady trajectory holds at a constant severity (present, not growing), in turn.
STEADY_FAULTS: tuple[str, ...] = ("friction", "backlash", "short_circuit_a", "eccentricity")
#: Severity of a steady fault, uniform: present and clear, well below the threshold.
STEADY_SEVERITY = (0.1, 0.3)
#: Growth law of each fault (degradation.py's reasons: wear linear, propagation exponential).
LAW: dict[str, str] = {
    "friction": "linear",
    "backlash": "linear",
    "short_circuit_a": "exponential",
    "eccentricity": "exponential",
}
PER_TYPE = 12
HEALTHY = 20
STEADY = 8
#: Cycles of a healthy or a steady trajectory.
HEALTHY_CYCLES = 30
#: Target true end of life [cycle], uniform whole numbers (inclusive).
LIFE_CYCLES = (25, 45)
#: Onset cycle, uniform whole numbers (inclusive).
ONSET_CYCLES = (0, 10)
#: Severity at the onset: linear laws (uniform) and exponential laws (uniform, > 0).
INITIAL_LINEAR = (0.0, 0.02)
INITIAL_EXPONENTIAL = (0.02, 0.05)
#: Failure threshold of the severity (the fault table's ERROR severity of k1..k6, 0.4).
THRESHOLD = float(ERROR_SEVERITY)


def _law(rng: np.random.Generator, name: str) -> tuple[dict, int]:
    """One fault's growth (as its YAML mapping) and the target end of life it was drawn for."""
    life = int(rng.integers(LIFE_CYCLES[0], LIFE_CYCLES[1] + 1))
    onset = int(rng.integers(ONSET_CYCLES[0], ONSET_CYCLES[1] + 1))
    span = life - onset
    if LAW[name] == "linear":
        initial = float(rng.uniform(*INITIAL_LINEAR))
        rate = (THRESHOLD - initial) / span
    else:
        initial = float(rng.uniform(*INITIAL_EXPONENTIAL))
        rate = math.log(THRESHOLD / initial) / span
    rate *= 1.0 + 1e-9  # reach the threshold at `life` itself, not one cycle later by rounding
    spec = {"law": LAW[name], "onset": onset, "initial": initial, "rate": rate, "cap": True}
    return spec, life


def _steady(rng: np.random.Generator, j: int) -> dict[str, dict]:
    """The j-th steady trajectory's fault: present from cycle 0 at a constant severity."""
    name = STEADY_FAULTS[j % len(STEADY_FAULTS)]
    level = float(rng.uniform(*STEADY_SEVERITY))
    return {name: {"law": "step", "onset": 0, "initial": level}}


def plan(
    seed: int, per_type: int = PER_TYPE, healthy: int = HEALTHY, steady: int = STEADY
) -> list[dict]:
    """Every trajectory: index, type, unit seed, degradation, true end of life, cycles.

    Degrading ones first (types interleaved), then healthy, then steady ones (a fault
    present at a constant severity: a RUL there is a false alarm).
    """
    out = []
    kinds = [TYPES[t % len(TYPES)] for t in range(per_type * len(TYPES))]
    kinds += ["healthy"] * healthy + ["steady"] * steady
    for t, kind in enumerate(kinds):
        rng = np.random.default_rng((seed, t, 23))
        faults: dict[str, dict] = {}
        targets: dict[str, int] = {}
        for name in TYPE_FAULTS[kind]:
            faults[name], targets[name] = _law(rng, name)
        if kind == "steady":
            faults = _steady(rng, t - per_type * len(TYPES) - healthy)
        if "eccentricity" in faults:
            faults["eccentricity_phase"] = {
                "law": "step",
                "onset": 0,
                "initial": float(rng.uniform(0.0, 1.0)),
                "cap": False,
            }
        deg = Degradation.from_mapping({"faults": faults}, source=f"trajectory {t}")
        eol = {name: deg.first_cycle_at(name, THRESHOLD) for name in TYPE_FAULTS[kind]}
        cycles = max(eol.values()) if eol else HEALTHY_CYCLES
        out.append(
            {
                "index": t,
                "type": kind,
                "unit_seed": seed + t,
                "degradation": deg.as_dict(),
                "target_life": targets,
                "true_eol": eol,
                "cycles": int(cycles),
            }
        )
    return out


def environment(seed: int, t: int, cycle: int) -> dict:
    """The cycle's temperature and unmeasured load (harness.scenarios' ranges)."""
    rng = np.random.default_rng((seed, t, cycle, 7))
    return {
        "temperature_c": float(rng.uniform(*TEMPERATURE_C)),
        "load_nm": float(rng.uniform(*LOAD_NM)),
        "spring_nm_per_rad": float(rng.uniform(*SPRING_NM_PER_RAD)),
    }


def run_seed(t: int, cycle: int) -> int:
    """Noise seed of a window, also its isolation seed."""
    return 1000 * t + cycle + 1


def settings() -> dict:
    """The plan's constants, recorded with the rows."""
    return {
        "per_type_default": PER_TYPE,
        "healthy_default": HEALTHY,
        "healthy_cycles": HEALTHY_CYCLES,
        "steady_default": STEADY,
        "steady_faults": STEADY_FAULTS,
        "steady_severity": STEADY_SEVERITY,
        "life_cycles": LIFE_CYCLES,
        "onset_cycles": ONSET_CYCLES,
        "initial_linear": INITIAL_LINEAR,
        "initial_exponential": INITIAL_EXPONENTIAL,
        "threshold": THRESHOLD,
        "noise": NOISE,
        "temperature_c": TEMPERATURE_C,
        "load_nm": LOAD_NM,
        "spring_nm_per_rad": SPRING_NM_PER_RAD,
        "baselines": BASELINES,
        "law": LAW,
    }
