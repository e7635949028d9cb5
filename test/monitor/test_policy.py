"""The monitor's policy: track then restart, which windows count, any estimator / predictor."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ema_phm.diagnosis.adequacy import Adequacy
from ema_phm.diagnosis.isolation import IsolationResult
from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import N_K, NOMINAL, fault
from ema_phm.domain.window import CHANNELS, Window
from ema_phm.errors import ExcitationError
from ema_phm.monitor import replay as replay_mod
from ema_phm.monitor.estimator import IsolationEstimator
from ema_phm.monitor.policy import FitPolicy
from ema_phm.prognostics.rul import History

FRICTION = fault("friction").index

#: A quick fit: the global stage's first evaluation, no nuisances (a replay's plumbing).
FIT = FitSettings(seed=1, max_evaluations=1, nuisance=False)


def _result(n: int, ok: bool | None = True, k: np.ndarray | None = None) -> IsolationResult:
    return IsolationResult(
        k=NOMINAL.copy() if k is None else k,
        fitness=0.1,
        evaluations=10 + n,
        wall_s=0.5,
        preset="de",
        seed=0,
        row=np.full(3, float(n)),
        adequacy=None if ok is None else Adequacy(statistic=1.0, threshold=1.43, ok=ok),
    )


class Scripted:
    """An estimator (any object with `fit`): returns the scripted verdicts in turn."""

    def __init__(self, verdicts):
        self.verdicts, self.starts = iter(verdicts), []

    def fit(self, window, start=None):
        self.starts.append(None if start is None else float(start[0]))
        verdict = next(self.verdicts)
        if isinstance(verdict, Exception):
            raise verdict
        return _result(len(self.starts), verdict)


def test_track_then_restart_with_a_global_search():
    est = Scripted([True, True, False, True, ExcitationError("not excited"), True, None])
    policy = FitPolicy()
    modes = [policy.fit(None, est).mode for _ in range(3)]
    assert modes == ["global", "tracked", "restarted"]
    # the restart's tracked attempt is kept; the next window tracks from the global fit
    assert est.starts == [None, 1.0, 2.0, None]
    with pytest.raises(ExcitationError):
        policy.fit(None, est)
    fit = policy.fit(None, est)  # nothing to track from after a fit that raised
    assert fit.mode == "global" and fit.tracked_attempt is None and est.starts[-1] is None
    assert policy.fit(None, est, tracking=False).mode == "global"


def test_a_restart_keeps_the_tracked_attempt():
    est = Scripted([True, False, False])
    policy = FitPolicy()
    policy.fit(None, est)
    fit = policy.fit(None, est)
    assert fit.mode == "restarted" and fit.tracked_attempt.evaluations == 12
    assert fit.result.evaluations == 13
    assert policy.fit(None, Scripted([True])).mode == "global"  # the restart was unexplained


class Recording:
    """A predictor (any object with `predict`): records the history it was given."""

    def __init__(self):
        self.histories: list[History] = []

    def predict(self, history, *, seed=0):
        self.histories.append(history)
        return SimpleNamespace(seed=seed)


def test_count_widens_intervals_skips_misfits_and_starts_a_new_run():
    predictor = Recording()
    policy = FitPolicy(predictor)
    k = NOMINAL.copy()
    k[FRICTION] = 0.2
    interval = np.column_stack([np.clip(k - 0.05, 0, 1), np.clip(k + 0.05, 0, 1)])
    interval[FRICTION] = (0.25, 0.3)  # does not hold k: widened to hold it
    fitted = SimpleNamespace(k=k, k_interval=interval, adequacy=None)
    counted = policy.count(0, fitted, ("hw", "a"), seed=7)
    assert counted.prognosis.seed == 7 and counted.estimate.known
    assert counted.estimate.low[FRICTION] == 0.2 and counted.estimate.high[FRICTION] == 0.3
    misfit = SimpleNamespace(k=k, adequacy={"ok": False, "statistic": 9.0, "threshold": 1.43})
    assert "does not explain" in policy.count(1, misfit, ("hw", "a")).verdict.reason
    policy.count(2, SimpleNamespace(k=k), ("hw", "a"))  # no interval: unknown from here
    assert len(policy.estimates) == 2 and not predictor.histories[-1].intervals_known
    assert policy.count(0, fitted, ("hw", "b")).verdict.new_run and len(policy.estimates) == 1
    assert predictor.histories[-1].intervals_known
    assert FitPolicy(count_unexplained=True, predictor=Recording()).count(0, misfit).estimate


def test_isolation_estimator_passes_its_options_and_start():
    seen = {}

    def fake(window, **kw):
        seen.update(kw)
        return "fit"

    est = IsolationEstimator({"seed": 3, "intervals": True}, fake)
    assert est.fit("w", np.zeros(N_K)) == "fit"
    assert seen["seed"] == 3 and seen["intervals"] and seen["start"] is not None


def _windows(n: int) -> list[Window]:
    out = []
    for c in range(n):
        data = np.zeros((101, len(CHANNELS)))
        data[:, 0] = c * 0.05 + np.arange(101) / 2000.0
        out.append(Window.from_matrix(data, k_true=NOMINAL.copy(), meta={"cycle": c}))
    return out


def test_replay_fits_as_the_live_monitor_tracked_then_restarted(monkeypatch):
    calls: list = []
    verdicts = iter([True, True, False, True, True])  # window 3's tracked fit is a misfit

    def fake_isolate(window, **kw):
        calls.append(kw["start"])
        return _result(len(calls), next(verdicts))

    monkeypatch.setattr(replay_mod, "isolate", fake_isolate)
    res = replay_mod.replay(_windows(4), fit=FIT)
    assert [r.fit_mode for r in res] == ["global", "tracked", "restarted", "tracked"]
    assert calls[0] is None and calls[1][0] == 1.0 and calls[3] is None and calls[4][0] == 4.0
    assert res[2].evaluations == 13 + 14 and not any(r.skipped for r in res)  # both fits
    assert res[2].as_dict()["fit_mode"] == "restarted"
    off = iter([True] * 4)
    monkeypatch.setattr(replay_mod, "isolate", lambda w, **kw: _result(0, next(off)))
    assert {r.fit_mode for r in replay_mod.replay(_windows(4), tracking=False)} == {"global"}
