"""monitor_node's parameter table (isolation, outputs, prognostics), declared once."""

from __future__ import annotations

from typing import Any, Iterable

from ..diagnosis import health
from ..domain.faults import LABELS, N_K, NOT_APPLICABLE, SEVERITY_INDICES
from ..errors import ConfigError
from ..monitor import status_texts
from ..physics.commands import COMMAND_TYPES
from ..prognostics.learn import load_growth_priors
from ..prognostics.rul import failure_thresholds
from .parameters import ACTUATOR_FILE, ParameterSpec, ParameterTable, check_cycle_hours_or_file

#: How monitor_node takes telemetry (its `telemetry_input` parameter).
TELEMETRY_INPUTS: tuple[str, ...] = ("multiarray", "batch")


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
            status_texts.DEFAULT_STALE_TIMEOUT,
            "s without telemetry after which /diagnostics says STALE",
            "stale_timeout",
        ),
        ParameterSpec(
            "hardware_id",
            "ema_sim",
            "DiagnosticStatus.hardware_id; telemetry of another hardware_id is not judged (ERROR)",
        ),
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
            status_texts.DEFAULT_QUEUE_DEPTH,
            "windows that may wait behind the running fit (first in, first out); a window "
            "completing with the queue full is skipped and counted",
            "queue_depth",
        ),
        *_monitor_node_input_parameters(),
        *_monitor_node_run_test_parameters(),
        ParameterSpec(
            "warm_up",
            True,
            "before subscribing to telemetry, run the fit once on a short synthetic window "
            "(numba's compilation / cache load) so the first windows are not skipped",
        ),
        *_monitor_node_prognostics_parameters(),
    ]


def _monitor_node_input_parameters() -> list[ParameterSpec]:
    """monitor_node's parameters on where its telemetry comes from (fixed at start-up)."""
    return [
        ParameterSpec(
            "telemetry_input",
            "multiarray",
            "the telemetry taken: 'multiarray' = std_msgs/Float64MultiArray on /ema/telemetry "
            "(8-column layout); 'batch' = ema_phm_msgs/TelemetryBatch on /ema/telemetry_batch",
            choices=TELEMETRY_INPUTS,
            choice_words="telemetry_input",
        ),
        ParameterSpec(
            "channel_map_file",
            "",
            "a channel map (docs/your_recordings.md): take the telemetry from a rig's own "
            "topics instead of telemetry_input's; '' = ema_phm's topics",
            check_value=_check_channel_map_file,
        ),
        ParameterSpec(
            "window_duration",
            2.0,
            "s, the window cut from a channel map's topics (at actuator_file's sample rate)",
            "duration",
        ),
    ]


def _monitor_node_run_test_parameters() -> list[ParameterSpec]:
    """monitor_node's parameters on its ~/run_test action (fixed at start-up)."""
    return [
        ParameterSpec(
            "run_test_enabled",
            False,
            "let ~/run_test command the actuator (a test excitation on run_test_command_topic); "
            "false: every goal is refused",
        ),
        ParameterSpec(
            "run_test_command_topic",
            "/joint_trajectory_controller/joint_trajectory",
            "where ~/run_test sends its position commands [rad, user shaft]",
            check_value=_check_topic_name,
        ),
        ParameterSpec(
            "run_test_command_type",
            "trajectory",
            "their form: 'trajectory' = one trajectory_msgs/JointTrajectory holding the whole "
            "test (a ros2_control joint trajectory controller's input), 'position' = "
            "std_msgs/Float64MultiArray data[0] streamed at 200 Hz (a forward position "
            "controller's input)",
            choices=COMMAND_TYPES,
            choice_words="run_test_command_type",
        ),
        ParameterSpec(
            "run_test_joint",
            "ema_joint",
            "the joint a 'trajectory' command names (the controller's joint)",
            check_value=_check_joint,
        ),
        ParameterSpec(
            "run_test_max_position_error_rad",
            0.025,
            "~/run_test aborts (and returns to the start) when the rig reports |user position - "
            "command| beyond this (the packaged chirp: ~6e-4 healthy, 0.012 with friction 0.5)",
            "position_error",
        ),
        ParameterSpec(
            "run_test_feedback_timeout_s",
            0.5,
            "~/run_test aborts (and returns to the start) after this long without telemetry",
            "feedback_timeout",
        ),
    ]


def _check_topic_name(value: Any) -> None:
    from rclpy.expand_topic_name import expand_topic_name  # noqa: PLC0415 - rclpy's own rule
    from rclpy.validate_full_topic_name import validate_full_topic_name  # noqa: PLC0415

    text = str(value)
    try:
        validate_full_topic_name(expand_topic_name(text, "monitor_node", "/"))
    except Exception as exc:  # noqa: BLE001 - rclpy raises several kinds for a bad name
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConfigError(f"run_test_command_topic {text!r} is not a topic name: {why}") from None


def _check_joint(value: Any) -> None:
    if not str(value).strip():
        raise ConfigError(f"run_test_joint must name a joint, got {value!r}")


def _check_channel_map_file(value: Any) -> None:
    if value:
        from ..importing.channel_map import load_channel_map  # noqa: PLC0415

        load_channel_map(str(value))


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
            check_value=check_cycle_hours_or_file,
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
