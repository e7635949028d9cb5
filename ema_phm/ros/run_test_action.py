"""monitor_node's ``~/run_test`` action (ema_phm_msgs/action/RunTest): ask the rig for a test.

A goal commands the test excitation (`monitor.rig_test.plan_rig_test`: config/commands.yaml's
chirp unless the goal says otherwise) around the position the rig last reported, on
`run_test_command_topic` in the form `run_test_command_type` says: ``trajectory``, one
trajectory_msgs/JointTrajectory of joint `run_test_joint` holding the whole test (points every
`TRAJECTORY_STEP_S`; a ros2_control joint trajectory controller interpolates it), or
``position``, std_msgs/Float64MultiArray data[0] streamed at `COMMAND_RATE_HZ` (a forward
position controller's input: a staircase to the drive); records the response from the node's
own inputs; fits the window with the node's settings and belief as ``ema-phm isolate`` does
(a global fit, the node's seed); and answers the verdict, the `ema-phm isolate --json` report
and the window.  Feedback while it runs: phase, elapsed time, the tracking error.

Safety, each answered in the result's outcome and reason:
- refused unless ``run_test_enabled``; refused while another goal runs; refused without
  telemetry in the last ``run_test_feedback_timeout_s`` (the start position is unknown);
  refused when the excitation leaves the actuator file's end stop or top speed;
- aborted when the telemetry stops for ``run_test_feedback_timeout_s`` or the rig reports a
  tracking error beyond ``run_test_max_position_error_rad``; canceled on request; in both
  the command goes back to the start position at a bounded rate before the answer.
A goal is always accepted, so a refusal reaches the client with its reason.  While a goal
runs, the windows the node assembles are skipped, not fitted (counted in
``windows_skipped_busy``): a fit would take the CPU the commands need to leave in time.
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
from ..monitor.rig_test import RETURN_RATE_SHARE, RigTest, RigTestLimits, plan_rig_test
from ..physics.commands import CommandSpec, default_specs
from ..physics.parameters import ActuatorParameters
from ..telemetry.typed import HealthReport, extras_of

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
        self._last: tuple[float, float] | None = None  # (when heard, user position)
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
    def heard(self, rows: np.ndarray) -> None:
        """Telemetry rows the node took (any input path): the position, and the test's rows."""
        if rows.shape[0] == 0:
            return
        now = time.monotonic()
        with self._lock:
            self._last = (now, float(rows[-1, COLUMN["theta_u"]]))
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

        threading.Thread(target=work, name="monitor_node-run_test", daemon=True).start()
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
        run = RigTest(spec, self.limits, started=now)
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
        if not streamed:  # the whole test at once; the controller interpolates it
            offsets = TRAJECTORY_STEP_S * np.arange(
                1, int(np.ceil((run.ends - run.started) / TRAJECTORY_STEP_S)) + 1
            )
            self._send_trajectory(offsets, [run.command(run.started + t) for t in offsets])
        while True:
            now = time.monotonic()
            if goal_handle.is_cancel_requested or self.stop.is_set():
                self._back_to_start(run.command(now), run.start)
                why = "canceled on request" if not self.stop.is_set() else "the node is closing"
                return _result(RunTest.Result.CANCELED, why, run.start)
            reason = run.abort_reason(now)
            if reason is not None:
                self._back_to_start(run.command(now), run.start)
                return _result(RunTest.Result.ABORTED, reason, run.start)
            phase = run.phase(now)
            if phase == "done":
                return None
            if streamed:
                self._send(run.command(now))
            if tick % every == 0:
                self._feedback(goal_handle, phase, now - run.started, run.position_error)
            tick += 1
            self.stop.wait(max(0.0, run.started + tick * period - time.monotonic()))

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

    def _send_trajectory(self, offsets: Any, positions: Any) -> None:
        """One trajectory of `joint`, starting on arrival (a zero stamp): points at `offsets` s."""
        points = []
        for t, value in zip(offsets, positions, strict=True):
            sec = int(t)
            points.append(
                JointTrajectoryPoint(
                    positions=[float(value)],
                    time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9)),
                )
            )
        self.publisher.publish(JointTrajectory(joint_names=[self.joint], points=points))

    def _back_to_start(self, position: float, start: float) -> None:
        """Ramp the command from `position` back to `start` at the return rate, then hold it."""
        rate = RETURN_RATE_SHARE * self.limits.max_rate_rad_s
        steps = int(np.ceil(abs(position - start) / (rate / COMMAND_RATE_HZ))) if rate > 0 else 0
        ramp = [*np.linspace(position, start, steps + 1)[1:], start]
        if self.command_type == "trajectory":  # replaces the test's trajectory from now on
            self._send_trajectory((1 + np.arange(len(ramp))) / COMMAND_RATE_HZ, ramp)
            return
        for value in ramp:
            self._send(float(value))
            time.sleep(1.0 / COMMAND_RATE_HZ)

    def _feedback(
        self, goal_handle: ServerGoalHandle, phase: str, elapsed: float, error: float
    ) -> None:
        goal_handle.publish_feedback(
            RunTest.Feedback(phase=phase, elapsed_s=float(elapsed), position_error_rad=error)
        )

    def destroy(self) -> None:
        """Stop a running test (its command returns to the start) and the action server."""
        self.stop.set()
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
