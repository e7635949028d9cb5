"""The benchmarks' shared scenarios: thesis fault cases, drawn environments, noise, hangar.

Defined once here; bench_isolation, bench_realistic, bench_robust, bench_prognostics,
bench_severity_bias, bench_commissioning_guard, bench_tracking and bench_excitation read them.
"""

from __future__ import annotations

import numpy as np

from ema_phm.domain.faults import NOMINAL, fault, k_with, phase_pairs
from ema_phm.domain.window import Window
from ema_phm.physics.commands import CommandSpec, LoadSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.envelope import (  # noqa: F401  (the benchmarks import them from here)
    BASELINES,
    HANGAR_C,
    HANGAR_LOAD_NM,
    HANGAR_SPRING,
    LOAD_NM,
    NOISE,
    SPRING_NM_PER_RAD,
    TEMPERATURE_C,
)
from ema_phm.simulator.unit import Unit

# ----------------------------------------------------------------------------- thesis cases

#: (label, fault, levels, thesis mean %err per level): the thesis's single-fault cases.
SINGLE: tuple[tuple[str, str, tuple[float, ...], tuple[float, ...]], ...] = (
    ("friction", "friction", (0.25, 0.5, 0.75), (1.99, 2.27, 6.76)),
    ("backlash", "backlash", (0.2, 0.6, 0.8), (1.91, 2.24, 2.01)),
    ("short circuit A", "short_circuit_a", (0.2, 0.4, 0.7), (4.74, 4.71, 6.20)),
    ("eccentricity", "eccentricity", (0.2, 0.4, 0.7), (2.85, 2.45, 1.80)),
    ("gain drift", "gain_drift", (0.2, 0.4, 0.7), (1.83, 1.19, 0.87)),
)
#: The thesis's multi-fault case (Table 6.17), every k entry.
MULTI = k_with(
    friction=0.2383,
    backlash=0.5003,
    short_circuit_a=5.32e-7,
    short_circuit_b=0.4503,
    short_circuit_c=0.0404,
    eccentricity=0.0028,
    eccentricity_phase=0.2785,
)
#: The one phase entry of k (k7) and the amount it is the phase of (eccentricity, k6).
((PHASE_AMOUNT, PHASE_INDEX),) = phase_pairs()
#: A case of `cases`: (name, true k, index of the single fault or None, severity tag or None).
Case = tuple[str, np.ndarray, int | None, str | None]
#: Tags of a single-fault case's three levels.
SEVERITY_TAGS = ("low", "medium", "high")


def scenarios() -> list[tuple[str, np.ndarray, float]]:
    """The thesis's 16 fault cases: (name, true k, thesis mean %err)."""
    out = []
    for label, name, levels, thesis in SINGLE:
        idx = fault(name).index
        for lvl, th, tag in zip(levels, thesis, SEVERITY_TAGS, strict=True):
            k = NOMINAL.copy()
            k[idx] = lvl
            out.append((f"{label} {tag} (k{idx + 1}={lvl:g})", k, th))
    out.append(("multi-fault (Table 6.17)", MULTI.copy(), 5.21))
    return out


def cases() -> list[Case]:
    """(name, true k, index of the single fault or None, severity tag or None)."""
    out = []
    for name, k, _thesis in scenarios():
        dev = np.abs(k - NOMINAL)
        dev[PHASE_INDEX] = 0.0  # a phase is no fault of its own
        single = int(np.argmax(dev)) if (dev > 0).sum() == 1 else None
        tag = next((t for t in SEVERITY_TAGS if f" {t} (" in name), None)
        out.append((name, k, single, tag))
    return out


def ideal_runs(todo: list[Case]) -> list[tuple[int, Case]]:
    """(run seed, case) of the ideal twin: `todo` and one healthy window, seeds 1, 2, ..."""
    return list(enumerate([*todo, ("healthy", NOMINAL.copy(), None, None)], start=1))


def unit_runs(todo: list[Case], unit_seed: int, healthy: int) -> list[tuple[int, Case]]:
    """(run seed, case) of a drawn unit u: `todo`, then `healthy` windows; seeds 1000 u + 1, ..."""
    windows = [(f"healthy #{h + 1}", NOMINAL.copy(), None, None) for h in range(healthy)]
    return list(enumerate([*todo, *windows], start=1000 * unit_seed + 1))


def case_fields(case: Case, run_seed: int) -> dict:
    """A result row's fields naming the case and its run seed."""
    name, k, single, tag = case
    return {
        "scenario": name,
        "k_true": [float(v) for v in k],
        "single_fault": single,
        "severity_tag": tag,
        "run_seed": run_seed,
    }


# ----------------------------------------------------------------------------- environment

# The ranges live in ema_phm.simulator.envelope (the fleet generator draws from them too).
#: Current noise RMS [A] of the isolation and excitation benchmarks: NOISE's current.
NOISE_RMS = NOISE["noise_current"]


def environment(unit_seed: int, stream: int = 7) -> dict:
    """The unit's temperature and its unmeasured load, drawn from its seed (and `stream`)."""
    rng = np.random.default_rng((unit_seed, stream))
    return {
        "temperature_c": float(rng.uniform(*TEMPERATURE_C)),
        "load_nm": float(rng.uniform(*LOAD_NM)),
        "spring_nm_per_rad": float(rng.uniform(*SPRING_NM_PER_RAD)),
    }


# ----------------------------------------------------------------------------- hangar


def hangar(unit_seed: int) -> list[dict]:
    """The commissioning windows' temperature and small unmeasured loads."""
    rng = np.random.default_rng((unit_seed, 11))
    return [
        {
            "temperature_c": float(rng.uniform(*HANGAR_C)),
            "load_nm": float(rng.uniform(*HANGAR_LOAD_NM)),
            "spring_nm_per_rad": float(rng.uniform(*HANGAR_SPRING)),
        }
        for _ in range(BASELINES)
    ]


def sim_kw(
    unit: Unit,
    base: ActuatorParameters,
    command: CommandSpec,
    env: dict,
    noise: dict[str, float] | None = None,
) -> dict:
    """`real_ema.simulate` keywords of a drawn unit in `env` (noise NOISE unless given)."""
    return dict(
        actuator=unit.actuator(base, temperature_c=env["temperature_c"]),
        command=command,
        load=LoadSpec(value=env["load_nm"], spring=env["spring_nm_per_rad"], measured=False),
        sensors=unit.sensors(**(NOISE if noise is None else noise)),
        temperature_c=env["temperature_c"],
    )


def hangar_windows(
    unit_seed: int,
    unit: Unit,
    base: ActuatorParameters,
    command: CommandSpec,
    *,
    k: np.ndarray | None = None,
    noise: dict[str, float] | None = None,
) -> list[Window]:
    """The unit's commissioning windows (`hangar`), healthy unless `k` is given."""
    return [
        real_ema.simulate(
            NOMINAL if k is None else k,
            seed=1000 * unit_seed + 900 + b,
            **sim_kw(unit, base, command, e, noise),
        ).window
        for b, e in enumerate(hangar(unit_seed))
    ]


# ----------------------------------------------------------------------------- ideal twin

IDEAL_LABEL = (
    "ideal: monitor parameters equal to the actuator's (datasheet unit, no noise, "
    "no unmeasured load)"
)
#: The ideal twin's environment: 20 degC, no load.
IDEAL_ENV = {"temperature_c": 20.0, "load_nm": 0.0, "spring_nm_per_rad": 0.0}


def ideal_kw(base: ActuatorParameters, command: CommandSpec) -> dict:
    """`real_ema.simulate` keywords of the ideal twin: datasheet unit, ideal sensors, 20 degC."""
    return dict(actuator=base, command=command, load=LoadSpec(), temperature_c=20.0)
