"""bench/prog/foreign_lives.py: lives off the prognostics benchmark's map, and its CLI."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from bench import bench_foreign_lives as bfl
from bench.harness import foreign as fd
from bench.harness import read_rows
from bench.prog import compare, ideal
from bench.prog import foreign_lives as fl
from bench.prog import plan as tuned_plan
from ema_phm.domain.faults import NAMES, NOMINAL, PREDICTED


def test_every_fault_with_a_rul_grows_by_both_laws():
    trs = fl.plan(per_kind=1, steady=0)
    kinds = {(tr["type"], tr["law"]) for tr in trs}
    assert kinds == {(NAMES[i], law) for i in PREDICTED for law in ("linear", "exponential")}
    # the tuned plan grows each fault by one law only: these lives are off its map
    assert ("friction", "exponential") in kinds and tuned_plan.LAW["friction"] == "linear"


def test_paths_reach_the_threshold_exactly_at_the_drawn_life():
    trs = fl.plan()
    lives = [tr["cycles"] for tr in trs if tr["type"] != "steady"]
    assert min(lives) >= fl.LIFE_CYCLES[0] and max(lives) <= fl.LIFE_CYCLES[1]
    assert max(lives) - min(lives) > 30  # far wider than the tuned plan's 25-45
    for tr in trs:
        if tr["type"] == "steady":
            assert tr["true_eol"] == {} and len(set(*tr["paths"].values())) == 1
            continue
        path = np.array(tr["paths"][tr["type"]])
        life = tr["true_eol"][tr["type"]]
        assert len(path) == life + 1 and tr["cycles"] == life
        assert path[life] >= fl.THRESHOLD > path[life - 1]
        assert np.all(np.diff(path) >= 0)  # growth, never healing
        onset = tr["growth"]["onset"]
        assert np.all(path[:onset] == 0.0) and path[onset] == tr["growth"]["initial"]


def test_rates_walk_and_change_in_mid_life():
    trs = [tr for tr in fl.plan() if tr["type"] != "steady"]
    changed = [tr for tr in trs if "change_factor" in tr["growth"]]
    assert len(changed) == len(trs) // 2  # every other life
    # the same kind appears once with and once without a change
    assert {(t["type"], t["law"]) for t in changed} == {(t["type"], t["law"]) for t in trs}
    tr = next(t for t in trs if t["law"] == "linear" and "change_factor" not in t["growth"])
    steps = np.diff(tr["paths"][tr["type"]][tr["growth"]["onset"] :])
    assert steps.std() / steps.mean() > 0.1  # not a straight line: the rate walks


def test_true_k_sets_the_growing_entry_and_the_eccentricity_phase():
    trs = fl.plan(per_kind=1, steady=0)
    ecc = next(tr for tr in trs if tr["type"] == "eccentricity")
    k = fl.true_k(ecc, ecc["cycles"] - 1)
    i = NAMES.index("eccentricity")
    assert k[i] == pytest.approx(ecc["paths"]["eccentricity"][ecc["cycles"] - 1])
    assert k[NAMES.index("eccentricity_phase")] == ecc["eccentricity_phase"]
    others = [j for j in range(len(k)) if j not in (i, NAMES.index("eccentricity_phase"))]
    assert np.array_equal(k[others], NOMINAL[others])


def test_seeds_are_apart_from_the_foreign_windows_benchmark_and_the_tuned_ones():
    assert fl.FIRST_SEED >= fd.FIRST_SEED + 100  # bench_foreign's default run uses 16 units
    assert fl.LAW_STREAM not in {fd.UNIT_STREAM, fd.HANGAR_STREAM, fd.WINDOW_STREAM}
    assert fl.run_seed(0, 0) > fd.SIM_SEED_BASE + 1000 * 100
    assert fl.plan() == fl.plan()  # deterministic


def test_isolate_then_score_writes_the_report(tmp_path, monkeypatch):
    """The CLI end to end on two short trajectories (one growing, one steady)."""
    argv = ["bench_foreign_lives", "--isolate", "--only", "0,24", "--max-cycles", "2"]
    monkeypatch.setattr(sys, "argv", [*argv, "--out", str(tmp_path)])
    monkeypatch.setattr(bfl, "RESULTS", tmp_path)  # no tuned rows: the foreign table only
    assert bfl.main() == 0
    data = read_rows(tmp_path / "bench_foreign_lives.json")
    assert sorted({w["trajectory"] for w in data["windows"]}) == [0, 24]
    assert len(data["windows"]) == 4 and set(data["units"]) == {"0", "24"}
    monkeypatch.setattr(sys, "argv", ["bench_foreign_lives", "--score", "--out", str(tmp_path)])
    assert bfl.main() == 0
    text = (tmp_path / "benchmarks_foreign_lives.md").read_text()
    assert "## Headline figures over seeds" in text and "| friction | linear | 1 |" in text
    assert "## The tuned population beside it" not in text
    assert "## The ceiling: a forecaster that knows all but the future" in text
    assert "## A fleet that learns from its own lives" in text
    # another plan (other counts) is refused, the stored rows untouched
    monkeypatch.setattr(fl, "PER_KIND", 3)
    monkeypatch.setattr(sys, "argv", ["bench_foreign_lives", "--isolate", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="another plan"):
        bfl.main()
    assert read_rows(tmp_path / "bench_foreign_lives.json") == data


def test_the_ideal_forecaster_regenerates_the_plan_and_is_calibrated():
    """Its future is the plan's own: over many lives the truth falls in its 90 % interval."""
    rng = np.random.default_rng(0)
    trs = [tr for tr in fl.plan(per_kind=2, steady=0)]
    inside = []
    for tr in trs:
        g = tr["growth"]
        t = g["onset"] + (g["life"] - g["onset"]) // 2
        rul = ideal.forecast(tr, t, rng)
        p5, p95 = np.percentile(rul, [5, 95], method="inverted_cdf")
        inside.append(p5 <= g["life"] - t <= p95)
    assert sum(inside) >= 0.8 * len(trs)  # 90 % nominal; 24 lives


def test_the_ceiling_is_scored_on_the_windows_a_method_predicted_at():
    trs = fl.plan(per_kind=1, steady=0)[:2]
    scored = []
    for tr in trs:
        life = tr["growth"]["life"]
        pts = [
            compare.Point(c, True, 1.0, 2.0, 3.0, 0.0, 0.0)
            for c in range(tr["growth"]["onset"] + 1, life)
        ]
        scored.append(
            compare.Scored(tr["index"], tr["type"], {tr["type"]: life}, {tr["type"]: pts})
        )
    c = ideal.ceiling({"plan": trs}, scored)
    assert c["al50"][1] == 2 and c["al75"][1] == 2
    assert 0 < c["coverage_late"][1] <= sum(len(s.points[s.kind]) for s in scored)
