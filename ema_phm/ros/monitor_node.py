"""monitor_node: the prognostics node.  Telemetry in, fault isolation, health out.

Subscribes
  /ema/telemetry     std_msgs/Float64MultiArray  (telemetry layout, see ema_node)
  /ema/run_info      std_msgs/String             JSON: sample_rate, samples_per_window, k history
  /ema/ground_truth  std_msgs/Float64MultiArray  true k (only for percent_err)
Publishes
  /ema/window        std_msgs/Float64MultiArray  exactly the window being fitted (telemetry layout)
  /ema/health        std_msgs/Float64MultiArray  one dim labelled wire.HEALTH_LABEL:
                     k1..k8, percent_err, fitness, evaluations, elapsed_s, window_t0,
                     window_t1, level, then the prognosis after the window: RUL
                     percentiles 5/50/95 [cycles] of k1..k6 and rul_dominant
  /diagnostics       diagnostic_msgs/DiagnosticArray  status "<node's full name>: actuator"
                     without the leading slash, as diagnostic_updater names it
                     (`status_name`: "monitor_node: actuator", "left/monitor_node: actuator"),
                     after every result and every `heartbeat_period` s
  /ema/window_batch  ema_phm_msgs/TelemetryBatch  the fitted window, typed (with /ema/window)
  /ema/actuator_health  ema_phm_msgs/ActuatorHealth  with every /diagnostics status: level,
                     message and the named k entries of the last fit (`assessed` true on
                     the message of the fit itself), each with its remaining life (`rul`)
                     and `no_degradation_detected` from the latest prognosis
Services (std_srvs/Trigger, `ema_phm.ros.services`)
  ~/commission, ~/reset_prognosis, ~/fit_next_now
The /ema/... names are relative to the node's namespace (`common.RelativeTopics`): under
`-r __ns:=/left` they are /left/ema/...; /diagnostics stays absolute.  A recording names
them as above whatever the namespace.

A shell over `ema_phm.monitor.health_monitor.HealthMonitor`, which decides
everything (windows, skipping while busy, statuses, counters, staleness, prognoses); this
node decodes the messages, forwards them, and publishes and logs what it returns.

With `warm_up` (default) the worker thread first runs the fit once on a synthetic window
(`ema_phm.diagnosis.warm_up`; /diagnostics says "warming up", OK and never STALE) and
only then are the inputs subscribed to, so an ema_node with `wait_for_subscribers` holds
its telemetry until the monitor is ready.  With `prognostics` (default) every explained fit feeds a
`monitor.tracker.PrognosticTracker`: /diagnostics carries the RUL key/values
(``prognosis``, ``rul_<fault>_cycles_p50``, ...) and is at least WARN once a degrading
fault's RUL 5th percentile has been below `rul_horizon_cycles` in `rul_alarm_windows`
consecutive prognoses (default 2).
Windows are fitted by an `IsolationWorker` thread so the executor keeps spinning;
shutdown (destroy_node; SIGINT/SIGTERM through `common.spin_main`) cancels a
running isolation.  Whatever a callback raises is reported as ERROR on
/diagnostics (`callback_errors`) and the node keeps serving; a failed write to
the recording is only logged (reporting it would be recorded again).

With `record_bag`, everything received (raw telemetry, run_info, ground truth) and
published (window, health, diagnostics) goes to a rosbag2 MCAP bag, closed on
shutdown; raw subscriptions, so the bag holds the bytes that were on the wire.
"""

from __future__ import annotations

import dataclasses
import functools
import sys
from typing import Any, Callable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, String

from ..diagnosis import health
from ..diagnosis.isolation_settings import IsolationSettings
from ..diagnosis.isolation_worker import IsolationWorker
from ..errors import EmaPhmError, WindowError
from ..monitor.health_monitor import HealthMonitor, Job, LogLine, Outputs
from ..monitor.tracker import PrognosticTracker
from ..telemetry.recording import open_recording
from ..telemetry.typed import HealthReport, extras_of
from ..telemetry.wire import (
    ACTUATOR_HEALTH_TOPIC,
    DIAGNOSTICS_TOPIC,
    GROUND_TRUTH_TOPIC,
    HEALTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
    WINDOW_BATCH_TOPIC,
    WINDOW_TOPIC,
    decode_ground_truth,
    decode_stream,
    decode_telemetry,
    encode_health,
    encode_telemetry,
)
from .common import (
    LATCHED_QOS,
    OUTPUT_QOS,
    TELEMETRY_QOS,
    RelativeTopics,
    relative,
    spin_main,
    to_rclpy,
)
from .parameters import declare_all, monitor_node_parameters
from .services import add_services
from .typed_messages import ActuatorHealth, TelemetryBatch, actuator_health, telemetry_batch

NODE_NAME = "monitor_node"
#: The task part of the DiagnosticStatus name (`status_name`).
STATUS_TASK = "actuator"
#: Topics (and types) of a recording, in the order the bag lists them.
RECORD_TOPICS: dict[str, str] = {
    topic: TOPIC_TYPES[topic]
    for topic in (
        RUN_INFO_TOPIC,
        GROUND_TRUTH_TOPIC,
        TELEMETRY_TOPIC,
        WINDOW_TOPIC,
        HEALTH_TOPIC,
        DIAGNOSTICS_TOPIC,
        WINDOW_BATCH_TOPIC,
        ACTUATOR_HEALTH_TOPIC,
    )
}


class WarmUp:
    """The warm-up, as the first job of the node's worker thread."""


def status_name(node_name: str) -> str:
    """DiagnosticStatus.name of a monitor: its fully qualified node name, then the task.

    Unique per node, as diagnostic_updater's "node: task", which drops the leading slash
    (diagnostic_aggregator splits names on "/"): 'left/monitor_node: actuator'.
    """
    return f"{node_name.lstrip('/')}: {STATUS_TASK}"


def diagnostic_array(
    status: health.HealthStatus, stamp: Any, *, name: str | None = None
) -> DiagnosticArray:
    """One HealthStatus as a DiagnosticArray stamped `stamp` (named `name` if given)."""
    msg = DiagnosticArray()
    msg.header.stamp = stamp
    msg.status = [
        DiagnosticStatus(
            level=bytes([status.level]),
            name=status.name if name is None else name,
            message=status.message,
            hardware_id=status.hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in status.values],
        )
    ]
    return msg


def _prognostics_words(tracker: PrognosticTracker | None) -> str:
    if tracker is None:
        return "prognostics off"
    return (
        f"prognostics on (horizon {tracker.horizon_cycles} cycles, "
        f"{tracker.cycle_hours:g} h per cycle)"
    )


class MonitorNode(RelativeTopics, Node):
    """Forwards telemetry to a HealthMonitor; publishes windows, health and diagnostics."""

    PARAMETERS = monitor_node_parameters()

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        try:
            self._setup()
        except BaseException:  # a bad parameter, or a stop signal during start-up
            self._abandon()
            raise

    def _abandon(self) -> None:
        """Undo a build cut short: stop the worker, finish an opened bag, destroy the node."""
        self.close()
        Node.destroy_node(self)

    def _setup(self) -> None:
        values = declare_all(self, self.PARAMETERS)
        self.service = HealthMonitor(
            IsolationSettings.from_values(values),
            hardware_id=values["hardware_id"],
            stale_timeout=values["stale_timeout"],
            commission_windows=values["commission_windows"],
            prognostics=PrognosticTracker.from_values(values),
            queue_depth=values["queue_depth"],
        )
        self._closed = False
        self.status_name = status_name(self.get_fully_qualified_name())
        self._pub_window = self.create_publisher(Float64MultiArray, WINDOW_TOPIC, OUTPUT_QOS)
        self._pub_health = self.create_publisher(Float64MultiArray, HEALTH_TOPIC, OUTPUT_QOS)
        self._pub_diag = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, OUTPUT_QOS)
        self._pub_window_batch = self.create_publisher(
            TelemetryBatch, WINDOW_BATCH_TOPIC, OUTPUT_QOS
        )
        self._pub_actuator_health = self.create_publisher(
            ActuatorHealth, ACTUATOR_HEALTH_TOPIC, OUTPUT_QOS
        )
        self._last_fit: health.Assessment | None = None
        self._start_recording(values["record_bag"])  # may refuse: before any thread starts
        self.worker: IsolationWorker[Job | WarmUp] = IsolationWorker(
            self._work, name="monitor_node-isolation"
        )
        self._subscribed = False
        # the inputs are subscribed to from the executor, once the warm-up is over
        self._inputs_wanted = self.create_guard_condition(
            self._guarded("subscribing to the inputs", self._subscribe_inputs)
        )
        self.create_timer(
            values["heartbeat_period"],
            self._guarded("heartbeat", self._on_heartbeat),
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(
            self._guarded("applying parameters", self._apply_parameters)
        )
        self.context.on_shutdown(self.worker.cancel.set)
        self._services = add_services(self)  # ~/commission, ~/reset_prognosis, ~/fit_next_now
        self._emit(self.service.start(warming_up=values["warm_up"]))
        if values["warm_up"]:
            self.worker.submit(WarmUp())
        else:
            self._subscribe_inputs()
        s = self.service.settings
        self.get_logger().info(
            f"monitoring {self.resolve_topic_name(relative(TELEMETRY_TOPIC))}: "
            f"preset {s.preset}, seed {s.seed}, "
            f"fitness {s.fitness}, "
            f"max_evaluations {s.max_evaluations or 'preset'}, "
            + _prognostics_words(self.service.tracker)
            + (f", recording to {self.record_path}" if self.record_path else "")
            + (", warming up before subscribing to telemetry" if values["warm_up"] else "")
        )

    def _start_recording(self, template: str) -> None:
        self._recorder = None
        self.record_path = ""
        self.recorded: dict[str, int] = {}  # messages written to the bag, per topic
        if not template:
            return
        self._recorder, self.record_path = open_recording(template, RECORD_TOPICS)
        group = ReentrantCallbackGroup()
        for topic, msg_type in (
            (WINDOW_TOPIC, Float64MultiArray),
            (HEALTH_TOPIC, Float64MultiArray),
            (DIAGNOSTICS_TOPIC, DiagnosticArray),
            (WINDOW_BATCH_TOPIC, TelemetryBatch),
            (ACTUATOR_HEALTH_TOPIC, ActuatorHealth),
        ):
            self.create_subscription(
                msg_type,
                topic,
                functools.partial(self._record, topic),
                OUTPUT_QOS,
                raw=True,
                callback_group=group,
            )

    def _subscribe_inputs(self) -> None:
        if self._subscribed:
            return
        self._subscribed = True
        inputs = MutuallyExclusiveCallbackGroup()
        for msg_type, topic, handler, qos in (
            (Float64MultiArray, TELEMETRY_TOPIC, self._on_telemetry, TELEMETRY_QOS),
            (String, RUN_INFO_TOPIC, self._on_run_info, LATCHED_QOS),
            (Float64MultiArray, GROUND_TRUTH_TOPIC, self._on_ground_truth, LATCHED_QOS),
        ):
            self.create_subscription(
                msg_type,
                topic,
                self._guarded(f"handling {topic}", handler),
                qos,
                raw=True,
                callback_group=inputs,
            )

    # ------------------------------------------------------------ parameters
    def _current_values(self, changes: list[Parameter]) -> dict[str, Any]:
        values = {name: self.get_parameter(name).value for name in self.PARAMETERS.names}
        values.update(self.PARAMETERS.own(changes))  # use_sim_time & co.: rclpy's
        return values

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        try:
            IsolationSettings.from_values(self.PARAMETERS.validated(self._current_values(params)))
        except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, _params: list[Parameter]) -> None:
        self.service.set_settings(IsolationSettings.from_values(self._current_values([])))

    # ---------------------------------------------------------------- inputs
    def _on_telemetry(self, raw: bytes) -> None:
        self._record(TELEMETRY_TOPIC, raw)
        try:
            msg = deserialize_message(raw, Float64MultiArray)
            rows, stream = decode_telemetry(msg), decode_stream(msg)
        except WindowError as exc:
            self._emit(self.service.on_malformed_telemetry(str(exc)))
            return
        self._emit(self.service.on_telemetry(rows, stream))

    def _on_run_info(self, raw: bytes) -> None:
        self._record(RUN_INFO_TOPIC, raw)
        try:
            text = deserialize_message(raw, String).data
        except Exception as exc:  # noqa: BLE001 - an undecodable run_info is ignored and reported
            self._emit(
                self.service.fault(f"ignoring {RUN_INFO_TOPIC}", f"{type(exc).__name__}: {exc}")
            )
            return
        self._emit(self.service.on_run_info(text))

    def _on_ground_truth(self, raw: bytes) -> None:
        self._record(GROUND_TRUTH_TOPIC, raw)
        try:
            k = decode_ground_truth(deserialize_message(raw, Float64MultiArray))
        except WindowError as exc:  # a bad layout is logged and ignored, as a bad k is
            out = Outputs()
            out.log("error", f"ignoring {GROUND_TRUTH_TOPIC}: {exc}")
            self._emit(out)
            return
        self._emit(self.service.on_ground_truth(k))

    def _on_heartbeat(self) -> None:
        self._emit(self.service.heartbeat())

    def _work(self, job: Job | WarmUp) -> None:
        """Worker thread: warm up, then subscribe; or fit one window; publish the outcome."""
        if not isinstance(job, WarmUp):
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
        """Publish and log what the HealthMonitor decided, in its order."""
        now_ns = self.get_clock().now().nanoseconds
        for job in out.jobs:  # every window scheduled, in order (one message may complete several)
            self._publish(self._pub_window, to_rclpy(encode_telemetry(job.matrix)))
            self._publish(
                self._pub_window_batch,
                telemetry_batch(job.matrix, self._stamp_origin_ns(), job.stream),
            )
            self.worker.submit(job)
        if out.health is not None:
            self._publish(self._pub_health, to_rclpy(encode_health(out.health)))
        if out.status is not None:
            self._publish(
                self._pub_diag,
                diagnostic_array(
                    out.status, self.get_clock().now().to_msg(), name=self.status_name
                ),
            )
        if out.assessment is not None:
            self._last_fit = out.assessment
        if out.status is not None or out.assessment is not None:
            self._publish(self._pub_actuator_health, actuator_health(self._report(out), now_ns))
        for line in out.logs:
            self._log(line)

    def _stamp_origin_ns(self) -> int:
        """The stream's t = 0 on the ROS clock (run_info ``stamp_origin_ns``; 0 if not given)."""
        origin = self.service.run_info.get("stamp_origin_ns", 0)
        return origin if isinstance(origin, int) and abs(origin) < 2**62 else 0

    def _report(self, out: Outputs) -> HealthReport:
        """What /ema/actuator_health says for `out`: its status, with the last fit's k."""
        a, status = out.assessment, out.status
        if status is not None:
            level, message, hardware_id = status.level, status.message, status.hardware_id
        elif a is not None:
            level, message, hardware_id = a.level, a.message, self.service.hardware_id
        else:
            raise ValueError("no status and no fit to report")
        fit = a if a is not None else self._last_fit
        extras, prognosis = extras_of(fit), self.service.prognosis
        if prognosis is not None:
            extras = dataclasses.replace(
                extras,
                rul=prognosis.remaining_life(),
                no_degradation_detected=prognosis.no_degradation_detected,
            )
        return HealthReport(
            level=level,
            message=message,
            hardware_id=hardware_id,
            assessed=a is not None,
            assessment=fit,
            extras=extras,
        )

    def _log(self, line: LogLine) -> None:
        # one call site per severity: rclpy refuses to change the severity of a call site
        logger = self.get_logger()
        if line.severity == "error":
            logger.error(line.text)
        elif line.severity == "warning":
            logger.warning(line.text)
        elif line.severity == "info":
            logger.info(line.text)
        else:
            logger.debug(line.text)

    def _publish(self, publisher: Publisher, msg: Any) -> None:
        try:
            publisher.publish(msg)
        except Exception as exc:  # noqa: BLE001 - publishing while the context shuts down
            if self.context.ok() and not self._closed:
                self.get_logger().error(f"publish on {publisher.topic_name} failed: {exc}")

    def _record(self, topic: str, raw: bytes) -> None:
        recorder = self._recorder
        if recorder is None or recorder.failed:  # stopped (e.g. disk full): said once already
            return
        try:
            recorder.write_raw(topic, raw, self.get_clock().now().nanoseconds)
            self.recorded[topic] = self.recorded.get(topic, 0) + 1
        except Exception as exc:  # noqa: BLE001 - logged only: reporting on /diagnostics would be recorded again
            if not self._closed:
                self.get_logger().error(f"recording {topic}: {type(exc).__name__}: {exc}")

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
    def last_status(self) -> health.HealthStatus | None:
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
        worker = getattr(self, "worker", None)
        if worker is not None:
            worker.close()
        self._closed = True
        recorder, self._recorder = getattr(self, "_recorder", None), None
        if recorder is not None:
            try:
                recorder.close()
                self._say(f"bag {self.record_path} closed")
            except EmaPhmError as exc:
                self._say(str(exc), error=True)

    def _say(self, text: str, *, error: bool = False) -> None:
        """Log, also once the context is gone (rosout is then unavailable)."""
        if not self.context.ok():
            print(f"[{'ERROR' if error else 'INFO'}] [{NODE_NAME}]: {text}", file=sys.stderr)
        elif error:  # one severity per call site
            self.get_logger().error(text)
        else:
            self.get_logger().info(text)

    def destroy_node(self) -> None:
        """Close (see `close`), then destroy the node."""
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """The `monitor_node` executable."""
    return spin_main(MonitorNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
