"""HealthMonitor without a node: windows scheduled, statuses decided, counters kept."""

from __future__ import annotations

import itertools
import json
import threading
import time

import numpy as np
import pytest
from helpers import growing_isolate

from ema_phm.diagnosis import health
from ema_phm.diagnosis.isolation import IsolationResult
from ema_phm.diagnosis.isolation_settings import IsolationSettings
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import ConfigError, ExcitationError
from ema_phm.evaluation.live_truth import LiveTruth
from ema_phm.monitor import commissioning_guard, health_monitor
from ema_phm.monitor.health_monitor import HealthMonitor
from ema_phm.simulator.real_ema import HFStream

FS, N = 2000.0, 200
RUN_INFO = json.dumps(
    {"sample_rate": FS, "samples_per_window": N, "k_true": NOMINAL.tolist(), "k_since_t": 0.0}
)


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture(scope="module")
def rows():
    return HFStream(NOMINAL).advance(2 * N + 1)


def make(clock=None, **kwargs) -> HealthMonitor:
    return HealthMonitor(
        IsolationSettings(), hardware_id="hw", stale_timeout=5.0, clock=clock or Clock(), **kwargs
    )


def test_starts_waiting_and_buffers_telemetry_until_run_info(rows):
    mon = make()
    assert mon.start().status.message.startswith("waiting for telemetry")
    assert mon.on_telemetry(rows[: N + 1]).jobs == [] and not mon.has_run_info
    out = mon.on_run_info(RUN_INFO)
    assert len(out.jobs) == 1 and out.jobs[0].matrix.shape == (N + 1, len(CHANNELS)) and mon.busy
    assert out.logs[0].text == "windows of 200 samples at 2000 Hz (0.1 s)"


@pytest.mark.parametrize("depth", [0, 1, 3])
def test_windows_wait_behind_the_running_fit_up_to_the_queue_depth(depth):
    windows = depth + 2  # the running one, `depth` queued, one skipped
    rows = HFStream(NOMINAL).advance(windows * N + 1)
    mon = make(queue_depth=depth)
    mon.on_run_info(RUN_INFO)
    jobs = [mon.on_telemetry(rows[: N + 1]).jobs[0]]
    for w in range(1, windows - 1):
        jobs.append(mon.on_telemetry(rows[w * N + 1 : (w + 1) * N + 1]).jobs[0])
    assert all(j is not None for j in jobs) and len(jobs) == depth + 1
    out = mon.on_telemetry(rows[(windows - 1) * N + 1 :])
    assert (
        out.jobs == []
        and mon.counters["windows_skipped_busy"] == 1
        and "skipped" in out.logs[0].text
        and f"{depth} window(s) queued" in out.logs[0].text
    )
    # each fit that ends hands over to the oldest queued window, in order
    for done, following in itertools.pairwise(jobs):
        assert mon.busy and mon.jobs.running is done
        with mon._lock:
            mon.jobs.done(done)
        assert mon.jobs.running is following
    with mon._lock:
        mon.jobs.done(jobs[-1])
    assert not mon.busy and not mon.queued


@pytest.mark.parametrize("depth", [-1, 1.5, True])
def test_bad_queue_depth_names_the_value(depth):
    with pytest.raises(ConfigError, match=f"queue_depth .*{depth!r}"):
        make(queue_depth=depth)


def test_bad_run_info_is_an_error_until_a_good_one(rows):
    mon = make()
    mon.start()
    out = mon.on_run_info("not json")
    assert out.status.level == health.ERROR and "ignoring /ema/run_info" in out.status.message
    assert mon.counters["callback_errors"] == 1 and not mon.has_run_info
    mon.on_run_info(RUN_INFO)
    assert mon.heartbeat().status.message.startswith("waiting for telemetry")


def test_stale_without_telemetry_and_back():
    clock = Clock()
    mon = make(clock)
    mon.start()
    clock.now = 5.5
    assert mon.heartbeat().status.level == health.STALE
    mon.on_telemetry(np.empty((0, len(CHANNELS))))
    assert mon.heartbeat().status.level == health.OK


def _job(mon, rows):
    mon.on_run_info(RUN_INFO)
    return mon.on_telemetry(rows[: N + 1]).jobs[0]


def fit_always(monkeypatch, k) -> None:
    """Every isolation returns `k` (no intervals, no adequacy test)."""
    monkeypatch.setattr(
        health_monitor,
        "isolate",
        lambda *a, **kw: IsolationResult(
            k=k, fitness=0.1, evaluations=10, wall_s=0.5, preset="de", seed=0
        ),
    )


def test_a_fitted_window_gives_health_and_status(rows, monkeypatch):
    k = NOMINAL.copy()
    k[0] = 0.5
    fit_always(monkeypatch, k)
    truth = LiveTruth()  # the evaluation listener beside the monitor
    mon = make(truth=truth.over)
    truth.note_run_info_text(RUN_INFO)
    out = mon.run_job(_job(mon, rows), threading.Event())
    assert not mon.busy and mon.counters["windows_done"] == 1
    assert (
        out.status.level == health.ERROR
        and out.health[0] == 0.5
        and out.logs[0].severity == "warning"
    )
    result = mon.wait_for_results(1, timeout=0.0)[0]
    assert result["k_true"] == NOMINAL.tolist() and result["percent_err"] is not None


def test_without_a_truth_listener_the_monitor_reports_no_percent_err(rows, monkeypatch):
    """The k_true of run_info is not the monitor's to read: only a listener beside it."""
    fit_always(monkeypatch, NOMINAL)
    mon = make()
    mon.run_job(_job(mon, rows), threading.Event())
    result = mon.wait_for_results(1, timeout=0.0)[0]
    assert result["k_true"] is None and result["percent_err"] is None


def test_the_truth_is_asked_after_the_fit_only_and_never_reaches_it(rows, monkeypatch):
    asked: list[tuple[float, float]] = []
    fitted: list[int] = []

    def truth(t0: float, t1: float):
        asked.append((t0, t1))
        assert fitted, "the truth was asked before the fit"
        return NOMINAL

    def fit(window, *_args, **_kwargs):
        fitted.append(1)
        assert window.k_true is None, "the window fitted carries a truth"
        return IsolationResult(
            k=NOMINAL, fitness=0.1, evaluations=10, wall_s=0.5, preset="de", seed=0
        )

    monkeypatch.setattr(health_monitor, "isolate", fit)
    mon = make(truth=truth)
    job = _job(mon, rows)
    mon.run_job(job, threading.Event())
    assert asked == [(job.t0, job.t1)]


@pytest.mark.parametrize(
    "exc,counter,level",
    [
        (ExcitationError("flat"), "windows_not_excited", health.OK),
        (RuntimeError("boom"), "isolation_failures", health.ERROR),
    ],
)
def test_a_window_not_fitted_is_reported(rows, monkeypatch, exc, counter, level):
    def fail(*args, **kwargs):
        raise exc

    monkeypatch.setattr(health_monitor, "isolate", fail)
    mon = make()
    out = mon.run_job(_job(mon, rows), threading.Event())
    assert (
        mon.counters[counter] == 1
        and out.status.level == level
        and out.health is None
        and not mon.busy
    )


def test_malformed_telemetry_discards_the_window(rows):
    mon = make()
    mon.on_run_info(RUN_INFO)
    mon.on_telemetry(rows[:50])
    assert mon.samples_collected == 50
    out = mon.on_malformed_telemetry("bad layout")
    assert (
        mon.counters["windows_discarded"] == 1
        and "malformed telemetry message: bad layout" in out.logs[0].text
    )


def test_without_a_unit_file_the_monitor_commissions_itself_then_fits(monkeypatch):
    from ema_phm.diagnosis.commissioning import CommissioningResult
    from ema_phm.model.belief import MonitorBelief

    seen: dict = {}

    def fake_commission(windows, **kw):
        seen["baselines"] = len(windows)
        j = MonitorBelief.default().value("mechanics.j_motor")
        return CommissioningResult(
            factors={"inertia": 1.1, "friction": 1.0},
            intervals={},
            identifiable={"inertia": True, "friction": False},
            values={"mechanics.j_motor": 1.1 * j, "monitor.healthy_fitness": 2.0},
            nuisances=[],
            fitness_before=[],
            fitness_after=[],
            temperature_c=20.0,
            wall_s=0.1,
            evaluations=1,
        )

    def fake_isolate(window, **kw):
        seen["belief"] = kw["belief"]
        seen["robust"] = (kw["nuisance"], kw["intervals"])
        return IsolationResult(
            k=NOMINAL, fitness=0.1, evaluations=10, wall_s=0.5, preset="de", seed=0
        )

    monkeypatch.setattr(commissioning_guard, "commission", fake_commission)
    monkeypatch.setattr(health_monitor, "isolate", fake_isolate)
    mon = HealthMonitor(
        IsolationSettings(),
        hardware_id="hw",
        stale_timeout=5.0,
        commission_windows=2,
        clock=Clock(),
    )
    rows = HFStream(NOMINAL).advance(3 * N + 1)
    mon.on_run_info(RUN_INFO)
    first = mon.run_job(mon.on_telemetry(rows[: N + 1]).jobs[0], threading.Event())
    assert first.status.message.startswith("commissioning: ") and "1 of 2" in first.status.message
    assert first.status.level == health.OK and mon.commissioned is None
    second = mon.run_job(mon.on_telemetry(rows[N + 1 : 2 * N + 1]).jobs[0], threading.Event())
    assert seen["baselines"] == 2 and mon.commissioned is not None
    assert "commissioned from 2 window(s)" in second.status.message
    assert "left at the datasheet" in second.status.message and "friction" in second.status.message
    assert mon.counters["windows_done"] == 0  # baselines are not assessments
    mon.run_job(mon.on_telemetry(rows[2 * N + 1 :]).jobs[0], threading.Event())
    assert seen["belief"] is mon.commissioned and seen["robust"] == (True, True)
    assert mon.counters["windows_done"] == 1


def test_a_unit_file_turns_self_commissioning_off(tmp_path):
    path = tmp_path / "unit.yaml"
    path.write_text("belief: {mechanics.j_motor: 1.4e-5, monitor.healthy_fitness: 3.0}\n")
    values = {
        "preset": "",
        "seed": 0,
        "fitness": "default",
        "max_evaluations": 0,
        "warn_threshold": list(health.DEFAULT_WARN),
        "error_threshold": list(health.DEFAULT_ERROR),
        "unit_file": str(path),
    }
    settings = IsolationSettings.from_values(values)
    assert settings.belief.value("mechanics.j_motor") == 1.4e-5
    mon = HealthMonitor(settings, hardware_id="hw", stale_timeout=5.0, commission_windows=3)
    assert mon.commission_windows == 0
    assert settings.reported()["unit"].endswith("unit.yaml")


def test_later_windows_track_from_the_last_explained_fit(monkeypatch):
    from ema_phm.diagnosis.adequacy import Adequacy

    calls: list = []
    verdicts = iter([True, True, False, True, True])  # the third window's tracked fit fails

    def fake_isolate(window, **kw):
        calls.append(kw.get("start"))
        ok = next(verdicts)
        row = np.full(10, 0.1 * len(calls))
        return IsolationResult(
            k=NOMINAL,
            fitness=0.1,
            evaluations=10,
            wall_s=0.1,
            preset="de",
            seed=0,
            row=row,
            adequacy=Adequacy(statistic=0.5 if ok else 9.0, threshold=1.43, ok=ok),
        )

    monkeypatch.setattr(health_monitor, "isolate", fake_isolate)
    mon = make()
    rows = HFStream(NOMINAL).advance(4 * N + 1)
    mon.on_run_info(RUN_INFO)
    for w in range(4):
        job = mon.on_telemetry(rows[w * N + (w > 0) : (w + 1) * N + 1]).jobs[0]
        mon.run_job(job, threading.Event())
    # window 1: global; 2: tracked from 1; 3: tracked from 2, not explained -> global again;
    # 4: tracked from that global fit
    assert calls[0] is None and calls[1] is not None and calls[1][0] == pytest.approx(0.1)
    assert calls[2] is not None and calls[3] is None
    assert calls[4] is not None and calls[4][0] == pytest.approx(0.4)
    assert mon.counters["tracking_restarts"] == 1


def test_tracking_off_searches_every_window_globally(monkeypatch):
    import dataclasses

    starts: list = []

    def fake_isolate(window, **kw):
        starts.append(kw.get("start"))
        return IsolationResult(
            k=NOMINAL, fitness=0.1, evaluations=1, wall_s=0.1, preset="de", seed=0, row=NOMINAL
        )

    monkeypatch.setattr(health_monitor, "isolate", fake_isolate)
    settings = dataclasses.replace(IsolationSettings(), tracking=False)
    mon = HealthMonitor(settings, hardware_id="hw", stale_timeout=5.0, clock=Clock())
    rows = HFStream(NOMINAL).advance(2 * N + 1)
    mon.on_run_info(RUN_INFO)
    for w in range(2):
        mon.run_job(
            mon.on_telemetry(rows[w * N + (w > 0) : (w + 1) * N + 1]).jobs[0], threading.Event()
        )
    assert starts == [None, None]


def test_fitted_windows_of_a_growing_fault_give_a_prognosis(monkeypatch):
    from ema_phm.monitor.tracker import PrognosticTracker

    monkeypatch.setattr(health_monitor, "isolate", growing_isolate(0.02, misfit=3))
    mon = make(prognostics=PrognosticTracker(horizon_cycles=10))
    windows = 16
    rows = HFStream(NOMINAL).advance(windows * N + 1)
    mon.on_run_info(RUN_INFO)
    for w in range(windows):
        out = mon.run_job(
            mon.on_telemetry(rows[w * N + (w > 0) : (w + 1) * N + 1]).jobs[0], threading.Event()
        )
    summary = mon.prognosis
    assert summary.windows == windows - 1 and summary.not_counted == 1
    assert summary.dominant.name == "friction" and summary.prognosis.cycle == windows - 1
    # k1 = 0.3 is a WARN by itself; the prognosis adds its reason only when it raises a level
    assert out.status.level == health.WARN and out.status.message.startswith("WARN: friction")
    assert out.status.value("prognosis_dominant_fault") == "friction"
    assert "prognosis: friction degrading" in out.logs[0].text
    result = mon.results[-1]["prognosis"]
    assert result["dominant_fault"] == "friction" and result["level"] == "WARN"
    busy = mon.heartbeat().status
    assert busy.value("rul_friction_cycles_p50") == out.status.value("rul_friction_cycles_p50")


def test_windows_by_excitation_are_the_segments_numbered_as_cycles(monkeypatch):
    """A run_info asking for windows by excitation: each test segment is one window, one cycle.

    Segments of different lengths: numbered by their times (`tracker.cycle_of`) they would
    step back and be skipped; numbered in order from first_cycle, each counts.
    """
    from ema_phm.monitor.tracker import PrognosticTracker

    monkeypatch.setattr(health_monitor, "isolate", growing_isolate(0.02))
    mon = make(prognostics=PrognosticTracker(horizon_cycles=10))
    lengths, rest = [0.3, 0.6] * 4, round(0.4 * FS)
    rows = HFStream(NOMINAL).advance(round((sum(lengths) + 0.4 * len(lengths) + 1) * FS))
    command, at = np.zeros(rows.shape[0]), rest
    for seconds in lengths:  # a moving command for each segment, still between
        n = round(seconds * FS)
        command[at : at + n] = 0.01 * np.sin(np.linspace(0, 2 * np.pi, n))
        at += n + rest
    rows[:, 1] = command
    rule = {"by": "excitation", "max_pause_s": 0.1, "settle_s": 0.02, "min_duration_s": 0.2}
    out = mon.on_run_info(
        json.dumps(
            {
                "sample_rate": FS,
                "samples_per_window": 20_000,
                "windows": {**rule, "first_cycle": 40},
            }
        )
    )
    assert (
        out.logs[0].text.startswith("windows by excitation") and "at most 10 s" in out.logs[0].text
    )
    for i in range(0, rows.shape[0], 500):
        for job in mon.on_telemetry(rows[i : i + 500]).jobs:
            mon.run_job(job, threading.Event())
    results = list(mon.results)
    spans = [r["window_t1"] - r["window_t0"] for r in results]
    assert np.allclose(spans, [x + 0.04 for x in lengths], atol=2 / FS), spans
    assert [r["cycle"] for r in results] == list(range(40, 40 + len(lengths)))
    summary = mon.prognosis
    assert summary.windows == len(lengths) and summary.not_counted == 0
    assert summary.prognosis.cycle == 40 + len(lengths) - 1


def test_without_prognostics_no_prognosis_is_reported(rows, monkeypatch):
    fit_always(monkeypatch, NOMINAL)
    mon = make()
    out = mon.run_job(_job(mon, rows), threading.Event())
    assert mon.prognosis is None and mon.results[-1]["prognosis"] is None
    assert "prognosis" not in dict(out.status.values)


def test_warming_up_is_reported_never_stale_and_staleness_counts_from_its_end():
    clock = Clock()
    mon = make(clock)
    assert mon.start(warming_up=True).status.message.startswith("warming up")
    clock.now = 60.0  # far past stale_timeout: warming up is not a lack of telemetry
    status = mon.heartbeat().status
    assert status.level == health.OK and status.value("warming_up") == "true"
    out = mon.warm_up(threading.Event())
    assert mon.warm_up_s is not None and mon.warm_up_s > 0
    assert out.status.message.startswith("waiting for telemetry: no window fitted yet (warmed up")
    assert out.logs[0].text.startswith("warmed up in ")
    assert mon.heartbeat().status.level == health.OK
    clock.now = 66.0
    assert mon.heartbeat().status.level == health.STALE


def test_a_failed_or_cancelled_warm_up_leaves_the_monitor_working(monkeypatch):
    from ema_phm.errors import IsolationCancelled

    def broken(*args, **kwargs):
        raise RuntimeError("no compiler")

    monkeypatch.setattr(health_monitor, "warm_up", broken)
    mon = make()
    mon.start(warming_up=True)
    out = mon.warm_up(threading.Event())
    assert out.logs[0].severity == "error" and "no compiler" in out.logs[0].text
    assert "(warm-up failed)" in out.status.message and mon.warm_up_s is None

    def cancelled(*args, **kwargs):
        raise IsolationCancelled("stop")

    monkeypatch.setattr(health_monitor, "warm_up", cancelled)
    assert mon.warm_up(threading.Event()).status is None


def _until(condition, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


@pytest.mark.parametrize("windows", [2, 4])
def test_one_message_completing_several_windows_fits_them_all_and_does_not_wedge(
    monkeypatch, windows
):
    """Issue 17 item 1: every window a message completes is scheduled.

    The worker that runs exactly what the monitor schedules leaves it free for the next
    message's window.
    """
    from ema_phm.diagnosis.isolation_worker import IsolationWorker

    monkeypatch.setattr(health_monitor, "isolate", growing_isolate(0.01))
    mon = make(queue_depth=windows)
    rows = HFStream(NOMINAL).advance((windows + 1) * N + 1)
    mon.on_run_info(RUN_INFO)
    ran: list = []
    worker = IsolationWorker(lambda job: ran.append(mon.run_job(job, worker.cancel)), name="t")
    try:
        out = mon.on_telemetry(rows[: windows * N + 1])  # one message, `windows` windows
        assert [(j.t0, j.t1) for j in out.jobs] == [
            (w * N / FS, (w + 1) * N / FS) for w in range(windows)
        ]
        for job in out.jobs:  # what monitor_node._emit does
            worker.submit(job)
        assert len(mon.wait_for_results(windows, timeout=30.0)) == windows
        assert _until(lambda: not mon.busy) and not mon.queued
        later = mon.on_telemetry(rows[windows * N + 1 :])  # the next window is fitted, not skipped
        assert len(later.jobs) == 1 and mon.counters["windows_skipped_busy"] == 0
        worker.submit(later.jobs[0])
        assert len(mon.wait_for_results(windows + 1, timeout=30.0)) == windows + 1
        assert _until(lambda: not mon.busy) and mon.counters["windows_done"] == windows + 1
    finally:
        worker.close()


def test_a_job_ending_out_of_turn_leaves_the_queue_and_never_wedges_it(rows):
    mon = make(queue_depth=2)
    mon.on_run_info(RUN_INFO)
    first, second = mon.on_telemetry(rows[: 2 * N + 1]).jobs
    with mon._lock:
        mon.jobs.done(second)  # the queued one ends first (cancelled, say)
        assert mon.jobs.running is first and not mon.queued
        mon.jobs.done(first)
    assert not mon.busy


def test_two_streams_mixed_on_the_topic_discard_the_window_with_an_error(rows):
    """Issue 17 item 5: alternate messages of two sources never make a window.

    The status is ERROR and names both streams.
    """
    from ema_phm.telemetry.wire import StreamId

    a, b = StreamId("hw", "run-a"), StreamId("hw", "run-b")  # this unit, two runs at once
    mon = make(queue_depth=3)
    mon.on_run_info(RUN_INFO)
    outs = [
        mon.on_telemetry(rows[m * 50 : (m + 1) * 50], a if m % 2 == 0 else b)
        for m in range(2 * N // 50)
    ]
    assert not any(o.jobs for o in outs) and mon.counters["stream_changes"] == len(outs) - 1
    status = outs[-1].status
    assert status.level == health.ERROR and "stream hw (run run-a)" in status.message
    assert "hw (run run-b)" in status.message and "two publishers" in status.message
    assert dict(status.values)["stream"] == "hw (run run-b)"  # the last message's
    assert mon.counters["windows_discarded"] >= 1


def test_the_tracker_learns_the_run_from_run_info():
    """A restarted source (new run_id) starts a new prognosis history, live as offline."""
    from ema_phm.monitor.tracker import PrognosticTracker

    mon = make(prognostics=PrognosticTracker(horizon_cycles=10))
    info = json.loads(RUN_INFO) | {"hardware_id": "ema-1", "run_id": "r1"}
    mon.on_run_info(json.dumps(info))
    assert mon.tracker.run is not None and "r1" in mon.tracker.run
    mon.on_run_info(json.dumps(info | {"run_id": "r2"}))
    assert "r2" in mon.tracker.run


def test_another_units_telemetry_is_not_judged_and_is_an_error_naming_both(rows):
    """Issue 33: a stream whose hardware_id is not the monitor's is an ERROR, never fitted.

    The unit file, the commissioning and the history are this unit's; another unit's windows
    judged against them would read its differences as faults.
    """
    from ema_phm.telemetry.wire import StreamId

    other, mine = StreamId("ema-7", "r"), StreamId("hw", "r")
    mon = make()
    mon.on_run_info(RUN_INFO)
    outs = [mon.on_telemetry(rows[m * 50 : (m + 1) * 50], other) for m in range(2 * N // 50)]
    assert not any(o.jobs for o in outs) and mon.counters["telemetry_other_unit"] == len(outs)
    errors = [line for o in outs for line in o.logs if line.severity == "error"]
    assert len(errors) == 1  # said once, counted every time
    status = outs[0].status
    assert status.level == health.ERROR and "stream ema-7 (run r)" in status.message
    assert "'hw'" in status.message and "parameter hardware_id" in status.message
    assert dict(mon.heartbeat().status.values)["telemetry_other_unit"] == str(len(outs))
    assert mon.heartbeat().status.level == health.ERROR  # still said, not STALE
    # this unit's telemetry again: the error gives way, its windows are fitted
    back = [mon.on_telemetry(rows[m * 50 : (m + 1) * 50], mine) for m in range(N // 50 + 1)]
    assert any(o.jobs for o in back)
    assert "not the unit" not in mon.heartbeat().status.message
