"""Scoring logic of bench/bench_prognostics.py (bench/prog/) on synthetic rows (no isolation)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.prog import compare
from bench.prog import plan as plan_mod
from bench.prog import report as report_mod
from ema_phm.domain.faults import NAMES, NOMINAL, PREDICTED
from ema_phm.simulator.degradation import Degradation


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
                "adequacy_ok": True,
                "adequacy_statistic": 1.0,
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


FRICTION = {"friction": {"law": "linear", "onset": 2, "initial": 0.0, "rate": 0.0125}}


def test_plan_is_seeded_balanced_and_lives_in_range():
    a, b = plan_mod.plan(100), plan_mod.plan(100)
    assert a == b and a != plan_mod.plan(101)
    degrading = [tr for tr in a if tr["type"] in plan_mod.TYPES]
    assert len(degrading) == plan_mod.PER_TYPE * len(plan_mod.TYPES) >= 60
    assert sum(tr["type"] == "healthy" for tr in a) == plan_mod.HEALTHY >= 20
    for kind in plan_mod.TYPES:
        idx = [tr["index"] for tr in degrading if tr["type"] == kind]
        assert sum(i % 2 for i in idx) == len(idx) // 2  # as many held out as tuned on
    for tr in degrading:
        for name, eol in tr["true_eol"].items():
            assert eol == tr["target_life"][name]  # the rate reaches 0.4 at the drawn life
            assert plan_mod.LIFE_CYCLES[0] <= eol <= plan_mod.LIFE_CYCLES[1]
        assert tr["cycles"] == max(tr["true_eol"].values())
    steady = [tr for tr in a if tr["type"] == "steady"]
    assert len(steady) == plan_mod.STEADY and all(not tr["true_eol"] for tr in steady)
    for tr in steady:  # one fault present from cycle 0 that never grows
        deg = Degradation.from_mapping(tr["degradation"])
        (name,) = [n for n in tr["degradation"]["faults"] if n != "eccentricity_phase"]
        i = plan_mod.STEADY_FAULTS.index(name)
        level = deg.k(0)[[0, 1, 2, 5][i]]
        assert plan_mod.STEADY_SEVERITY[0] <= level <= plan_mod.STEADY_SEVERITY[1]
        assert np.array_equal(deg.k(0), deg.k(tr["cycles"] - 1))


class Exact:
    """A point predictor that knows the truth: RUL = the true RUL of every growing fault."""

    def __init__(self, eol: dict[str, int], off: float = 0.0) -> None:
        self.eol, self.off = eol, off

    def predict(self, history, *, seed=0):
        from ema_phm.prognostics.rul import FaultPrognosis, Percentiles, Prognosis

        c = float(history.cycles[-1])
        faults = []
        for i in PREDICTED:
            name = NAMES[i]
            if name not in self.eol:
                faults.append(FaultPrognosis(i, "no_degradation", "", 0.4, 0.0))
                continue
            r = max(self.eol[name] - c, 0.0) * (1.0 + self.off)
            pct = Percentiles(r, r, r)
            faults.append(
                FaultPrognosis(
                    i,
                    "degrading",
                    "",
                    0.4,
                    0.0,
                    rul_cycles=pct,
                    rul_hours=pct,
                    samples=np.array([r]),
                )
            )
        return Prognosis(c, 1.0, 10.0, True, tuple(faults))


def test_a_predictor_that_knows_the_truth_meets_every_metric_and_one_off_by_half_none():
    tr = synthetic("friction", FRICTION)
    assert tr["true_eol"] == {"friction": 34}
    ws = rows(tr, noise=0.005, half=0.02)
    s = compare.score_trajectory(tr, ws, Exact(tr["true_eol"]))
    h = compare.history_metrics(s.points["friction"], 34)
    assert h["predictions"] == 34 and h["ph"] == h["ph_stays"] == 1.0 and h["al50"] and h["al75"]
    assert h["cone"] == (8, 8)  # cycles 17..24: from lambda 0.5, true RUL >= 10
    assert h["ra50"] == 1.0 and h["covered"] == (34, 34)
    off = compare.score_trajectory(tr, ws, Exact(tr["true_eol"], off=0.5))
    h = compare.history_metrics(off.points["friction"], 34)
    assert h["ph"] < 0.5 and not h["al50"] and not h["al75"] and h["cone"][0] == 0
    assert h["ph_stays"] <= h["ph"]
    assert h["ra50"] == pytest.approx(0.5)


def test_ph_stays_waits_for_the_last_swing_out_of_the_band():
    P = compare.Point
    # true end of life 20: in band at cycles 2 and 6-9, out at 3-5
    pts = [P(c, True, cone=0.0, band=1.0 if c in (2, 6, 7, 8, 9) else 0.0) for c in range(10)]
    h = compare.history_metrics(pts, 20)
    assert h["ph"] == pytest.approx(18 / 20) and h["ph_stays"] == pytest.approx(14 / 20)


def test_windows_the_model_does_not_explain_are_not_prediction_times():
    tr = synthetic("friction", FRICTION)
    ws = rows(tr, noise=0.005, half=0.02)
    for w in ws[::3]:
        w["adequacy_ok"] = False
    s = compare.score_trajectory(tr, ws, Exact(tr["true_eol"]))
    assert [p.cycle for p in s.points["friction"]] == [w["cycle"] for w in ws if w["adequacy_ok"]]


def test_the_project_model_on_clean_estimates_scores_well_and_raises_no_alarm():
    from ema_phm.monitor.predictor import RulPredictor

    tr = synthetic("friction", FRICTION, index=1)
    he = synthetic("healthy", {}, index=3)
    scored = [
        compare.score_trajectory(tr, rows(tr, noise=0.005, half=0.02), RulPredictor()),
        compare.score_trajectory(he, rows(he, noise=0.005, half=0.02, seed=3), RulPredictor()),
    ]
    s = compare.summary(scored)
    assert s["histories"] == 1 and s["ph_median"] >= 0.5
    assert s["al50"] == (1, 1)
    assert s["healthy_warn"] == (0, 1) and s["healthy_rul"] == (0, 1)
    assert s["still_warn"] == (0, 5)  # the 5 other faults of the friction life
    assert s["coverage"][1] > 0 and s["update_ms_median"] > 0


def test_a_healthy_life_whose_estimate_climbs_is_a_false_alarm():
    from ema_phm.monitor.predictor import RulPredictor

    he = synthetic("healthy", {}, index=1)
    ws = rows(he, noise=0.005, half=0.02, seed=3)
    for w in ws:
        if w["cycle"] >= 10:
            w["k"][2] = 0.03 * (w["cycle"] - 9)
            w["k_interval"][2] = [max(w["k"][2] - 0.02, 0.0), w["k"][2] + 0.02]
    s = compare.score_trajectory(he, ws, RulPredictor())
    assert compare.warned(s.points["short_circuit_a"])
    assert compare.summary([s])["healthy_warn"] == (1, 1)


def test_warned_needs_the_alarm_windows_in_a_row():
    P = compare.Point
    pts = [P(0, True, 5.0), P(1, False), P(2, True, 5.0), P(3, True, 4.0), P(4, True, 50.0)]
    assert compare.warned(pts) == [3]


def test_tuning_lives_read_the_even_half_only_and_stop_at_the_end_of_life():
    from bench.prog import lives

    tr0 = synthetic("friction", FRICTION, index=0)
    tr1 = synthetic("friction", FRICTION, index=1)
    data = {"plan": [tr0, tr1], "windows": rows(tr0, noise=0.005, half=0.02)}
    data["windows"] += [dict(w, trajectory=1) for w in data["windows"]]
    got = lives.tuning_lives(data)
    assert len(got) == 1 and got[0][0] == "friction" and got[0][2] == 0
    assert got[0][1].n == 34 and got[0][1].cycles[-1] == 33
    assert len(lives.tuning_lives(data, parity=1)) == 1


def test_the_particle_filter_finds_a_linear_growth_and_ignores_a_flat_fault():
    from bench.prog import particle
    from ema_phm.prognostics.rul import History

    rng = np.random.default_rng(0)
    cycles = np.arange(25.0)
    k = np.tile(NOMINAL, (25, 1))
    k[:, 0] = np.clip(0.0125 * (cycles - 2), 0, 1) + rng.normal(0, 0.005, 25).clip(0)
    prog = particle.ParticleFilter().predict(History.from_estimates(cycles, k), seed=1)
    f = prog.fault("friction")
    assert f.status == "degrading" and 4 <= f.rul_cycles.p50 <= 14  # true RUL 34 - 24 = 10
    assert prog.fault("backlash").status == "no_degradation"


def test_cycles_as_ranges():
    assert report_mod._cycles([3, 4, 5, 7, 9, 10]) == "3-5, 7, 9-10"
    assert report_mod._cycles([]) == ""


def test_severity_bias_is_the_median_relative_error_per_trajectory():
    from bench.prog import bias as bias_mod

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
    from bench.prog import baseline as base
    from ema_phm.prognostics.rul import History

    cycles = np.arange(11.0)
    k = np.tile(NOMINAL, (11, 1))
    k[:, 0] = 0.01 * cycles  # friction grows 0.01 a cycle: 0.1 at cycle 10, 0.4 at cycle 40
    k[:6, 0] = 0.3  # early estimates off the line: only the last five count
    hist = History.from_estimates(cycles, k, k, k)
    prog = base.Line(5).predict(hist)
    f = prog.fault("friction")
    assert f.status == "degrading" and f.rul_cycles.p50 == 30
    assert prog.fault("backlash").status == "no_degradation"
    assert base.Line(5).predict(hist.upto(4)).fault("friction").status == "insufficient_data"
    # the log-line through 0.05 * 1.1^c reaches 0.4 where 1.1^c = 8: c = 21.8 -> 12 after 10
    k[:, 0] = 0.05 * 1.1**cycles
    f = base.Line(10, log=True).predict(History.from_estimates(cycles, k)).fault("friction")
    assert f.status == "degrading" and f.rul_cycles.p50 == 12
