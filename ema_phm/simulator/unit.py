"""One manufactured actuator: how it differs from its datasheet, and at what temperature.

`Unit` holds factors on datasheet quantities and sensor errors; `Unit.actuator(base)`
gives the `ActuatorParameters` of that unit (at a temperature), `Unit.sensors(...)` its
`SensorSpec`.  Which quantities of `physics/parameters.py` each factor scales is found by
name in `QUANTITIES` (only the sections `ActuatorParameters` has), so quantities the HF
gains later follow the same rule:

=================  ===================================================  =================
key                scales (rule: section.name)                          today
=================  ===================================================  =================
inertia            mechanics.j_*                                        j_motor, j_user
torque_constant    motor.ke_*, motor.torque_constant                    ke_phase_peak,
                                                                        torque_constant
resistance         motor.r_*                                            r_phase_to_phase
inductance         motor.l_*                                            l_phase_to_phase
friction           mechanics.friction_* (healthy values, before k1)     the four FST/FDT
damping            mechanics.c_* (viscous damping)                      c_motor, c_user
stiffness          every *stiffness in the actuator's sections          high_fidelity.
                                                                        torsional_stiffness
mesh_damping       every *damping_ratio in the actuator's sections      high_fidelity.
                                                                        torsional_damping_ratio
=================  ===================================================  =================

The controller's own torque gain (controller.torque_gain) is what the controller
believes, not the magnet, and is never scaled.  Sensor keys (`current_gain`,
`current_offset` [A], `position_offset` [rad, user position sensor], `speed_gain`) go to
`SensorSpec`.  `Unit.draw(seed)` draws a unit from the tolerance bands of
config/unit_tolerances.yaml (each with its reason there).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..limits import FINITE, check
from ..physics.parameters import ActuatorParameters, read_yaml
from ..physics.tolerances import (
    OFFSET_KEYS,
    SCALED_BY_NAME,
    SENSOR_KEYS,
    UNIT_KEYS,
    Thermal,
    Tolerances,
    check_unit_keys,
    scaled_quantities,
)
from .sensors import SensorSpec


@dataclass(frozen=True)
class Unit:
    """One manufactured actuator: factors on its datasheet values (1 = datasheet), sensor errors.

    The default is the datasheet unit.  See the module docstring for what each key scales.
    """

    inertia: float = 1.0
    torque_constant: float = 1.0
    resistance: float = 1.0
    inductance: float = 1.0
    friction: float = 1.0
    damping: float = 1.0
    stiffness: float = 1.0
    current_gain: float = 1.0
    current_offset: float = 0.0  # A, on the acquired I_3eq
    position_offset: float = 0.0  # rad, user position sensor
    speed_gain: float = 1.0
    # last, so that adding it left the draws of every key above unchanged
    mesh_damping: float = 1.0

    def __post_init__(self) -> None:
        for key in UNIT_KEYS:
            value = getattr(self, key)
            limit = SENSOR_KEYS.get(key, "unit_factor")
            checked = check(limit, value, label=f"unit {key}")
            object.__setattr__(self, key, float(checked))

    @classmethod
    def parse(cls, spec: str) -> Unit:
        """A unit from ``KEY=VALUE[,KEY=VALUE...]`` or a YAML file with the same keys.

        `spec` is read as a file when it holds no "=".  Unknown keys, repeated keys and
        impossible values raise ConfigError naming them.
        """
        text = str(spec).strip()
        if not text:
            raise ConfigError("unit spec is empty: give KEY=VALUE[,KEY=VALUE...] or a YAML file")
        if "=" not in text:
            return cls.from_mapping(_read_unit_file(Path(text)), where=f"unit file {text}")
        values: dict[str, str] = {}
        for item in text.split(","):
            key, sep, value = (part.strip() for part in item.partition("="))
            if not sep or not key or not value:
                raise ConfigError(f"unit spec item {item.strip()!r} is not KEY=VALUE")
            if key in values:
                raise ConfigError(f"unit spec gives {key!r} twice")
            values[key] = value
        return cls.from_mapping(values, where="unit spec")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], *, where: str = "unit") -> Unit:
        """A unit from {key: number} (numbers may be numeric strings); ConfigError otherwise."""
        check_unit_keys(values, where=where)
        numbers = {k: check(k, v, limit=FINITE, label=f"{where}: {k}") for k, v in values.items()}
        return cls(**{k: float(v) for k, v in numbers.items()})

    @classmethod
    def draw(cls, seed: int, *, tolerances: Tolerances | None = None) -> Unit:
        """A unit drawn from `tolerances` (default: config/unit_tolerances.yaml) by `seed`.

        Each key in `UNIT_KEYS` order: a standard normal z from
        ``numpy.random.default_rng(seed)``, redrawn until |z| <= 3, then
        1 + band*z/3 (factors) or band*z/3 (offsets).  The same seed gives the same unit.
        """
        tol = tolerances or Tolerances.load()
        rng = np.random.default_rng(int(check("seed", seed, label="unit seed")))
        values = {}
        for key in UNIT_KEYS:
            z = rng.standard_normal()
            while abs(z) > 3.0:
                z = rng.standard_normal()
            spread = tol.bands[key] * z / 3.0
            values[key] = spread if key in OFFSET_KEYS else 1.0 + spread
        return cls(**values)

    def as_dict(self) -> dict[str, float]:
        """The keys and values (for run_info)."""
        return asdict(self)

    def spec(self) -> str:
        """The ``KEY=VALUE,...`` text of every key; `Unit.parse` gives this unit back."""
        return ",".join(f"{k}={getattr(self, k)!r}" for k in UNIT_KEYS)

    def actuator(
        self,
        base: ActuatorParameters,
        *,
        temperature_c: float | None = None,
        thermal: Thermal | None = None,
    ) -> ActuatorParameters:
        """The parameters of this unit built to `base`, at `temperature_c` (None: reference).

        A PI drive keeps the gains and constants it was tuned with on `base`
        (`ActuatorParameters.drive_frozen`).  Every quantity a factor scales (module table)
        is multiplied by it; then, at a
        temperature T, R (motor.r_*) is multiplied by 1 + a_Cu*(T - T_ref) and the back-EMF
        / torque constant (the `torque_constant` quantities) by 1 + a_mag*(T - T_ref), with
        `thermal` (default: config/unit_tolerances.yaml).
        """
        base.require_simulable()  # a description without the HF section: say so, in one line
        base = base.drive_frozen()  # the drive was tuned on the datasheet: it keeps its gains
        changes: dict[str, float] = {}
        for key in SCALED_BY_NAME:
            for name in scaled_quantities(key):
                changes[name] = changes.get(name, base.value(name)) * getattr(self, key)
        if temperature_c is not None:
            law = thermal or Tolerances.load().thermal
            dt = float(check("temperature", temperature_c)) - law.reference_temperature_c
            for name in scaled_quantities("resistance"):
                changes[name] *= 1.0 + law.copper_resistance_coefficient * dt
            for name in scaled_quantities("torque_constant"):
                changes[name] *= 1.0 + law.magnet_backemf_coefficient * dt
        return base.with_values(changes)

    def sensors(
        self, *, noise_current: float = 0.0, noise_position: float = 0.0, noise_speed: float = 0.0
    ) -> SensorSpec:
        """The sensors of this unit, with the given white-noise RMS levels."""
        return SensorSpec(
            current_gain=self.current_gain,
            current_offset=self.current_offset,
            position_offset=self.position_offset,
            speed_gain=self.speed_gain,
            noise_current=noise_current,
            noise_position=noise_position,
            noise_speed=noise_speed,
        )


#: Every key of a unit, in the order `Unit.draw` draws them.
if tuple(f.name for f in fields(Unit)) != UNIT_KEYS:  # one list of keys, in draw order
    raise ImportError("Unit's fields and physics.tolerances.UNIT_KEYS differ")


def _read_unit_file(path: Path) -> Mapping[str, Any]:
    if not path.is_file():
        raise ConfigError(
            f"unit spec {str(path)!r} is neither KEY=VALUE[,KEY=VALUE...] nor a readable file"
        )
    data = read_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"unit file {path}: must be a mapping of KEY: VALUE, got {data!r}")
    return data


def select_unit(
    spec: str | None, seed: int | None, *, names: tuple[str, str] = ("unit", "unit_seed")
) -> Unit:
    """The unit `spec` describes, or the one drawn by `seed`, or the datasheet unit.

    An empty / None `spec` and a None `seed` mean "not given"; giving both is a
    ConfigError naming both (`names`: how the caller calls them).
    """
    given = bool(spec and str(spec).strip())
    if given and seed is not None:
        raise ConfigError(
            f"{names[0]} ({spec!r}) and {names[1]} ({seed!r}) both given: a unit is either "
            "described or drawn, give one of them"
        )
    if given:
        return Unit.parse(str(spec))
    return Unit() if seed is None else Unit.draw(seed)


def unit_record(unit: Unit, *, spec: str | None, seed: int | None) -> dict[str, Any]:
    """What produced `unit`, for run_info / bag metadata: the spec or seed and every value."""
    return {"spec": spec or None, "seed": seed, "values": unit.as_dict()}
