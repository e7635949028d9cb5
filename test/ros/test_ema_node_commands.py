"""ema_node commanded from outside: set-points streamed on `command_topic` are what it follows."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("rclpy")

from node_helpers import Probe, wait_until  # noqa: E402 - after importorskip
from std_msgs.msg import Float64MultiArray  # noqa: E402 - after importorskip

from ema_phm.domain.window import COLUMN  # noqa: E402 - after importorskip
from ema_phm.errors import ConfigError  # noqa: E402 - after importorskip
from ema_phm.ros.ema_node import EmaNode  # noqa: E402 - after importorskip
from ema_phm.telemetry import wire  # noqa: E402 - after importorskip

TOPIC = "/rig/setpoints"


def _rows(probe: Probe) -> np.ndarray:
    with probe.lock:
        return np.vstack([wire.decode_telemetry(m) for m in probe.telemetry])


@pytest.mark.parametrize("mode", ["hold", "linear"])
def test_streamed_set_points_are_the_recorded_command(graph, mode):
    ema = graph.add(
        EmaNode,
        command_topic=TOPIC,
        command_type="position",
        command_interpolation=mode,
        realtime_factor=1.0,
    )
    probe = Probe(graph)
    pub = probe.node.create_publisher(Float64MultiArray, TOPIC, 10)
    assert wait_until(lambda: pub.get_subscription_count() > 0, 10.0)
    pub.publish(Float64MultiArray(data=[]))  # no value: logged, not taken
    for value in (0.01, 0.02, float("nan"), 0.02):  # NaN: logged, not taken
        pub.publish(Float64MultiArray(data=[value]))
        time.sleep(0.05)
    assert wait_until(lambda: ema.commands is not None and ema.commands.received == 3, 5.0)
    time.sleep(0.3)
    rows = _rows(probe)
    cmd, pos = rows[:, COLUMN["command"]], rows[:, COLUMN["theta_u"]]
    assert set(np.round(cmd[cmd == cmd[0]], 12)) == {0.0} and cmd[-1] == 0.02
    assert abs(pos[-1] - 0.02) < 1e-3  # the actuator went there
    between = cmd[(cmd > 0.01) & (cmd < 0.02)]
    assert (between.size == 0) == (mode == "hold")  # linear ramps between set-points


def test_following_commands_needs_real_time(graph):
    with pytest.raises(ConfigError, match="needs realtime_factor > 0"):
        graph.add(EmaNode, command_topic=TOPIC, realtime_factor=0.0)
