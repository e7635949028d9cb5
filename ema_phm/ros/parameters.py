"""The parameters of each node, declared once: one table gives name, default, range, description.

A node declares its parameters from its table (`declare_all`), with a
`ParameterDescriptor` carrying the description, read-only flag and, for every
number, the `ema_phm.limits` range as `IntegerRange` / `FloatingPointRange` (rqt's
sliders; rclpy refuses a value outside it at run time).  The same table checks the
values at start-up and when a dynamic parameter is set (`ParameterTable.validated`);
rclpy's own parameters (use_sim_time, ...) are left to rclpy (`ParameterTable.own`).
Whole numbers given for a float parameter (``-p k:=[0,0,0,0,0,0,0,1]``, ``load:=1``)
are taken as floats, at start-up and at run time (`as_declared`).  `config/<node>.yaml`
and the README's parameter tables are checked against `defaults()` by the tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter

from ..diagnosis import health
from ..domain.faults import LABELS, N_K, NOMINAL, NOT_APPLICABLE, SEVERITY_INDICES, validate
from ..errors import ConfigError
from ..limits import LIMITS, check
from ..physics.actuator_file import load_actuator
from ..physics.commands import KINDS, default_specs
from ..physics.degradation import Degradation, check_cycle_hours
from ..physics.unit import Tolerances, Unit
from ..prognostics.learn import load_growth_priors
from ..prognostics.rul import failure_thresholds
from ..telemetry.wire import StreamId


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


def declare_all(node: Any, table: ParameterTable) -> dict[str, Any]:
    """Declare every parameter of `table` on `node`; return the values, checked.

    Whole numbers given for float parameters are taken as floats, in the overrides
    (``--ros-args -p``, a params file) and in every later set (a pre-set callback).
    """
    overrides = getattr(node, "_parameter_overrides", None)  # rclpy's; no public setter
    if isinstance(overrides, dict):
        for param in table.as_declared([p for p in overrides.values() if p.name in table]):
            overrides[param.name] = param
    node.add_pre_set_parameters_callback(table.as_declared)
    return table.validated({spec.name: _declare(node, spec) for spec in table})


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


def _check_fault_vector(value: Any) -> None:
    k: Any = list(value) if value is not None else None  # None: validate names it
    validate(k)


def ema_node_parameters() -> ParameterTable:
    """ema_node's parameters (command and load defaults from config/commands.yaml)."""
    cmd, load = default_specs()
    return ParameterTable(
        "ema_node",
        [
            ParameterSpec(
                "k",
                [float(v) for v in NOMINAL],
                f"true fault vector {LABELS[0]}..{LABELS[-1]} in [0, 1]; a new value is "
                "applied at the next window boundary",
                dynamic=True,
                check_value=_check_fault_vector,
            ),
            ParameterSpec("noise_current", 0.0, "white-noise RMS on I_3eq [A]", "noise_current"),
            ParameterSpec(
                "noise_position", 0.0, "white-noise RMS on theta_u [rad]", "noise_position"
            ),
            ParameterSpec("noise_speed", 0.0, "white-noise RMS on omega_m [rad/s]", "noise_speed"),
            ParameterSpec("seed", 0, "seed of the measurement noise", "seed"),
            ParameterSpec(
                "command_kind",
                cmd.kind,
                "position command, repeated every window",
                choices=KINDS,
                choice_words="command kind",
            ),
            ParameterSpec(
                "amplitude",
                float(cmd.amplitude),
                "command amplitude, rad at the user shaft (ramp: rad/s)",
                "amplitude",
            ),
            ParameterSpec("f0", float(cmd.f0), "chirp start / sine frequency [Hz]", "frequency"),
            ParameterSpec("f1", float(cmd.f1), "chirp end frequency [Hz]", "frequency"),
            ParameterSpec(
                "duration", float(cmd.duration), "one window, the command period [s]", "duration"
            ),
            ParameterSpec(
                "load", float(load.value), "constant load at the user shaft [N*m]", "load"
            ),
            *_ema_node_unit_parameters(),
            *_ema_node_stream_parameters(),
            *_ema_node_degradation_parameters(),
        ],
    )


def _check_actuator_file(value: Any) -> None:
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
    check_value=_check_actuator_file,
)


def _check_unit(value: Any) -> None:
    if str(value).strip():
        Unit.parse(str(value))


def _ema_node_unit_parameters() -> list[ParameterSpec]:
    """ema_node's parameters on the rest of its load, the actuator, its unit and temperature."""
    return [
        ParameterSpec(
            "load_spring",
            0.0,
            "hinge-moment load -load_spring * theta_u on top of load [N*m/rad]",
            "load_spring",
        ),
        ParameterSpec(
            "load_unmeasured",
            False,
            "true: the load acts but the telemetry's load channel is NaN (not measured)",
        ),
        ACTUATOR_FILE,
        ParameterSpec(
            "unit",
            "",
            "how this unit differs from its datasheet: KEY=VALUE[,KEY=VALUE...] or a YAML "
            "file (physics/unit.py); empty = the datasheet unit",
            check_value=_check_unit,
        ),
        ParameterSpec(
            "unit_seed",
            -1,
            "draw the unit from config/unit_tolerances.yaml with this seed; -1 = none "
            "(not with unit)",
            "unit_seed",
        ),
        ParameterSpec(
            "temperature",
            float(Tolerances.load().thermal.reference_temperature_c),
            "winding and magnet temperature [degC]: R and the back-EMF constant follow it, "
            "the telemetry's temperature channel reads it",
            "temperature",
        ),
    ]


def _ema_node_stream_parameters() -> list[ParameterSpec]:
    """ema_node's parameters on how the stream is published."""
    return [
        ParameterSpec(
            "samples_per_message",
            100,
            "samples per /ema/telemetry message",
            "samples_per_message",
        ),
        ParameterSpec(
            "realtime_factor",
            1.0,
            "simulated s per wall s; 0 = as fast as possible",
            "realtime_factor",
        ),
        ParameterSpec(
            "max_windows",
            0,
            "0 = publish forever; n > 0 = publish n complete windows, then exit",
            "max_windows",
        ),
        ParameterSpec(
            "wait_for_subscribers",
            0,
            "hold the telemetry until this many subscriptions matched (0 = don't wait)",
            "wait_for_subscribers",
        ),
        ParameterSpec(
            "hardware_id",
            "ema_sim",
            "the actuator's id, carried by every telemetry message and run_info (stream identity)",
            check_value=_check_hardware_id,
        ),
        ParameterSpec(
            "run_id",
            "",
            "this run's id, carried with hardware_id; '' = a new random one at start-up",
            check_value=_check_run_id,
        ),
    ]


def _check_hardware_id(value: Any) -> None:
    StreamId(str(value), "run")  # WindowError naming hardware_id and the value


def _check_run_id(value: Any) -> None:
    if str(value):  # '' = a random one at start-up
        StreamId("hardware", str(value))


def _check_degradation(value: Any) -> None:
    if str(value).strip():
        Degradation.load(str(value))


def _check_cycle_hours_or_file(value: Any) -> None:
    if value != 0.0:  # 0: the file's / stream's (the sentinel itself, not a computed value)
        check_cycle_hours(value, label="cycle_hours")


def _ema_node_degradation_parameters() -> list[ParameterSpec]:
    """ema_node's parameters on faults that grow (one window = one operating cycle)."""
    return [
        ParameterSpec(
            "degradation",
            "",
            "YAML file of how each fault grows over cycles (config/degradation_*.yaml): "
            "window c runs with its k at cycle c (k must stay nominal); '' = k fixed",
            check_value=_check_degradation,
        ),
        ParameterSpec(
            "cycle_hours",
            0.0,
            "operating hours per cycle (window) in run_info; 0 = the degradation file's, else 1",
            check_value=_check_cycle_hours_or_file,
        ),
    ]


def monitor_node_parameters() -> ParameterTable:
    """monitor_node's parameters; the first seven may change at run time (from the next window)."""
    return ParameterTable(
        "monitor_node",
        [*_monitor_node_isolation_parameters(), *_monitor_node_output_parameters()],
    )


def _labels(indices: Iterable[int]) -> str:
    """'k7' or 'k7, k8': the thesis's labels of these entries of k."""
    return ", ".join(LABELS[i] for i in indices)


def _monitor_node_isolation_parameters() -> list[ParameterSpec]:
    """monitor_node's parameters on how a window is fitted and judged (dynamic)."""
    # imported here: ema_node need not load the optimizers (pymoo, ~2.5 s)
    from ..diagnosis.fitness import WEIGHTINGS  # noqa: PLC0415
    from ..diagnosis.isolation import PRESETS  # noqa: PLC0415

    no_severity = _labels(i for i in range(N_K) if i not in SEVERITY_INDICES)
    return [
        ParameterSpec(
            "preset",
            "",
            "isolation preset; '' = ema_phm.diagnosis.isolation.DEFAULT_PRESET",
            choices=("", *sorted(PRESETS)),
            choice_words="preset",
            dynamic=True,
        ),
        ParameterSpec(
            "seed", 0, "isolation seed (same seed, same window -> same k)", "seed", dynamic=True
        ),
        ParameterSpec(
            "fitness",
            "default",
            "fitness: 'default' = 'recorded' (follows the recorded loop), 'thesis' (replays the "
            "command open-loop), or a weighting of the open-loop residuals",
            choices=tuple(sorted(WEIGHTINGS)),
            choice_words="fitness weighting",
            dynamic=True,
        ),
        ParameterSpec(
            "max_evaluations",
            0,
            "evaluation budget of one isolation; 0 = the preset's own",
            "max_evaluations",
            dynamic=True,
        ),
        ParameterSpec(
            "tracking",
            True,
            "start each window from the last explained fit (a global search when none, "
            "or when the tracked fit is not explained)",
            dynamic=True,
        ),
        ParameterSpec(
            "warn_threshold",
            list(health.DEFAULT_WARN),
            f"per-fault severity at which the status is WARN ({no_severity} ignored)",
            dynamic=True,
        ),
        ParameterSpec(
            "error_threshold",
            list(health.DEFAULT_ERROR),
            f"per-fault severity at which the status is ERROR ({no_severity} ignored)",
            dynamic=True,
        ),
    ]


def _monitor_node_output_parameters() -> list[ParameterSpec]:
    """monitor_node's parameters on recording and /diagnostics (fixed at start-up)."""
    return [
        ParameterSpec(
            "record_bag",
            "",
            "record to this new rosbag2 MCAP directory ('{stamp}' -> start time); '' = off",
        ),
        ParameterSpec(
            "heartbeat_period", 1.0, "s between /diagnostics heartbeats", "heartbeat_period"
        ),
        ParameterSpec(
            "stale_timeout",
            health.DEFAULT_STALE_TIMEOUT,
            "s without telemetry after which /diagnostics says STALE",
            "stale_timeout",
        ),
        ParameterSpec("hardware_id", "ema_sim", "DiagnosticStatus.hardware_id"),
        ACTUATOR_FILE,
        ParameterSpec(
            "unit_file",
            "",
            "commissioned unit (`ema-phm calibrate --baseline BAG --out FILE`); '' = none",
        ),
        ParameterSpec(
            "commission_windows",
            0,
            "without unit_file: commission from this many first windows, assumed healthy, "
            "against the actuator_file's belief or the packaged one (0 = use that belief as "
            "given)",
            "commission_windows",
        ),
        ParameterSpec(
            "queue_depth",
            health.DEFAULT_QUEUE_DEPTH,
            "windows that may wait behind the running fit (first in, first out); a window "
            "completing with the queue full is skipped and counted",
            "queue_depth",
        ),
        ParameterSpec(
            "warm_up",
            True,
            "before subscribing to telemetry, run the fit once on a short synthetic window "
            "(numba's compilation / cache load) so the first windows are not skipped",
        ),
        *_monitor_node_prognostics_parameters(),
    ]


def _check_failure_thresholds(value: Any) -> None:
    try:
        failure_thresholds(list(value) if value is not None else None)
    except ConfigError as exc:
        raise ConfigError(f"failure_thresholds: {exc}") from None


def _check_growth_priors_file(value: Any) -> None:
    try:
        load_growth_priors(str(value))
    except ConfigError as exc:
        raise ConfigError(f"growth_priors_file: {exc}") from None


def _monitor_node_prognostics_parameters() -> list[ParameterSpec]:
    """monitor_node's parameters on the remaining useful life (fixed at start-up)."""
    return [
        ParameterSpec(
            "prognostics",
            True,
            "after each explained window, predict each fault's remaining useful life from "
            "the windows so far (one window = one operating cycle)",
        ),
        ParameterSpec(
            "cycle_hours",
            0.0,
            "operating hours per cycle (window), for RUL in hours; 0 = the stream's "
            "(run_info cycle_hours), else 1",
            check_value=_check_cycle_hours_or_file,
        ),
        ParameterSpec(
            "rul_horizon_cycles",
            10,
            "WARN when a degrading fault's RUL 5th percentile is below this many cycles (in "
            "rul_alarm_windows consecutive prognoses)",
            "rul_horizon_cycles",
        ),
        ParameterSpec(
            "rul_alarm_windows",
            2,
            "the WARN needs the RUL 5th percentile below the horizon in this many consecutive "
            "prognoses",
            "rul_alarm_windows",
        ),
        ParameterSpec(
            "growth_priors_file",
            "",
            "how fast each fault grew in the fleet's past lives, a YAML file (fault: {linear: "
            "[median, log sd], exponential: [median, log sd], p_exponential: P}); '' = the "
            "packaged ones, 'none' = no growth prior",
            check_value=_check_growth_priors_file,
        ),
        ParameterSpec(
            "failure_thresholds",
            list(health.DEFAULT_ERROR),
            "per-fault severity at which a fault has failed (the end of its RUL; "
            f"{_labels(NOT_APPLICABLE)} ignored: no RUL)",
            check_value=_check_failure_thresholds,
        ),
    ]
