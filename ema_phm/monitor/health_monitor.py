"""The monitor's decisions, free of rclpy: telemetry in, what to publish out.

`HealthMonitor` assembles windows (`WindowIntake`), decides which to fit (one at a time; windows
that complete while one is being fitted wait in a `job_queue.JobQueue` of `queue_depth`
windows, first in first out; one completing with the queue full is skipped and counted),
fits them (`run_job`, called from a worker thread) by the monitor's policy
(`policy.FitPolicy`: tracked from the last explained fit, searched again when that fit is
not explained), commissions itself from its first windows when it has no unit file
(`commissioning_guard`), keeps the counters and what callers read (`result_log`), prognoses
after each fitted window (`monitor.tracker`, when given one), and decides every
`/diagnostics` status, including STALE when no telemetry arrived for `stale_timeout` s,
"isolating…" while busy and "warming up" while `warm_up` runs.  Each call returns an
`Outputs`: the windows to publish and fit, the health vector, the status and the log lines,
for the node to send.

Threads: the node calls the inputs (`on_*`), `heartbeat`, `fault` and the requests
(`reset_prognosis`, `recommission`, `fit_next_now`) from its executor, and `run_job` /
`warm_up` from one worker thread at a time.  Each takes the monitor's lock around the state
it changes, except the blocking parts of `run_job` and `warm_up`: the fit, the warm-up and
the commissioning run without it, and so do their writes of the tracked start
(`FitPolicy.fit`), the baselines (`CommissioningGuard.keep`), ``tracking_restarts`` and the
progress count.  A `recommission` during such a fit is not atomic with it: the running fit
may still leave a start to track from, and a baseline being kept may be lost or count
toward the new commissioning.  The read-only properties (`busy`, `queued`, `prognosis`, ...)
read without the lock.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from typing import Any, Callable

import numpy as np

from ..diagnosis import health
from ..diagnosis.isolation import IsolationResult, Progress, isolate
from ..diagnosis.isolation_settings import IsolationSettings
from ..diagnosis.warm_up import warm_up
from ..domain.faults import validate
from ..errors import ConfigError, ExcitationError, IsolationCancelled
from ..limits import check
from ..model.belief import MonitorBelief
from ..telemetry.window_assembler import RunInfo
from ..telemetry.window_intake import rule_of
from ..telemetry.wire import (
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    StreamId,
    describe_stream,
)
from . import status_texts
from .estimator import IsolationEstimator
from .job_queue import Job
from .outputs import LogLine, Outputs
from .state import MonitorState, TruthLookup
from .status_cause import StatusCause
from .tracker import PrognosticSummary, PrognosticTracker

__all__ = ["HealthMonitor", "Job", "LogLine", "Outputs"]


#: What the status says of telemetry from another unit than the monitor's `hardware_id`.
OTHER_UNIT = "not the unit this monitor watches, hardware_id"


class WindowFitter:
    """The worker's side: fits a job's window by the policy (or keeps it as a baseline)."""

    def __init__(self, state: MonitorState) -> None:
        """Act on the monitor's `state`."""
        self.s = state

    def run(self, job: Job, cancel: threading.Event) -> Outputs:
        """Fit `job`'s window (blocking) and decide what to report; a failed fit is reported."""
        try:
            with self.s.lock:
                if self.s.windows.jobs.take_dropped(job):
                    return Outputs()
            if self.s.guard.active:
                return self._baseline(job)
            return self._fitted(job, self._isolate(job, cancel))
        except IsolationCancelled:
            return Outputs()
        except ExcitationError as exc:
            return self._ended(job, "not_excited", str(exc))
        except Exception as exc:  # noqa: BLE001 - any failure is reported; the monitor goes on
            return self._ended(job, "failure", f"{type(exc).__name__}: {exc}")
        finally:
            with self.s.lock:
                self.s.windows.jobs.done(job)

    def skip(self, job: Job, why: str) -> Outputs:
        """Leave `job`'s window unfitted because `why` (counted in windows_skipped_busy)."""
        out = Outputs()
        with self.s.lock:
            self.s.counters["windows_skipped_busy"] += 1
            self.s.windows.jobs.done(job)
        out.log("info", f"window t = {job.t0:g}..{job.t1:g} s skipped: {why}")
        return out

    def _baseline(self, job: Job) -> Outputs:
        """Keep the window as a healthy baseline; commission once there are enough."""
        kept = self.s.guard.keep(job.window, job.t0, job.t1, job.settings.belief)
        out = Outputs()
        with self.s.lock:
            self.s.board.decide(StatusCause(kept.kind, reason=kept.detail), out)
        out.log(kept.severity, kept.detail)
        return out

    def _isolate(self, job: Job, cancel: threading.Event) -> IsolationResult:
        """Fit by the policy: tracked from the last explained fit, searched again if need be."""
        s = job.settings
        options = s.isolate_options(
            self.s.guard.belief(s), cancel=cancel, on_progress=self._note_progress
        )
        # `isolate` is read here, at the call: a test may have replaced it in this module
        fit = self.s.policy.fit(
            job.window, IsolationEstimator(options, isolate), tracking=s.tracking
        )
        if fit.mode == "restarted":
            self.s.counters["tracking_restarts"] += 1
        return fit.result

    def _note_progress(self, progress: Progress) -> None:
        self.s.windows.jobs.evaluations = progress.evaluations

    def _fitted(self, job: Job, res: IsolationResult) -> Outputs:
        out = Outputs()
        with self.s.lock:
            truth = None if self.s.truth is None else self.s.truth(job.t0, job.t1)
            res = dataclasses.replace(res, k_true=None if truth is None else validate(truth))
            a = health.assess_isolation(
                res, self.s.settings.thresholds, window_t0=job.t0, window_t1=job.t1
            )
            a = dataclasses.replace(a, cycle=job.cycle)
            self.s.counters["windows_done"] += 1
            self._prognose(a, job, out)
            self.s.board.window_ended(StatusCause("result", a), out)
            result = {
                **a.as_dict(),
                **job.settings.reported(),
                "latency_s": self.s.clock() - job.started,
                "counters": dict(self.s.counters),
                "prognosis": None if self.s.prognosis is None else self.s.prognosis.as_dict(),
            }
            self.s.windows.jobs.done(job)
            log = self.s.result_log
            log.results.append(result)  # recorded first: nothing below can lose the result
            log.notify()
            summary = self.s.prognosis  # the one stored with the result (a reset may follow)
        rul = None if summary is None else summary.health_fields()
        out.health, out.assessment = a.vector(rul), a
        pe = "" if result["percent_err"] is None else f", %err {result['percent_err']:.2f}"
        prog = "" if summary is None else f"; prognosis: {summary.headline}"
        out.log(
            "warning" if a.level else "info",
            f"window t = {job.t0:g}..{job.t1:g} s: {a.message}; "
            f"k = {np.round(a.k, 3).tolist()}{pe} "
            f"({res.evaluations} evaluations, {res.wall_s:.2f} s){prog}",
        )
        return out

    def _prognose(self, a: health.Assessment, job: Job, out: Outputs) -> None:
        """Feed the tracker; a prognostics failure is logged and the fit still reported."""
        if self.s.tracker is None:
            return
        try:
            self.s.tracker.observe(a, seed=job.settings.seed)
        except Exception as exc:  # noqa: BLE001 - the fit must not be lost to its prognosis
            out.log(
                "error",
                f"prognostics after window t = {job.t0:g}..{job.t1:g} s failed "
                f"(the last prognosis stands): {type(exc).__name__}: {exc}",
            )

    def _ended(self, job: Job, kind: str, reason: str) -> Outputs:
        """`job`'s isolation failed (`kind` failure) or its window was not assessed."""
        out = Outputs()
        failed = kind == "failure"
        with self.s.lock:
            self.s.counters["isolation_failures" if failed else "windows_not_excited"] += 1
            shown = self.s.board.last_assessment if failed else None
            self.s.board.window_ended(StatusCause(kind, shown, reason, "", job.t0, job.t1), out)
            self.s.windows.jobs.done(job)
            log = self.s.result_log
            (log.failures if failed else log.not_excited).append(reason)
            log.notify()
        span = f"window t = {job.t0:g}..{job.t1:g} s"
        if failed:
            out.log("error", f"isolation of {span} failed: {reason}")
        else:
            out.log("info", f"{span} not assessed: {reason}")
        return out


class MonitorView:
    """What a HealthMonitor shows of its state (read only; its parts are `MonitorState`'s)."""

    s: MonitorState

    @property
    def settings(self) -> IsolationSettings:
        """The isolation settings of the next window."""
        return self.s.settings

    @property
    def tracker(self) -> PrognosticTracker | None:
        """The prognostic tracker (None: prognostics off)."""
        return self.s.tracker

    @property
    def busy(self) -> bool:
        """True while a window is being fitted."""
        return self.s.windows.jobs.running is not None

    @property
    def queued(self) -> bool:
        """True while a window waits behind the running fit."""
        return bool(self.s.windows.jobs.pending)

    @property
    def evaluations_so_far(self) -> int:
        """Evaluations of the running isolation so far."""
        return self.s.windows.jobs.evaluations

    @property
    def last_status(self) -> status_texts.HealthStatus | None:
        """The last status decided (on /diagnostics)."""
        return self.s.board.last_status

    @property
    def prognosis(self) -> PrognosticSummary | None:
        """The latest prognostic summary (None: prognostics off)."""
        return self.s.prognosis

    @property
    def commission_windows(self) -> int:
        """Windows the monitor commissions itself from (0: it does not)."""
        return self.s.guard.windows

    @property
    def commissioned(self) -> MonitorBelief | None:
        """The belief commissioned from the first windows (None: not, or not yet)."""
        return self.s.guard.commissioned

    @property
    def has_run_info(self) -> bool:
        """True once a good run_info set the window geometry."""
        return self.s.windows.intake.has_geometry

    @property
    def samples_collected(self) -> int:
        """Samples of the window being assembled."""
        return self.s.windows.intake.samples_collected

    @property
    def run_info(self) -> dict[str, Any]:
        """The last accepted run_info object."""
        return self.s.windows.intake.run_info


class HealthMonitor(MonitorView):
    """Window assembly, job scheduling, health / status decisions, counters and staleness."""

    def __init__(
        self,
        settings: IsolationSettings,
        *,
        hardware_id: str,
        stale_timeout: float,
        commission_windows: int = 0,
        prognostics: PrognosticTracker | None = None,
        queue_depth: int = status_texts.DEFAULT_QUEUE_DEPTH,
        clock: Callable[[], float] = time.monotonic,
        truth: TruthLookup | None = None,
    ) -> None:
        """`prognostics`: the tracker fed every fitted window (None: no prognostics).

        `truth`: the true k over a window, asked after each fit for %err only (an evaluation
        listener's `LiveTruth.over`; None: no truth, as on a real actuator).

        `queue_depth`: windows that may wait behind the running fit (>= 0).
        """
        self.s = MonitorState(  # what the monitor's parts share; its lock guards it
            settings,
            hardware_id=hardware_id,
            commission_windows=commission_windows,
            tracker=prognostics,
            queue_depth=queue_depth,
            clock=clock,
            truth=truth,
        )
        self.stale_timeout, self.queue_depth = stale_timeout, queue_depth
        self.hardware_id = hardware_id
        self._lock, self.counters, self._clock = self.s.lock, self.s.counters, clock
        self.windows, self.jobs, self.board = self.s.windows, self.s.windows.jobs, self.s.board
        self.guard, self.policy, self.result_log = self.s.guard, self.s.policy, self.s.result_log
        self.results, self.failures = self.result_log.results, self.result_log.failures
        self.not_excited, self.faults = self.result_log.not_excited, self.result_log.faults
        self.discard_reasons = self.result_log.discard_reasons
        self.wait_for_results = self.result_log.wait  # blocks until n results exist
        self.fitter = WindowFitter(self.s)
        self.warm_up_s: float | None = None  # wall time of the warm-up, once done

    def set_settings(self, settings: IsolationSettings) -> None:
        """Use `settings` from the next window on."""
        with self._lock:
            self.s.settings = settings

    # -------------------------------------------------------------- status
    def start(self, *, warming_up: bool = False) -> Outputs:
        """The status at start-up: waiting for telemetry, or warming up (see `warm_up`)."""
        out = Outputs()
        with self._lock:
            self.board.decide(StatusCause("warming_up" if warming_up else "waiting"), out)
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
            took = warm_up(s, belief=self.guard.belief(s), cancel=cancel)
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
            self.windows.heard()
            if self.board.cause.kind == "warming_up":
                self.board.decide(StatusCause("waiting", reason=detail), out)
        return out

    def heartbeat(self) -> Outputs:
        """The current status, 'isolating…' while busy, or STALE without recent telemetry."""
        out = Outputs()
        with self._lock:
            age = self._clock() - self.windows.last_telemetry
            self.board.heartbeat(
                out, self.jobs.running, self.jobs.evaluations, age, self.stale_timeout
            )
        return out

    def fault(self, where: str, reason: str) -> Outputs:
        """A fault of the monitor itself (a callback raised, an input refused): ERROR."""
        out = Outputs()
        with self._lock:
            self.counters["callback_errors"] += 1
            self.faults.append(f"{where}: {reason}")
            self.board.fault(where, reason, out)
        out.log("error", f"{where}: {reason}")
        return out

    # -------------------------------------------------------------- inputs
    def on_run_info(self, text: str) -> Outputs:
        """A run_info JSON text; a malformed one is ignored as a whole and reported."""
        with self._lock:
            try:
                update = self.windows.intake.accept_run_info(text)
            except Exception as exc:  # noqa: BLE001 - ignored as a whole, reported
                return self.fault(f"ignoring {RUN_INFO_TOPIC}", f"{type(exc).__name__}: {exc}")
            self.board.clear_fault()
            out = Outputs()
            if self.tracker is not None:
                try:  # its cycle_hours, and its run identity (a new run: a new history)
                    self.tracker.note_run_info(update.run_info.info)
                except ConfigError as exc:
                    out.log("warning", f"run_info cycle_hours ignored: {exc}")
            if update.new_geometry:
                out.log("info", _windows_line(update.run_info))
            self.windows.handle(update.events, self.settings, out)
        return out

    def on_telemetry(self, rows: np.ndarray, stream: StreamId | None = None) -> Outputs:
        """One telemetry message's samples from `stream` (None: anonymous).

        `rows`: n samples x len(`window.CHANNELS`) columns in that order (t, command, ...),
        as `wire.decode_telemetry` gives them.  Telemetry of another stream than the
        window's (two publishers on the topic) discards that window and makes the status
        ERROR with both identities until a window is fitted.  Telemetry of another unit than
        this monitor's `hardware_id` is not judged (`_other_unit`).
        """
        out = Outputs()
        with self._lock:
            if stream is not None and stream.hardware_id != self.hardware_id:
                self._other_unit(stream, out)
                return out
            if self.board.cause.where == TELEMETRY_TOPIC and OTHER_UNIT in self.board.cause.reason:
                self.board.clear_fault()  # this unit's telemetry again
            events, changed = self.windows.take_rows(rows, stream)
            if changed:
                out.log("warning", f"{TELEMETRY_TOPIC}: {changed}")
                cause = StatusCause("fault", self.board.last_assessment, changed, TELEMETRY_TOPIC)
                self.board.decide(cause, out)
            self.windows.handle(events, self.settings, out)
        return out

    def on_window_marked(
        self, start_s: float, end_s: float, stream: StreamId | None = None
    ) -> Outputs:
        """A window [start_s, end_s] of `stream`'s rows, marked (a map's ``marker`` rule, live).

        Scheduled as soon as its rows are in (`telemetry.listed_assembler`); ignored unless
        the run_info's windows are by marker or times.
        """
        out = Outputs()
        with self._lock:
            if stream is not None and stream.hardware_id != self.hardware_id:
                return out
            events = self.windows.intake.mark(start_s, end_s, stream)
            self.windows.handle(events, self.settings, out)
        return out

    def _other_unit(self, stream: StreamId, out: Outputs) -> None:
        """Telemetry of another unit: counted, not judged, ERROR naming both (logged once).

        The belief, the commissioning and the prognostic history are this unit's; another
        unit's windows judged against them would read its differences as faults.
        """
        self.windows.heard()  # telemetry arrives: not STALE
        self.counters["telemetry_other_unit"] += 1
        reason = (
            f"{describe_stream(stream)} is {OTHER_UNIT} {self.hardware_id!r} (parameter "
            "hardware_id): its telemetry is not judged; set hardware_id to the unit's, or "
            "remap the topic"
        )
        if self.board.cause.reason != reason:
            out.log("error", f"{TELEMETRY_TOPIC}: {reason}")
            self.board.fault(TELEMETRY_TOPIC, reason, out)

    def on_malformed_telemetry(self, reason: str) -> Outputs:
        """An undecodable telemetry message: the window being assembled is discarded."""
        out = Outputs()
        with self._lock:
            self.windows.heard()
            events = self.windows.intake.reject_message(f"malformed telemetry message: {reason}")
            self.windows.handle(events, self.settings, out)
        return out

    def run_job(self, job: Job, cancel: threading.Event) -> Outputs:
        """Fit `job`'s window (blocking) and decide what to report; a failed fit is reported."""
        return self.fitter.run(job, cancel)

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
            self.s.tracker = self.tracker.fresh()
            self.board.decide(self.board.cause, out)  # the status without the old prognosis
        out.log("info", f"prognosis reset: {n} window(s) of history forgotten")
        return out

    def recommission(self, windows: int) -> Outputs:
        """Commission again from the next `windows` windows fitted, assumed healthy.

        The current commissioning, the tracked fit and the prognosis are dropped (a new
        baseline changes what k means).  Commissioned against the settings' belief (an
        actuator file's, else the packaged one).  ConfigError with a unit file (it is the
        baseline) or a count outside [1, LIMITS commission_windows].
        """
        n = int(check("commission_windows", windows))
        if n < 1:
            raise ConfigError(f"commissioning needs at least 1 window, got {windows!r}")
        out = Outputs()
        with self._lock:
            if self.settings.unit_file:
                raise ConfigError("a unit_file is in use: it is the commissioned baseline")
            self.guard.restart(n)
            self.policy.forget_track()
            if self.tracker is not None:
                self.s.tracker = self.tracker.fresh()
            detail = (
                f"commissioning requested: the next {n} window(s) are kept as healthy "
                "baselines, then the monitor is commissioned from them"
            )
            self.board.decide(StatusCause("commissioning", reason=detail), out)
        out.log("info", detail)
        return out

    def fit_next_now(self) -> Outputs:
        """Drop the windows queued behind the running fit, to catch up with the stream.

        The next window to complete is then fitted as soon as the running fit ends (which
        goes on).  Each dropped window counts in windows_skipped_busy.
        """
        out = Outputs()
        with self._lock:
            dropped = self.jobs.drop_pending()
            self.counters["windows_skipped_busy"] += len(dropped)
            spans = ", ".join(f"t = {j.t0:g}..{j.t1:g} s" for j in dropped) or "none"
        out.log(
            "info", f"fit the next window now: {len(dropped)} queued window(s) dropped ({spans})"
        )
        return out


def _windows_line(info: RunInfo) -> str:
    """How the windows of a run_info are cut (its geometry was checked)."""
    fs, n = info.sample_rate, info.samples_per_window
    rule = rule_of(info)
    if rule is None:
        return f"windows of {n} samples at {fs:g} Hz ({n / fs:g} s)"
    spec = rule.as_info()
    return f"windows by {spec['by']} {spec}, at most {n / fs:g} s, at {fs:g} Hz"
