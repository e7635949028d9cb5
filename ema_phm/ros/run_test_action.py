"""monitor_node's ``~/run_test`` action (ema_phm_msgs/action/RunTest): ask the rig for a test.

A goal commands the test excitation (`monitor.rig_test.plan_rig_test`: config/commands.yaml's
chirp unless the goal says otherwise) around where the rig last reported being commanded, on
`run_test_command_topic` in the form `run_test_command_type` says: ``trajectory``, one
trajectory_msgs/JointTrajectory of joint `run_test_joint` holding the whole test (points every
`TRAJECTORY_STEP_S`, stamped to start `LEAD_S` after it is sent; a ros2_control joint
trajectory controller interpolates it), or ``position``, std_msgs/Float64MultiArray data[0]
streamed at `COMMAND_RATE_HZ` (a forward position controller's input: a staircase to a drive
that holds set-points); records the response from the node's own inputs; fits the window with
the node's settings and belief as ``ema-phm isolate`` does (a global fit, the node's seed);
and answers the verdict, the fit's report and the window.  Feedback while it runs: phase,
elapsed time, the tracking error.

Safety (the rules: `monitor.rig_test`), each answered in the result's outcome and reason:
refused unless ``run_test_enabled``, while another goal runs, without recent telemetry, or
when the excitation leaves the actuator file's limits; aborted on stale telemetry, a tracking
error beyond ``run_test_max_position_error_rad``, a non-finite reading, a rig that does not
follow, or the node closing (`close` waits for the return); canceled on request.  When cut
short the command goes back to the start at a bounded rate, and the answer waits for that.
A goal is always accepted, so a refusal reaches the client with its reason.  While a goal
runs, the node starts no fit of its own (`active`): a fit would take the CPU the commands
need to leave in time.
"""

from __future__ import annotations

import json
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, Mapping

import numpy as np
from builtin_interfaces.msg import Duration
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.task import Future
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from ..diagnosis import health
from ..domain.window import COLUMN
from ..errors import ConfigError, ExcitationError, WindowError
from ..monitor.rig_test import (
    SETTLE_S,
    RigTest,
    RigTestLimits,
    plan_rig_test,
)
from ..physics.commands import CommandSpec, default_specs
from ..physics.parameters import ActuatorParameters
from ..telemetry.typed import HealthReport, extras_of
from ..telemetry.wire import StreamId

if TYPE_CHECKING:
    from ..monitor.health_monitor import HealthMonitor

try:
    from ema_phm_msgs.action import RunTest  # type: ignore[attr-defined]  # generated
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        f"ema_phm_msgs is not built ({exc}); run scripts/setup_env.sh (pip) or "
        "colcon build (ROS) -- see README, 'Typed messages'"
    ) from None

from .typed_messages import actuator_health, telemetry_batch

#: The action's name, relative to the node (``/monitor_node/run_test``).
RUN_TEST_ACTION = "~/run_test"
#: Position commands per second while a test runs (command type position), and the return's
#: trajectory points per second.
COMMAND_RATE_HZ = 200.0
#: s between the points of a test's trajectory (command type trajectory).
TRAJECTORY_STEP_S = 0.002
#: s between sending a trajectory and its stamped start: the rig and this node then agree
#: on where the test is at any instant (a return starts from what the rig commands then).
LEAD_S = 0.2
#: s `close` waits for a running goal to put the command back at the start.
CLOSE_WAIT_S = 5.0
#: Feedback messages per second.
FEEDBACK_RATE_HZ = 10.0


class RunTestServer:
    """The action server of one monitor node; `heard(rows)` is fed every telemetry message."""

    def __init__(
        self,
        node: Any,
        service: HealthMonitor,
        *,
        enabled: bool,
        command_topic: str,
        command_type: str,
        joint: str,
        limits: RigTestLimits,
        default_command: CommandSpec,
        sample_rate: Callable[[], float],
    ) -> None:
        """`sample_rate()`: the telemetry's sample rate [Hz] when the test window is cut."""
        self.node, self.service, self.enabled = node, service, enabled
        self.limits, self.default_command, self.sample_rate = limits, default_command, sample_rate
        self.command_topic, self.command_type, self.joint = command_topic, command_type, joint
        self._lock = threading.Lock()
        self._busy = False
        self._run: RigTest | None = None
        self._last: tuple[float, float] | None = None  # (when heard, the rig's command)
        self._thread: threading.Thread | None = None
        self.stop = threading.Event()  # the node is closing
        trajectory = command_type == "trajectory"
        self.publisher = node.create_publisher(
            JointTrajectory if trajectory else Float64MultiArray, command_topic, 10
        )
        self.server = ActionServer(
            node,
            RunTest,
            RUN_TEST_ACTION,
            execute_callback=self._execute,
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            cancel_callback=lambda _goal: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup(),
        )

    @property
    def active(self) -> bool:
        """True while a goal is being run (the node then fits no window of its own)."""
        return self._busy

    # ------------------------------------------------------------- the inputs
    def heard(self, rows: np.ndarray, stream: StreamId | None = None) -> None:
        """Telemetry rows the node took (any input path): the rig's command, the test's rows.

        Rows of another unit than the monitor's (its hardware_id) are not this rig's.
        """
        if rows.shape[0] == 0:
            return
        if stream is not None and stream.hardware_id != self.service.hardware_id:
            return
        now = time.monotonic()
        last = rows[-1]
        held = last[COLUMN["command"]]  # where the rig is commanded: the test starts there
        with self._lock:
            self._last = (now, float(held if np.isfinite(held) else last[COLUMN["theta_u"]]))
            run = self._run
        if run is not None:
            run.on_rows(rows, now)

    # -------------------------------------------------------------- the goal
    async def _execute(self, goal_handle: ServerGoalHandle) -> Any:
        """Run the goal in a thread (the executor keeps spinning), then set its end state."""
        done: Future = Future()

        def work() -> None:
            try:
                result = self._run_goal(goal_handle)
            except Exception as exc:  # noqa: BLE001 - a goal never takes the node down
                result = _result(RunTest.Result.ABORTED, f"{type(exc).__name__}: {exc}")
            done.set_result(result)

        self._thread = threading.Thread(target=work, name="monitor_node-run_test", daemon=True)
        self._thread.start()
        result: Any = await done
        if result.outcome == RunTest.Result.CANCELED:
            goal_handle.canceled()
        elif result.outcome in (RunTest.Result.FITTED, RunTest.Result.NOT_ASSESSED):
            goal_handle.succeed()
        else:
            goal_handle.abort()
        line = f"run_test {result.outcome}: {result.reason}"
        if result.outcome == RunTest.Result.FITTED:  # one call site per severity (rclpy)
            self.node.get_logger().info(line)
        else:
            self.node.get_logger().warning(line)
        return result

    def _run_goal(self, goal_handle: ServerGoalHandle) -> Any:
        """Refuse, or command, record and fit; the result message."""
        if not self.enabled:
            return _result(
                RunTest.Result.REFUSED,
                "run_test_enabled is false: this node commands no actuator unless it is set",
            )
        with self._lock:
            if self._busy:
                return _result(RunTest.Result.REFUSED, "another test is running")
            self._busy = True
            last = self._last
        try:
            return self._test(goal_handle, last)
        finally:
            with self._lock:
                self._busy, self._run = False, None

    def _test(self, goal_handle: ServerGoalHandle, last: tuple[float, float] | None) -> Any:
        now = time.monotonic()
        if last is None or now - last[0] > self.limits.feedback_timeout_s:
            return _result(
                RunTest.Result.REFUSED,
                f"no telemetry in the last {self.limits.feedback_timeout_s:g} s "
                "(run_test_feedback_timeout_s): the start position is unknown",
            )
        g = goal_handle.request
        request = {f: getattr(g, f) for f in ("kind", "amplitude_rad", "f0_hz", "f1_hz")}
        request["duration_s"] = g.duration_s
        try:
            spec = plan_rig_test(request, self.default_command, last[1], self.limits)
        except ConfigError as exc:
            return _result(RunTest.Result.REFUSED, str(exc), last[1])
        lead = LEAD_S if self.command_type == "trajectory" else 0.0
        run = RigTest(spec, self.limits, started=now + lead)
        with self._lock:
            self._run = run
        ended = self._command(goal_handle, run)
        if ended is not None:
            return ended
        with self._lock:
            self._run = None
        return self._fit(goal_handle, run)

    def _command(self, goal_handle: ServerGoalHandle, run: RigTest) -> Any | None:
        """Send the test's commands until it is done; a result if it was cut short."""
        period, every = 1.0 / COMMAND_RATE_HZ, max(1, round(COMMAND_RATE_HZ / FEEDBACK_RATE_HZ))
        tick = 0
        streamed = self.command_type == "position"
        if not streamed:  # the whole test at once, from its stamped start; the rig interpolates
            offsets = TRAJECTORY_STEP_S * np.arange(
                0, int(np.ceil((run.ends - run.started) / TRAJECTORY_STEP_S)) + 1
            )
            positions = [run.command(run.started + t) for t in offsets]
            self._send_trajectory(run.started, offsets, positions)
        while True:
            now = time.monotonic()
            if self.stop.is_set():
                self._back_to_start(run)
                return _result(RunTest.Result.ABORTED, "the node is closing", run.start)
            if goal_handle.is_cancel_requested:
                self._back_to_start(run)
                return _result(RunTest.Result.CANCELED, "canceled on request", run.start)
            reason = run.abort_reason(now)
            if reason is not None:
                self._back_to_start(run)
                return _result(RunTest.Result.ABORTED, reason, run.start)
            phase = run.phase(now)
            if phase == "done":
                return None
            if streamed:
                self._send(run.command(now))
            if tick % every == 0:
                self._feedback(goal_handle, phase, now - run.started, run.position_error)
            tick += 1
            self.stop.wait(max(0.0, now + period - time.monotonic()))

    def _fit(self, goal_handle: ServerGoalHandle, run: RigTest) -> Any:
        """Cut the recorded window and fit it as `ema-phm isolate` does; the result."""
        from ..diagnosis.isolation import isolate  # noqa: PLC0415 - the optimizers load late

        try:
            window = run.window(self.sample_rate(), meta=dict(self.service.run_info))
        except WindowError as exc:
            return _result(RunTest.Result.ABORTED, str(exc), run.start)
        self._feedback(goal_handle, "fitting", time.monotonic() - run.started, 0.0)
        settings = self.service.settings
        belief = self.service.guard.belief(settings)
        try:
            res = isolate(window, **settings.isolate_options(belief, cancel=self.stop))
        except ExcitationError as exc:
            out = _result(RunTest.Result.NOT_ASSESSED, str(exc), run.start)
            out.window = telemetry_batch(window.matrix(), 0)
            return out
        verdict = health.assess_isolation(res, settings.thresholds)
        out = _result(RunTest.Result.FITTED, verdict.message, run.start)
        report = HealthReport(
            level=verdict.level,
            message=verdict.message,
            hardware_id=self.service.hardware_id,
            assessed=True,
            assessment=verdict,
            extras=extras_of(verdict),
        )
        out.health = actuator_health(report, self.node.get_clock().now().nanoseconds)
        out.report_json = json.dumps(health.isolation_report(res, verdict))
        out.window = telemetry_batch(window.matrix(), 0)
        return out

    # ------------------------------------------------------------- commanding
    def _send(self, position: float) -> None:
        self.publisher.publish(Float64MultiArray(data=[float(position)]))

    def _send_trajectory(self, begins: float, offsets: Any, positions: Any) -> None:
        """One trajectory of `joint` from `begins` [s, monotonic]: points at `offsets` s.

        Stamped with `begins` on the node's clock, read at the moment of sending (building
        a long trajectory takes milliseconds the rig must not lag by).
        """
        points = []
        for t, value in zip(offsets, positions, strict=True):
            sec = int(t)
            points.append(
                JointTrajectoryPoint(
                    positions=[float(value)],
                    time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9)),
                )
            )
        msg = JointTrajectory(joint_names=[self.joint], points=points)
        ahead = begins - time.monotonic()
        stamp = self.node.get_clock().now().nanoseconds + round(ahead * 1e9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        self.publisher.publish(msg)

    def _back_to_start(self, run: RigTest) -> None:
        """Ramp the command back to the start at the return rate and hold it; wait until done.

        A trajectory replaces the test's from its stamped start, from where the test's
        commands the rig then; set-points go from the last one sent.
        """
        trajectory = self.command_type == "trajectory"
        effective = time.monotonic() + (LEAD_S if trajectory else 0.0)
        ramp = [*run.ramp_back(run.command(effective), COMMAND_RATE_HZ), run.start]
        if trajectory:
            self._send_trajectory(effective, np.arange(len(ramp)) / COMMAND_RATE_HZ, ramp)
            time.sleep(LEAD_S + len(ramp) / COMMAND_RATE_HZ + SETTLE_S)  # the rig is back
            return
        for value in ramp[1:]:
            self._send(float(value))
            time.sleep(1.0 / COMMAND_RATE_HZ)

    def join(self, timeout: float = CLOSE_WAIT_S) -> None:
        """Wait for a running goal's thread (after `stop`: its return to the start)."""
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)

    def _feedback(
        self, goal_handle: ServerGoalHandle, phase: str, elapsed: float, error: float
    ) -> None:
        goal_handle.publish_feedback(
            RunTest.Feedback(phase=phase, elapsed_s=max(0.0, elapsed), position_error_rad=error)
        )

    def close(self) -> None:
        """Stop a running test; return once its command is back at the start (or after 5 s)."""
        self.stop.set()
        self.join()

    def destroy(self) -> None:
        """Stop a running test (its command back at the start first), then the server."""
        self.close()
        self.server.destroy()
        self.node.destroy_publisher(self.publisher)


def run_test_server(
    node: Any, service: HealthMonitor, values: Mapping[str, Any], actuator: ActuatorParameters
) -> RunTestServer:
    """monitor_node's ~/run_test of its checked parameter `values`, for `actuator`."""
    limits = RigTestLimits.of(
        actuator,
        max_position_error_rad=values["run_test_max_position_error_rad"],
        feedback_timeout_s=values["run_test_feedback_timeout_s"],
    )
    return RunTestServer(
        node,
        service,
        enabled=bool(values["run_test_enabled"]),
        command_topic=str(values["run_test_command_topic"]),
        command_type=str(values["run_test_command_type"]),
        joint=str(values["run_test_joint"]),
        limits=limits,
        default_command=default_specs()[0],
        sample_rate=lambda: float(
            service.run_info.get("sample_rate", actuator.acquisition.sample_rate)
        ),
    )


def _result(outcome: str, reason: str, start: float = float("nan")) -> Any:
    return RunTest.Result(outcome=outcome, reason=reason, start_position_rad=float(start))
