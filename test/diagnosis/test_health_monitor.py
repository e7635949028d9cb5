"""HealthMonitor without a node: windows scheduled, statuses decided, counters kept."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest

from ema_phm.diagnosis import health, health_monitor
from ema_phm.diagnosis.health_monitor import HealthMonitor
from ema_phm.diagnosis.isolation import IsolationResult
from ema_phm.diagnosis.isolation_settings import IsolationSettings
from ema_phm.errors import ExcitationError
from ema_phm.physics.fault_vector import NOMINAL
from ema_phm.physics.real_ema import HFStream
from ema_phm.telemetry.window import CHANNELS

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


def make(clock=None) -> HealthMonitor:
    return HealthMonitor(
        IsolationSettings(), hardware_id="hw", stale_timeout=5.0, clock=clock or Clock()
    )


def test_starts_waiting_and_buffers_telemetry_until_run_info(rows):
    mon = make()
    assert mon.start().status.message.startswith("waiting for telemetry")
    assert mon.on_telemetry(rows[: N + 1]).job is None and not mon.has_run_info
    out = mon.on_run_info(RUN_INFO)
    assert out.job is not None and out.window.shape == (N + 1, len(CHANNELS)) and mon.busy
    assert out.logs[0].text == "windows of 200 samples at 2000 Hz (0.1 s)"


def test_a_window_completed_while_busy_is_skipped(rows):
    mon = make()
    mon.on_run_info(RUN_INFO)
    assert mon.on_telemetry(rows[: N + 1]).job is not None
    out = mon.on_telemetry(rows[N + 1 :])
    assert (
        out.job is None
        and mon.counters["windows_skipped_busy"] == 1
        and "skipped" in out.logs[0].text
    )


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
    return mon.on_telemetry(rows[: N + 1]).job


def test_a_fitted_window_gives_health_and_status(rows, monkeypatch):
    k = NOMINAL.copy()
    k[0] = 0.5
    monkeypatch.setattr(
        health_monitor,
        "isolate",
        lambda *a, **kw: IsolationResult(
            k=k, fitness=0.1, evaluations=10, wall_s=0.5, preset="de", seed=0
        ),
    )
    mon = make()
    out = mon.run_job(_job(mon, rows), threading.Event())
    assert not mon.busy and mon.counters["windows_done"] == 1
    assert (
        out.status.level == health.ERROR
        and out.health[0] == 0.5
        and out.logs[0].severity == "warning"
    )
    result = mon.wait_for_results(1, timeout=0.0)[0]
    assert result["k_true"] == NOMINAL.tolist() and result["percent_err"] is not None


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
