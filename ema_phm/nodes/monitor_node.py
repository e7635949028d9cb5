"""monitor_node: the prognostics node.  Telemetry in, fault isolation, health out.

Subscribes
  /ema/telemetry     std_msgs/Float64MultiArray  (telemetry layout, see ema_node)
  /ema/run_info      std_msgs/String             JSON: sample_rate, samples_per_window, k history
  /ema/ground_truth  std_msgs/Float64MultiArray  true k (only for percent_err)
Publishes
  /ema/window        std_msgs/Float64MultiArray  exactly the window being fitted (telemetry layout)
  /ema/health        std_msgs/Float64MultiArray  one dim labelled health.HEALTH_LABEL:
                     k1..k8, percent_err, fitness, evaluations, elapsed_s, window_t0, window_t1, level
  /diagnostics       diagnostic_msgs/DiagnosticArray  status "ema_phm: actuator" (OK/WARN/ERROR),
                     after every result and every `heartbeat_period` s

Windows are cut by `WindowAssembler` (aligned to window boundaries; a gap or an
out-of-order message discards the window being assembled).  Each complete window
is fitted by `isolate()` in a worker thread so the executor keeps spinning; a
window that completes while the worker is busy is skipped (counted).  Shutdown
(destroy_node, SIGINT/SIGTERM via rclpy's handlers) cancels a running isolation.

With `record_bag`, everything received (raw telemetry, run_info, ground truth) and
published (window, health, diagnostics) goes to a rosbag2 MCAP bag, closed on
shutdown.  Recording uses raw subscriptions, so the bag holds the bytes that were
on the wire.
"""
from __future__ import annotations

import json
import math
import queue
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any, Callable

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray, String

from .. import health
from ..bag_io import FLOAT64_MULTIARRAY, STRING, BagRecorder
from ..errors import ConfigError, EmaPhmError, IsolationCancelled, WindowError
from ..fault_vector import validate
from ..fitness import WEIGHTINGS
from ..isolation import DEFAULT_PRESET, PRESETS, Progress, isolate
from ..telemetry import Window
from ..window_assembler import Completed, Discarded, WindowAssembler
from .common import (spin_main, DIAGNOSTICS_TOPIC, GROUND_TRUTH_TOPIC, HEALTH_TOPIC, LATCHED_QOS, OUTPUT_QOS,
                     RUN_INFO_TOPIC, TELEMETRY_QOS, TELEMETRY_TOPIC, WINDOW_TOPIC, multiarray, rows_of)

NODE_NAME = "monitor_node"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
#: Topics (and types) of a recording.
RECORD_TOPICS: dict[str, str] = {
    RUN_INFO_TOPIC: STRING, GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY, TELEMETRY_TOPIC: FLOAT64_MULTIARRAY,
    WINDOW_TOPIC: FLOAT64_MULTIARRAY, HEALTH_TOPIC: FLOAT64_MULTIARRAY, DIAGNOSTICS_TOPIC: DIAGNOSTIC_ARRAY,
}
#: Telemetry messages kept while waiting for the first run_info.
PENDING_MESSAGES = 5000


def defaults() -> dict[str, Any]:
    """Declared defaults (config/monitor_node.yaml holds the same values)."""
    return {
        "preset": "",
        "seed": 0,
        "fitness": "default",
        "max_evaluations": 0,
        "warn_threshold": list(health.DEFAULT_WARN),
        "error_threshold": list(health.DEFAULT_ERROR),
        "record_bag": "",
        "heartbeat_period": 1.0,
        "hardware_id": "ema_sim",
    }


_DESCRIPTIONS = {
    "preset": f"isolation preset ({', '.join(sorted(PRESETS))}); '' = ema_phm.isolation.DEFAULT_PRESET",
    "seed": "seed of the isolation (same seed, same window -> same k)",
    "fitness": f"fitness weighting ({', '.join(sorted(WEIGHTINGS))})",
    "max_evaluations": "evaluation budget of one isolation; 0 = the preset's own",
    "warn_threshold": "per-fault severity |k_i - nominal_i| at which the status is WARN (k7 ignored)",
    "error_threshold": "per-fault severity at which the status is ERROR (k7 ignored)",
    "record_bag": "record to this new rosbag2 (MCAP) directory; '' = off; '{stamp}' is replaced by the start time",
    "heartbeat_period": "s between /diagnostics heartbeats",
    "hardware_id": "DiagnosticStatus.hardware_id",
}
_DYNAMIC = ("preset", "seed", "fitness", "max_evaluations", "warn_threshold", "error_threshold")


@dataclass(frozen=True)
class Settings:
    preset: str
    seed: int
    fitness: str
    max_evaluations: int
    thresholds: health.Thresholds

    @classmethod
    def from_values(cls, v: dict[str, Any]) -> Settings:
        preset = str(v["preset"]) or DEFAULT_PRESET
        if preset not in PRESETS:
            raise ConfigError(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}")
        if str(v["fitness"]) not in WEIGHTINGS:
            raise ConfigError(f"unknown fitness weighting {v['fitness']!r}; choose from {sorted(WEIGHTINGS)}")
        if int(v["seed"]) < 0:
            raise ConfigError(f"seed must be >= 0, got {v['seed']}")
        if int(v["max_evaluations"]) < 0:
            raise ConfigError(f"max_evaluations must be >= 0 (0 = preset default), got {v['max_evaluations']}")
        return cls(preset, int(v["seed"]), str(v["fitness"]), int(v["max_evaluations"]),
                   health.Thresholds(tuple(v["warn_threshold"]), tuple(v["error_threshold"])))

    def reported(self) -> dict[str, Any]:
        """Settings copied into every diagnostic status (and so into recordings)."""
        return {"preset": self.preset, "seed": self.seed, "fitness_weighting": self.fitness,
                "max_evaluations": self.max_evaluations}


@dataclass
class _Job:
    window: Window
    t0: float
    t1: float
    settings: Settings
    started: float


class MonitorNode(Node):
    """Assembles windows, isolates faults in a worker thread, publishes health and diagnostics."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        try:
            self._setup()
        except BaseException:
            Node.destroy_node(self)   # a bad parameter must not leave a half-built node behind
            raise

    def _setup(self) -> None:
        d = defaults()
        for name, value in d.items():
            desc = ParameterDescriptor(description=_DESCRIPTIONS[name], read_only=name not in _DYNAMIC)
            if isinstance(value, list):
                desc.type = ParameterType.PARAMETER_DOUBLE_ARRAY
            self.declare_parameter(name, value, desc)
        values = {name: self.get_parameter(name).value for name in d}
        self.settings = Settings.from_values(values)
        self.heartbeat_period = float(values["heartbeat_period"])
        if not (math.isfinite(self.heartbeat_period) and self.heartbeat_period > 0):
            raise ConfigError(f"heartbeat_period must be > 0 s, got {self.heartbeat_period}")
        self.hardware_id = str(values["hardware_id"])

        self._lock = threading.RLock()
        self._assembler: WindowAssembler | None = None
        self._pending: deque[np.ndarray] = deque(maxlen=PENDING_MESSAGES)
        self._truth_history: deque[tuple[float, np.ndarray]] = deque(maxlen=64)   # (k_since_t, k) from run_info
        self._truth_latest: np.ndarray | None = None                               # from /ema/ground_truth
        self.run_info: dict[str, Any] = {}
        self.counters: dict[str, int] = dict.fromkeys(health.COUNTERS, 0)
        self.discard_reasons: deque[str] = deque(maxlen=100)
        self._busy: _Job | None = None
        self._progress = 0
        self._last_status: health.HealthStatus | None = None
        self._last_assessment: health.Assessment | None = None
        self._status_of: Callable[[health.StatusContext], health.HealthStatus] | None = None
        self.results: deque[dict[str, Any]] = deque(maxlen=1000)   # health dicts, newest last
        self.failures: deque[str] = deque(maxlen=1000)              # reasons of failed isolations
        self._results_cv = threading.Condition(self._lock)
        self._cancel = threading.Event()
        self._closed = False

        self._pub_window = self.create_publisher(Float64MultiArray, WINDOW_TOPIC, OUTPUT_QOS)
        self._pub_health = self.create_publisher(Float64MultiArray, HEALTH_TOPIC, OUTPUT_QOS)
        self._pub_diag = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, OUTPUT_QOS)

        self._recorder: BagRecorder | None = None
        self.recorded: dict[str, int] = {}     # messages written to the bag, per topic
        path = str(values["record_bag"])
        if path:
            path = path.replace("{stamp}", datetime.now().strftime("%Y%m%d-%H%M%S"))
            try:
                Path(path).parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ConfigError(f"record_bag {path}: cannot create its folder: {exc}") from None
            self._recorder = BagRecorder(path, topics=RECORD_TOPICS)
            self.record_path = path
            rec_group = ReentrantCallbackGroup()
            for topic in (WINDOW_TOPIC, HEALTH_TOPIC):
                self.create_subscription(Float64MultiArray, topic, self._recorder_cb(topic), OUTPUT_QOS,
                                         raw=True, callback_group=rec_group)
            self.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self._recorder_cb(DIAGNOSTICS_TOPIC),
                                     OUTPUT_QOS, raw=True, callback_group=rec_group)
        else:
            self.record_path = ""

        inputs = MutuallyExclusiveCallbackGroup()
        self.create_subscription(Float64MultiArray, TELEMETRY_TOPIC, self._on_telemetry, TELEMETRY_QOS,
                                 raw=True, callback_group=inputs)
        self.create_subscription(String, RUN_INFO_TOPIC, self._on_run_info, LATCHED_QOS, raw=True,
                                 callback_group=inputs)
        self.create_subscription(Float64MultiArray, GROUND_TRUTH_TOPIC, self._on_ground_truth, LATCHED_QOS,
                                 raw=True, callback_group=inputs)

        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._worker = threading.Thread(target=self._work, name="monitor_node-isolation", daemon=True)
        self._worker.start()
        self._status_of = lambda ctx: health.waiting_status(ctx)
        self._heartbeat = self.create_timer(self.heartbeat_period, self._on_heartbeat,
                                            callback_group=MutuallyExclusiveCallbackGroup())
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.context.on_shutdown(self._cancel.set)
        self._publish_status(self._status_of(self._ctx()))
        self.get_logger().info(
            f"monitoring {TELEMETRY_TOPIC}: preset {self.settings.preset}, seed {self.settings.seed}, "
            f"fitness {self.settings.fitness}, max_evaluations {self.settings.max_evaluations or 'preset'}"
            + (f", recording to {self.record_path}" if self.record_path else ""))

    # ----------------------------------------------------------------- parameters
    def _validate_parameters(self, params: list[Any]) -> SetParametersResult:
        values = {name: self.get_parameter(name).value for name in defaults()}
        values.update({p.name: p.value for p in params})
        try:
            Settings.from_values(values)
        except (ConfigError, TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Any]) -> None:
        values = {name: self.get_parameter(name).value for name in defaults()}
        with self._lock:
            self.settings = Settings.from_values(values)

    # ------------------------------------------------------------------ recording
    def _record(self, topic: str, raw: bytes) -> None:
        rec = self._recorder
        if rec is None:
            return
        try:
            rec.write_raw(topic, raw, self.get_clock().now().nanoseconds)
            self.recorded[topic] = self.recorded.get(topic, 0) + 1
        except EmaPhmError as exc:
            if not self._closed:
                self.get_logger().error(f"recording {topic}: {exc}")

    def _recorder_cb(self, topic: str) -> Callable[[bytes], None]:
        return lambda raw: self._record(topic, raw)

    # --------------------------------------------------------------------- inputs
    def _on_run_info(self, raw: bytes) -> None:
        self._record(RUN_INFO_TOPIC, raw)
        text = deserialize_message(raw, String).data
        try:
            info = json.loads(text)
            fs = float(info["sample_rate"])
            n = int(info["samples_per_window"])
            asm = WindowAssembler(fs, n)
        except (ValueError, KeyError, TypeError, EmaPhmError) as exc:
            self.get_logger().error(f"ignoring {RUN_INFO_TOPIC}: {type(exc).__name__}: {exc}")
            return
        with self._lock:
            self.run_info = info
            if "k_true" in info:
                try:
                    self._truth_history.append((float(info.get("k_since_t", 0.0)), validate(info["k_true"])))
                except (EmaPhmError, TypeError, ValueError):
                    pass
            old = self._assembler
            if old is not None and (old.sample_rate, old.n) == (fs, n):
                return
            if old is not None:
                self._handle(old.reset(f"run_info changed the window to {n} samples at {fs:g} Hz"))
            self._assembler = asm
            pending, self._pending = list(self._pending), deque(maxlen=PENDING_MESSAGES)
        self.get_logger().info(f"windows of {n} samples at {fs:g} Hz ({n / fs:g} s)")
        for rows in pending:
            self._feed(rows)

    def _on_ground_truth(self, raw: bytes) -> None:
        self._record(GROUND_TRUTH_TOPIC, raw)
        msg = deserialize_message(raw, Float64MultiArray)
        try:
            k = validate(np.frombuffer(msg.data, dtype=np.float64) if len(msg.data) else [])
        except EmaPhmError as exc:
            self.get_logger().error(f"ignoring {GROUND_TRUTH_TOPIC}: {exc}")
            return
        with self._lock:
            self._truth_latest = k

    def _on_telemetry(self, raw: bytes) -> None:
        self._record(TELEMETRY_TOPIC, raw)
        msg = deserialize_message(raw, Float64MultiArray)
        try:
            rows = rows_of(msg)
        except WindowError as exc:
            with self._lock:
                asm = self._assembler
                if asm is not None:
                    self._handle(asm.reset(f"malformed telemetry message: {exc}"))
            return
        with self._lock:
            if self._assembler is None:
                self._pending.append(rows)
                return
        self._feed(rows)

    def _feed(self, rows: np.ndarray) -> None:
        with self._lock:
            events = self._assembler.feed(rows)
            self._handle(events)

    def _handle(self, events: list[Completed | Discarded]) -> None:
        for ev in events:
            if isinstance(ev, Discarded):
                self._discard(f"window t0 = {ev.t0:g} s discarded after {ev.samples} samples: {ev.reason}")
            else:
                self._on_window(ev)

    def _discard(self, reason: str) -> None:
        self.counters["windows_discarded"] += 1
        self.discard_reasons.append(reason)
        self.get_logger().warning(reason)

    def _on_window(self, ev: Completed) -> None:
        if self._busy is not None:
            self.counters["windows_skipped_busy"] += 1
            self.get_logger().info(f"window t = {ev.t0:g}..{ev.t1:g} s skipped: still isolating "
                                   f"t = {self._busy.t0:g}..{self._busy.t1:g} s")
            return
        try:
            window = Window.from_matrix(ev.data, meta=dict(self.run_info)).validated()
        except WindowError as exc:
            self._discard(f"window t = {ev.t0:g}..{ev.t1:g} s discarded: {exc}")
            return
        job = _Job(window, ev.t0, ev.t1, self.settings, time.monotonic())
        self._busy = job
        self._progress = 0
        try:
            self._pub_window.publish(multiarray(ev.data, ["samples", "channels"]))
        except Exception as exc:  # noqa: BLE001 - context going down
            self.get_logger().debug(f"cannot publish {WINDOW_TOPIC}: {exc}")
        self._jobs.put(job)

    # --------------------------------------------------------------------- worker
    def _on_progress(self, p: Progress) -> None:
        self._progress = p.evaluations

    def _truth_for(self, t0: float, t1: float) -> np.ndarray | None:
        """The true k over [t0, t1] from run_info's history; None if it changed inside the window."""
        eps = 1e-9 + 1e-6 * abs(t1)
        hist = sorted(self._truth_history, key=lambda e: e[0])
        if hist:
            if any(t0 + eps < since < t1 - eps for since, _ in hist):
                return None
            before = [k for since, k in hist if since <= t0 + eps]
            if before:
                return before[-1]
        return self._truth_latest

    def _work(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            s = job.settings
            try:
                res = isolate(job.window, preset=s.preset, seed=s.seed, weights=s.fitness,
                              on_progress=self._on_progress, cancel=self._cancel,
                              max_evaluations=s.max_evaluations or None)
            except IsolationCancelled:
                with self._lock:
                    self._busy = None
                if self._cancel.is_set():
                    return
                continue
            except Exception as exc:  # noqa: BLE001 - report any failure, keep running
                reason = f"{type(exc).__name__}: {exc}"
                with self._lock:
                    self.counters["isolation_failures"] += 1
                    last = self._last_assessment
                    self._status_of = (lambda ctx, r=reason, a=last, j=job:
                                       health.failure_status(r, ctx, a, j.t0, j.t1))
                    status = self._status_of(self._ctx())
                    self._busy = None
                self.get_logger().error(f"isolation of window t = {job.t0:g}..{job.t1:g} s failed: {reason}")
                self._publish_status(status)
                with self._results_cv:
                    self.failures.append(reason)
                    self._results_cv.notify_all()
                continue
            with self._lock:
                k_true = self._truth_for(job.t0, job.t1)
                a = health.assess(res.k, self.settings.thresholds, k_true=k_true, fitness=res.fitness,
                                  evaluations=res.evaluations, elapsed_s=res.wall_s,
                                  window_t0=job.t0, window_t1=job.t1)
                self.counters["windows_done"] += 1
                self._last_assessment = a
                self._status_of = lambda ctx, a=a: health.result_status(a, ctx)
                status = self._status_of(self._ctx())
                result = a.as_dict()
                result.update(s.reported())
                result["latency_s"] = time.monotonic() - job.started
                result["counters"] = dict(self.counters)
                self._busy = None
            self._publish(self._pub_health, multiarray(a.vector(), [health.HEALTH_LABEL]))
            self._publish_status(status)
            log = self.get_logger().warning if a.level else self.get_logger().info
            pe = "" if result["percent_err"] is None else f", %err {result['percent_err']:.2f}"
            log(f"window t = {job.t0:g}..{job.t1:g} s: {a.message}; k = {np.round(a.k, 3).tolist()}{pe} "
                f"({res.evaluations} evaluations, {res.wall_s:.2f} s)")
            with self._results_cv:
                self.results.append(result)
                self._results_cv.notify_all()

    # -------------------------------------------------------------------- outputs
    def _ctx(self) -> health.StatusContext:
        return health.StatusContext(hardware_id=self.hardware_id, counters=dict(self.counters),
                                    settings=self.settings.reported())

    def _publish(self, pub: Any, msg: Any) -> None:
        try:
            pub.publish(msg)
        except Exception as exc:  # noqa: BLE001 - publishing while the context shuts down
            if self.context.ok() and not self._closed:
                self.get_logger().error(f"publish on {pub.topic_name} failed: {exc}")

    def _publish_status(self, status: health.HealthStatus, *, remember: bool = True) -> None:
        if remember:
            with self._lock:
                self._last_status = status
        msg = DiagnosticArray()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.status = [DiagnosticStatus(level=bytes([status.level]), name=status.name, message=status.message,
                                       hardware_id=status.hardware_id,
                                       values=[KeyValue(key=k, value=v) for k, v in status.values])]
        self._publish(self._pub_diag, msg)

    def _on_heartbeat(self) -> None:
        """Republish the current status (or 'isolating…' while busy) so nothing goes stale."""
        with self._lock:
            ctx = self._ctx()
            job = self._busy
            if job is not None:
                status = health.busy_status(self._last_status, self._last_assessment, ctx, window_t0=job.t0,
                                            window_t1=job.t1, evaluations=self._progress)
            else:
                status = self._status_of(ctx)
        self._publish_status(status, remember=job is None)

    @property
    def busy(self) -> bool:
        return self._busy is not None

    @property
    def last_status(self) -> health.HealthStatus | None:
        return self._last_status

    def wait_for_results(self, n: int = 1, timeout: float | None = None, *,
                         failures: int | None = None) -> list[dict[str, Any]]:
        """Block until at least n health results exist (or `failures` isolations failed, or
        timeout); return the results so far."""
        def done() -> bool:
            return len(self.results) >= n or (failures is not None and len(self.failures) >= failures)
        with self._results_cv:
            self._results_cv.wait_for(done, timeout)
            return list(self.results)

    def close(self) -> None:
        """Cancel a running isolation, stop the worker and finish the bag (idempotent)."""
        if self._closed:
            return
        self._cancel.set()
        self._jobs.put(None)
        if self._worker is not threading.current_thread():
            self._worker.join(timeout=30.0)
        self._closed = True
        rec, self._recorder = self._recorder, None
        if rec is not None:
            try:
                rec.close()
                self._say(f"bag {self.record_path} closed")
            except EmaPhmError as exc:
                self._say(str(exc), error=True)

    def _say(self, text: str, *, error: bool = False) -> None:
        """Log, also once the context is gone (rosout is then unavailable)."""
        if self.context.ok():
            (self.get_logger().error if error else self.get_logger().info)(text)
        else:
            print(f"[{'ERROR' if error else 'INFO'}] [{NODE_NAME}]: {text}", file=sys.stderr)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return spin_main(MonitorNode, "monitor_node", args)


if __name__ == "__main__":
    sys.exit(main())
