"""monitor_node: the prognostics node.  Telemetry in, fault isolation, health out.

Subscribes
  /ema/telemetry     std_msgs/Float64MultiArray  (telemetry layout, see ema_node)
  /ema/run_info      std_msgs/String             JSON: sample_rate, samples_per_window, k history
  /ema/ground_truth  std_msgs/Float64MultiArray  true k, for percent_err only: kept by an
                     evaluation listener beside the monitor (`evaluation.live_truth`)
Publishes
  /ema/window        std_msgs/Float64MultiArray  exactly the window being fitted (telemetry layout)
  /ema/health        std_msgs/Float64MultiArray  one dim labelled wire.HEALTH_LABEL
                     (`domain.health_layout`, from the fault table): every k entry,
                     percent_err, fitness, evaluations, elapsed_s, window_t0, window_t1,
                     level, then the prognosis after the window: RUL percentiles 5/50/95
                     [cycles] of every fault with a RUL, and rul_dominant
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

`actuator_file` (read-only) names the actuator watched: the belief is built from that file
(`model.belief.belief_for`, at start-up only); '' = the packaged belief.

A shell over `ema_phm.monitor.health_monitor.HealthMonitor`, which decides
everything (windows, skipping while busy, statuses, counters, staleness, prognoses); this
node decodes the messages, forwards them, and publishes and logs what it returns
(`monitor_outputs.MonitorOutputs`); `monitor_settings` builds the HealthMonitor from the
parameters and checks their changes, `monitor_recording.NodeRecording` writes the bag.

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
published (window, window_batch, health, diagnostics, actuator_health) goes to a rosbag2
MCAP bag, closed on shutdown; raw subscriptions, so the bag holds the bytes that were on the wire.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Any, Callable

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, String

from ..diagnosis.isolation_worker import IsolationWorker
from ..errors import WindowError
from ..evaluation.live_truth import LiveTruth
from ..monitor import status_texts
from ..monitor.health_monitor import HealthMonitor, Job, Outputs
from ..monitor.tracker import PrognosticTracker
from ..telemetry.wire import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    decode_ground_truth,
    decode_stream,
    decode_telemetry,
)
from .common import LATCHED_QOS, TELEMETRY_QOS, RelativeTopics, relative, spin_main
from .monitor_node_parameters import monitor_node_parameters
from .monitor_outputs import STATUS_TASK, MonitorOutputs, diagnostic_array, status_name
from .monitor_recording import RECORD_TOPICS, NodeRecording
from .monitor_settings import RunTimeSettings, health_monitor_from
from .parameters import declare_all
from .services import add_services

NODE_NAME = "monitor_node"

__all__ = [
    "NODE_NAME",
    "RECORD_TOPICS",
    "STATUS_TASK",
    "MonitorNode",
    "WarmUp",
    "diagnostic_array",
    "main",
    "status_name",
]


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
        # the truth a simulated actuator announces: beside the monitor, asked after a fit only
        self.truth = LiveTruth()
        self.service = health_monitor_from(values, truth=self.truth.over)
        self._closed = False
        self.outputs = MonitorOutputs(self, self.service)
        # may refuse (an existing bag): before any thread starts
        self.recording = NodeRecording(self, values["record_bag"], NODE_NAME)
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
        self._settings = RunTimeSettings(
            self.PARAMETERS, lambda name: self.get_parameter(name).value, self.service
        )
        self.add_on_set_parameters_callback(self._settings.validate)
        self.add_post_set_parameters_callback(
            self._guarded("applying parameters", self._settings.apply)
        )
        self.context.on_shutdown(self.worker.cancel.set)
        # ~/commission, ~/reset_prognosis, ~/fit_next_now; not `_services`: that is rclpy's own
        # list of the node's services, and replacing it dropped the parameter services
        self._trigger_services = add_services(self)
        self._start(warm_up=values["warm_up"])

    def _start(self, *, warm_up: bool) -> None:
        """Say the first status, then warm up (subscribing after it) or subscribe now."""
        self._emit(self.service.start(warming_up=warm_up))
        if warm_up:
            self.worker.submit(WarmUp())
        else:
            self._subscribe_inputs()
        topic = self.resolve_topic_name(relative(TELEMETRY_TOPIC))
        self.get_logger().info(_start_line(topic, self.service, self.record_path, warm_up))

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

    # ---------------------------------------------------------------- inputs
    def _on_telemetry(self, raw: bytes) -> None:
        self.recording.write(TELEMETRY_TOPIC, raw)
        try:
            msg = deserialize_message(raw, Float64MultiArray)
            rows, stream = decode_telemetry(msg), decode_stream(msg)
        except WindowError as exc:
            self._emit(self.service.on_malformed_telemetry(str(exc)))
            return
        self._emit(self.service.on_telemetry(rows, stream))

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

    def destroy_node(self) -> None:
        """Close (see `close`), then destroy the node."""
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """The `monitor_node` executable."""
    return spin_main(MonitorNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
