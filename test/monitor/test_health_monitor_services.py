"""HealthMonitor's requests behind monitor_node's services (issue 17), without a node."""

from __future__ import annotations

import json
import threading

import pytest
from helpers import ISOLATION_DEFAULTS, growing_isolate

from ema_phm.diagnosis import health
from ema_phm.diagnosis.isolation_settings import IsolationSettings
from ema_phm.domain.faults import NOMINAL
from ema_phm.errors import ConfigError
from ema_phm.monitor import commissioning_guard, health_monitor
from ema_phm.monitor.health_monitor import HealthMonitor
from ema_phm.monitor.tracker import PrognosticTracker
from ema_phm.simulator.real_ema import HFStream

FS, N = 2000.0, 200
RUN_INFO = json.dumps({"sample_rate": FS, "samples_per_window": N, "cycle_hours": 2.5})


def _monitor(**kwargs) -> HealthMonitor:
    return HealthMonitor(IsolationSettings(), hardware_id="hw", stale_timeout=5.0, **kwargs)


def _window(mon: HealthMonitor, rows, w: int):
    (job,) = mon.on_telemetry(rows[w * N + (w > 0) : (w + 1) * N + 1]).jobs
    return job


def test_reset_prognosis_forgets_the_history_and_keeps_the_settings(monkeypatch):
    monkeypatch.setattr(health_monitor, "isolate", growing_isolate(0.02, misfit=3))
    tracker = PrognosticTracker(horizon_cycles=7, alarm_windows=3, cycle_hours=None)
    mon = _monitor(prognostics=tracker)
    rows = HFStream(NOMINAL).advance(6 * N + 1)
    mon.on_run_info(RUN_INFO)
    for w in range(5):
        mon.run_job(_window(mon, rows, w), threading.Event())
    assert mon.prognosis.windows == 4  # the tracker counts explained windows
    out = mon.reset_prognosis()
    assert out.logs[0].text == "prognosis reset: 4 window(s) of history forgotten"
    assert mon.prognosis.windows == 0 and mon.prognosis.prognosis is None
    assert out.status is not None and out.status.value("prognosis_windows") in (None, "0")
    t = mon.tracker
    assert (t.horizon_cycles, t.alarm_windows, t.cycle_hours, t.follows_stream) == (
        7,
        3,
        2.5,
        True,
    )
    mon.run_job(_window(mon, rows, 5), threading.Event())
    assert mon.prognosis.windows == 1  # a new life from the next window


def test_reset_prognosis_is_refused_without_prognostics():
    with pytest.raises(ConfigError, match="prognostics is off"):
        _monitor().reset_prognosis()


def test_recommission_keeps_the_next_windows_as_baselines_then_commissions(monkeypatch):
    calls = []

    def fake_commission(windows, **kw):
        calls.append(len(windows))
        raise RuntimeError("stop here: commissioning was reached")

    monkeypatch.setattr(commissioning_guard, "commission", fake_commission)
    monkeypatch.setattr(health_monitor, "isolate", growing_isolate(0.0, misfit=99))
    mon = _monitor(prognostics=PrognosticTracker())
    rows = HFStream(NOMINAL).advance(4 * N + 1)
    mon.on_run_info(RUN_INFO)
    mon.run_job(_window(mon, rows, 0), threading.Event())  # fitted: no commissioning asked
    assert mon.counters["windows_done"] == 1 and mon.prognosis.windows == 1
    out = mon.recommission(2)
    assert out.status.level == health.OK and "commissioning requested" in out.status.message
    assert mon.commission_windows == 2 and mon.commissioned is None
    assert mon.prognosis.windows == 0  # a new baseline: a new life
    mon.run_job(_window(mon, rows, 1), threading.Event())
    assert "baseline 1 of 2" in mon.last_status.message and calls == []
    out = mon.run_job(_window(mon, rows, 2), threading.Event())
    assert calls == [2]  # commissioned from exactly the two windows after the request


@pytest.mark.parametrize("n,words", [(0, "at least 1 window"), (21, r"\[0, 20\]")])
def test_recommission_refuses_a_bad_count(n, words):
    with pytest.raises(ConfigError, match=words):
        _monitor().recommission(n)


def test_recommission_is_refused_with_a_unit_file(tmp_path):
    path = tmp_path / "unit.yaml"
    path.write_text("belief: {mechanics.j_motor: 1.4e-5, monitor.healthy_fitness: 3.0}\n")
    settings = IsolationSettings.from_values({**ISOLATION_DEFAULTS, "unit_file": str(path)})
    mon = HealthMonitor(settings, hardware_id="hw", stale_timeout=5.0)
    with pytest.raises(ConfigError, match="unit_file is in use"):
        mon.recommission(3)


def test_fit_next_now_drops_the_queued_windows_and_they_are_not_fitted(monkeypatch):
    fitted = []
    real = growing_isolate(0.0, misfit=99)

    def counting(window, **kwargs):
        fitted.append(window)
        return real(window, **kwargs)

    monkeypatch.setattr(health_monitor, "isolate", counting)
    mon = _monitor(queue_depth=3)
    rows = HFStream(NOMINAL).advance(5 * N + 1)
    mon.on_run_info(RUN_INFO)
    jobs = [_window(mon, rows, w) for w in range(3)]  # one running, two queued
    out = mon.fit_next_now()
    assert out.logs[0].text == (
        "fit the next window now: 2 queued window(s) dropped (t = 0.1..0.2 s, t = 0.2..0.3 s)"
    )
    assert mon.counters["windows_skipped_busy"] == 2 and not mon.queued
    later = _window(mon, rows, 3)  # queued behind the running fit, as the next one
    for job in [*jobs, later]:  # the worker runs what was submitted, in order
        mon.run_job(job, threading.Event())
    assert len(fitted) == 2 and mon.counters["windows_done"] == 2
    assert [r["window_t0"] for r in mon.results] == [0.0, 0.3]
    assert not mon.busy and not mon.queued
