"""One unit's work, window by window, as the live monitor does it (runs on a Dask worker).

A unit's state (`UnitState`) is its monitor: the belief (its commissioned values over the
actuator's), the fit policy that tracks from the last explained fit, and the live
`tracker.PrognosticTracker` with its history and alarm.  `diagnose_window(ref, state,
settings)` reads one window, fits it (`policy.FitPolicy.fit`: tracked, restarted when not
explained), judges it (`health.assess_isolation`) and hands it to the tracker, as
`monitor_node` does; it returns the window's `WindowResult` and the next state, leaving the
state it was given untouched (Dask may run a task twice).  `commission_unit` makes a unit's
first state from its healthy baselines; `resume_state` rebuilds a state from a store's rows.
"""

from __future__ import annotations

import copy
import functools
import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..diagnosis import health
from ..diagnosis.commissioning import commission, review
from ..domain.faults import NAMES
from ..domain.window import Window
from ..errors import EmaPhmError
from ..monitor.estimator import IsolationEstimator
from ..monitor.policy import FitPolicy, not_assessed
from ..monitor.tracker import PrognosticTracker
from ..monitor.window_rule import WindowRule, run_identity, run_sample_rate
from .catalog import WindowRef, read_recording
from .settings import DiagnosisSettings


@dataclass
class UnitState:
    """A unit's monitor between two windows (see the module docstring)."""

    unit_id: str
    belief_values: dict[str, float] | None  # commissioned belief values; None: not commissioned
    fit_policy: FitPolicy
    tracker: PrognosticTracker


def new_state(
    unit_id: str, settings: DiagnosisSettings, belief_values: Mapping[str, float] | None = None
) -> UnitState:
    """A unit's monitor before its first window."""
    return UnitState(
        unit_id,
        None if belief_values is None else {str(k): float(v) for k, v in belief_values.items()},
        FitPolicy(),
        PrognosticTracker(
            thresholds=settings.thresholds,
            cycle_hours=settings.cycle_hours,
            horizon_cycles=settings.horizon_cycles,
            alarm_windows=settings.alarm_windows,
            growth_priors=settings.growth_priors,
        ),
    )


@dataclass(frozen=True)
class Commissioned:
    """A unit's commissioning from its baselines: the values, or why there are none."""

    unit_id: str
    belief_values: dict[str, float] | None
    problem: str = ""  # why the unit was not commissioned ('' when it was)
    baselines: tuple[str, ...] = ()  # the baseline recordings' digests
    wall_s: float = math.nan
    #: what spoke against a unit commissioned anyway (`CommissioningResult.warnings`: a factor
    #: at a bound, a level measured without one to judge by, ...); not kept in the store
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class WindowResult:
    """What one window gave: JSON-ready values, stored as one row (`store.Store`)."""

    unit_id: str
    run_id: str
    cycle: int
    recording: str  # the recording's digest
    status: str  # 'counted', 'not_counted' or 'skipped' (view.WindowPoint)
    reason: str = ""
    t0: float = math.nan
    t1: float = math.nan
    fit_mode: str = ""
    level: str = ""  # the window's health level
    dominant: str = ""  # the fault with the largest severity / WARN
    message: str = ""  # the window's verdict in words
    k: list[float] | None = None
    k_interval: list[list[float]] | None = None
    k_true: list[float] | None = None
    adequacy: dict[str, Any] | None = None
    evaluations: int = 0
    wall_s: float = math.nan
    track_row: list[float] | None = None  # the row the next window is tracked from
    cycle_hours: float = math.nan  # hours per cycle the tracker used
    prognosis: dict[str, Any] | None = None  # the tracker's summary after this window
    streak: dict[str, int] = field(default_factory=dict)
    #: faults the recording could not show, held healthy by the fit: name -> why
    unseen: dict[str, str] | None = None


def _vec(a: Any) -> list[float] | None:
    return None if a is None else [float(v) for v in np.asarray(a, dtype=np.float64).ravel()]


@functools.lru_cache(maxsize=4)
def _windows_of(path: str, digest: str) -> tuple[Window, ...]:
    """A recording's windows (cached per worker: a unit's windows often share a file)."""
    return tuple(read_recording(path, digest).windows or ())


def window_of(ref: WindowRef) -> Window:
    """The window `ref` names, read from its recording."""
    windows = _windows_of(ref.path, ref.recording)
    if not 0 <= ref.index < len(windows):
        raise EmaPhmError(f"{ref.path}: no window {ref.index} (it holds {len(windows)})")
    return windows[ref.index]


def commission_unit(
    unit_id: str, baselines: Sequence[WindowRef], settings: DiagnosisSettings
) -> Commissioned:
    """Commission a unit from its healthy baseline windows, as `ema-phm calibrate --baseline`.

    A unit whose baselines speak against commissioning (not excited, looking faulty,
    disagreeing) or whose commissioned fit does not explain it is not commissioned: its
    windows are judged with the actuator's belief, and `problem` says why.  Where the
    actuator description gives no healthy level, a baseline above the stand-in is not
    refused (`commissioning.review`); that and every other warning of the commissioning is
    in `warnings`, which the ingest report lists.
    """
    _limit_threads()
    t0 = time.perf_counter()
    digests = tuple(sorted({b.recording for b in baselines}))
    try:
        windows = [window_of(b).validated() for b in baselines]
    except EmaPhmError as exc:
        why = f"baseline unreadable: {' '.join(str(exc).split())}"
        return Commissioned(unit_id, None, why, digests, time.perf_counter() - t0)
    belief = settings.belief()
    checks, problems = review(windows, [b.path for b in baselines], belief=belief)
    if not problems:
        res = commission(windows, belief=belief, checks=checks)
        problems = list(res.unexplained())
        if not problems:
            values = {str(k): float(v) for k, v in res.values.items()}
            wall = time.perf_counter() - t0
            return Commissioned(unit_id, values, "", digests, wall, tuple(res.warnings))
    return Commissioned(unit_id, None, problems[0], digests, time.perf_counter() - t0)


#: Threads one window's fit uses (numba's and BLAS's): the fleet's parallelism is across units.
THREADS_PER_FIT = 1


def _limit_threads() -> None:
    """One window's fit on `THREADS_PER_FIT` numba threads and as many BLAS threads.

    The BLAS thread count changes the last bits of its sums, and a search amplifies them: a
    window fitted with 2 BLAS threads differs from the same fit with 1.  Fixing both makes a
    result independent of where it ran (this process, an embedded worker, a remote one).
    """
    import numba  # noqa: PLC0415  (numba is loaded by the fit anyway)
    from threadpoolctl import threadpool_limits  # noqa: PLC0415

    numba.set_num_threads(THREADS_PER_FIT)
    threadpool_limits(limits=THREADS_PER_FIT, user_api="blas")


def diagnose_window(
    ref: WindowRef, state: UnitState | Commissioned | tuple[Any, Any], settings: DiagnosisSettings
) -> tuple[WindowResult, UnitState]:
    """Fit, judge and track one window from `state` (a previous task's output is accepted)."""
    _limit_threads()
    state = _as_state(state, settings)
    state = copy.deepcopy(state)  # the given state stays as it was: a retry starts from it
    try:
        window = window_of(ref)
    except EmaPhmError as exc:  # the catalog read its run_info only; the window is lost
        ident = {"unit_id": ref.unit_id, "run_id": ref.run_id, "cycle": ref.cycle}
        unread = {**ident, "recording": ref.recording}
        reason = f"recording unreadable: {' '.join(str(exc).split())}"
        return _skipped(unread, reason, state), state
    duration = float(window.t[-1] - window.t[0])
    base = {
        "unit_id": ref.unit_id,
        "run_id": ref.run_id,
        "cycle": ref.cycle,
        "recording": ref.recording,
        # on the unit's cycle clock, as a live stream times its windows (tracker.cycle_of):
        # a recording of one flight starts at its own t = 0
        "t0": ref.cycle * duration,
        "t1": (ref.cycle + 1) * duration,
        "k_true": _vec(window.k_true),
    }
    why = WindowRule.fit_problem(window, run_sample_rate(window.meta))
    if why:  # not fitted: the next window is tracked as before
        return _skipped(base, why, state), state
    belief = settings.belief()
    if state.belief_values is not None:
        belief = belief.commissioned_with(state.belief_values)
    estimator = IsolationEstimator(settings.isolate_options(belief))
    try:
        fit = state.fit_policy.fit(window, estimator)
    except EmaPhmError as exc:  # the policy leaves nothing to track from
        return _skipped(base, not_assessed(exc), state), state
    except Exception as exc:  # noqa: BLE001  (as monitor_node: a failed fit, not a dead unit)
        return _skipped(base, f"failed: {type(exc).__name__}: {exc}", state), state
    return _judged(base, fit, window, state, settings)


def _skipped(base: dict[str, Any], reason: str, state: UnitState) -> WindowResult:
    """A window not fitted or not judged, and the row the next one is tracked from."""
    track_row = _vec(state.fit_policy.tracking_row)
    return WindowResult(status="skipped", reason=reason, track_row=track_row, **base)


def _judged(
    base: dict[str, Any],
    fit: Any,
    window: Window,
    state: UnitState,
    settings: DiagnosisSettings,
) -> tuple[WindowResult, UnitState]:
    """The fitted window assessed and handed to the tracker, as the live monitor does."""
    res = fit.result
    spent = [res] if fit.tracked_attempt is None else [fit.tracked_attempt, res]
    a = health.assess_isolation(res, window_t0=base["t0"], window_t1=base["t1"])
    try:
        state.tracker.note_run_info(window.meta)  # the run (a new one: a new life), its hours
    except EmaPhmError:  # a bad cycle_hours is ignored, as monitor_node does; the run counts
        state.tracker.run = run_identity(window.meta)
    before = state.tracker.not_counted
    try:
        summary = state.tracker.observe(a, seed=settings.seed)
    except Exception as exc:  # noqa: BLE001  (as monitor_node: the fit stands, no prognosis)
        return _skipped(base, f"prognosis failed: {type(exc).__name__}: {exc}", state), state
    counted = state.tracker.not_counted == before
    return WindowResult(
        status="counted" if counted else "not_counted",
        reason="" if counted else summary.last_skipped,
        fit_mode=fit.mode,
        level=health.LEVEL_NAMES[a.level],
        dominant=NAMES[a.dominant],
        message=a.message,
        k=_vec(a.k),
        k_interval=None if a.k_interval is None else np.asarray(a.k_interval).tolist(),
        adequacy=None if a.adequacy is None else dict(a.adequacy),
        evaluations=sum(int(r.evaluations) for r in spent),
        wall_s=sum(float(r.wall_s) for r in spent),
        track_row=_vec(state.fit_policy.tracking_row),
        cycle_hours=state.tracker.cycle_hours,
        prognosis=summary.as_dict(),
        streak=state.tracker.streak,
        unseen={NAMES[i]: why for i, why in sorted(a.unseen.items())} or None,
        **base,
    ), state


def _as_state(
    state: UnitState | Commissioned | tuple[Any, Any], settings: DiagnosisSettings
) -> UnitState:
    """The state a task was handed: a state, a commissioning, or a previous task's output."""
    if isinstance(state, tuple):
        state = state[1]
    if isinstance(state, Commissioned):
        return new_state(state.unit_id, settings, state.belief_values)
    assert isinstance(state, UnitState), type(state)
    return state


@dataclass(frozen=True)
class _Fitted:
    """A stored fitted window as the tracker reads an assessment."""

    k: np.ndarray
    k_interval: np.ndarray | None
    adequacy: Mapping[str, Any] | None
    window_t0: float
    window_t1: float
    unseen: Mapping[int, str]


def resume_state(
    unit_id: str,
    settings: DiagnosisSettings,
    belief_values: Mapping[str, float] | None,
    rows: Sequence[Mapping[str, Any]],
) -> UnitState:
    """The state after a unit's stored windows (`rows`, in the order they were diagnosed).

    The tracker counts every fitted window again (`PrognosticTracker.resume`) and the next
    window is tracked from the last stored row's `track_row`: the state is the one the
    uninterrupted run had (stored floats round-trip exactly).
    """
    state = new_state(unit_id, settings, belief_values)
    if not rows:
        return state
    fitted = []
    for r in rows:
        if r["status"] == "skipped":
            continue
        iv = None if r["k_interval"] is None else np.asarray(r["k_interval"], dtype=np.float64)
        unseen = {NAMES.index(name): why for name, why in (r.get("unseen") or {}).items()}
        k = np.asarray(r["k"], dtype=np.float64)
        item = _Fitted(k, iv, r["adequacy"], r["t0"], r["t1"], unseen)
        fitted.append(((str(r["unit_id"]), str(r["run_id"])), item))
    if fitted:
        last_fitted = next(r for r in reversed(rows) if r["status"] != "skipped")
        counted = [r for r in rows if r["status"] == "counted"]
        # the last prognosis was made with the hours of the last counted window's time
        hours = counted[-1]["cycle_hours"] if counted else last_fitted["cycle_hours"]
        state.tracker.note_stream_cycle_hours(hours)
        state.tracker.resume(fitted, last_fitted["streak"] or {}, seed=settings.seed)
        state.tracker.note_stream_cycle_hours(last_fitted["cycle_hours"])
    row = rows[-1]["track_row"]
    state.fit_policy.track_from(None if row is None else np.asarray(row, dtype=np.float64))
    return state
