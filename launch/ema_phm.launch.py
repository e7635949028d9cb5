"""Launch one simulated EMA (ema_node) and its monitor (monitor_node), or the monitor alone.

    ros2 launch ema_phm ema_phm.launch.py [namespace:=left] [record_bag:=out/run_{stamp}]
        [max_windows:=N] [wait_for_subscribers:=1] [realtime_factor:=F] [max_evaluations:=N]
        [hardware_id:=ID] [degradation:=FILE] [warm_up:=false] [actuator_file:=FILE]
        [ema_params:=FILE] [monitor_params:=FILE] [exit_with_ema:=true] [grace_s:=30]
        [use_sim_time:=false] [log_level:=info] [simulator:=true] [managed:=false]
        [telemetry_topic:=/rig/ema_telemetry] [run_info_topic:=/rig/ema_run_info]
        [channel_map_file:=FILE] [window_duration:=S]

`simulator:=false` starts the monitor alone, to watch an actuator that publishes on its own
(a rig, or `ema-phm play` of a recording); the `*_topic` arguments remap the monitor's inputs
(/ema/telemetry, /ema/run_info, /ema/ground_truth) to the topics that actuator publishes on
('' = as they are); or `channel_map_file` points the monitor at a rig's own topics through a
channel map (docs/your_recordings.md), cut into windows of `window_duration` s.
`managed:=true` starts `monitor_lifecycle_node` instead of `monitor_node`: a lifecycle
manager (or `ros2 lifecycle set /monitor_node configure`, then `activate`) brings it up.

Both nodes read their parameter file (config/<node>.yaml from the package share, keyed by
`/**` so it applies under any namespace), then the arguments given here (an empty argument
leaves the file's value; `wait_for_subscribers` defaults to 1, not to the file's 0).
`namespace` moves both nodes and their /ema/... topics to /<namespace>/...; `record_bag`
makes the monitor record everything it receives and publishes. ema_node exits once
`max_windows` windows are out; with `exit_with_ema` true the launch then shuts everything
down `grace_s` seconds later (time for the monitor to fit the last window; shutting down
cancels a fit still running and closes the bag).  `actuator_file` goes to both nodes (ema_node
simulates that actuator, monitor_node's belief is built from the file), `use_sim_time` to
both (they then follow /clock), `log_level` (debug, info, warn, error, fatal) to both as
--log-level.

A node that exits with a non-zero code (a bad parameter: 2) shuts the launch down, and the
launch itself then exits 1 (`check_exit`): ROS launch has no exit-code action, but an
exception in an event handler makes LaunchService.run return 1.  After Ctrl-C the nodes
exit 0 and nothing more is logged or scheduled (the launch is already shutting down).

Needs ROS 2 launch and launch_ros (a ROS install: they have no PyPI wheels). This file does
not import ema_phm, so the Python that runs `ros2 launch` need not have it.
"""

from __future__ import annotations

from launch import LaunchContext, LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    LogInfo,
    OpaqueFunction,
    RegisterEventHandler,
    TimerAction,
)
from launch.event_handlers import OnProcessExit
from launch.events import Shutdown
from launch.substitutions import PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = "ema_phm"

#: rcl's log levels (--log-level), the choices of the log_level argument.
LOG_LEVELS: tuple[str, ...] = ("debug", "info", "warn", "error", "fatal")
#: Launch argument -> (node, parameter, type); empty = keep the parameter file's value.
OVERRIDES: dict[str, tuple[str, str, type]] = {
    "max_windows": ("ema_node", "max_windows", int),
    "wait_for_subscribers": ("ema_node", "wait_for_subscribers", int),
    "realtime_factor": ("ema_node", "realtime_factor", float),
    "degradation": ("ema_node", "degradation", str),
    "max_evaluations": ("monitor_node", "max_evaluations", int),
    "record_bag": ("monitor_node", "record_bag", str),
    "warm_up": ("monitor_node", "warm_up", bool),
    "channel_map_file": ("monitor_node", "channel_map_file", str),
    "window_duration": ("monitor_node", "window_duration", float),
}
#: Launch argument -> the monitor's input it remaps (relative, as monitor_node subscribes).
INPUT_REMAPS: dict[str, str] = {
    "telemetry_topic": "ema/telemetry",
    "run_info_topic": "ema/run_info",
    "ground_truth_topic": "ema/ground_truth",
}
#: Launch arguments -> (parameter, type) given to both nodes.
SHARED_OVERRIDES: dict[str, tuple[str, type]] = {
    "actuator_file": ("actuator_file", str),
    # the actuator's id: the stream ema_node stamps and the id monitor_node reports
    "hardware_id": ("hardware_id", str),
    "use_sim_time": ("use_sim_time", bool),
}


class NodeFailed(RuntimeError):
    """A node of this launch exited with a non-zero code."""


def _config(name: str) -> PathJoinSubstitution:
    return PathJoinSubstitution([FindPackageShare(PACKAGE), "config", name])


def _boolean(text: str) -> bool:
    """'true' / 'false' (any case), as ROS parameters spell them; ValueError otherwise."""
    if text.lower() not in ("true", "false"):
        raise ValueError(text)
    return text.lower() == "true"


def overrides(values: dict[str, str]) -> dict[str, dict[str, object]]:
    """Node -> {parameter: value} from the non-empty launch arguments, typed."""
    out: dict[str, dict[str, object]] = {"ema_node": {}, "monitor_node": {}}
    shared = {arg: (tuple(out), param, kind) for arg, (param, kind) in SHARED_OVERRIDES.items()}
    single = {arg: ((node,), param, kind) for arg, (node, param, kind) in OVERRIDES.items()}
    for arg, (nodes, param, kind) in {**single, **shared}.items():
        text = values.get(arg, "").strip()
        if text:
            try:
                value = _boolean(text) if kind is bool else kind(text)
            except ValueError:
                raise ValueError(
                    f"launch argument {arg} must be {kind.__name__}, got {text!r}"
                ) from None
            for node in nodes:
                out[node][param] = value
    return out


def ros_arguments(values: dict[str, str]) -> list[str]:
    """--ros-args of both nodes: the log level (lower case; '' = rcl's default, info)."""
    level = values.get("log_level", "").strip().lower()
    if not level:
        return []
    if level not in LOG_LEVELS:
        raise ValueError(f"launch argument log_level must be one of {LOG_LEVELS}, got {level!r}")
    return ["--log-level", level]


def check_exit(event, context) -> None:  # noqa: ANN001 - launch's ProcessExited, LaunchContext
    """OnProcessExit: a node that exited non-zero fails the launch (exit 1, everything stopped).

    Raising is how an event handler makes LaunchService shut down and return 1.
    """
    if event.returncode != 0:
        raise NodeFailed(
            f"{event.action.name} exited with code {event.returncode}: shutting the launch down"
        )


def shut_down_after(grace: float):  # noqa: ANN201 - an OnProcessExit callback
    """OnProcessExit of ema_node: the launch ends `grace` s after ema_node's clean exit.

    Not after a failure (check_exit ends the launch) nor during a shutdown (Ctrl-C): the
    nodes exit 0 then too, and "shutting down in 30 s" would be false.
    """

    def on_exit(event, context) -> list:  # noqa: ANN001 - ProcessExited, LaunchContext
        if event.returncode != 0 or context.is_shutdown:
            return []
        return [
            LogInfo(msg=f"ema_node ended; shutting down in {grace:g} s"),
            TimerAction(
                period=grace,
                actions=[EmitEvent(event=Shutdown(reason="ema_node ended"))],
            ),
        ]

    return on_exit


def input_remappings(values: dict[str, str]) -> list[tuple[str, str]]:
    """The monitor's (input, topic) remappings of the non-empty `*_topic` arguments."""
    return [
        (source, values[arg].strip())
        for arg, source in INPUT_REMAPS.items()
        if values.get(arg, "").strip()
    ]


def _flag(values: dict[str, str], name: str, default: str) -> bool:
    """A true/false launch argument; ValueError naming it otherwise."""
    text = values.get(name, default).strip() or default
    try:
        return _boolean(text)
    except ValueError:
        raise ValueError(f"launch argument {name} must be true or false, got {text!r}") from None


def actuator_nodes(context: LaunchContext) -> list:
    """The nodes (and the shutdown after ema_node's exit), from the resolved arguments."""
    values = {name: value for name, value in context.launch_configurations.items()}
    params = overrides(values)
    ros_args = ros_arguments(values)
    namespace = values.get("namespace", "").strip().strip("/")
    simulator = _flag(values, "simulator", "true")

    def node(name: str, params_file: str, executable: str, remaps: list) -> Node:
        """Node `name` with its parameter file, then the launch's overrides of it."""
        return Node(
            package=PACKAGE,
            executable=executable,
            name=name,
            namespace=namespace,
            parameters=[values[params_file], params[name]],
            ros_arguments=ros_args,
            remappings=remaps,
            output="screen",
        )

    managed = _flag(values, "managed", "false")
    monitor_exe = "monitor_lifecycle_node" if managed else "monitor_node"
    monitor = node("monitor_node", "monitor_params", monitor_exe, input_remappings(values))
    if not simulator:  # the monitor alone, on an actuator that publishes by itself
        return [
            monitor,
            RegisterEventHandler(OnProcessExit(target_action=monitor, on_exit=check_exit)),
        ]
    ema = node("ema_node", "ema_params", "ema_node", [])
    actions: list = [monitor, ema]
    actions += [
        RegisterEventHandler(OnProcessExit(target_action=node, on_exit=check_exit))
        for node in (monitor, ema)
    ]
    if values.get("exit_with_ema", "true").strip().lower() in ("true", "1", "yes"):
        grace = float(values.get("grace_s", "30"))
        actions.append(
            RegisterEventHandler(OnProcessExit(target_action=ema, on_exit=shut_down_after(grace)))
        )
    return actions


def launch_arguments() -> list:
    """The launch arguments, each with its default ('' = the parameter file's value)."""
    return [
        DeclareLaunchArgument("namespace", default_value="", description="'' = root"),
        DeclareLaunchArgument(
            "ema_params", default_value=_config("ema_node.yaml"), description="ema_node file"
        ),
        DeclareLaunchArgument(
            "monitor_params",
            default_value=_config("monitor_node.yaml"),
            description="monitor_node file",
        ),
        DeclareLaunchArgument(
            "record_bag", default_value="", description="bag to record; '' = off"
        ),
        DeclareLaunchArgument("max_windows", default_value="", description="'' = file"),
        # the monitor starts after ema_node may have published: hold the telemetry for it
        DeclareLaunchArgument(
            "wait_for_subscribers",
            default_value="1",
            description="ema_node holds its telemetry until this many subscribers (the "
            "monitor) matched; '' = file",
        ),
        DeclareLaunchArgument("realtime_factor", default_value="", description="'' = file"),
        DeclareLaunchArgument("max_evaluations", default_value="", description="'' = file"),
        DeclareLaunchArgument(
            "hardware_id", default_value="", description="both nodes' hardware_id; '' = files"
        ),
        DeclareLaunchArgument(
            "degradation",
            default_value="",
            description="ema_node: YAML of how faults grow per cycle; '' = file",
        ),
        DeclareLaunchArgument(
            "warm_up", default_value="", description="monitor_node: true / false; '' = file"
        ),
        DeclareLaunchArgument(
            "actuator_file",
            default_value="",
            description="both nodes: the actuator file (simulated, believed); '' = file",
        ),
        DeclareLaunchArgument(
            "channel_map_file",
            default_value="",
            description="monitor_node: a rig's topics through this channel map; '' = file",
        ),
        DeclareLaunchArgument(
            "window_duration",
            default_value="",
            description="monitor_node: s per window of a channel map's topics; '' = file",
        ),
        *_run_arguments(),
    ]


def _run_arguments() -> list:
    """The arguments on how the launch ends and what both nodes log and follow."""
    return [
        DeclareLaunchArgument(
            "exit_with_ema",
            default_value="true",
            description="shut the launch down after ema_node exits (max_windows)",
        ),
        DeclareLaunchArgument(
            "grace_s", default_value="30", description="s between ema_node's exit and that"
        ),
        DeclareLaunchArgument(
            "use_sim_time",
            default_value="false",
            description="both nodes: true = follow /clock; '' = file",
        ),
        DeclareLaunchArgument(
            "log_level",
            default_value="info",
            description="both nodes' --log-level",
            choices=list(LOG_LEVELS),
        ),
        DeclareLaunchArgument(
            "simulator",
            default_value="true",
            description="false = the monitor alone, on an actuator that publishes by itself",
        ),
        DeclareLaunchArgument(
            "managed",
            default_value="false",
            description="true = monitor_lifecycle_node (a lifecycle manager brings it up)",
        ),
        *(
            DeclareLaunchArgument(
                arg, default_value="", description=f"the monitor's /{source} from; '' = as is"
            )
            for arg, source in INPUT_REMAPS.items()
        ),
    ]


def generate_launch_description() -> LaunchDescription:
    """The launch arguments, then the nodes built from their values."""
    return LaunchDescription([*launch_arguments(), OpaqueFunction(function=actuator_nodes)])
