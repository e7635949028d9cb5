"""Scoring logic of bench/bench_prognostics.py (bench/prog/) on synthetic rows (no isolation)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

plan_mod = pytest.importorskip("prog.plan")
score_mod = pytest.importorskip("prog.score")
report_mod = pytest.importorskip("prog.report")

from ema_phm.domain.faults import N_K, NOMINAL, PREDICTED  # noqa: E402
from ema_phm.physics.degradation import Degradation  # noqa: E402


def rows(tr: dict, *, noise: float, half: float, seed: int = 0, bias: float = 0.0) -> list[dict]:
    """Per-window rows as --isolate stores them: truth plus noise (and a bias), +/- half."""
    deg = Degradation.from_mapping(tr["degradation"])
    rng = np.random.default_rng(seed)
    out = []
    for c in range(tr["cycles"]):
        kt = deg.k(c)
        k = kt.copy()
        p = list(PREDICTED)
        k[p] = np.clip(k[p] + bias + rng.normal(0.0, noise, len(p)), 0.0, 1.0)
        iv = [[max(v - half, 0.0), min(v + half, 1.0)] for v in k]
        out.append(
            {
                "trajectory": tr["index"],
                "cycle": c,
                "k_true": kt.tolist(),
                "k": k.tolist(),
                "k_interval": iv,
            }
        )
    return out


def synthetic(kind: str, faults: dict, index: int = 0) -> dict:
    deg = Degradation.from_mapping({"faults": faults})
    eol = {n: deg.first_cycle_at(n, plan_mod.THRESHOLD) for n in plan_mod.TYPE_FAULTS[kind]}
    return {
        "index": index,
        "type": kind,
        "unit_seed": 0,
        "degradation": deg.as_dict(),
        "true_eol": eol,
        "cycles": max(eol.values()) if eol else 20,
    }


def test_plan_is_seeded_balanced_and_lives_in_range():
    a, b = plan_mod.plan(100), plan_mod.plan(100)
    assert a == b and a != plan_mod.plan(101)
    degrading = [tr for tr in a if tr["type"] != "healthy"]
    assert len(degrading) == plan_mod.PER_TYPE * len(plan_mod.TYPES)
    assert len(a) - len(degrading) == plan_mod.HEALTHY
    for kind in plan_mod.TYPES:
        idx = [tr["index"] for tr in degrading if tr["type"] == kind]
        assert sum(i % 2 for i in idx) == len(idx) // 2  # as many held out as tuned on
    for tr in degrading:
        for name, eol in tr["true_eol"].items():
            assert eol == tr["target_life"][name]  # the rate reaches 0.4 at the drawn life
            assert plan_mod.LIFE_CYCLES[0] <= eol <= plan_mod.LIFE_CYCLES[1]
        assert tr["cycles"] == max(tr["true_eol"].values())


def test_exact_estimates_score_well_and_the_window_count_matches_alpha_lambda_from():
    tr = synthetic(
        "friction", {"friction": {"law": "linear", "onset": 2, "initial": 0.0, "rate": 0.0125}}
    )
    assert tr["true_eol"] == {"friction": 34}
    s = score_mod.score_trajectory(tr, rows(tr, noise=0.005, half=0.02))
    f = s["faults"]["friction"]
    assert f["predictions"] == 34
    assert f["first_rul_cycle"] is not None and f["first_rul_cycle"] < 17
    assert f["prognostic_horizon_cycles"] / 34 >= 0.5
    met, n = f["al_windows"]
    assert n == 17  # cycles 17..33: from lambda 0.5 of the life (first window cycle 0)
    assert f["alpha_lambda_from_lambda"] is (met == n)
    assert f["interval_coverage_90"] > 0.5
    # no other fault gets a RUL from estimates that do not grow
    assert not any(a["degrading"] for n_, a in s["alarms"].items() if n_ != "friction")


def test_biased_low_estimates_make_the_rul_long():
    tr = synthetic(
        "friction", {"friction": {"law": "linear", "onset": 2, "initial": 0.0, "rate": 0.0125}}
    )
    good = score_mod.score_trajectory(tr, rows(tr, noise=0.005, half=0.02))["faults"]["friction"]
    ws = rows(tr, noise=0.005, half=0.02)
    for w in ws:  # estimates 30 % below the truth, as a monitor that under-reads
        w["k"][0] = 0.7 * w["k_true"][0]
        w["k_interval"][0] = [max(w["k"][0] - 0.02, 0.0), w["k"][0] + 0.02]
    low = score_mod.score_trajectory(tr, ws)["faults"]["friction"]
    last_good, last_low = good["rul"][-1], low["rul"][-1]
    assert last_low[2] > last_good[2]  # median RUL at the last window
    errs = score_mod._rul_errors(low, 34)
    assert np.median(errs["rel"]) > 0.2


def test_headline_counts_healthy_alarms_and_pools_coverage():
    fr = synthetic(
        "friction",
        {"friction": {"law": "linear", "onset": 2, "initial": 0.0, "rate": 0.0125}},
        index=0,
    )
    he = synthetic("healthy", {}, index=1)
    h_rows = rows(he, noise=0.005, half=0.02, seed=3)
    scored = [
        score_mod.score_trajectory(fr, rows(fr, noise=0.005, half=0.02)),
        score_mod.score_trajectory(he, h_rows),
    ]
    h = score_mod.headline(scored, {0: fr, 1: he})
    f = scored[0]["faults"]["friction"]
    assert h["trajectories"] == 1 and h["healthy"] == 1
    assert h["healthy_warn"] == 0 and h["healthy_degrading"] == 0
    assert h["coverage"] == pytest.approx(f["interval_coverage_90"])
    assert h["coverage_windows"] == f["windows_with_rul"]
    assert h["others"] == 5  # the five other predicted faults of a single-fault trajectory
    # a healthy history whose k3 climbs at the end is a RUL alarm
    for w in h_rows:
        if w["cycle"] >= 10:
            w["k"][2] = 0.03 * (w["cycle"] - 9)
            w["k_interval"][2] = [max(w["k"][2] - 0.02, 0.0), w["k"][2] + 0.02]
    alarmed = score_mod.score_trajectory(he, h_rows)
    assert alarmed["alarms"]["short_circuit_a"]["warn"]
    h2 = score_mod.headline([alarmed], {1: he})
    assert h2["healthy_warn"] == 1


def test_history_widens_an_interval_that_misses_its_estimate():
    tr = synthetic("healthy", {}, index=0)
    ws = rows(tr, noise=0.0, half=0.01)[:3]
    ws[1]["k"][0] = 0.2  # outside [0, 0.01]
    hist, _ = score_mod.history_of(ws)
    assert hist.k_high[1, 0] == pytest.approx(0.2)
    rest = [i for i in range(N_K) if i not in PREDICTED]  # no RUL: no estimate to move
    assert np.all(hist.k[:, rest] == NOMINAL[rest])


def test_cycles_as_ranges():
    assert report_mod._cycles([3, 4, 5, 7, 9, 10]) == "3-5, 7, 9-10"
    assert report_mod._cycles([]) == ""


def test_severity_bias_is_the_median_relative_error_per_trajectory():
    bias_mod = pytest.importorskip("prog.bias")
    tr = synthetic(
        "friction", {"friction": {"law": "linear", "onset": 0, "initial": 0.0, "rate": 0.02}}
    )
    ws = rows(tr, noise=0.0, half=0.05)
    for w in ws:  # estimates 10 % high where the truth is past the bias section's floor
        w["k"][0] = 1.1 * w["k_true"][0]
    for w in ws[::2]:  # windows not explained add nothing
        w["adequacy_ok"], w["k"][0] = False, 0.0
    got = bias_mod.per_trajectory({"plan": [tr], "windows": ws})
    assert list(got) == ["friction"] and got["friction"][0] == pytest.approx(10.0)
    assert "| friction | 1 | +10.0 |" in "\n".join(bias_mod.lines({"plan": [tr], "windows": ws}))


def test_the_straight_line_baseline_extrapolates_the_last_five_severities():
    base = pytest.importorskip("prog.baseline")
    from ema_phm.prognostics.rul import History

    cycles = np.arange(11.0)
    k = np.tile(NOMINAL, (11, 1))
    k[:, 0] = 0.01 * cycles  # friction grows 0.01 a cycle: 0.1 at cycle 10, 0.4 at cycle 40
    k[:6, 0] = 0.3  # early estimates off the line: only the last five count
    hist = History.from_estimates(cycles, k, k, k)
    prog = base.straight_line(hist, cycle_hours=2.0)
    f = prog.fault("friction")
    assert f.status == "degrading" and f.rul_cycles.p50 == 30 and f.rul_hours.p50 == 60
    assert prog.fault("backlash").status == "no_degradation"
    assert base.straight_line(hist.upto(4)).fault("friction").status == "insufficient_data"
