"""Two actuators side by side: ema_phm.launch.py in namespaces left and right.

    ros2 launch ema_phm two_actuators.launch.py [max_windows:=N] [realtime_factor:=F]
        [max_evaluations:=N] [actuator_file:=FILE] [use_sim_time:=false] [log_level:=info]

Each side is one ema_node + monitor_node pair in its own namespace, so the topics are
/left/ema/... and /right/ema/...; both monitors publish on /diagnostics, with status names
'left/monitor_node: actuator' and 'right/monitor_node: actuator' and hardware ids ema_left
and ema_right (both nodes of a side: the stream's id and the monitor's); `actuator_file` is
both sides' actuator (all four nodes).  The launch runs until interrupted (exit_with_ema
false on both sides, so one side ending does not stop the other); a node exiting non-zero
stops it all with exit code 1 (ema_phm.launch.py's check_exit).

Needs ROS 2 launch and launch_ros (a ROS install).
"""

from __future__ import annotations

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.substitutions import FindPackageShare

PACKAGE = "ema_phm"
SIDES: tuple[str, ...] = ("left", "right")
#: Arguments passed on to both sides unchanged ('' = the parameter files' values).
SHARED: tuple[str, ...] = ("max_windows", "realtime_factor", "max_evaluations", "actuator_file")
#: ... and those with a default of their own: name -> (default, choices or None).
SHARED_WITH_DEFAULTS: dict[str, tuple[str, list[str] | None]] = {
    "use_sim_time": ("false", None),
    "log_level": ("info", ["debug", "info", "warn", "error", "fatal"]),
}


def side(name: str) -> IncludeLaunchDescription:
    """ema_phm.launch.py in namespace `name`, hardware id ema_<name>."""
    arguments = {
        "namespace": name,
        "hardware_id": f"ema_{name}",
        "exit_with_ema": "false",
        **{arg: LaunchConfiguration(arg) for arg in (*SHARED, *SHARED_WITH_DEFAULTS)},
    }
    return IncludeLaunchDescription(
        PythonLaunchDescriptionSource(
            PathJoinSubstitution([FindPackageShare(PACKAGE), "launch", "ema_phm.launch.py"])
        ),
        launch_arguments=arguments.items(),
    )


def generate_launch_description() -> LaunchDescription:
    """The shared arguments, then one side per namespace."""
    return LaunchDescription(
        [DeclareLaunchArgument(arg, default_value="", description="'' = file") for arg in SHARED]
        + [
            DeclareLaunchArgument(
                arg, default_value=default, description="both sides", choices=choices
            )
            for arg, (default, choices) in SHARED_WITH_DEFAULTS.items()
        ]
        + [side(name) for name in SIDES]
    )
