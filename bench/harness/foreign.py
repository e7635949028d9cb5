"""The foreign population's draws: units, hangar days and operating windows off the map.

Shared by bench_foreign (one window per fault at a medium severity) and bench_foreign_lives
(faults that grow over a life).  Nothing in the package is chosen on these draws.  How they
differ from every other benchmark's: the docstring of bench/bench_foreign.py.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness.scenarios import NOISE
from ema_phm.diagnosis.commissioning import commission, review, write_unit
from ema_phm.domain.faults import NOMINAL
from ema_phm.model.belief import belief_for
from ema_phm.physics.commands import LoadSpec, default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.physics.tolerances import OFFSET_KEYS, UNIT_KEYS, Tolerances
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

# ----------------------------------------------------------------------------- seeds

#: First unit seed of the population (unit i has seed FIRST_SEED + i).
FIRST_SEED = 9000
#: Noise (and isolation) seed of window j of unit i: SIM_SEED_BASE + 1000 i + j; hangar
#: baseline b: SIM_SEED_BASE + 1000 i + 900 + b.
SIM_SEED_BASE = 9_000_000
#: numpy random streams: the unit's draw, its hangar, its windows.
UNIT_STREAM, HANGAR_STREAM, WINDOW_STREAM = 41, 43, 47

# ----------------------------------------------------------------------------- the map

#: Unit kinds, in turn (unit i is KIND_CYCLE[i % 8]): 3 corner, 3 wide, 2 inside per 8.
KIND_CYCLE = ("corner", "wide", "inside", "corner", "wide", "corner", "inside", "wide")
#: Wide units draw every key uniformly inside this many times its declared band.
WIDE = 2.0
#: Smallest factor a wide unit gets (the package's `unit_factor` limit).
FACTOR_FLOOR = 0.25
#: Operating temperatures [degC] and the hangar's.
TEMPERATURE_C = (-40.0, 85.0)
HANGAR_C = (0.0, 40.0)
HANGAR_LOAD_NM = (-20.0, 20.0)
HANGAR_SPRING = (0.0, 600.0)
#: Noise per channel: this range of multiples of the envelope's NOISE (log-uniform).
NOISE_FACTOR = (0.5, 2.0)
#: The fine user-position sensor [rad RMS] drawn on every third unit (hangar) and window.
FINE_POSITION = (1.0e-5, 2.0e-5)
#: The windows' load profiles, in turn (window j has LOAD_KINDS[(i + j) % 3]).
LOAD_KINDS = ("unmeasured constant", "measured constant", "measured sine")

# ----------------------------------------------------------------------------- units


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def draw_unit(
    index: int, seed: int = FIRST_SEED, bands: Mapping[str, float] | None = None
) -> tuple[str, Unit]:
    """(kind, unit) of unit `index` of the population."""
    bands = bands or Tolerances.load().bands
    kind = KIND_CYCLE[index % len(KIND_CYCLE)]
    rng = np.random.default_rng((seed + index, UNIT_STREAM))
    values: dict[str, float] = {}
    if kind == "corner":
        n = int(rng.integers(3, 5))
        keys = rng.choice(len(UNIT_KEYS), size=n, replace=False)
        signs = rng.choice((-1.0, 1.0), size=n)
        for key_i, sign in zip(keys, signs, strict=True):
            key = UNIT_KEYS[int(key_i)]
            dev = float(sign) * bands[key]
            values[key] = dev if key in OFFSET_KEYS else 1.0 + dev
    else:
        reach = 1.0 if kind == "inside" else WIDE
        for key in UNIT_KEYS:
            dev = float(rng.uniform(-reach, reach)) * bands[key]
            values[key] = dev if key in OFFSET_KEYS else max(FACTOR_FLOOR, 1.0 + dev)
    return kind, Unit(**values)


def outside_bands(unit: Unit, bands: Mapping[str, float] | None = None) -> list[str]:
    """The keys of `unit` outside their declared band (config/unit_tolerances.yaml)."""
    bands = bands or Tolerances.load().bands
    out = []
    for key in UNIT_KEYS:
        value = getattr(unit, key)
        dev = value if key in OFFSET_KEYS else value - 1.0
        if abs(dev) > bands[key] * (1.0 + 1e-9) + 1e-15:
            out.append(key)
    return out


def in_spec(unit: Unit, bands: Mapping[str, float] | None = None) -> bool:
    """Whether every key of `unit` lies inside its declared band (edges included)."""
    return not outside_bands(unit, bands)


# ----------------------------------------------------------------------------- environments


def _noise(rng: np.random.Generator, fine: bool) -> dict[str, float]:
    out = {
        name: NOISE[name] * _log_uniform(rng, *NOISE_FACTOR)
        for name in ("noise_current", "noise_speed")
    }
    out["noise_position"] = (
        _log_uniform(rng, *FINE_POSITION)
        if fine
        else NOISE["noise_position"] * _log_uniform(rng, *NOISE_FACTOR)
    )
    return out


def hangar(index: int, seed: int = FIRST_SEED, baselines: int = 2) -> dict:
    """The commissioning day of unit `index`: one noise, `baselines` temperatures and loads."""
    rng = np.random.default_rng((seed + index, HANGAR_STREAM))
    noise = _noise(rng, fine=index % 3 == 0)
    envs = [
        {
            "temperature_c": float(rng.uniform(*HANGAR_C)),
            "load": {
                "kind": "unmeasured constant",
                "value": float(rng.uniform(*HANGAR_LOAD_NM)),
                "spring": float(rng.uniform(*HANGAR_SPRING)),
            },
            "noise": noise,
        }
        for _ in range(baselines)
    ]
    return {"noise": noise, "baselines": envs}


def fine_window(index: int, j: int) -> bool:
    """Whether window `j` of unit `index` has the fine user-position sensor (1 in 3).

    On a cycle of its own, so that every load profile meets every noise band (the first
    run drew both on (index + j) % 3: every fine window was also an unmeasured load).
    """
    return (index + 2 * j + 1) % 3 == 0


def window_env(index: int, j: int, seed: int = FIRST_SEED) -> dict:
    """Temperature, noise and load of window `j` of unit `index`."""
    rng = np.random.default_rng((seed + index, WINDOW_STREAM, j))
    kind = LOAD_KINDS[(index + j) % len(LOAD_KINDS)]
    env = {
        "temperature_c": float(rng.uniform(*TEMPERATURE_C)),
        "noise": _noise(rng, fine=fine_window(index, j)),
    }
    if kind == "unmeasured constant":
        load = {"value": rng.uniform(-100, 100), "spring": rng.uniform(0, 4000)}
    elif kind == "measured constant":
        load = {"value": rng.uniform(-150, 150), "spring": rng.uniform(0, 4000)}
    else:
        load = {
            "value": rng.uniform(-50, 50),
            "amplitude": rng.uniform(20, 100),
            "frequency": rng.uniform(0.5, 5.0),
            "spring": rng.uniform(0, 2000),
        }
    env["load"] = {"kind": kind, **{k: float(v) for k, v in load.items()}}
    return env


def load_spec(load: dict) -> LoadSpec:
    """The simulator's LoadSpec of a drawn load."""
    return LoadSpec(
        kind="sine" if "sine" in load["kind"] else "constant",
        value=load["value"],
        amplitude=load.get("amplitude", 0.0),
        frequency=load.get("frequency", 0.0),
        spring=load["spring"],
        measured=load["kind"].startswith("measured"),
    )


def simulate(unit: Unit, k: np.ndarray, env: dict, seed: int) -> Any:
    """The recorded window of `unit` with faults `k` in `env`."""
    base = ActuatorParameters.default()
    command, _ = default_specs()
    return real_ema.simulate(
        k,
        seed=seed,
        actuator=unit.actuator(base, temperature_c=env["temperature_c"]),
        command=command,
        load=load_spec(env["load"]),
        sensors=unit.sensors(**env["noise"]),
        temperature_c=env["temperature_c"],
    ).window


# ----------------------------------------------------------------------------- one unit


def commission_like_cli(windows: list, folder: Path) -> tuple[dict, Any]:
    """`ema-phm calibrate --baseline` on `windows`: (what it said, the belief it gives).

    Refused where the CLI refuses (review problems, then the fit's `unexplained`); the belief
    is then that of `--force` (the unit file carries the problems), so the windows can still
    be judged as a user forcing it would see them.
    """
    sources = [f"#{b + 1}" for b in range(len(windows))]
    t0 = time.perf_counter()
    checks, review_problems = review(windows, sources)
    res = commission(windows, checks=checks)
    fit_problems = res.unexplained()
    problems = review_problems + fit_problems
    res = dataclasses.replace(res, forced=bool(problems))
    res.warnings.extend(problems)
    path = write_unit(res, folder / "unit.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        belief = belief_for(unit_file=path)
    said = {
        "accepted": not problems,
        "refused_at": "review" if review_problems else ("fit" if fit_problems else None),
        "problems": problems,
        "start_statistics": [float(c.adequacy.statistic) for c in checks],
        "excited": [bool(c.excitation.ok) for c in checks],
        "references": [ref.as_dict() for ref in res.references],
        "factors": res.factors,
        "identifiable": res.identifiable,
        "wall_s": time.perf_counter() - t0,
    }
    return said, belief


def commissioned_unit(index: int, seed: int, seed_base: int) -> tuple[Unit, Any, dict]:
    """(unit, belief, record) of unit `index`: drawn, its hangar day simulated, commissioned.

    Commissioned as the CLI does (`commission_like_cli`); baseline b's noise seed is
    `seed_base` + 1000 index + 900 + b.  The record: kind, unit, in-spec, keys outside the
    bands, the hangar day and what commissioning said.
    """
    bands = Tolerances.load().bands
    kind, unit = draw_unit(index, seed, bands)
    day = hangar(index, seed)
    baselines = [
        simulate(unit, NOMINAL, env, seed_base + 1000 * index + 900 + b)
        for b, env in enumerate(day["baselines"])
    ]
    with tempfile.TemporaryDirectory() as folder:
        said, belief = commission_like_cli(baselines, Path(folder))
    record = {
        "kind": kind,
        "unit": unit.as_dict(),
        "in_spec": in_spec(unit, bands),
        "outside": outside_bands(unit, bands),
        "hangar": day,
        "commissioning": said,
    }
    return unit, belief, record
