"""Actuator files: one actuator's description in YAML, every key named with its unit.

`load_actuator(path)` reads one (None: the packaged thesis actuator,
config/actuators/thesis_ema.yaml) and `write_actuator(actuator, path)` writes one.  The
file has the sections of `ActuatorParameters` (motor, inverter, controller, current_loop,
mechanics, acquisition, high_fidelity) and an optional `monitor` section (`MONITOR_KEYS`:
what the monitor expects of a healthy unit).  The keys of `actuator.OPTIONAL` may be left
out, so the whole current_loop section unless the controller's kind is pi_dq_current.  Each
key is a quantity's name followed by its unit (`r_phase_to_phase_ohm`, `j_motor_kg_m2`);
dimensionless quantities keep their bare name (`gear_ratio`; `min_working_coils_fraction`
names its fraction), and `controller.kind` names the control law (physics/actuator.py).
An unknown, missing or mistyped key, or a value out of range, is a ConfigError naming the
file, the key and the value.  A quantity of `parameters.UNKNOWABLE` (a drive's speed-loop
gains) may be written ``{unknown: [low, high]}``: the monitor starts from the range's
geometric mean and commissioning identifies the unit's value (`ActuatorParameters.unknowns`).

The actuator and the monitor.  The actuator file says what the (simulated) actuator IS; the
monitor's belief (`MonitorBelief`) says what the LF model assumes.
`MonitorBelief.for_actuator(actuator, calibration=...)` builds the belief of an actuator: its
physical sections and controller kind are the actuator's; its `monitor` section (the LF's
equivalents r, l, ke, gt, vdc, stiffness, ...) is the packaged config/ema.yaml's with the
actuator's electrical equivalents for its kind (`parameters.monitor_equivalents`) and the
file's `monitor` values over it, then ke and gt from a calibration file (kind
hysteresis_current: the packaged one by default; pi_dq_current: none by default).  A
commissioned unit file (`MonitorBelief.with_unit`) then sets the belief quantities it lists
(any monitor or physical quantity of `QUANTITIES`) over that belief.  For the packaged
actuator, `MonitorBelief.for_actuator(load_actuator(None))` has the sections (values) of
`MonitorBelief.default()`; only its `source` differs.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import yaml

from ..atomic_file import write_text_atomic
from ..errors import ConfigError
from .actuator import CONTROLLER_KINDS, OPTIONAL, PI_DQ_CURRENT, file_keys
from .parameters import (
    HF_SECTION,
    QUANTITIES,
    ActuatorParameters,
    check_quantity,
    check_unknown,
    packaged_config_dir,
    read_yaml,
)

#: The packaged thesis actuator, relative to the packaged config folder.
THESIS_ACTUATOR = Path("actuators") / "thesis_ema.yaml"


def packaged_actuator_path() -> Path:
    """Where the packaged thesis actuator file is (beside the packaged ema.yaml)."""
    return packaged_config_dir() / THESIS_ACTUATOR


def load_actuator(path: str | os.PathLike[str] | None = None) -> ActuatorParameters:
    """The actuator an actuator file describes (None: the packaged thesis actuator)."""
    path = packaged_actuator_path() if path is None else Path(path)
    where = str(path)
    data = read_yaml(path)
    known = (*ActuatorParameters.SECTIONS, MONITOR_SECTION)
    _no_unknown("section", set(map(str, data)), known, where)
    sections: dict[str, dict[str, float]] = {}
    unknowns: dict[str, tuple[float, float]] = {}
    kind = ""
    for sec in ActuatorParameters.SECTIONS:
        keys = file_keys(sec)
        raw = data.get(sec)
        if raw is None and sec == HF_SECTION:  # monitored, not simulated: `simulable` False
            continue
        if raw is None and all(f"{sec}.{name}" in OPTIONAL for name in keys):
            raw = {}
        if not isinstance(raw, dict):
            raise ConfigError(f"{where}: section {sec!r} is missing or not a mapping, got {raw!r}")
        _no_unknown(f"key in {sec}", set(map(str, raw)), tuple(keys.values()), where)
        values: dict[str, float] = {}
        for name, key in keys.items():
            if key not in raw:
                if f"{sec}.{name}" in OPTIONAL:
                    continue
                raise ConfigError(f"{where}: {sec}.{key} is missing")
            if name == "kind":
                kind = _kind(raw[key], f"{where}: {sec}.{key}")
            elif isinstance(raw[key], dict):  # {unknown: [low, high]}
                rng = _unknown(f"{sec}.{name}", raw[key], f"{where}: {sec}.{key}")
                unknowns[f"{sec}.{name}"] = rng
                values[name] = math.sqrt(rng[0] * rng[1])
            else:
                values[name] = check_quantity(f"{sec}.{name}", raw[key], f"{where}: {sec}.{key}")
        sections[sec] = values
    return ActuatorParameters.from_sections(
        sections,
        source=where,
        controller_kind=kind,
        monitor_values=_monitor_values(data, where),
        unknowns=unknowns,
    )


#: How a file marks a quantity it does not know: ``speed_kp_N_m_s_per_rad: {unknown: [lo, hi]}``.
UNKNOWN_KEY = "unknown"


def _unknown(name: str, raw: dict[str, Any], where: str) -> tuple[float, float]:
    """The (low, high) range of a quantity the file marks ``{unknown: [low, high]}``."""
    if set(map(str, raw)) != {UNKNOWN_KEY}:
        raise ConfigError(
            f"{where}: a quantity is a number or {{{UNKNOWN_KEY}: [low, high]}}, got {raw!r}"
        )
    return check_unknown(name, raw[UNKNOWN_KEY], where)


#: The optional `monitor` section: what the monitor expects of a healthy unit of this
#: actuator, the datasheet stiffness it believes, how finely it integrates (file key ->
#: monitor quantity).
MONITOR_SECTION = "monitor"
MONITOR_KEYS: dict[str, str] = {
    "healthy_fitness": "monitor.healthy_fitness",
    "healthy_fitness_followed": "monitor.healthy_fitness_followed",
    "stiffness_N_m_per_rad": "monitor.stiffness",
    "steps_per_sample": "monitor.steps_per_sample",
    "mesh_damping_ratio": "monitor.mesh_damping_ratio",
}


def _monitor_values(data: dict[str, Any], where: str) -> dict[str, float]:
    raw = data.get(MONITOR_SECTION, {})
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: section {MONITOR_SECTION!r} is not a mapping, got {raw!r}")
    _no_unknown(f"key in {MONITOR_SECTION}", set(map(str, raw)), tuple(MONITOR_KEYS), where)
    return {
        MONITOR_KEYS[key]: check_quantity(MONITOR_KEYS[key], value, f"{where}: monitor.{key}")
        for key, value in raw.items()
    }


def actuator_text(actuator: ActuatorParameters, *, title: str = "") -> str:
    """The YAML an actuator file holds for `actuator`, a unit comment on every line.

    `title`: comment lines put at the top (default: where the values were read).
    """
    lines = [f"# {line}".rstrip() for line in (title or f"From {actuator.source}").splitlines()]
    lines += [
        "# Actuator file (ema_phm/physics/actuator_file.py): every key is a quantity with its",
        "# unit; keys without a unit are dimensionless.",
    ]
    for sec in ActuatorParameters.SECTIONS:
        if sec == "current_loop" and actuator.controller_kind != PI_DQ_CURRENT:
            continue  # only kind pi_dq_current reads it (every key optional)
        if sec == HF_SECTION and not actuator.simulable:
            continue  # a description to monitor with, not to simulate
        lines.append(f"{sec}:")
        for name, key in file_keys(sec).items():
            if name == "kind":
                lines.append(f"  {key}: {actuator.controller_kind}  # one of: {_kinds()}")
                continue
            value = _scalar(actuator[sec][name])
            rng = actuator.unknowns.get(f"{sec}.{name}")
            if rng is not None:
                value = f"{{{UNKNOWN_KEY}: [{_scalar(rng[0])}, {_scalar(rng[1])}]}}"
            unit = QUANTITIES[f"{sec}.{name}"]
            unit = "dimensionless" + unit[1:] if unit.startswith("-") else unit
            lines.append(f"  {key}: {value}  # {unit}")
    if actuator.monitor_values:
        lines.append(f"{MONITOR_SECTION}:")
        for key, name in MONITOR_KEYS.items():
            if name in actuator.monitor_values:
                value = _scalar(actuator.monitor_values[name])
                unit = QUANTITIES[name]
                unit = "dimensionless" + unit[1:] if unit.startswith("-") else unit
                lines.append(f"  {key}: {value}  # {unit}")
    return "\n".join(lines) + "\n"


def write_actuator(
    actuator: ActuatorParameters, path: str | os.PathLike[str], *, title: str = ""
) -> Path:
    """Write `actuator` as an actuator file at `path` (whole or not at all); the path."""
    return write_text_atomic(Path(path), actuator_text(actuator, title=title))


#: The title comment of the packaged thesis actuator file.
THESIS_TITLE = """The thesis's EMA (Table 2.1 and the choices config/ema.yaml explains): the
packaged default actuator, ActuatorParameters.default().  Its values are config/ema.yaml's
motor, inverter, controller, mechanics, acquisition and high_fidelity sections, whose
comments say where each comes from; test/physics/test_actuator_file.py keeps the two equal.
Generated: python -c 'from ema_phm.physics import actuator_file as a; a.write_packaged()'"""


def write_packaged() -> Path:
    """Rewrite the packaged thesis actuator file from ActuatorParameters.default()."""
    default = ActuatorParameters.default()
    return write_actuator(default, packaged_actuator_path(), title=THESIS_TITLE)


def _kinds() -> str:
    return ", ".join(CONTROLLER_KINDS)


def _scalar(value: float) -> str:
    # YAML's own spelling of the float: it reads back to the same value
    return yaml.safe_dump(float(value), default_flow_style=True).splitlines()[0]


def _no_unknown(what: str, given: set[str], known: tuple[str, ...], where: str) -> None:
    unknown = sorted(given - set(known))
    if unknown:
        raise ConfigError(f"{where}: unknown {what} {unknown[0]!r} (known: {', '.join(known)})")


def _kind(value: Any, where: str) -> str:
    if not isinstance(value, str) or value not in CONTROLLER_KINDS:
        raise ConfigError(f"{where} must be one of {_kinds()}, got {value!r}")
    return value
