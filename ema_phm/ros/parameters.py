"""The parameters of each node, declared once: one table gives name, default, range, description.

A node declares its parameters from its table (`declare_all`), with a
`ParameterDescriptor` carrying the description, read-only flag and, for every
number, the `ema_phm.limits` range as `IntegerRange` / `FloatingPointRange` (rqt's
sliders; rclpy refuses a value outside it at run time).  The same table checks the
values at start-up and when a dynamic parameter is set (`ParameterTable.validated`);
rclpy's own parameters (use_sim_time, ...) are left to rclpy (`ParameterTable.own`).
Whole numbers given for a float parameter (``-p k:=[0,0,0,0,0,0,0,1]``, ``load:=1``)
are taken as floats, at start-up and at run time (`as_declared`).  `config/<node>.yaml`
and the documented parameter tables are checked against `defaults()` by the tests.  Each
node's table lives beside its node: `ema_node_parameters`, `monitor_node_parameters`; here
only the mechanism and the parameters both tables hold.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter

from ..domain.cycles import check_cycle_hours
from ..errors import ConfigError
from ..limits import LIMITS, check
from ..physics.actuator_file import load_actuator


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: its default (which fixes its type), meaning and allowed values."""

    name: str
    default: Any
    description: str
    limit: str | None = None  # key of ema_phm.limits.LIMITS
    choices: tuple[str, ...] = ()  # allowed strings
    choice_words: str = ""  # how an error names a choice ("preset")
    dynamic: bool = False  # may change while the node runs
    check_value: Callable[[Any], Any] | None = None  # further check (e.g. a fault vector)

    def validate(self, value: Any) -> Any:
        """`value` checked (ConfigError / FaultVectorError naming the parameter and value)."""
        if self.limit is not None:
            number = check(self.limit, value, label=self.name)
            return float(number) if isinstance(self.default, float) else number
        if self.choices and value not in self.choices:
            shown = ", ".join(repr(c) for c in self.choices)
            raise ConfigError(
                f"unknown {self.choice_words or self.name} {value!r}; choose from {shown}"
            )
        if self.check_value is not None:
            self.check_value(value)
        return value

    def constraints(self) -> str:
        """The allowed values in words (`ros2 param describe`)."""
        if self.limit is not None:
            return LIMITS[self.limit].describe()
        if self.choices:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        return ""

    def descriptor(self, *, with_range: bool = True) -> ParameterDescriptor:
        """The ParameterDescriptor to declare with: a number carries its range.

        At start-up a value out of range is refused in `validate`'s words (`declare_all`);
        at run time by rclpy ("Parameter seed out of range. Min: 0, Max: ..., value: ...").
        """
        desc = ParameterDescriptor(
            description=self.description,
            read_only=not self.dynamic,
            additional_constraints=self.constraints(),
        )
        if with_range and self.limit is not None:
            lim = LIMITS[self.limit]
            if isinstance(self.default, int):
                desc.integer_range = [
                    IntegerRange(from_value=int(lim.low), to_value=int(lim.high), step=0)
                ]
            else:
                desc.floating_point_range = [
                    FloatingPointRange(from_value=lim.low, to_value=lim.high, step=0.0)
                ]
        return desc


class ParameterTable:
    """The parameters of one node, in declaration order."""

    def __init__(self, node_name: str, specs: Sequence[ParameterSpec]) -> None:
        self.node_name = node_name
        self._specs = {spec.name: spec for spec in specs}

    def __iter__(self) -> Iterator[ParameterSpec]:
        return iter(self._specs.values())

    def __getitem__(self, name: str) -> ParameterSpec:
        return self._specs[name]

    def __contains__(self, name: object) -> bool:
        return name in self._specs

    @property
    def names(self) -> list[str]:
        """Every parameter name, in table order."""
        return list(self._specs)

    @property
    def dynamic_names(self) -> list[str]:
        """Names of the parameters that may change while running."""
        return [spec.name for spec in self if spec.dynamic]

    def defaults(self) -> dict[str, Any]:
        """Name -> default (a fresh copy: lists may be changed by the caller)."""
        return {
            spec.name: list(spec.default) if isinstance(spec.default, list) else spec.default
            for spec in self
        }

    def own(self, params: Iterable[Parameter]) -> dict[str, Any]:
        """Name -> value of those of `params` in this table.

        The others are rclpy's own (use_sim_time, start_type_description_service, QoS
        overrides): rclpy declared and checks them, so a node's callback lets them through.
        """
        return {p.name: p.value for p in params if p.name in self._specs}

    def as_declared(self, params: Iterable[Parameter]) -> list[Parameter]:
        """`params` with whole numbers for a float parameter made floats (others unchanged).

        rclpy types `-p load:=1` and `k:=[0,0,0,0,0,0,0,1]` as integers and would refuse
        them for a float parameter ("expected DOUBLE got INTEGER").
        """
        return [self._as_declared(p) for p in params]

    def _as_declared(self, param: Parameter) -> Parameter:
        spec = self._specs.get(param.name)
        if spec is None or isinstance(spec.default, bool):
            return param
        if isinstance(spec.default, float) and param.type_ == Parameter.Type.INTEGER:
            return Parameter(param.name, Parameter.Type.DOUBLE, float(param.value))
        if isinstance(spec.default, list) and param.type_ == Parameter.Type.INTEGER_ARRAY:
            return Parameter(
                param.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in param.value]
            )
        return param

    def validated(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Every value of `values` checked against its spec (unknown names are an error)."""
        unknown = sorted(set(values) - set(self._specs))
        if unknown:
            raise ConfigError(
                f"unknown {self.node_name} parameter(s) {unknown}; known: {self.names}"
            )
        return {name: self._specs[name].validate(value) for name, value in values.items()}


def declare_all(node: Any, table: ParameterTable, *, check: bool = True) -> dict[str, Any]:
    """Declare every parameter of `table` on `node`; return the values, checked.

    Whole numbers given for float parameters are taken as floats, in the overrides
    (``--ros-args -p``, a params file) and in every later set (a pre-set callback).
    `check` False: the values as given (a managed node checks them at configure, with
    `table.validated`).
    """
    overrides = getattr(node, "_parameter_overrides", None)  # rclpy's; no public setter
    if isinstance(overrides, dict):
        for param in table.as_declared([p for p in overrides.values() if p.name in table]):
            overrides[param.name] = param
    node.add_pre_set_parameters_callback(table.as_declared)
    values = {spec.name: _declare(node, spec) for spec in table}
    return table.validated(values) if check else values


def _declare(node: Any, spec: ParameterSpec) -> Any:
    try:
        return node.declare_parameter(spec.name, spec.default, spec.descriptor()).value
    except InvalidParameterValueException:
        # rclpy's range check refused the value: declare it unranged to say why in our words
        value = node.declare_parameter(
            spec.name, spec.default, spec.descriptor(with_range=False)
        ).value
        spec.validate(value)
        raise


def check_actuator_file(value: Any) -> None:
    """ConfigError naming the parameter unless '' or a readable actuator file."""
    if str(value).strip():
        try:
            load_actuator(str(value).strip())
        except ConfigError as exc:  # names the file and the key; say which parameter too
            raise ConfigError(f"actuator_file: {exc}") from None


#: Both nodes' `actuator_file` (one spec, in both tables): what is simulated and believed.
ACTUATOR_FILE = ParameterSpec(
    "actuator_file",
    "",
    "the actuator, an actuator file (ema_phm/physics/actuator_file.py): ema_node simulates it, "
    "monitor_node's belief is built from it; '' = the packaged thesis actuator; fixed at "
    "start-up",
    check_value=check_actuator_file,
)


def check_cycle_hours_or_file(value: Any) -> None:
    """ConfigError unless 0 (the file's or stream's) or hours per cycle in range."""
    if value != 0.0:  # 0: the file's / stream's (the sentinel itself, not a computed value)
        check_cycle_hours(value, label="cycle_hours")
