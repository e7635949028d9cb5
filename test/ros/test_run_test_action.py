"""monitor_node's ~/run_test, driven from another process against a rig that takes commands.

The rig is ema_node following the trajectories of `command_topic` (the simulated actuator
behind a joint trajectory controller); the monitors run as executables of their own; this
test process is the action client, as `ros2 action send_goal` or a BIT sequencer is.  Each
refusal and abort docs/ros.md lists as provoked here is, and after every test that
commanded, the last command sent is the start position.  monitor_stream streams set-points
(command type position) to a topic no rig follows: the rig's command stays at the start, so
the test is aborted as not followed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from node_processes import ROOT, start_node, stop_node

pytest.importorskip("rclpy")

from ema_phm.domain.window import COLUMN  # noqa: E402 - after importorskip

COMMANDS = "/rig/joint_trajectory"
SETPOINTS = "/rig/setpoints"  # followed by nothing
#: The rig's fault: a friction the verdict names.
K_RIG = "k:=[0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]"
#: A small budget keeps the two monitors that fit no test light beside a real-time rig.
BUDGET = 300
MONITORS = {
    "monitor_node": ("run_test_enabled:=true",),
    "monitor_stream": (
        "run_test_enabled:=true",
        "run_test_command_type:=position",
        f"run_test_command_topic:={SETPOINTS}",
        f"max_evaluations:={BUDGET}",
    ),
    "monitor_strict": (
        "run_test_enabled:=true",
        "run_test_max_position_error_rad:=1e-4",
        f"max_evaluations:={BUDGET}",
    ),
    "monitor_off": (f"max_evaluations:={BUDGET}",),
}


class Client:
    """This process's node: an action client per monitor, and a listener on the commands."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Float64MultiArray
        from trajectory_msgs.msg import JointTrajectory

        from ema_phm.ros.common import TELEMETRY_QOS
        from ema_phm.telemetry import wire

        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("run_test_client", context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.trajectories: list[np.ndarray] = []  # each one's positions
        self.setpoints: list[float] = []
        self.node.create_subscription(
            JointTrajectory,
            COMMANDS,
            lambda m: self.trajectories.append(np.array([p.positions[0] for p in m.points])),
            100,
        )
        self.node.create_subscription(
            Float64MultiArray, SETPOINTS, lambda m: self.setpoints.append(float(m.data[0])), 1000
        )
        self.telemetry: list[np.ndarray] = []  # what the rig reports, its command included
        self.node.create_subscription(
            Float64MultiArray,
            wire.TELEMETRY_TOPIC,
            lambda m: self.telemetry.append(wire.decode_telemetry(m)),
            TELEMETRY_QOS,
        )
        self.clients: dict[str, Any] = {}

    def spin_until(self, done: Any, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        return bool(done())

    def action(self, monitor: str) -> Any:
        from rclpy.action import ActionClient

        from ema_phm_msgs.action import RunTest

        if monitor not in self.clients:
            self.clients[monitor] = ActionClient(self.node, RunTest, f"/{monitor}/run_test")
        client = self.clients[monitor]
        assert self.spin_until(client.server_is_ready, 60.0), f"/{monitor}/run_test not served"
        return client

    def send(self, monitor: str, feedback: list[Any] | None = None, **goal: Any) -> Any:
        """Send a goal; its goal handle once accepted."""
        from ema_phm_msgs.action import RunTest

        future = self.action(monitor).send_goal_async(
            RunTest.Goal(**goal),
            feedback_callback=None if feedback is None else lambda m: feedback.append(m.feedback),
        )
        assert self.spin_until(future.done, 30.0)
        handle = future.result()
        assert handle.accepted  # a refusal comes as a result, with its reason
        return handle

    def result(self, handle: Any, timeout: float = 180.0) -> Any:
        future = handle.get_result_async()
        assert self.spin_until(future.done, timeout), "no result"
        return future.result()

    def settle(self, seconds: float) -> None:
        self.spin_until(lambda: False, seconds)

    def close(self) -> None:
        import rclpy

        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


@pytest.fixture(scope="module")
def rig(ros_domain_id: int) -> Iterator[tuple[Client, subprocess.Popen]]:
    """ema_node on COMMANDS, four monitors, and the client; all checked to exit cleanly."""
    ema = start_node(
        "ema_node", ros_domain_id, f"command_topic:={COMMANDS}", "realtime_factor:=1.0", K_RIG
    )
    monitors = {
        name: start_node(
            "monitor_node",
            ros_domain_id,
            "warm_up:=false",
            "prognostics:=false",
            "queue_depth:=0",
            f"run_test_command_topic:={COMMANDS}",
            *params,  # a later value of a parameter wins
            remaps=() if name == "monitor_node" else (f"__node:={name}",),
        )
        for name, params in MONITORS.items()
    }
    client = Client(ros_domain_id)
    try:
        for name in MONITORS:
            client.action(name)
        client.settle(3.0)  # telemetry flows: the monitors know the start position
        yield client, ema
    finally:
        client.close()
        for name, proc in [*monitors.items(), ("ema_node", ema)]:
            code, err = stop_node(proc)
            assert code == 0, f"{name} exited {code}: {err[-3000:]}"


def _outcome(result: Any) -> tuple[str, str]:
    return result.result.outcome, result.result.reason


def test_the_test_window_gets_the_offline_verdict(rig, tmp_path: Path) -> None:
    from ema_phm.domain.window import Window
    from ema_phm.telemetry import bags
    from ema_phm.telemetry.typed import batch_rows

    client, _ = rig
    feedback: list[Any] = []
    handle = client.send("monitor_node", feedback)
    got = client.result(handle)
    outcome, reason = _outcome(got)
    assert outcome == "fitted", reason
    assert got.status == 4  # SUCCEEDED
    phases = [f.phase for f in feedback]
    assert phases[0] == "commanding" and "settling" in phases and phases[-1] == "fitting"
    assert max(f.position_error_rad for f in feedback) > 0  # the rig's tracking error read

    r = got.result
    report = json.loads(r.report_json)
    assert abs(report["k"][0] - 0.5) < 0.15, report["k"]  # the rig's friction read
    assert r.health.friction.value == report["k"][0] and r.reason == report["message"]
    window = Window.from_matrix(batch_rows(r.window))
    assert 2.0 <= window.duration <= 2.5
    assert np.ptp(window.command) == pytest.approx(0.06, rel=0.01)  # the 0.03 rad chirp
    sent = client.trajectories[-1]  # the test, one trajectory ending where it started
    assert sent[-1] == r.start_position_rad and np.ptp(sent) == pytest.approx(0.06, rel=0.01)

    bag = tmp_path / "test_window"
    bags.write_window(bag, window)
    offline = subprocess.run(
        [sys.executable, "-m", "ema_phm.tools.cli", "isolate", str(bag), "--json"],
        check=False,
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=dict(os.environ),
        timeout=300,
    )
    assert offline.returncode == 0, offline.stderr
    expected = json.loads(offline.stdout)
    assert (report["level"], report["message"]) == (expected["level"], expected["message"])
    np.testing.assert_allclose(report["k"], expected["k"], atol=1e-6)


def test_refusals_come_with_their_reason_and_command_nothing(rig) -> None:
    client, _ = rig
    before = len(client.trajectories)
    cases = [
        ("monitor_off", {}, "run_test_enabled is false"),
        ("monitor_node", {"kind": "step"}, "must be one of chirp, sine"),
        ("monitor_node", {"amplitude_rad": 0.46}, "beyond 0.9 x the end stop"),
        ("monitor_node", {"amplitude_rad": 0.2}, "beyond 0.9 x the top speed"),
    ]
    for monitor, goal, words in cases:
        got = client.result(client.send(monitor, **goal), timeout=30.0)
        outcome, reason = _outcome(got)
        assert outcome == "refused" and words in reason, (monitor, goal, reason, got.status)
        assert got.status == 6  # ABORTED
    client.settle(0.5)
    assert len(client.trajectories) == before


def test_a_second_goal_is_refused_and_a_cancel_returns_to_the_start(rig) -> None:
    client, _ = rig
    heard_before = len(client.telemetry)
    first = client.send("monitor_node")
    client.settle(0.3)
    second = client.result(client.send("monitor_node"), timeout=30.0)
    assert _outcome(second) == ("refused", "another test is running")
    client.settle(0.5)  # mid-chirp: off the start
    cancel = first.cancel_goal_async()
    assert client.spin_until(cancel.done, 10.0)
    got = client.result(first, timeout=30.0)
    assert _outcome(got) == ("canceled", "canceled on request")
    assert got.status == 5  # CANCELED
    client.settle(0.3)
    back = client.trajectories[-1]  # replaces the test's trajectory from now on
    assert back[-1] == got.result.start_position_rad
    # a ramp at a quarter of the top speed, 0.42 rad/s: 2.1e-3 rad per 5 ms point
    assert np.abs(np.diff(back)).max() < 0.0025 and 0 < np.ptp(back) < 0.031
    # what the rig was commanded, out and back: never faster than its top speed (the return
    # starts from where the test's trajectory is when it takes over, not from an older point)
    rows = np.vstack(client.telemetry[heard_before:])
    rows = rows[np.argsort(rows[:, 0])]
    rate = np.abs(np.diff(rows[:, COLUMN["command"]])) / np.diff(rows[:, 0])
    assert rate.max() < 8000 * 2 * np.pi / 60 * 0.002  # 1.68 rad/s at the user shaft


def test_a_tracking_error_beyond_the_limit_aborts_back_to_the_start(rig) -> None:
    client, _ = rig
    got = client.result(client.send("monitor_strict"), timeout=30.0)
    outcome, reason = _outcome(got)
    assert outcome == "aborted" and "beyond max_position_error_rad 0.0001" in reason, reason
    client.settle(0.3)
    assert client.trajectories[-1][-1] == got.result.start_position_rad


def test_a_rig_that_does_not_follow_aborts_and_streamed_set_points_return(rig) -> None:
    # monitor_stream's set-points reach no rig: the rig's command stays at the start
    client, _ = rig
    got = client.result(client.send("monitor_stream"), timeout=30.0)
    outcome, reason = _outcome(got)
    assert outcome == "aborted" and "the rig does not follow the test's commands" in reason
    client.settle(0.3)
    sent = np.array(client.setpoints)
    assert sent.size > 20  # streamed (at 200 Hz, when the machine allows)
    assert np.abs(sent).max() > 0.015 and sent[-1] == got.result.start_position_rad


def test_stale_feedback_aborts_back_to_the_start(rig) -> None:
    client, ema = rig
    feedback: list[Any] = []
    # an 8 s test: a client or rig slowed by a busy machine still stops it mid-way
    handle = client.send("monitor_node", feedback, duration_s=8.0)
    if not client.spin_until(lambda: any(f.elapsed_s > 0.3 for f in feedback), 10.0):
        pytest.fail(f"the test did not run: {_outcome(client.result(handle, 60.0))}")
    os.kill(ema.pid, signal.SIGSTOP)  # the rig's telemetry stops mid-test
    try:
        got = client.result(handle, timeout=30.0)
    finally:
        os.kill(ema.pid, signal.SIGCONT)
    outcome, reason = _outcome(got)
    seen = [(f.phase, round(f.elapsed_s, 2)) for f in feedback]
    assert outcome == "aborted" and "no telemetry for" in reason, (outcome, reason, seen)
    client.settle(0.3)
    assert client.trajectories[-1][-1] == got.result.start_position_rad


def test_a_node_stopped_mid_test_puts_the_command_back_first(rig, ros_domain_id) -> None:
    client, _ = rig
    proc = start_node(
        "monitor_node",
        ros_domain_id,
        "warm_up:=false",
        "prognostics:=false",
        f"run_test_command_topic:={COMMANDS}",
        "run_test_enabled:=true",
        f"max_evaluations:={BUDGET}",
        remaps=("__node:=monitor_close",),
    )
    try:
        client.action("monitor_close")  # served: the node is up
        ran, deadline = False, time.monotonic() + 60.0
        feedback: list[Any] = []
        while not ran and time.monotonic() < deadline:  # refused until it hears the rig
            feedback.clear()
            handle = client.send("monitor_close", feedback, duration_s=8.0)
            ran = client.spin_until(lambda: any(f.elapsed_s > 1.0 for f in feedback), 10.0)
            if not ran:
                client.result(handle, 30.0)
                client.settle(1.0)
        sent = len(client.trajectories)
    finally:
        code, err = stop_node(proc)  # SIGTERM, as ros2 launch or a service manager stops it
    assert ran, err[-3000:]
    assert code == 0, err[-3000:]
    client.settle(0.5)
    assert len(client.trajectories) == sent + 1, "no return was sent before the node exited"
    test, back = client.trajectories[-2], client.trajectories[-1]
    assert back[-1] == test[0] and np.ptp(back) > 0  # a ramp back to where the test began
    assert np.abs(np.diff(back)).max() < 0.0025
