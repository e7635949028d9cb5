"""`ema-phm prognose BAG`: replay a multi-window bag (ema_phm/tools/prognose.py, replay.py)."""

from __future__ import annotations

import json
import re
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import run_cli

from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.domain.window import Window
from ema_phm.evaluation import truth as truth_mod
from ema_phm.monitor import replay as replay_mod
from ema_phm.simulator.degradation import Degradation, FaultGrowth
from ema_phm.tools.cli import main

DEGRADATION = """\
cycle_hours: 2.0
faults:
  friction: {law: linear, onset: 0, initial: 0.0, rate: 0.05}
"""

#: A quick fit: the global stage's first evaluation, no nuisances (a replay's plumbing).
FIT = FitSettings(seed=1, max_evaluations=1, nuisance=False)


@pytest.fixture(scope="module")
def tiny_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp("prognose")
    deg = folder / "deg.yaml"
    deg.write_text(DEGRADATION)
    bag = folder / "bag"
    argv = ["simulate", "--windows", "3", "--degradation", str(deg), "--duration", "0.5"]
    assert main([*argv, "--out", str(bag)]) == 0
    return bag


def test_json_has_one_entry_per_window_with_k_intervals_and_prognosis(tiny_bag, tmp_path, capsys):
    png = tmp_path / "p.png"
    code, out, err = run_cli(
        capsys,
        "prognose",
        str(tiny_bag),
        "--max-evaluations",
        "40",
        "--count-unexplained",  # 40 evaluations leave misfits
        "--json",
        "--plot",
        str(png),
        "--growth-priors",
        "none",
    )
    assert code == 0, err
    d = json.loads(out)
    assert d["growth_priors"] == {}  # 'none': no growth prior, said in the output
    assert [w["cycle"] for w in d["windows"]] == [0, 1, 2]
    assert d["cycle_hours"] == 2.0 and d["cycle_hours_source"] == "bag"
    for w in d["windows"]:
        assert len(w["k"]) == len(w["k_low"]) == len(w["k_high"]) == N_K
        assert all(
            lo <= k <= hi for lo, k, hi in zip(w["k_low"], w["k"], w["k_high"], strict=True)
        )
        assert w["interval_source"] in ("isolate", "unavailable")
        faults = {f["fault"]: f for f in w["prognosis"]["faults"]}
        assert len(faults) == N_K
        # three windows are fewer than the five estimates a trend needs
        assert faults["friction"]["status"] == "insufficient_data"
        assert faults["gain_drift"]["status"] == "not_applicable"
    assert d["summary"]["true_eol_cycles"]["friction"] == 8  # 0.05 per cycle to 0.4
    assert d["summary"]["scores"]["friction"]["predictions"] == 3
    assert png.stat().st_size > 0


def test_text_output_prints_each_window_and_a_summary(tiny_bag, capsys):
    code, out, err = run_cli(
        capsys, "prognose", str(tiny_bag), "--max-evaluations", "40", "--count-unexplained"
    )
    assert code == 0, err
    assert len(re.findall(r"^cycle +\d+: k1 ", out, flags=re.M)) == 3
    assert "summary after 3 counted (assessed and explained) of 3 windows" in out
    assert re.search(r"gain_drift +not_applicable .*sec\. 4\.6", out)
    assert "friction reaches its threshold at cycle 8" in out


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["BAG", "--thresholds", "0.4,0.4"], "--thresholds must have 8 entries"),
        (["BAG", "--thresholds", "0,0,0,0,0,0,0,0"], r"k1 \(friction\) must be in \(0, 1\]"),
        (["BAG", "--horizon", "-1"], r"--horizon must be .* got '-1'"),
        (["BAG", "--noise-floor", "0"], r"--noise-floor must be .* got '0'"),
        (["BAG", "--growth-priors", "MISSING"], "cannot read growth priors"),
        (["BAG", "--growth-priors", "BADPRIORS"], "unknown fault 'wear'"),
        (["BAG", "--preset", "nope"], "unknown preset 'nope'"),
        (["BAG", "--plot", "out.nope"], "matplotlib cannot write"),
        (["MISSING"], "does not exist"),
        (["BAG", "--unit", "MISSING"], "not found"),
        (["ONE"], "samples_per_window"),
    ],
)
def test_bad_input_is_one_line_exit_2(tiny_bag, tmp_path, capsys, argv, match):
    one = tmp_path / "one"
    data = np.zeros((300, 8))
    data[:, 0] = np.arange(300) / 2000.0
    from ema_phm.telemetry import bags

    bags.write_window(one, Window.from_matrix(data))
    bad = tmp_path / "priors.yaml"
    bad.write_text("wear: {linear: [0.01, 0.3], exponential: [0.1, 0.3]}\n")
    names = {
        "BAG": str(tiny_bag),
        "MISSING": str(tmp_path / "missing"),
        "ONE": str(one),
        "BADPRIORS": str(bad),
    }
    code, out, err = run_cli(capsys, "prognose", *[names.get(a, a) for a in argv])
    assert code == 2
    assert re.match(r"ema-phm( prognose)?: error: ", err) and err.count("\n") == 1, err
    assert re.search(match, err), err


def _windows(deg: Degradation, n: int) -> list[Window]:
    out = []
    for c in range(n):
        data = np.zeros((101, 8))
        data[:, 0] = c * 0.05 + np.arange(101) / 2000.0
        w = Window.from_matrix(data, k_true=deg.k(c), meta={"cycle": c, **_meta(deg)})
        out.append(w)
    return out


def _meta(deg: Degradation) -> dict:
    return {"degradation": deg.as_dict(), "cycle_hours": 1.0}


def test_replay_without_intervals_says_unavailable_and_scores_against_the_truth(monkeypatch):
    deg = Degradation(faults=(FaultGrowth("backlash", "linear", 2, 0.0, 0.02),))
    rng = np.random.default_rng(0)

    def fake_isolate(window, **_):  # an isolate() whose result has no k_interval
        k = window.k_true.copy()
        k[:6] = np.clip(k[:6] + rng.normal(0, 0.01, 6), 0, 1)
        return SimpleNamespace(k=k, evaluations=1, wall_s=0.0)

    monkeypatch.setattr(replay_mod, "isolate", fake_isolate)
    windows = _windows(deg, 20)
    res = replay_mod.replay(windows, fit=FIT)
    assert all(r.interval_source == "unavailable" for r in res)
    assert all(np.array_equal(r.k_low, r.k) and np.array_equal(r.k_high, r.k) for r in res)
    assert res[-1].prognosis.intervals_known is False
    assert res[-1].prognosis.fault("backlash").status == "degrading"
    eol = truth_mod.true_end_of_life(windows, [0.4] * 6 + [0.0, 0.25])
    assert eol["backlash"] == 22 and eol["friction"] is None
    s = truth_mod.score(res, eol)
    assert set(s) == {"backlash"} and s["backlash"]["predictions"] == 20
    assert s["backlash"]["prognostic_horizon_cycles"] > 0
    assert 0 < s["backlash"]["windows_with_rul"] < 20  # no RUL before the trend shows
    assert 0.0 <= s["backlash"]["interval_coverage_90"] <= 1.0


def test_replay_does_not_count_windows_the_model_does_not_explain(monkeypatch):
    from ema_phm.diagnosis.adequacy import Adequacy

    deg = Degradation(faults=(FaultGrowth("friction", "linear", 2, 0.0, 0.02),))

    def fake_isolate(window, **_):  # every third window a misfit claiming a wrong fault
        k = window.k_true.copy()
        misfit = window.meta["cycle"] % 3 == 2
        if misfit:
            k[1] = 0.9
        ok = Adequacy(statistic=3.0 if misfit else 0.5, threshold=1.43, ok=not misfit)
        return SimpleNamespace(k=k, evaluations=1, wall_s=0.0, adequacy=ok)

    monkeypatch.setattr(replay_mod, "isolate", fake_isolate)
    res = replay_mod.replay(_windows(deg, 12), fit=FIT)
    misfits = [r for r in res if r.cycle % 3 == 2]
    assert misfits and all("does not explain" in r.skipped and r.k is None for r in misfits)
    counted = [r for r in res if not r.skipped]
    assert len(counted) == 8
    every = replay_mod.replay(_windows(deg, 12), fit=FIT, count_unexplained=True)
    assert not any(r.skipped for r in every)
    # the wrong backlash of the misfits never reaches the history
    assert counted[-1].prognosis.fault("backlash").status != "degrading"


# ---- bad windows are skipped with their reason (issue 17 item 3) -------------------------------

RATE = 2000.0


def _good_isolate(window, **_):
    """An isolate() that fits every window perfectly (k = its truth), explained."""
    from ema_phm.diagnosis.adequacy import Adequacy

    k = NOMINAL.copy() if window.k_true is None else window.k_true.copy()
    ok = Adequacy(statistic=0.5, threshold=1.43, ok=True)
    return SimpleNamespace(k=k, evaluations=1, wall_s=0.0, adequacy=ok)


def _rows(cycle: int, *, rate: float = RATE, n: int = 101) -> np.ndarray:
    data = np.zeros((n, 8))
    data[:, 0] = cycle * 0.05 + np.arange(n) / rate
    return data


def _bad_windows() -> tuple[list[Window], dict[int, str]]:
    """Cycles 0..7 with a NaN sample, a 1000 Hz window, a duplicate and a step back."""
    meta = {"sample_rate": RATE, "samples_per_window": 100, "window_duration": 0.05}
    plan = [(0, "ok"), (1, "ok"), (2, "nan"), (3, "slow"), (3, "ok"), (3, "ok"), (1, "ok")]
    plan += [(c, "ok") for c in range(4, 8)]
    out, expected = [], {}
    for i, (c, kind) in enumerate(plan):
        data = _rows(c, rate=1000.0 if kind == "slow" else RATE)
        if kind == "nan":
            data[40, 3] = np.nan
        out.append(Window.from_matrix(data, meta={**meta, "cycle": c}))
        expected[i] = kind
    return out, expected


def test_replay_skips_every_bad_window_with_its_reason_and_goes_on(monkeypatch):
    # each of these used to abort the replay (exit 2 from `ema-phm prognose`, no summary)
    monkeypatch.setattr(replay_mod, "isolate", _good_isolate)
    windows, _ = _bad_windows()
    res = replay_mod.replay(windows, fit=FIT)
    reasons = [r.skipped for r in res]
    assert re.search(r"bad window: channel '\w+' has 1 non-finite", reasons[2]), reasons[2]
    assert re.search(r"bad window: sampled at 1000 Hz, the run at 2000 Hz", reasons[3])
    assert reasons[4] == ""  # cycle 3 first fitted here: the 1000 Hz one was not fitted
    assert re.search(r"cycle 3 again \(duplicate\)", reasons[5])
    assert re.search(r"cycle 1 steps back from cycle 3 of the same run", reasons[6])
    counted = [r.cycle for r in res if not r.skipped]
    assert counted == [0, 1, 3, 4, 5, 6, 7]
    assert res[-1].prognosis.cycle == 7.0


def test_replay_starts_a_new_history_for_a_new_run(monkeypatch):
    monkeypatch.setattr(replay_mod, "isolate", _good_isolate)
    windows = [
        Window.from_matrix(_rows(c), meta={"cycle": c, "run_id": run})
        for run, cycles in (("a", range(4)), ("b", range(3)))
        for c in cycles
    ]
    res = replay_mod.replay(windows, fit=FIT)
    assert not any(r.skipped for r in res)
    assert "4 estimates" in res[3].prognosis.fault("friction").message
    assert res[-1].prognosis.cycle == 2.0
    assert "3 estimates" in res[-1].prognosis.fault("friction").message


def _monitor_bag(path, windows: list[Window]) -> None:
    """A bag as a monitor records it: run_info, then each fitted window on /ema/window."""
    from ema_phm.telemetry.bags import BagRecorder, float64_multiarray, string_msg
    from ema_phm.telemetry.wire import (
        FLOAT64_MULTIARRAY,
        RUN_INFO_TOPIC,
        STRING,
        WINDOW_TOPIC,
        encode_run_info,
    )

    info = {k: v for k, v in windows[0].meta.items() if k != "cycle"}
    topics = {RUN_INFO_TOPIC: STRING, WINDOW_TOPIC: FLOAT64_MULTIARRAY}
    with BagRecorder(path, topics=topics) as rec:
        rec.write(RUN_INFO_TOPIC, string_msg(encode_run_info(info)), 1)
        for i, w in enumerate(windows):
            rec.write(
                WINDOW_TOPIC, float64_multiarray(w.matrix(), ["samples", "channels"]), 10 + i
            )


def test_prognose_reports_bad_windows_and_still_summarises(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(replay_mod, "isolate", _good_isolate)
    windows, _ = _bad_windows()
    _monitor_bag(tmp_path / "bag", windows)
    code, out, err = run_cli(capsys, "prognose", str(tmp_path / "bag"))
    assert code == 0, err
    for words in (
        "non-finite",
        "sampled at 1000 Hz",
        r"cycle 3 again \(duplicate\)",
        "steps back",
    ):
        assert re.search(rf"^cycle +\d+: skipped: .*{words}", out, flags=re.M), (words, out)
        assert re.search(rf"^  skipped cycle \d+: .*{words}", out, flags=re.M), (words, out)
    assert "summary after 7 counted (assessed and explained) of 11 windows" in out
    code, out, err = run_cli(capsys, "prognose", str(tmp_path / "bag"), "--json")
    summary = json.loads(out)["summary"]
    assert summary["skipped_windows"] == 4 and len(summary["skipped"]) == 4


def test_relative_accuracy_without_a_finite_prediction_is_not_minus_inf(
    monkeypatch, tmp_path, capsys
):
    # friction reaches 0.4 at cycle 8; the fits see no growth, so the prognosis at lambda
    # (cycle 4) has its median RUL at inf and RA = 1 - |r* - inf| / r* was printed "-inf"
    monkeypatch.setattr(replay_mod, "isolate", _good_isolate)
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 0, 0.0, 0.05),))
    meta = {"sample_rate": RATE, "window_duration": 0.05, **_meta(deg)}
    _monitor_bag(tmp_path / "bag", [Window.from_matrix(_rows(c), meta=meta) for c in range(8)])
    code, out, err = run_cli(capsys, "prognose", str(tmp_path / "bag"))
    assert code == 0, err
    assert "friction reaches its threshold at cycle 8" in out
    assert "-inf" not in out
    assert "relative accuracy at lambda 0.5: n/a (no finite median RUL predicted at lambda" in out
