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
(destroy_node; SIGINT/SIGTERM through `common.spin_main`) cancels a running isolation.

A node never dies from a callback: every subscription, timer, parameter callback
and the worker catch whatever they raise, log it, count it (`callback_errors`,
`isolation_failures`) and report it as ERROR on /diagnostics with the reason;
the node keeps serving and the next result replaces that status.  (A failed
write to the recording is only logged: reporting it on /diagnostics would feed
back into the recording.)

A malformed /ema/run_info (not JSON, nested too deeply, no object, sample_rate or
samples_per_window missing, of the wrong type, NaN, infinite or outside
`ema_phm.limits`) is ignored as a whole: it is reported (ERROR "ignoring
/ema/run_info: <reason>", until the next good run_info or result), the window
being assembled keeps going on the last good run_info, and before any good one
telemetry keeps waiting in the bounded pending buffer (`PENDING_MESSAGES`
messages, `PENDING_SAMPLES` samples; the oldest go first).

A window whose isolation raises `ExcitationError` (it does not excite the
actuator enough to identify k) is not a failure: status OK "not enough excitation
... not assessed: <reason>", no k and no fault claimed, `assessed: false`,
counted in `windows_not_excited`; nothing goes out on /ema/health for it.

Staleness: when no telemetry has arrived for `stale_timeout` s (counted from
start-up before the first message), the heartbeat reports STALE "no telemetry
for N s" (`health.current_status`); fresh telemetry brings the last status back.
While an isolation runs the heartbeat says "isolating…" instead.

With `record_bag`, everything received (raw telemetry, run_info, ground truth) and
published (window, health, diagnostics) goes to a rosbag2 MCAP bag, closed on
shutdown.  Recording uses raw subscriptions, so the bag holds the bytes that were
on the wire.
"""
from __future__ import annotations

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

from ..diagnosis import health
from ..telemetry.bags import FLOAT64_MULTIARRAY, STRING, BagRecorder
from ..errors import ConfigError, EmaPhmError, ExcitationError, IsolationCancelled, WindowError
from ..physics.fault_vector import validate
from ..diagnosis.fitness import WEIGHTINGS
from ..diagnosis.isolation import DEFAULT_PRESET, PRESETS, Progress, isolate
from ..limits import LIMITS, check
from ..telemetry.window import Window
from ..telemetry.window_assembler import Completed, Discarded, WindowAssembler, parse_run_info
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
#: ... and at most this many samples (two of the longest windows allowed).
PENDING_SAMPLES = 2 * int(LIMITS["samples_per_window"].high)


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
        "stale_timeout": health.DEFAULT_STALE_TIMEOUT,
        "hardware_id": "ema_sim",
    }


_DESCRIPTIONS = {
    "preset": f"isolation preset ({', '.join(sorted(PRESETS))}); '' = ema_phm.diagnosis.isolation.DEFAULT_PRESET",
    "seed": "seed of the isolation (same seed, same window -> same k)",
    "fitness": f"fitness weighting ({', '.join(sorted(WEIGHTINGS))})",
    "max_evaluations": "evaluation budget of one isolation; 0 = the preset's own",
    "warn_threshold": "per-fault severity |k_i - nominal_i| at which the status is WARN (k7 ignored)",
    "error_threshold": "per-fault severity at which the status is ERROR (k7 ignored)",
    "record_bag": "record to this new rosbag2 (MCAP) directory; '' = off; '{stamp}' is replaced by the start time",
    "heartbeat_period": "s between /diagnostics heartbeats",
    "stale_timeout": "s without telemetry after which /diagnostics says STALE",
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
        seed = int(check("seed", v["seed"]))
        max_evaluations = int(check("max_evaluations", v["max_evaluations"]))
        return cls(preset, seed, str(v["fitness"]), max_evaluations,
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
        self.heartbeat_period = float(check("heartbeat_period", values["heartbeat_period"]))
        self.stale_timeout = float(check("stale_timeout", values["stale_timeout"]))
        self.hardware_id = str(values["hardware_id"])

        self._lock = threading.RLock()
        self._assembler: WindowAssembler | None = None
        self._pending: deque[np.ndarray] = deque()
        self._pending_samples = 0
        self._last_telemetry = time.monotonic()      # start-up counts as "last heard" for staleness
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
        self.not_excited: deque[str] = deque(maxlen=1000)           # reasons of windows not assessed
        self.faults: deque[str] = deque(maxlen=1000)                # callback errors and rejected inputs
        self._status_before_fault: Callable[[health.StatusContext], health.HealthStatus] | None = None
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
        self.create_subscription(Float64MultiArray, TELEMETRY_TOPIC,
                                 self._guarded(f"handling {TELEMETRY_TOPIC}", self._on_telemetry), TELEMETRY_QOS,
                                 raw=True, callback_group=inputs)
        self.create_subscription(String, RUN_INFO_TOPIC, self._guarded(f"handling {RUN_INFO_TOPIC}", self._on_run_info),
                                 LATCHED_QOS, raw=True, callback_group=inputs)
        self.create_subscription(Float64MultiArray, GROUND_TRUTH_TOPIC,
                                 self._guarded(f"handling {GROUND_TRUTH_TOPIC}", self._on_ground_truth), LATCHED_QOS,
                                 raw=True, callback_group=inputs)

        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._worker = threading.Thread(target=self._work, name="monitor_node-isolation", daemon=True)
        self._worker.start()
        self._status_of = lambda ctx: health.waiting_status(ctx)
        self._heartbeat = self.create_timer(self.heartbeat_period, self._guarded("heartbeat", self._on_heartbeat),
                                            callback_group=MutuallyExclusiveCallbackGroup())
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._guarded("applying parameters", self._apply_parameters))
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
        except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
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
        except Exception as exc:  # noqa: BLE001 - logged only: reporting on /diagnostics would be recorded again
            if not self._closed:
                self.get_logger().error(f"recording {topic}: {type(exc).__name__}: {exc}")

    def _recorder_cb(self, topic: str) -> Callable[[bytes], None]:
        return lambda raw: self._record(topic, raw)      # _record never raises

    # ------------------------------------------------------------ fault handling
    def _guarded(self, where: str, fn: Callable[..., None]) -> Callable[..., None]:
        """`fn` for a callback: whatever it raises is logged and reported, never propagated."""
        def run(*args: Any) -> None:
            try:
                fn(*args)
            except Exception as exc:  # noqa: BLE001 - a callback never takes the node down
                _safely(self._report_fault, where, f"{type(exc).__name__}: {exc}")
        return run

    def _report_fault(self, where: str, reason: str) -> None:
        """Count, log and publish (ERROR on /diagnostics) a fault of the monitor itself."""
        with self._lock:
            self.counters["callback_errors"] += 1
            self.faults.append(f"{where}: {reason}")
            if self._status_before_fault is None:
                self._status_before_fault = self._status_of
            last = self._last_assessment
            self._status_of = lambda ctx, w=where, r=reason, a=last: health.fault_status(w, r, ctx, a)
            status = self._status_of(self._ctx())
        self.get_logger().error(f"{where}: {reason}")
        self._publish_status(status)

    def _clear_fault(self) -> None:
        """Back to the status from before a reported fault (a good input arrived)."""
        with self._lock:
            if self._status_before_fault is not None:
                self._status_of, self._status_before_fault = self._status_before_fault, None

    # --------------------------------------------------------------------- inputs
    def _on_run_info(self, raw: bytes) -> None:
        self._record(RUN_INFO_TOPIC, raw)
        try:
            parsed = parse_run_info(deserialize_message(raw, String).data)
            asm = WindowAssembler(parsed.sample_rate, parsed.samples_per_window)
        except Exception as exc:  # noqa: BLE001 - ignored as a whole, reported
            self._report_fault(f"ignoring {RUN_INFO_TOPIC}", f"{type(exc).__name__}: {exc}")
            return
        fs, n, info = parsed.sample_rate, parsed.samples_per_window, parsed.info
        self._clear_fault()
        with self._lock:
            self.run_info = info
            if "k_true" in info:
                try:
                    since = float(info.get("k_since_t", 0.0))
                    if math.isfinite(since):
                        self._truth_history.append((since, validate(info["k_true"])))
                except (EmaPhmError, TypeError, ValueError, OverflowError):
                    pass
            old = self._assembler
            if old is not None and (old.sample_rate, old.n) == (fs, n):
                return
            if old is not None:
                self._handle(old.reset(f"run_info changed the window to {n} samples at {fs:g} Hz"))
            self._assembler = asm
            pending, self._pending, self._pending_samples = list(self._pending), deque(), 0
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
        self._last_telemetry = time.monotonic()
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
                self._buffer(rows)
                return
        self._feed(rows)

    def _buffer(self, rows: np.ndarray) -> None:
        """Keep telemetry until the first good run_info, within PENDING_MESSAGES / PENDING_SAMPLES."""
        self._pending.append(rows)
        self._pending_samples += rows.shape[0]
        while self._pending and (len(self._pending) > PENDING_MESSAGES or self._pending_samples > PENDING_SAMPLES):
            self._pending_samples -= self._pending.popleft().shape[0]

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
        """Fit queued windows until None arrives or shutdown; nothing a job raises ends the loop."""
        while True:
            job = self._jobs.get()
            if job is None:
                return
            try:
                self._fit(job)
            except IsolationCancelled:
                if self._cancel.is_set():
                    return
            except ExcitationError as exc:
                _safely(self._not_assessed, job, str(exc))
            except Exception as exc:  # noqa: BLE001 - report any failure, keep running
                _safely(self._failed, job, f"{type(exc).__name__}: {exc}")
            finally:
                with self._lock:
                    self._busy = None

    def _fit(self, job: _Job) -> None:
        s = job.settings
        res = isolate(job.window, preset=s.preset, seed=s.seed, weights=s.fitness, on_progress=self._on_progress,
                      cancel=self._cancel, max_evaluations=s.max_evaluations or None)
        with self._lock:
            k_true = self._truth_for(job.t0, job.t1)
            a = health.assess(res.k, self.settings.thresholds, k_true=k_true, fitness=res.fitness,
                              evaluations=res.evaluations, elapsed_s=res.wall_s,
                              window_t0=job.t0, window_t1=job.t1)
            self.counters["windows_done"] += 1
            self._last_assessment = a
            self._status_of = lambda ctx, a=a: health.result_status(a, ctx)
            self._status_before_fault = None
            status = self._status_of(self._ctx())
            result = a.as_dict()
            result.update(s.reported())
            result["latency_s"] = time.monotonic() - job.started
            result["counters"] = dict(self.counters)
            self._busy = None
        with self._results_cv:             # recorded first: nothing below can lose the result
            self.results.append(result)
            self._results_cv.notify_all()
        self._publish(self._pub_health, multiarray(a.vector(), [health.HEALTH_LABEL]))
        self._publish_status(status)
        pe = "" if result["percent_err"] is None else f", %err {result['percent_err']:.2f}"
        text = (f"window t = {job.t0:g}..{job.t1:g} s: {a.message}; k = {np.round(a.k, 3).tolist()}{pe} "
                f"({res.evaluations} evaluations, {res.wall_s:.2f} s)")
        # one severity per call site: rclpy refuses to change it between calls of one site
        if a.level:
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

    def _failed(self, job: _Job, reason: str) -> None:
        with self._lock:
            self.counters["isolation_failures"] += 1
            last = self._last_assessment
            self._status_of = lambda ctx, r=reason, a=last, j=job: health.failure_status(r, ctx, a, j.t0, j.t1)
            self._status_before_fault = None
            status = self._status_of(self._ctx())
            self._busy = None
        with self._results_cv:
            self.failures.append(reason)
            self._results_cv.notify_all()
        self.get_logger().error(f"isolation of window t = {job.t0:g}..{job.t1:g} s failed: {reason}")
        self._publish_status(status)

    def _not_assessed(self, job: _Job, reason: str) -> None:
        with self._lock:
            self.counters["windows_not_excited"] += 1
            self._status_of = lambda ctx, r=reason, j=job: health.not_excited_status(r, ctx, j.t0, j.t1)
            self._status_before_fault = None
            status = self._status_of(self._ctx())
            self._busy = None
        with self._results_cv:
            self.not_excited.append(reason)
            self._results_cv.notify_all()
        self.get_logger().info(f"window t = {job.t0:g}..{job.t1:g} s not assessed: {reason}")
        self._publish_status(status)

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
        """Republish the current status, 'isolating…' while busy, or STALE without recent telemetry."""
        with self._lock:
            ctx = self._ctx()
            job = self._busy
            if job is not None:
                status = health.busy_status(self._status_of(ctx), self._last_assessment, ctx, window_t0=job.t0,
                                            window_t1=job.t1, evaluations=self._progress)
            else:
                status = health.current_status(self._status_of(ctx),
                                               telemetry_age_s=time.monotonic() - self._last_telemetry,
                                               stale_timeout_s=self.stale_timeout, ctx=ctx,
                                               last=self._last_assessment)
        self._publish_status(status, remember=job is None)

    @property
    def busy(self) -> bool:
        return self._busy is not None

    @property
    def last_status(self) -> health.HealthStatus | None:
        return self._last_status

    def wait_for_results(self, n: int = 1, timeout: float | None = None, *, failures: int | None = None,
                         not_excited: int | None = None) -> list[dict[str, Any]]:
        """Block until at least n health results exist (or `failures` isolations failed, or
        `not_excited` windows were not assessed, or timeout); return the results so far."""
        def done() -> bool:
            return (len(self.results) >= n or (failures is not None and len(self.failures) >= failures)
                    or (not_excited is not None and len(self.not_excited) >= not_excited))
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
            if error:   # one severity per call site (rclpy refuses a change between calls)
                self.get_logger().error(text)
            else:
                self.get_logger().info(text)
        else:
            print(f"[{'ERROR' if error else 'INFO'}] [{NODE_NAME}]: {text}", file=sys.stderr)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


def _safely(fn: Callable[..., None], *args: Any) -> None:
    """Call a reporting function; if reporting itself fails, say so on stderr and carry on."""
    try:
        fn(*args)
    except Exception as exc:  # noqa: BLE001 - the last line of defence of a callback or the worker
        print(f"[ERROR] [{NODE_NAME}]: {getattr(fn, '__name__', fn)} failed: {type(exc).__name__}: {exc}",
              file=sys.stderr)


def main(args: list[str] | None = None) -> int:
    return spin_main(MonitorNode, "monitor_node", args)


if __name__ == "__main__":
    sys.exit(main())
