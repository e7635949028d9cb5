"""A simulated fleet for tests and benchmarks: N drawn units, each with its own life.

`generate_fleet(out, units=N, windows=W, seed=S)` draws, per unit, a manufactured unit
(`physics.unit.Unit.draw`), whether it degrades (with probability `degrading_share`) and which
predicted fault grows by which law (wear linear, propagation exponential), and writes:

- ``UNIT/baseline_B/``: `envelope.BASELINES` healthy hangar windows (run_info ``purpose:
  baseline``) the fleet ingest commissions the unit from;
- ``UNIT/flight_CCCC/``: one window per operating cycle C = 0..W-1, each a separate
  recording at that flight's own temperature and unmeasured load (drawn from
  `physics.envelope`), with the unit's realistic sensors;
- ``fleet_truth.json``: what was drawn, per unit (the fault and its degradation), so that a
  benchmark can score what the fleet's report names.

The HF model plays every unit (nothing of the monitor is used).  Every draw comes from
``numpy.random.default_rng((seed, unit index, stream))``: the same seed gives the same fleet.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..atomic_file import write_text_atomic
from ..domain.faults import NAMES, NOMINAL, PREDICTED
from ..errors import ConfigError
from ..limits import Limit, check
from ..physics.commands import LoadSpec, default_specs
from ..physics.parameters import ActuatorParameters
from ..simulator import envelope
from ..simulator.degradation import Degradation
from ..simulator.unit import Unit
from .catalog import BASELINE, CYCLE_KEY, PURPOSE_KEY, RUN_KEY, UNIT_KEY

#: Growth law of each predicted fault: wear grows linearly, a short or an eccentricity
#: propagates (physics.degradation's reasons).
LAW = {
    "friction": "linear",
    "backlash": "linear",
    "short_circuit_a": "exponential",
    "short_circuit_b": "exponential",
    "short_circuit_c": "exponential",
    "eccentricity": "exponential",
}
#: Severity a degrading unit's fault reaches at its last window, uniform: past the WARN
#: severity (0.15), short of the failure threshold (0.4).
FINAL_SEVERITY = (0.25, 0.38)
#: Severity at the onset: linear (uniform) and exponential (uniform, > 0).
INITIAL_LINEAR = (0.0, 0.02)
INITIAL_EXPONENTIAL = (0.02, 0.05)
#: Share of the units that degrade (the others stay healthy).
DEGRADING_SHARE = 0.75
#: Operating hours per cycle written in every recording.
CYCLE_HOURS = 2.0
#: Truth file written beside the units.
TRUTH_FILE = "fleet_truth.json"
UNITS_LIMIT = Limit(1, 100000, integer=True)
WINDOWS_LIMIT = Limit(2, 1000, integer=True)


@dataclass(frozen=True)
class DrawnUnit:
    """One unit of a generated fleet: its id, seeds and degradation (None: healthy)."""

    unit_id: str
    unit_seed: int
    fault: str | None
    degradation: Degradation
    final_severity: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready truth."""
        return {
            "unit_seed": self.unit_seed,
            "fault": self.fault,
            "final_severity": self.final_severity,
            "degradation": self.degradation.as_dict(),
        }


def draw_unit(seed: int, index: int, windows: int, degrading_share: float) -> DrawnUnit:
    """Unit `index` of the fleet of `seed`: whether and how it degrades over `windows`."""
    rng = np.random.default_rng((seed, index, 31))
    unit_seed = int(rng.integers(0, 2**31 - 1))
    unit_id = f"EMA-{index + 1:04d}"
    if rng.uniform() >= degrading_share:
        return DrawnUnit(unit_id, unit_seed, None, Degradation.from_mapping({"faults": {}}), 0.0)
    name = NAMES[PREDICTED[int(rng.integers(len(PREDICTED)))]]
    onset = int(rng.integers(0, max(1, windows // 3) + 1))
    final = float(rng.uniform(*FINAL_SEVERITY))
    span = max(1, windows - 1 - onset)
    if LAW[name] == "linear":
        initial = float(rng.uniform(*INITIAL_LINEAR))
        rate = (final - initial) / span
    else:
        initial = float(rng.uniform(*INITIAL_EXPONENTIAL))
        rate = math.log(final / initial) / span
    spec = {"law": LAW[name], "onset": onset, "initial": initial, "rate": rate, "cap": True}
    deg = Degradation.from_mapping({"faults": {name: spec}}, source=f"unit {unit_id}")
    return DrawnUnit(unit_id, unit_seed, name, deg, final)


def _flight(rng: np.random.Generator, hangar: bool) -> dict[str, float]:
    """One window's temperature and unmeasured load: the flight envelope or the hangar's."""
    e = envelope
    t, load, spring = (
        (e.HANGAR_C, e.HANGAR_LOAD_NM, e.HANGAR_SPRING)
        if hangar
        else (e.TEMPERATURE_C, e.LOAD_NM, e.SPRING_NM_PER_RAD)
    )
    return {
        "temperature_c": float(rng.uniform(*t)),
        "load_nm": float(rng.uniform(*load)),
        "spring_nm_per_rad": float(rng.uniform(*spring)),
    }


def _window(
    unit: Unit, k: np.ndarray, env: dict[str, float], run_seed: int, meta: dict[str, Any]
) -> Any:
    """One HF window of `unit` in `env`, carrying `meta` as its run_info."""
    from ..simulator import real_ema  # noqa: PLC0415  (numba only when windows are simulated)

    command, _ = default_specs()
    res = real_ema.simulate(
        k,
        actuator=unit.actuator(ActuatorParameters.default(), temperature_c=env["temperature_c"]),
        command=command,
        load=LoadSpec(value=env["load_nm"], spring=env["spring_nm_per_rad"], measured=False),
        sensors=unit.sensors(**envelope.NOISE),
        seed=run_seed,
        temperature_c=env["temperature_c"],
    )
    return replace(res.window, meta={**res.window.meta, **meta, **env})


def write_unit(
    out: Path, drawn: DrawnUnit, seed: int, index: int, windows: int, *, baselines: int
) -> int:
    """Write one unit's baselines and flights under ``out/UNIT``; how many recordings."""
    from ..telemetry.bags import write_window  # noqa: PLC0415

    folder = out / drawn.unit_id
    folder.mkdir(parents=True)
    common = {UNIT_KEY: drawn.unit_id, RUN_KEY: "life-1", "cycle_hours": CYCLE_HOURS}
    rng = np.random.default_rng((seed, index, 37))
    unit = Unit.draw(drawn.unit_seed)
    for b in range(baselines):
        meta = {**common, PURPOSE_KEY: BASELINE, CYCLE_KEY: b}
        w = _window(unit, NOMINAL.copy(), _flight(rng, True), int(rng.integers(2**31)), meta)
        write_window(folder / f"baseline_{b}", w)
    for c in range(windows):
        meta = {**common, PURPOSE_KEY: "flight", CYCLE_KEY: c}
        k = drawn.degradation.k(c)
        w = _window(unit, k, _flight(rng, False), int(rng.integers(2**31)), meta)
        write_window(folder / f"flight_{c:04d}", w)
    return baselines + windows


def generate_fleet(
    out: str | Path,
    *,
    units: int,
    windows: int,
    seed: int = 0,
    degrading_share: float = DEGRADING_SHARE,
    baselines: int = envelope.BASELINES,
    on_unit: Callable[[DrawnUnit], None] | None = None,
) -> list[DrawnUnit]:
    """Write a fleet of `units` units with `windows` flights each under `out` (new folder).

    `baselines`: healthy hangar windows per unit (0: none; the fleet's units are then not
    commissioned).  ConfigError naming a bad count, share or an existing `out`.
    """
    out = Path(out)
    units = int(check("units", units, limit=UNITS_LIMIT, label="units"))
    windows = int(check("windows", windows, limit=WINDOWS_LIMIT, label="windows"))
    if not 0.0 <= float(degrading_share) <= 1.0:
        raise ConfigError(f"degrading share must lie in [0, 1], got {degrading_share!r}")
    if out.exists():
        raise ConfigError(f"refusing to write the fleet into {out}: it already exists")
    drawn = [draw_unit(seed, i, windows, degrading_share) for i in range(units)]
    out.mkdir(parents=True)
    for i, d in enumerate(drawn):
        write_unit(out, d, seed, i, windows, baselines=baselines)
        if on_unit is not None:
            on_unit(d)
    truth = {
        "seed": seed,
        "windows": windows,
        "baselines": baselines,
        "cycle_hours": CYCLE_HOURS,
        "units": {d.unit_id: d.as_dict() for d in drawn},
    }
    write_text_atomic(out / TRUTH_FILE, json.dumps(truth, indent=1))
    return drawn
