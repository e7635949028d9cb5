"""Launch one simulated EMA (ema_node) and its monitor (monitor_node).

    ros2 launch ema_phm ema_phm.launch.py [namespace:=left] [record_bag:=out/run_{stamp}]
        [max_windows:=N] [wait_for_subscribers:=1] [realtime_factor:=F] [max_evaluations:=N]
        [hardware_id:=ID] [degradation:=FILE] [warm_up:=false] [ema_params:=FILE]
        [monitor_params:=FILE] [exit_with_ema:=true] [grace_s:=30]

Both nodes read their parameter file (config/<node>.yaml from the package share, keyed by
`/**` so it applies under any namespace), then the arguments given here (an empty argument
leaves the file's value; `wait_for_subscribers` defaults to 1, not to the file's 0).
`namespace` moves both nodes and their /ema/... topics to /<namespace>/...; `record_bag`
makes the monitor record everything it receives and publishes. ema_node exits once
`max_windows` windows are out; with `exit_with_ema` true the launch then shuts everything
down `grace_s` seconds later (time for the monitor to fit the last window; shutting down
cancels a fit still running and closes the bag).

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

#: Launch argument -> (node, parameter, type); empty = keep the parameter file's value.
OVERRIDES: dict[str, tuple[str, str, type]] = {
    "max_windows": ("ema_node", "max_windows", int),
    "wait_for_subscribers": ("ema_node", "wait_for_subscribers", int),
    "realtime_factor": ("ema_node", "realtime_factor", float),
    "degradation": ("ema_node", "degradation", str),
    "max_evaluations": ("monitor_node", "max_evaluations", int),
    "hardware_id": ("monitor_node", "hardware_id", str),
    "record_bag": ("monitor_node", "record_bag", str),
    "warm_up": ("monitor_node", "warm_up", bool),
}


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
    for arg, (node, param, kind) in OVERRIDES.items():
        text = values.get(arg, "").strip()
        if text:
            try:
                out[node][param] = _boolean(text) if kind is bool else kind(text)
            except ValueError:
                raise ValueError(
                    f"launch argument {arg} must be {kind.__name__}, got {text!r}"
                ) from None
    return out


def actuator_nodes(context: LaunchContext) -> list:
    """The two nodes (and the shutdown after ema_node's exit), from the resolved arguments."""
    values = {name: value for name, value in context.launch_configurations.items()}
    params = overrides(values)
    namespace = values.get("namespace", "").strip().strip("/")
    ema = Node(
        package=PACKAGE,
        executable="ema_node",
        name="ema_node",
        namespace=namespace,
        parameters=[values["ema_params"], params["ema_node"]],
        output="screen",
    )
    monitor = Node(
        package=PACKAGE,
        executable="monitor_node",
        name="monitor_node",
        namespace=namespace,
        parameters=[values["monitor_params"], params["monitor_node"]],
        output="screen",
    )
    actions: list = [monitor, ema]
    if values.get("exit_with_ema", "true").strip().lower() in ("true", "1", "yes"):
        grace = float(values.get("grace_s", "30"))
        actions.append(
            RegisterEventHandler(
                OnProcessExit(
                    target_action=ema,
                    on_exit=[
                        LogInfo(msg=f"ema_node ended; shutting down in {grace:g} s"),
                        TimerAction(
                            period=grace,
                            actions=[EmitEvent(event=Shutdown(reason="ema_node ended"))],
                        ),
                    ],
                )
            )
        )
    return actions


def generate_launch_description() -> LaunchDescription:
    """The launch arguments, then the nodes built from their values."""
    return LaunchDescription(
        [
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
            DeclareLaunchArgument("hardware_id", default_value="", description="'' = file"),
            DeclareLaunchArgument(
                "degradation",
                default_value="",
                description="ema_node: YAML of how faults grow per cycle; '' = file",
            ),
            DeclareLaunchArgument(
                "warm_up", default_value="", description="monitor_node: true / false; '' = file"
            ),
            DeclareLaunchArgument(
                "exit_with_ema",
                default_value="true",
                description="shut the launch down after ema_node exits (max_windows)",
            ),
            DeclareLaunchArgument(
                "grace_s", default_value="30", description="s between ema_node's exit and that"
            ),
            OpaqueFunction(function=actuator_nodes),
        ]
    )
