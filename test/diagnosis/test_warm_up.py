"""The monitor's warm-up: the fit's compiled paths, run once on a synthetic window."""

from __future__ import annotations

import threading

import pytest

from ema_phm.diagnosis import warm_up as warm_up_mod
from ema_phm.diagnosis.isolation_settings import IsolationSettings
from ema_phm.domain.faults import N_K
from ema_phm.errors import IsolationCancelled
from ema_phm.model.belief import MonitorBelief


def test_the_synthetic_window_is_one_the_monitor_model_accepts():
    belief = MonitorBelief.default()
    w = warm_up_mod.synthetic_window(belief).validated()
    assert 1.0 / w.dt == pytest.approx(belief["acquisition"]["sample_rate"])
    assert w.duration == pytest.approx(warm_up_mod.WINDOW_S) and w.command.std() > 0


def test_warm_up_runs_a_global_and_a_tracked_fit_as_the_monitor_does(monkeypatch):
    calls = []
    real = warm_up_mod.isolate

    def spy(window, **kw):
        calls.append(kw)
        return real(window, **kw)

    monkeypatch.setattr(warm_up_mod, "isolate", spy)
    took = warm_up_mod.warm_up(IsolationSettings(seed=3, fitness="all"))
    assert took > 0 and len(calls) == 2
    first, tracked = calls
    assert first.get("start") is None and first["max_evaluations"] > 0
    assert tracked["start"] is not None and tracked["start"].size > N_K  # k and the nuisances
    for kw in calls:
        assert kw["nuisance"] and kw["intervals"]
        assert (kw["seed"], kw["weights"]) == (3, "all")


def test_a_set_cancel_stops_the_warm_up():
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(IsolationCancelled):
        warm_up_mod.warm_up(IsolationSettings(), cancel=cancel)
