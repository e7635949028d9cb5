"""Two actuators side by side: ema_phm.launch.py in namespaces left and right.

    ros2 launch ema_phm two_actuators.launch.py [max_windows:=N] [realtime_factor:=F]
        [max_evaluations:=N] [left_k:="[...]"] ...

Each side is one ema_node + monitor_node pair in its own namespace, so the topics are
/left/ema/... and /right/ema/...; both monitors publish on /diagnostics, with status names
'/left/monitor_node: actuator' and '/right/monitor_node: actuator' and hardware ids
ema_left and ema_right.  The launch runs until interrupted (exit_with_ema false on both
sides, so one side ending does not stop the other).

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
#: Arguments passed on to both sides unchanged.
SHARED: tuple[str, ...] = ("max_windows", "realtime_factor", "max_evaluations")


def side(name: str) -> IncludeLaunchDescription:
    """ema_phm.launch.py in namespace `name`, hardware id ema_<name>."""
    arguments = {
        "namespace": name,
        "hardware_id": f"ema_{name}",
        "exit_with_ema": "false",
        **{arg: LaunchConfiguration(arg) for arg in SHARED},
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
        + [side(name) for name in SIDES]
    )
