"""A manufacturing tolerance spec: how far units of one datasheet may spread, and why.

The keys a unit differs from its datasheet by (`UNIT_KEYS`: factors on physical quantities,
sensor gains and offsets), the +/- band of each (read as 3 sigma) and the thermal law, as
config/unit_tolerances.yaml writes them.  A datasheet fact a user can write: the simulator
draws units from it (`simulator.unit.Unit.draw`); commissioning takes it as an input to judge
how far a fitted unit may sit from its description.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import cache
from pathlib import Path
from typing import Any, Mapping

from ..errors import ConfigError
from ..limits import FINITE, LIMITS, check
from .parameters import QUANTITIES, ActuatorParameters, packaged_config_dir, read_yaml

#: Every unit key, in the order a unit is drawn (`simulator.unit.Unit`'s fields).
UNIT_KEYS: tuple[str, ...] = (
    "inertia",
    "torque_constant",
    "resistance",
    "inductance",
    "friction",
    "damping",
    "stiffness",
    "current_gain",
    "current_offset",
    "position_offset",
    "speed_gain",
    "mesh_damping",
)
#: The factors on physical quantities, and how each finds its quantities: (section, test).
SCALED_BY_NAME: Mapping[str, tuple[tuple[str, ...], Any]] = {
    "inertia": (("mechanics",), lambda key: key.startswith("j_")),
    "torque_constant": (
        ("motor",),
        lambda key: key.startswith("ke_") or key == "torque_constant",
    ),
    "resistance": (("motor",), lambda key: key.startswith("r_")),
    "inductance": (("motor",), lambda key: key.startswith("l_")),
    "friction": (("mechanics",), lambda key: key.startswith("friction_")),
    "damping": (("mechanics",), lambda key: key.startswith("c_")),
    "stiffness": (ActuatorParameters.SECTIONS, lambda key: key.endswith("stiffness")),
    "mesh_damping": (ActuatorParameters.SECTIONS, lambda key: key.endswith("damping_ratio")),
}
#: Sensor gain factors and offsets (with the limits.py range each is checked against).
SENSOR_KEYS: Mapping[str, str] = {
    "current_gain": "sensor_gain",
    "current_offset": "current_offset",
    "position_offset": "position_offset",
    "speed_gain": "sensor_gain",
}
#: Keys that are offsets (0 = datasheet) rather than factors (1 = datasheet).
OFFSET_KEYS = frozenset({"current_offset", "position_offset"})


def scaled_quantities(key: str) -> tuple[str, ...]:
    """The "section.name" quantities the factor `key` scales (see the module table)."""
    sections, matches = SCALED_BY_NAME[key]
    return tuple(
        name
        for name in QUANTITIES
        if name.split(".", 1)[0] in sections and matches(name.split(".", 1)[1])
    )


@dataclass(frozen=True)
class Thermal:
    """How R and the back-EMF constant follow temperature (config/unit_tolerances.yaml)."""

    reference_temperature_c: float
    copper_resistance_coefficient: float  # 1/K
    magnet_backemf_coefficient: float  # 1/K


@dataclass(frozen=True)
class Tolerances:
    """Manufacturing tolerance bands (+/-, read as 3 sigma) per unit key, and the thermal law."""

    bands: Mapping[str, float]
    thermal: Thermal
    source: str

    @classmethod
    def load(cls, path: str | Path | None = None) -> Tolerances:
        """The tolerances of `path` (default: the packaged config/unit_tolerances.yaml)."""
        return _packaged_tolerances() if path is None else _read_tolerances(Path(path))


@cache
def _packaged_tolerances() -> Tolerances:
    return _read_tolerances(packaged_config_dir() / "unit_tolerances.yaml")


def _read_tolerances(path: Path) -> Tolerances:
    data = read_yaml(path)
    bands = data.get("tolerances") if isinstance(data, dict) else None
    thermal = data.get("temperature") if isinstance(data, dict) else None
    if not isinstance(bands, dict) or not isinstance(thermal, dict):
        raise ConfigError(f"{path}: needs the mappings 'tolerances' and 'temperature'")
    check_unit_keys(bands, where=f"{path}: tolerances", require_all=True)
    checked = {}
    for key, band in bands.items():
        # an offset's band: up to the offset's own limit; a factor's: LIMITS["unit_tolerance"]
        lim = replace(LIMITS[key], low=0.0) if key in OFFSET_KEYS else LIMITS["unit_tolerance"]
        checked[key] = float(check(key, band, limit=lim, label=f"{path}: tolerances.{key}"))
    names = [f.name for f in fields(Thermal)]
    if sorted(thermal) != sorted(names):
        raise ConfigError(f"{path}: temperature needs exactly {names}, got {sorted(thermal)}")
    coefficients = {
        name: float(check(name, v, limit=FINITE, label=f"{path}: temperature.{name}"))
        for name, v in thermal.items()
    }
    check("temperature", thermal["reference_temperature_c"], label=f"{path}: reference")
    return Tolerances(bands=checked, thermal=Thermal(**coefficients), source=str(path))


def check_unit_keys(mapping: Mapping[str, Any], *, where: str, require_all: bool = False) -> None:
    """ConfigError naming keys of `mapping` that are no unit key (or, `require_all`, missing)."""
    known = list(UNIT_KEYS)
    unknown = [k for k in mapping if k not in known]
    if unknown:
        raise ConfigError(
            f"{where}: unknown key(s) {', '.join(map(str, unknown))} (known: {', '.join(known)})"
        )
    missing = [k for k in known if k not in mapping]
    if require_all and missing:
        raise ConfigError(f"{where}: missing key(s) {', '.join(missing)}")
