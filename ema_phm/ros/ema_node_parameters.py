"""ema_node's parameter table (the simulated actuator's stream), declared once."""

from __future__ import annotations

from typing import Any

from ..domain.faults import LABELS, NOMINAL, validate
from ..physics.commands import COMMAND_TYPES, KINDS, default_specs
from ..physics.tolerances import Tolerances
from ..simulator.command_inbox import MODES as COMMAND_MODES
from ..simulator.degradation import Degradation
from ..simulator.unit import Unit
from ..telemetry.wire import StreamId
from .parameters import ACTUATOR_FILE, ParameterSpec, ParameterTable, check_cycle_hours_or_file


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
            *_ema_node_command_parameters(),
            *_ema_node_degradation_parameters(),
        ],
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
            "file (simulator/unit.py); empty = the datasheet unit",
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
            "hold the telemetry until this many subscriptions matched on /ema/telemetry, or on "
            "/ema/telemetry_batch (0 = don't wait)",
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


def _ema_node_command_parameters() -> list[ParameterSpec]:
    """ema_node's parameters on following commands from outside (a rig's simulator)."""
    return [
        ParameterSpec(
            "command_topic",
            "",
            "follow the position commands [rad, user shaft] of this topic, as a rig commanded "
            "from outside (command_type says its form); '' = command_kind's window",
        ),
        ParameterSpec(
            "command_type",
            "trajectory",
            "command_topic's form: 'trajectory' = trajectory_msgs/JointTrajectory (a ros2_control "
            "joint trajectory controller's input; the first joint), 'position' = "
            "std_msgs/Float64MultiArray data[0] (a forward position controller's)",
            choices=COMMAND_TYPES,
            choice_words="command_type",
        ),
        ParameterSpec(
            "command_interpolation",
            "linear",
            "how command_type 'position' set-points are taken: 'linear' = interpolated from one "
            "to the next over the interval between them (after CiA 402 interpolated position), "
            "'hold' = each held until the next (a staircase)",
            choices=COMMAND_MODES,
            choice_words="command_interpolation",
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
            check_value=check_cycle_hours_or_file,
        ),
    ]
