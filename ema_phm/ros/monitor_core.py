"""What monitor_node does, in either of its forms (plain and managed).

`MonitorCore` is mixed into an rclpy Node (`monitor_node.MonitorNode`) or LifecycleNode
(`monitor_lifecycle_node.MonitorLifecycleNode`); each of those only says when to build, start,
stop and tear down.  The topics, services and parameters are monitor_node's docstring's.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import TYPE_CHECKING, Any, Callable, Mapping

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, String

from ..diagnosis.isolation_worker import IsolationWorker
from ..errors import WindowError
from ..evaluation.live_truth import LiveTruth
from ..monitor import status_texts
from ..monitor.health_monitor import HealthMonitor, Job, Outputs
from ..monitor.tracker import PrognosticTracker
from ..physics.actuator_file import load_actuator
from ..physics.parameters import ActuatorParameters
from ..telemetry.typed import batch_rows, stream_of
from ..telemetry.wire import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_BATCH_TOPIC,
    TELEMETRY_TOPIC,
    decode_ground_truth,
    decode_stream,
    decode_telemetry,
)
from .common import LATCHED_QOS, TELEMETRY_QOS, relative
from .mapped_inputs import mapped_inputs_of
from .monitor_node_parameters import monitor_node_parameters
from .monitor_outputs import MonitorOutputs
from .monitor_recording import NodeRecording
from .monitor_settings import RunTimeSettings, health_monitor_from
from .run_test_action import run_test_server
from .services import add_services
from .typed_messages import TelemetryBatch

NODE_NAME = "monitor_node"


class WarmUp:
    """The warm-up, as the first job of the node's worker thread."""


def _prognostics_words(tracker: PrognosticTracker | None) -> str:
    if tracker is None:
        return "prognostics off"
    return (
        f"prognostics on (horizon {tracker.horizon_cycles} cycles, "
        f"{tracker.cycle_hours:g} h per cycle)"
    )


def _start_line(topic: str, service: HealthMonitor, record_path: str, warm_up: bool) -> str:
    """The log line that says what the node monitors and how."""
    s = service.settings
    return (
        f"monitoring {topic}: preset {s.preset}, seed {s.seed}, fitness {s.fitness}, "
        f"max_evaluations {s.max_evaluations or 'preset'}, "
        + _prognostics_words(service.tracker)
        + (f", recording to {record_path}" if record_path else "")
        + (", warming up before subscribing to telemetry" if warm_up else "")
    )


def _actuator(values: Mapping[str, Any]) -> ActuatorParameters:
    """The actuator of the `actuator_file` parameter ('' = the packaged one)."""
    path = values["actuator_file"]
    return load_actuator(path) if path else ActuatorParameters.default()


if TYPE_CHECKING:  # a mixin of rclpy nodes: type-checked as one
    from rclpy.node import Node as _NodeBase
else:
    _NodeBase = object


class MonitorCore(_NodeBase):
    """What both monitor nodes do, mixed into an rclpy Node or LifecycleNode (`self`).

    `_build(values)` makes the monitor and its publishers, worker, timer, services and
    parameter callbacks; `_start` says the first status and subscribes (after a warm-up);
    `_unsubscribe_inputs` stops the inputs; `close` stops the worker and the bag;
    `_teardown` destroys what `_build` made.  Forwards telemetry to a HealthMonitor and
    publishes windows, health and diagnostics.
    """

    PARAMETERS = monitor_node_parameters()

    def _build(self, values: Mapping[str, Any]) -> None:
        """Make the monitor of the checked parameter `values`; nothing subscribed yet."""
        # the truth a simulated actuator announces: beside the monitor, asked after a fit only
        self.truth = LiveTruth()
        self._telemetry_input = str(values["telemetry_input"])
        self.service = health_monitor_from(values, truth=self.truth.over)
        actuator = _actuator(values)
        self._mapped = mapped_inputs_of(
            self, values, actuator, self.service, self._emit, self._telemetry, self._guarded
        )
        self._closed = False
        self.outputs = MonitorOutputs(self, self.service)
        # may refuse (an existing bag): before any thread starts
        self.recording = NodeRecording(self, values["record_bag"], NODE_NAME)
        self.worker: IsolationWorker[Job | WarmUp] = IsolationWorker(
            self._work, name="monitor_node-isolation"
        )
        self._input_subscriptions: list[Any] = []
        # the inputs are subscribed to from the executor, once the warm-up is over
        self._inputs_wanted = self.create_guard_condition(
            self._guarded("subscribing to the inputs", self._subscribe_inputs)
        )
        self._heartbeat = self.create_timer(
            values["heartbeat_period"],
            self._guarded("heartbeat", self._on_heartbeat),
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        self._settings = RunTimeSettings(
            self.PARAMETERS, lambda name: self.get_parameter(name).value, self.service
        )
        self._parameter_callbacks = (
            self._settings.validate,
            self._guarded("applying parameters", self._settings.apply),
        )
        self.add_on_set_parameters_callback(self._parameter_callbacks[0])
        self.add_post_set_parameters_callback(self._parameter_callbacks[1])
        self.context.on_shutdown(self.worker.cancel.set)
        # ~/commission, ~/reset_prognosis, ~/fit_next_now; not `_services`: that is rclpy's own
        # list of the node's services, and replacing it dropped the parameter services
        self._trigger_services = add_services(self)
        self._run_test = run_test_server(self, self.service, values, actuator)

    def _start(self, *, warm_up: bool) -> None:
        """Say the first status, then warm up (subscribing after it) or subscribe now."""
        self._emit(self.service.start(warming_up=warm_up))
        if warm_up:
            self.worker.submit(WarmUp())
        else:
            self._subscribe_inputs()
        if self._mapped is not None:
            topic = f"{', '.join(self._mapped.live.topics)} ({self._mapped.live.cmap.source})"
        else:
            name = TELEMETRY_BATCH_TOPIC if self._telemetry_input == "batch" else TELEMETRY_TOPIC
            topic = self.resolve_topic_name(relative(name))
        self.get_logger().info(_start_line(topic, self.service, self.record_path, warm_up))

    def _subscribe_inputs(self) -> None:
        if self._mapped is not None:
            if not self._closed and not self._mapped.started:
                self._emit(self.service.on_run_info(self._mapped.run_info))
                self._mapped.started = True
                self._mapped.subscribe_ready()
            return
        if self._input_subscriptions or self._closed:
            return
        inputs = MutuallyExclusiveCallbackGroup()
        telemetry = (
            (TelemetryBatch, TELEMETRY_BATCH_TOPIC, self._on_telemetry_batch, TELEMETRY_QOS)
            if self._telemetry_input == "batch"
            else (Float64MultiArray, TELEMETRY_TOPIC, self._on_telemetry, TELEMETRY_QOS)
        )
        for msg_type, topic, handler, qos in (
            telemetry,
            (String, RUN_INFO_TOPIC, self._on_run_info, LATCHED_QOS),
            (Float64MultiArray, GROUND_TRUTH_TOPIC, self._on_ground_truth, LATCHED_QOS),
        ):
            self._input_subscriptions.append(
                self.create_subscription(
                    msg_type,
                    topic,
                    self._guarded(f"handling {topic}", handler),
                    qos,
                    raw=True,
                    callback_group=inputs,
                )
            )

    def _unsubscribe_inputs(self) -> None:
        """Stop taking telemetry, run_info and ground truth (a fit under way still ends)."""
        if self._mapped is not None:
            self._mapped.close()
        for sub in self._input_subscriptions:
            self.destroy_subscription(sub)
        self._input_subscriptions = []

    # ---------------------------------------------------------------- inputs
    def _on_telemetry(self, raw: bytes) -> None:
        self.recording.write(TELEMETRY_TOPIC, raw)
        try:
            msg = deserialize_message(raw, Float64MultiArray)
            rows, stream = decode_telemetry(msg), decode_stream(msg)
        except WindowError as exc:
            self._emit(self.service.on_malformed_telemetry(str(exc)))
            return
        self._telemetry(rows, stream)

    def _telemetry(self, rows: Any, stream: Any) -> None:
        """Rows of any input: to ~/run_test (the rig's position), then to the monitor."""
        self._run_test.heard(rows, stream)
        self._emit(self.service.on_telemetry(rows, stream))

    def _on_telemetry_batch(self, raw: bytes) -> None:
        self.recording.write(TELEMETRY_BATCH_TOPIC, raw)
        try:
            msg = deserialize_message(raw, TelemetryBatch)
            rows, stream = batch_rows(msg), stream_of(msg)
        except WindowError as exc:
            self._emit(self.service.on_malformed_telemetry(str(exc)))
            return
        self._telemetry(rows, stream)

    def _on_run_info(self, raw: bytes) -> None:
        self.recording.write(RUN_INFO_TOPIC, raw)
        try:
            text = deserialize_message(raw, String).data
        except Exception as exc:  # noqa: BLE001 - an undecodable run_info is ignored and reported
            self._emit(
                self.service.fault(f"ignoring {RUN_INFO_TOPIC}", f"{type(exc).__name__}: {exc}")
            )
            return
        self.truth.note_run_info_text(text)
        self._emit(self.service.on_run_info(text))

    def _on_ground_truth(self, raw: bytes) -> None:
        self.recording.write(GROUND_TRUTH_TOPIC, raw)
        try:
            ignored = self.truth.note_message(
                decode_ground_truth(deserialize_message(raw, Float64MultiArray))
            )
        except WindowError as exc:  # a bad layout is logged and ignored, as a bad k is
            ignored = str(exc)
        if ignored is not None:
            out = Outputs()
            out.log("error", f"ignoring {GROUND_TRUTH_TOPIC}: {ignored}")
            self._emit(out)

    def _on_heartbeat(self) -> None:
        if self._mapped is not None and self._mapped.started and self._mapped.pending:
            self._mapped.subscribe_ready()  # a rig's topic that was not on the graph yet
        self._emit(self.service.heartbeat())

    def _work(self, job: Job | WarmUp) -> None:
        """Worker thread: warm up, then subscribe; or fit one window; publish the outcome."""
        if not isinstance(job, WarmUp):
            if self._run_test.active:  # its commands leave in time if no fit takes the CPU
                self._emit(self.service.fitter.skip(job, "a test (~/run_test) is running"))
                return
            self._emit(self.service.run_job(job, self.worker.cancel))
            return
        self._emit(self.service.warm_up(self.worker.cancel))
        if self.worker.cancel.is_set() or self._closed:
            return
        try:
            self._inputs_wanted.trigger()
        except Exception as exc:  # noqa: BLE001 - a node destroyed meanwhile has no inputs
            if self.context.ok() and not self._closed:
                self.get_logger().error(f"subscribing after the warm-up failed: {exc}")

    # --------------------------------------------------------------- outputs
    def _emit(self, out: Outputs) -> None:
        """Publish and log what the HealthMonitor decided, in its order (`MonitorOutputs`)."""
        self.outputs.emit(out, self.worker.submit)

    def _guarded(self, where: str, handler: Callable[..., None]) -> Callable[..., None]:
        """`handler` as a callback: what it raises is reported on /diagnostics, not propagated."""

        def run(*args: Any) -> None:
            try:
                handler(*args)
            except Exception as exc:  # noqa: BLE001 - a callback never takes the node down
                try:
                    self._emit(self.service.fault(where, f"{type(exc).__name__}: {exc}"))
                except Exception as report_exc:  # noqa: BLE001 - the last line of defence
                    print(
                        f"[ERROR] [{NODE_NAME}]: reporting a fault failed: {report_exc}",
                        file=sys.stderr,
                    )

        return run

    # ----------------------------------------------------- for callers and tests
    @property
    def status_name(self) -> str:
        """This node's DiagnosticStatus name ('left/monitor_node: actuator')."""
        return self.outputs.status_name

    @property
    def record_path(self) -> str:
        """The bag being recorded to ('' = none)."""
        return self.recording.path

    @property
    def recorded(self) -> dict[str, int]:
        """Messages written to the bag so far, per topic."""
        return self.recording.recorded

    @property
    def counters(self) -> dict[str, int]:
        """The HealthMonitor's counters."""
        return self.service.counters

    @property
    def results(self) -> Any:
        """Health results so far (HealthMonitor.results)."""
        return self.service.results

    @property
    def failures(self) -> Any:
        """Failed isolations so far (HealthMonitor.failures)."""
        return self.service.failures

    @property
    def not_excited(self) -> Any:
        """Windows not assessed for lack of excitation (HealthMonitor)."""
        return self.service.not_excited

    @property
    def last_status(self) -> status_texts.HealthStatus | None:
        """The last status published on /diagnostics, if any."""
        status = self.service.last_status
        return None if status is None else dataclasses.replace(status, name=self.status_name)

    def wait_for_results(
        self, n: int = 1, timeout: float | None = None, **until: int | None
    ) -> list[dict[str, Any]]:
        """Block until n results (or `failures` / `not_excited`), see HealthMonitor."""
        return self.service.wait_for_results(n, timeout, **until)

    # -------------------------------------------------------------- shutdown
    def close(self) -> None:
        """Cancel a running isolation, stop the worker and finish the bag (idempotent).

        Also on a node whose build was cut short (no worker or bag yet).
        """
        if getattr(self, "_closed", False):
            return
        if "_run_test" in self.__dict__:  # a running test puts its command back at the start
            self._run_test.close()
        worker = getattr(self, "worker", None)
        if worker is not None:
            worker.close()
        self._closed = True
        outputs = getattr(self, "outputs", None)
        if outputs is not None:
            outputs.closed = True
        recording = getattr(self, "recording", None)
        if recording is not None:
            recording.close()

    def _teardown(self) -> None:
        """Close (see `close`), then destroy what `_build` made, also of a build cut short."""
        self.close()
        if getattr(self, "_input_subscriptions", None):
            self._unsubscribe_inputs()
        for name, destroy in (
            ("_heartbeat", self.destroy_timer),
            ("_inputs_wanted", self.destroy_guard_condition),
            ("_run_test", lambda tester: tester.destroy()),
        ):
            entity = self.__dict__.pop(name, None)
            if entity is not None:
                destroy(entity)
        for service in self.__dict__.pop("_trigger_services", []):
            self.destroy_service(service)
        callbacks = self.__dict__.pop("_parameter_callbacks", None)
        if callbacks is not None:
            self.remove_on_set_parameters_callback(callbacks[0])
            self.remove_post_set_parameters_callback(callbacks[1])
        outputs = self.__dict__.pop("outputs", None)
        if outputs is not None:
            outputs.destroy()
