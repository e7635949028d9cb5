"""The monitor's decisions, free of rclpy: telemetry in, what to publish out.

`HealthMonitor` assembles windows (`WindowIntake`), decides which to fit (one
at a time; windows that complete while one is being fitted wait in a queue of
`queue_depth` windows, first in first out; one completing with the queue full is skipped and
counted), fits them (`run_job`, called from a worker thread), keeps the
counters, prognoses after each fitted window (`monitor.tracker`, when given one), and
decides every `/diagnostics` status, including STALE when no telemetry arrived for
`stale_timeout` s, "isolating…" while busy and "warming up" while `warm_up` runs.  Each call
returns an `Outputs`: the window to publish and fit, the health vector, the
status and the log lines, for the node to send.  All methods are thread-safe.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ..diagnosis import health
from ..diagnosis.commissioning import commission, review
from ..diagnosis.ground_truth import GroundTruth
from ..diagnosis.isolation import IsolationResult, Progress, isolate
from ..diagnosis.isolation_settings import IsolationSettings
from ..diagnosis.status_cause import StatusCause
from ..diagnosis.warm_up import warm_up
from ..domain.faults import validate
from ..domain.window import Window
from ..errors import ConfigError, EmaPhmError, ExcitationError, IsolationCancelled, WindowError
from ..limits import check
from ..physics.parameters import MonitorBelief
from ..telemetry.window_assembler import Completed, Discarded
from ..telemetry.window_intake import WindowIntake
from ..telemetry.wire import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    StreamId,
    describe_stream,
)
from .tracker import PrognosticSummary, PrognosticTracker

#: Results, failures, skipped windows and faults kept for callers (newest last).
HISTORY = 1000


@dataclass(frozen=True, eq=False)  # a job is itself: compared by identity
class Job:
    """A window to fit, with the settings current when it completed."""

    window: Window
    t0: float
    t1: float
    settings: IsolationSettings
    started: float
    matrix: np.ndarray  # the window as received (telemetry layout), for /ema/window
    stream: StreamId | None = None  # the stream it came from (None: anonymous)


@dataclass(frozen=True)
class LogLine:
    """One line for the node to log at `severity`."""

    severity: str  # debug, info, warning or error
    text: str


@dataclass
class Outputs:
    """What one input made the monitor decide to send."""

    # windows scheduled to be fitted, oldest first: each is published (/ema/window) and
    # submitted to the worker; one message can complete several windows
    jobs: list[Job] = field(default_factory=list)
    health: np.ndarray | None = None  # /ema/health vector
    assessment: health.Assessment | None = None  # ... the fit behind it (/ema/actuator_health)
    status: health.HealthStatus | None = None  # /diagnostics
    logs: list[LogLine] = field(default_factory=list)

    def log(self, severity: str, text: str) -> None:
        """Queue a log line."""
        self.logs.append(LogLine(severity, text))


class HealthMonitor:
    """Window assembly, job scheduling, health / status decisions, counters and staleness."""

    def __init__(
        self,
        settings: IsolationSettings,
        *,
        hardware_id: str,
        stale_timeout: float,
        commission_windows: int = 0,
        prognostics: PrognosticTracker | None = None,
        queue_depth: int = health.DEFAULT_QUEUE_DEPTH,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """`prognostics`: the tracker fed every fitted window (None: no prognostics).

        `queue_depth`: windows that may wait behind the running fit (>= 0).
        """
        if isinstance(queue_depth, bool) or not isinstance(queue_depth, int) or queue_depth < 0:
            raise ConfigError(f"queue_depth must be a whole number >= 0, got {queue_depth!r}")
        self.queue_depth = queue_depth
        self.settings = settings
        # without a unit file, commission from the first windows (0: use the packaged belief)
        self.commission_windows = 0 if settings.belief is not None else int(commission_windows)
        self.commissioned: MonitorBelief | None = None
        self.commissioning_report: dict[str, Any] | None = None
        #: why the monitor did not commission itself from its first windows (shown on
        #: every status as ``unit_warnings``, with the unit file's own warnings)
        self.commissioning_warnings: list[str] = []
        self._baselines: list[Window] = []
        self._track_from: np.ndarray | None = None  # the last explained fit's search row
        self.hardware_id = hardware_id
        self.stale_timeout = stale_timeout
        self._clock = clock
        self._lock = threading.RLock()
        self._results_changed = threading.Condition(self._lock)
        self._intake = WindowIntake()
        self._truth = GroundTruth()
        self._last_telemetry = clock()  # start-up counts as "last heard" for staleness
        self.counters: dict[str, int] = dict.fromkeys(health.COUNTERS, 0)
        self.discard_reasons: deque[str] = deque(maxlen=100)
        self.results: deque[dict[str, Any]] = deque(maxlen=HISTORY)  # health dicts
        self.failures: deque[str] = deque(maxlen=HISTORY)  # reasons of failed isolations
        self.not_excited: deque[str] = deque(maxlen=HISTORY)  # reasons of windows not assessed
        self.faults: deque[str] = deque(maxlen=HISTORY)  # callback errors, rejected inputs
        self._busy: Job | None = None
        self._pending: deque[Job] = deque()  # windows queued behind the running fit, oldest first
        self._dropped: set[Job] = set()  # queued jobs `fit_next_now` dropped, not yet run
        self.evaluations_so_far = 0  # of the running isolation
        self._cause = StatusCause()
        self._cause_before_fault: StatusCause | None = None
        self._last_assessment: health.Assessment | None = None
        self.last_status: health.HealthStatus | None = None
        self.tracker = prognostics
        self.warm_up_s: float | None = None  # wall time of the warm-up, once done

    # ---------------------------------------------------------------- state
    @property
    def busy(self) -> bool:
        """True while a window is being fitted."""
        return self._busy is not None

    @property
    def queued(self) -> bool:
        """True while a window waits behind the running fit."""
        return bool(self._pending)

    @property
    def prognosis(self) -> PrognosticSummary | None:
        """The latest prognostic summary (None: prognostics off)."""
        return None if self.tracker is None else self.tracker.summary

    @property
    def has_run_info(self) -> bool:
        """True once a good run_info set the window geometry."""
        return self._intake.has_geometry

    @property
    def samples_collected(self) -> int:
        """Samples of the window being assembled."""
        return self._intake.samples_collected

    @property
    def run_info(self) -> dict[str, Any]:
        """The last accepted run_info object."""
        return self._intake.run_info

    def set_settings(self, settings: IsolationSettings) -> None:
        """Use `settings` from the next window on."""
        with self._lock:
            self.settings = settings

    def _context(self) -> health.StatusContext:
        return health.StatusContext(
            hardware_id=self.hardware_id,
            counters=dict(self.counters),
            settings=self._reported_settings(),
            prognostics=self.prognosis,
            stream=self._stream_name(),
        )

    def _reported_settings(self) -> dict[str, Any]:
        """The settings, and what speaks against the belief (unit file, refused baselines)."""
        reported = self.settings.reported()
        warnings = [*self.settings.unit_warnings, *self.commissioning_warnings]
        if warnings:
            reported["unit_warnings"] = "; ".join(warnings)
        return reported

    def _stream_name(self) -> str:
        if self.counters["stream_changes"] == 0 and self._intake.stream is None:
            return ""  # an anonymous stream that never changed: nothing worth a key
        s = self._intake.stream
        return "anonymous" if s is None else str(s)

    def _decide(self, cause: StatusCause, out: Outputs) -> None:
        """Make `cause` the status and send it (a fault clears only with a good input)."""
        self._cause = cause
        out.status = self.last_status = cause.render(self._context())

    # -------------------------------------------------------------- status
    def start(self, *, warming_up: bool = False) -> Outputs:
        """The status at start-up: waiting for telemetry, or warming up (see `warm_up`)."""
        out = Outputs()
        with self._lock:
            self._decide(StatusCause("warming_up" if warming_up else "waiting"), out)
        for warning in self.settings.unit_warnings:
            out.log("warning", warning)
        return out

    def warm_up(self, cancel: threading.Event) -> Outputs:
        """Run the fit's compiled paths once (blocking; `warm_up.warm_up`), then wait.

        Staleness counts from its end.  A failed warm-up is logged and the monitor goes on
        (the first window then pays the compilation); a cancelled one returns nothing.
        """
        out = Outputs()
        s = self.settings
        try:
            took = warm_up(
                s, belief=s.belief if s.belief is not None else self.commissioned, cancel=cancel
            )
        except IsolationCancelled:
            return out
        except Exception as exc:  # noqa: BLE001 - a warm-up failure only costs time later
            detail = "no window fitted yet (warm-up failed)"
            reason = f"{type(exc).__name__}: {exc}"
            out.log("error", f"warm-up failed (the first fit pays the compilation): {reason}")
        else:
            self.warm_up_s = took
            detail = f"no window fitted yet (warmed up in {took:.2f} s)"
            out.log("info", f"warmed up in {took:.2f} s (the fit's compiled paths are loaded)")
        with self._lock:
            self._last_telemetry = self._clock()
            if self._cause.kind == "warming_up":
                self._decide(StatusCause("waiting", reason=detail), out)
        return out

    def heartbeat(self) -> Outputs:
        """The current status, 'isolating…' while busy, or STALE without recent telemetry."""
        out = Outputs()
        with self._lock:
            ctx, job = self._context(), self._busy
            current = self._cause.render(ctx)
            if self._cause.kind == "warming_up":  # no telemetry is expected yet: not stale
                out.status = self.last_status = current
                return out
            if job is not None:
                out.status = health.busy_status(
                    current,
                    self._last_assessment,
                    ctx,
                    window_t0=job.t0,
                    window_t1=job.t1,
                    evaluations=self.evaluations_so_far,
                )
                return out
            age = self._clock() - self._last_telemetry
            out.status = self.last_status = health.current_status(
                current,
                telemetry_age_s=age,
                stale_timeout_s=self.stale_timeout,
                ctx=ctx,
                last=self._last_assessment,
            )
        return out

    def fault(self, where: str, reason: str) -> Outputs:
        """A fault of the monitor itself (a callback raised, an input refused): ERROR."""
        out = Outputs()
        with self._lock:
            self.counters["callback_errors"] += 1
            self.faults.append(f"{where}: {reason}")
            if self._cause_before_fault is None:
                self._cause_before_fault = self._cause
            self._decide(StatusCause("fault", self._last_assessment, reason, where), out)
        out.log("error", f"{where}: {reason}")
        return out

    def _clear_fault(self) -> None:
        if self._cause_before_fault is not None:
            self._cause, self._cause_before_fault = self._cause_before_fault, None

    # -------------------------------------------------------------- inputs
    def on_run_info(self, text: str) -> Outputs:
        """A run_info JSON text; a malformed one is ignored as a whole and reported."""
        with self._lock:
            try:
                update = self._intake.accept_run_info(text)
            except Exception as exc:  # noqa: BLE001 - ignored as a whole, reported
                return self.fault(f"ignoring {RUN_INFO_TOPIC}", f"{type(exc).__name__}: {exc}")
            self._clear_fault()
            self._truth.note_run_info(update.run_info.info)
            out = Outputs()
            if self.tracker is not None:
                try:  # its cycle_hours, and its run identity (a new run: a new history)
                    self.tracker.note_run_info(update.run_info.info)
                except ConfigError as exc:
                    out.log("warning", f"run_info cycle_hours ignored: {exc}")
            if update.new_geometry:
                fs, n = update.run_info.sample_rate, update.run_info.samples_per_window
                out.log("info", f"windows of {n} samples at {fs:g} Hz ({n / fs:g} s)")
            self._handle(update.events, out)
        return out

    def on_ground_truth(self, values: Sequence[float] | np.ndarray) -> Outputs:
        """A ground-truth k (for percent_err); a bad one is logged and ignored."""
        out = Outputs()
        try:
            k = validate(values)
        except EmaPhmError as exc:
            out.log("error", f"ignoring {GROUND_TRUTH_TOPIC}: {exc}")
            return out
        with self._lock:
            self._truth.note_message(k)
        return out

    def on_telemetry(self, rows: np.ndarray, stream: StreamId | None = None) -> Outputs:
        """One telemetry message's n x 8 rows, from `stream` (None: anonymous).

        Telemetry of another stream than the window's (two publishers on the topic) discards
        that window and makes the status ERROR with both identities until a window is fitted.
        """
        out = Outputs()
        with self._lock:
            self._last_telemetry = self._clock()
            changes, before = self._intake.stream_changes, self._intake.stream
            events = self._intake.add_rows(rows, stream)
            if self._intake.stream_changes != changes:
                self.counters["stream_changes"] += 1
                reason = (
                    f"telemetry of {describe_stream(stream)} after {describe_stream(before)}: "
                    "two publishers on the topic, or a restarted source; the window being "
                    "assembled is discarded"
                )
                out.log("warning", f"{TELEMETRY_TOPIC}: {reason}")
                self._decide(
                    StatusCause("fault", self._last_assessment, reason, TELEMETRY_TOPIC), out
                )
            self._handle(events, out)
        return out

    def on_malformed_telemetry(self, reason: str) -> Outputs:
        """An undecodable telemetry message: the window being assembled is discarded."""
        out = Outputs()
        with self._lock:
            self._last_telemetry = self._clock()
            self._handle(
                self._intake.reject_message(f"malformed telemetry message: {reason}"), out
            )
        return out

    def _handle(self, events: list[Completed | Discarded], out: Outputs) -> None:
        for event in events:
            if isinstance(event, Discarded):
                self._discard(
                    f"window t0 = {event.t0:g} s discarded after {event.samples} samples: "
                    f"{event.reason}",
                    out,
                )
            else:
                self._schedule(event, out)

    def _discard(self, reason: str, out: Outputs) -> None:
        self.counters["windows_discarded"] += 1
        self.discard_reasons.append(reason)
        out.log("warning", reason)

    def _schedule(self, event: Completed, out: Outputs) -> None:
        """Fit the window now, or queue it behind the running fit, or skip it (queue full)."""
        if self._busy is not None and len(self._pending) >= self.queue_depth:
            self.counters["windows_skipped_busy"] += 1
            out.log(
                "info",
                f"window t = {event.t0:g}..{event.t1:g} s skipped: still isolating "
                f"t = {self._busy.t0:g}..{self._busy.t1:g} s with {len(self._pending)} "
                f"window(s) queued (queue_depth {self.queue_depth})",
            )
            return
        try:
            window = Window.from_matrix(event.data, meta=dict(self.run_info)).validated()
        except WindowError as exc:
            self._discard(f"window t = {event.t0:g}..{event.t1:g} s discarded: {exc}", out)
            return
        job = Job(
            window,
            event.t0,
            event.t1,
            self.settings,
            self._clock(),
            event.data,
            self._intake.stream,
        )
        if self._busy is None:
            self._busy = job
            self.evaluations_so_far = 0
        else:  # a tracked fit is shorter than a window: the queue drains
            self._pending.append(job)
        out.jobs.append(job)

    def _done(self, job: Job) -> None:
        """`job` ended: the oldest queued window (if any) is the one being fitted now."""
        if self._busy is job:
            self._busy = self._pending.popleft() if self._pending else None
            self.evaluations_so_far = 0
        elif job in self._pending:  # ended out of turn (e.g. cancelled): never wedge the queue
            self._pending.remove(job)

    # ----------------------------------------------------------------- jobs
    def run_job(self, job: Job, cancel: threading.Event) -> Outputs:
        """Fit `job`'s window (blocking) and decide what to report; a failed fit is reported."""
        try:
            if self._was_dropped(job):
                return Outputs()
            if self._commissioning():
                return self._baseline(job)
            return self._fitted(job, self._isolate(job, cancel))
        except IsolationCancelled:
            return Outputs()
        except ExcitationError as exc:
            return self._not_assessed(job, str(exc))
        except Exception as exc:  # noqa: BLE001 - any failure is reported; the monitor goes on
            return self._failed(job, f"{type(exc).__name__}: {exc}")
        finally:
            with self._lock:
                self._done(job)

    def _commissioning(self) -> bool:
        return self.commissioned is None and len(self._baselines) < self.commission_windows

    def _baseline(self, job: Job) -> Outputs:
        """Keep the window as a healthy baseline; commission once there are enough."""
        self._baselines.append(job.window)
        n, need = len(self._baselines), self.commission_windows
        out = Outputs()
        severity, kind = "info", "commissioning"
        if n < need:
            detail = (
                f"window t = {job.t0:g}..{job.t1:g} s kept as healthy baseline {n} of {need} "
                f"(the first windows are assumed healthy; give unit_file to skip this)"
            )
        else:
            spans = [f"window t = {w.t[0]:g}..{w.t[-1]:g} s" for w in self._baselines]
            checks, problems = review(self._baselines, spans)  # what speaks against them
            if problems:  # not silently: the packaged belief judges the windows instead
                self.commissioned = MonitorBelief.default()
                self.commissioning_report = {"refused": problems}
                self.commissioning_warnings = [f"not commissioned: {p}" for p in problems]
                severity, kind = "warning", "commissioning_refused"
                detail = (
                    f"WARN: not commissioned, later windows are judged against the packaged "
                    f"belief (give unit_file to use a commissioned unit): {'; '.join(problems)}"
                )
            else:
                res = commission(self._baselines, checks=checks)
                factors = {k: round(v, 4) for k, v in res.factors.items() if res.identifiable[k]}
                fixed = sorted(k for k, ok in res.identifiable.items() if not ok)
                self.commissioned = MonitorBelief.default().with_values(res.values)
                self.commissioning_report = {
                    "factors": res.factors,
                    "identifiable": res.identifiable,
                }
                detail = (
                    f"commissioned from {need} window(s) in {res.wall_s:.1f} s: factors "
                    f"{factors}; left at the datasheet (not pinned by these windows): "
                    f"{', '.join(fixed) or 'none'}"
                )
            self._baselines.clear()
        with self._lock:
            self._decide(StatusCause(kind, reason=detail), out)
        out.log(severity, detail)
        return out

    def _isolate(self, job: Job, cancel: threading.Event) -> IsolationResult:
        """Track from the last adequate fit, or search globally; re-search if tracking fails.

        A tracked fit that the model does not explain (a fault jumped, or the last fit was
        off) is done again with the global search on the same window.
        """
        s = job.settings
        common = s.isolate_options(
            s.belief if s.belief is not None else self.commissioned,
            cancel=cancel,
            on_progress=self._note_progress,
        )
        start = self._track_from if s.tracking else None
        self._track_from = None  # kept only if this fit is explained (below)
        res = isolate(job.window, start=start, **common)
        if start is not None and res.adequacy is not None and not res.adequacy.ok:
            self.counters["tracking_restarts"] += 1
            res = isolate(job.window, **common)
        if res.adequacy is None or res.adequacy.ok:
            self._track_from = res.row
        return res

    def _note_progress(self, progress: Progress) -> None:
        self.evaluations_so_far = progress.evaluations

    def _fitted(self, job: Job, res: IsolationResult) -> Outputs:
        out = Outputs()
        with self._lock:
            truth = self._truth.over(job.t0, job.t1)
            res = dataclasses.replace(res, k_true=None if truth is None else validate(truth))
            a = health.assess_isolation(
                res, self.settings.thresholds, window_t0=job.t0, window_t1=job.t1
            )
            self.counters["windows_done"] += 1
            self._prognose(a, job, out)
            self._last_assessment, self._cause_before_fault = a, None
            self._decide(StatusCause("result", a), out)
            result = {
                **a.as_dict(),
                **job.settings.reported(),
                "latency_s": self._clock() - job.started,
                "counters": dict(self.counters),
                "prognosis": None if self.prognosis is None else self.prognosis.as_dict(),
            }
            self._done(job)
            self.results.append(result)  # recorded first: nothing below can lose the result
            self._results_changed.notify_all()
        rul = None if self.prognosis is None else self.prognosis.health_fields()
        out.health, out.assessment = a.vector(rul), a
        pe = "" if result["percent_err"] is None else f", %err {result['percent_err']:.2f}"
        prog = "" if self.prognosis is None else f"; prognosis: {self.prognosis.headline}"
        out.log(
            "warning" if a.level else "info",
            f"window t = {job.t0:g}..{job.t1:g} s: {a.message}; "
            f"k = {np.round(a.k, 3).tolist()}{pe} "
            f"({res.evaluations} evaluations, {res.wall_s:.2f} s){prog}",
        )
        return out

    def _prognose(self, a: health.Assessment, job: Job, out: Outputs) -> None:
        """Feed the tracker; a prognostics failure is logged and the fit still reported."""
        if self.tracker is None:
            return
        try:
            self.tracker.observe(a, seed=job.settings.seed)
        except Exception as exc:  # noqa: BLE001 - the fit must not be lost to its prognosis
            out.log(
                "error",
                f"prognostics after window t = {job.t0:g}..{job.t1:g} s failed "
                f"(the last prognosis stands): {type(exc).__name__}: {exc}",
            )

    def _failed(self, job: Job, reason: str) -> Outputs:
        out = Outputs()
        with self._lock:
            self.counters["isolation_failures"] += 1
            self._cause_before_fault = None
            self._decide(
                StatusCause(
                    "failure", self._last_assessment, reason, window_t0=job.t0, window_t1=job.t1
                ),
                out,
            )
            self._done(job)
            self.failures.append(reason)
            self._results_changed.notify_all()
        out.log("error", f"isolation of window t = {job.t0:g}..{job.t1:g} s failed: {reason}")
        return out

    def _not_assessed(self, job: Job, reason: str) -> Outputs:
        out = Outputs()
        with self._lock:
            self.counters["windows_not_excited"] += 1
            self._cause_before_fault = None
            self._decide(
                StatusCause("not_excited", reason=reason, window_t0=job.t0, window_t1=job.t1), out
            )
            self._done(job)
            self.not_excited.append(reason)
            self._results_changed.notify_all()
        out.log("info", f"window t = {job.t0:g}..{job.t1:g} s not assessed: {reason}")
        return out

    def wait_for_results(
        self,
        n: int = 1,
        timeout: float | None = None,
        *,
        failures: int | None = None,
        not_excited: int | None = None,
    ) -> list[dict[str, Any]]:
        """Block until at least n health results exist; return the results so far.

        Also returns once `failures` isolations failed, `not_excited` windows were not
        assessed, or `timeout` s passed.
        """

        def done() -> bool:
            return (
                len(self.results) >= n
                or (failures is not None and len(self.failures) >= failures)
                or (not_excited is not None and len(self.not_excited) >= not_excited)
            )

        with self._results_changed:
            self._results_changed.wait_for(done, timeout)
            return list(self.results)

    # ------------------------------------------- requests (monitor_node's services)
    def reset_prognosis(self) -> Outputs:
        """Forget the prognostic history (e.g. after maintenance): the next window starts anew.

        The tracker keeps its settings (thresholds, cycle hours, horizon, alarm windows).
        ConfigError when prognostics is off.
        """
        out = Outputs()
        with self._lock:
            if self.tracker is None:
                raise ConfigError("prognostics is off: there is no prognosis to reset")
            n = self.tracker.windows
            self.tracker = _fresh_tracker(self.tracker)
            self._decide(self._cause, out)  # the status without the old prognosis
        out.log("info", f"prognosis reset: {n} window(s) of history forgotten")
        return out

    def recommission(self, windows: int) -> Outputs:
        """Commission again from the next `windows` windows fitted, assumed healthy.

        The current commissioning, the tracked fit and the prognosis are dropped (a new
        baseline changes what k means).  ConfigError with a unit file (it is the baseline)
        or a count outside [1, LIMITS commission_windows].
        """
        n = int(check("commission_windows", windows))
        if n < 1:
            raise ConfigError(f"commissioning needs at least 1 window, got {windows!r}")
        out = Outputs()
        with self._lock:
            if self.settings.belief is not None:
                raise ConfigError("a unit_file is in use: it is the commissioned baseline")
            self.commission_windows, self.commissioned = n, None
            self.commissioning_report = None
            self._baselines.clear()
            self._track_from = None
            if self.tracker is not None:
                self.tracker = _fresh_tracker(self.tracker)
            detail = (
                f"commissioning requested: the next {n} window(s) are kept as healthy "
                "baselines, then the monitor is commissioned from them"
            )
            self._decide(StatusCause("commissioning", reason=detail), out)
        out.log("info", detail)
        return out

    def fit_next_now(self) -> Outputs:
        """Drop the windows queued behind the running fit, to catch up with the stream.

        The next window to complete is then fitted as soon as the running fit ends (which
        goes on).  Each dropped window counts in windows_skipped_busy.
        """
        out = Outputs()
        with self._lock:
            dropped = list(self._pending)
            self._pending.clear()
            self._dropped.update(dropped)
            self.counters["windows_skipped_busy"] += len(dropped)
            spans = ", ".join(f"t = {j.t0:g}..{j.t1:g} s" for j in dropped) or "none"
        out.log(
            "info", f"fit the next window now: {len(dropped)} queued window(s) dropped ({spans})"
        )
        return out

    def _was_dropped(self, job: Job) -> bool:
        with self._lock:
            if job in self._dropped:
                self._dropped.discard(job)
                return True
            return False


def _fresh_tracker(old: PrognosticTracker) -> PrognosticTracker:
    """A tracker with `old`'s settings and no history."""
    new = PrognosticTracker(
        thresholds=list(old.thresholds),
        cycle_hours=None if old.follows_stream else old.cycle_hours,
        horizon_cycles=old.horizon_cycles,
        alarm_windows=old.alarm_windows,
    )
    if old.follows_stream:
        new.note_stream_cycle_hours(old.cycle_hours)
    return new
