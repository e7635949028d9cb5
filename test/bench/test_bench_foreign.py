"""bench/bench_foreign.py: the foreign population, its seeds, its units and its report."""

from __future__ import annotations

import sys

import pytest

from bench import bench_foreign as bf
from bench.harness import KEEP_MARKER, read_rows
from bench.harness import foreign as fd
from bench.harness.scenarios import cases, hangar, unit_runs
from bench.prog.plan import run_seed
from ema_phm.physics.tolerances import Tolerances
from ema_phm.simulator.unit import Unit

#: The largest unit seed any other benchmark draws with `Unit.draw` at its defaults or as
#: documented (bench_robust 0-19, bench_commissioning_guard 0-39, healthy_level 10.., the
#: prognostics plan 100 + trajectories) -- with ample room.
OTHER_UNIT_SEEDS_BELOW = 1000
#: numpy stream numbers the other benchmarks and the fleet generator use with a seed.
OTHER_STREAMS = {7, 11, 23, 31, 37}


def test_seeds_are_disjoint_from_every_other_benchmark():
    assert fd.FIRST_SEED >= OTHER_UNIT_SEEDS_BELOW
    assert {fd.UNIT_STREAM, fd.HANGAR_STREAM, fd.WINDOW_STREAM}.isdisjoint(OTHER_STREAMS)
    assert len({fd.UNIT_STREAM, fd.HANGAR_STREAM, fd.WINDOW_STREAM}) == 3
    # the noise seeds others simulate with, for any unit or trajectory below 1000
    top = OTHER_UNIT_SEEDS_BELOW - 1
    others = [s for s, _ in unit_runs(cases(), top, 10)]
    others += [1000 * top + 900 + b for b in range(len(hangar(top)))]  # hangar_windows
    others.append(run_seed(top, 500))  # prognostics: trajectory t, cycle c
    assert max(others) < fd.SIM_SEED_BASE


def test_in_spec_classification_on_hand_made_units():
    bands = Tolerances.load().bands
    assert fd.in_spec(Unit(), bands)
    edge = Unit(friction=1.0 + bands["friction"], inertia=1.0 - bands["inertia"])
    assert fd.in_spec(edge, bands)  # band edges are inside
    assert fd.outside_bands(Unit(friction=1.0 + 1.05 * bands["friction"]), bands) == ["friction"]
    assert fd.in_spec(Unit(position_offset=bands["position_offset"]), bands)
    out = Unit(position_offset=-1.5 * bands["position_offset"], damping=0.5)
    assert fd.outside_bands(out, bands) == ["damping", "position_offset"]
    assert not fd.in_spec(out, bands)


def test_drawn_kinds_land_where_they_should():
    bands = Tolerances.load().bands
    for i in range(16):
        kind, unit = fd.draw_unit(i, fd.FIRST_SEED, bands)
        assert kind == fd.KIND_CYCLE[i % len(fd.KIND_CYCLE)]
        if kind in ("corner", "inside"):
            assert fd.in_spec(unit, bands), (i, unit)
        if kind == "corner":
            moved = [k for k, v in unit.as_dict().items() if v not in (0.0, 1.0)]
            assert 3 <= len(moved) <= 4
        if kind == "wide":
            assert not fd.in_spec(unit, bands), (i, unit)


def test_environments_are_off_the_envelope_and_fine_position_noise_is_drawn():
    envs = [fd.window_env(i, j) for i in range(6) for j in range(1, 10)]
    assert min(e["temperature_c"] for e in envs) < -20.0  # below the envelope's -20
    assert max(e["temperature_c"] for e in envs) > 70.0  # above its +70
    fine = [e for e in envs if e["noise"]["noise_position"] <= fd.FINE_POSITION[1]]
    assert fine and all(e["noise"]["noise_position"] >= fd.FINE_POSITION[0] for e in fine)
    assert {e["load"]["kind"] for e in envs} == set(fd.LOAD_KINDS)
    day = fd.hangar(0)
    assert day["noise"]["noise_position"] <= fd.FINE_POSITION[1]  # unit 0: fine sensor
    assert len({(e["temperature_c"]) for e in day["baselines"]}) == 2


def test_wilson_interval():
    lo, hi = bf.wilson(0, 10)
    assert lo == 0.0 and 0.25 < hi < 0.35
    lo, hi = bf.wilson(10, 10)
    assert hi == pytest.approx(1.0) and 0.65 < lo < 0.75
    assert bf.rate(1, 4).startswith("1/4 (25 %;")
    assert bf.rate(0, 0) == "-"


def test_quick_run_end_to_end_writes_rows_and_every_table(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["bench_foreign", "--quick", "--out", str(tmp_path)])
    assert bf.main() == 0
    data = read_rows(tmp_path / "bench_foreign_quick.json")
    assert data["quick"] and "machine" in data and data["command"].endswith("--quick")
    assert [u["kind"] for u in data["units"]] == ["corner", "wide", "inside"]
    rows = [r for u in data["units"] for r in u["rows"]]
    assert len(rows) == 3 * 3 * 2  # 3 units x (healthy, friction, short circuit B) x 2 modes
    assert all("k" in r and "explained" in r for r in rows)
    md = (tmp_path / "benchmarks_foreign_quick.md").read_text()
    for heading in (
        "(--quick run",
        "## Commissioning",
        "## Headline",
        "## Beside the tuned population",
        "## Per fault",
        "## By the operating window's user-position noise",
        "## By load profile",
        "## Units",
        KEEP_MARKER,
    ):
        assert heading in md, heading
    # the hand-written part survives a rewrite from the rows
    (tmp_path / "benchmarks_foreign_quick.md").write_text(md + "hand-written note\n")
    monkeypatch.setattr(
        sys, "argv", ["bench_foreign", "--quick", "--report-only", "--out", str(tmp_path)]
    )
    assert bf.main() == 0
    again = (tmp_path / "benchmarks_foreign_quick.md").read_text()
    assert again.endswith("hand-written note\n") and again.count(KEEP_MARKER) == 1


@pytest.mark.parametrize("accepted", [True, False])
def test_refusal_kinds(accepted):
    said = {
        "accepted": accepted,
        "refused_at": None if accepted else "fit",
        "problems": []
        if accepted
        else ["the commissioned unit is not explained: its recorded fit leaves model error 1"],
    }
    assert bf.refusal(said) == ("accepted" if accepted else "not explained, recorded loop")
