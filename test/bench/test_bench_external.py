"""bench/external/motulator_ema.py and bench/bench_external.py: motulator playing the actuator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench import bench_external
from bench.harness import ROOT
from ema_phm.domain.faults import NOMINAL, k_with
from ema_phm.errors import ConfigError
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator_file import load_actuator
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema

SMALL_PI = ROOT / "config" / "actuators" / "small_pi_ema.yaml"
#: A short window keeps the motulator runs to a few seconds.
SHORT = CommandSpec(duration=0.3)
#: Healthy I_3eq of motulator against our averaged HF on SHORT: RMS difference at most this
#: share of the HF's RMS current (measured 0.18: the two current controllers and friction
#: laws differ, most in the start-up transient).
AGREEMENT = 0.25


def _mot():
    pytest.importorskip(
        "motulator", reason="motulator is a benchmark-only dependency (requirements.txt)"
    )
    from bench.external import motulator_ema

    return motulator_ema


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture(scope="module")
def healthy():
    mot = _mot()
    return mot.simulate(load_actuator(SMALL_PI), command=SHORT)


def test_motulator_window_is_valid_telemetry_of_a_healthy_actuator(healthy):
    w = healthy.validated()
    assert w.n == 601 and w.dt == pytest.approx(5e-4)
    np.testing.assert_array_equal(w.k_true, NOMINAL)
    assert np.all(np.isfinite(w.load)) and np.all(w.temperature == 20.0)
    # the position loop follows the command, the resolver turns with the user shaft
    assert _rms(w.theta_u - w.command) < 0.2 * _rms(w.command)
    gear = load_actuator(SMALL_PI).mechanics.gear_ratio
    assert _rms(w.theta_u - gear * w.theta_m) < 0.02 * _rms(w.theta_u)


def test_healthy_current_agrees_with_our_hf_within_the_stated_bound(healthy):
    averaged = load_actuator(SMALL_PI).with_values({"current_loop.pwm": 0.0})
    hf = real_ema.simulate(NOMINAL, actuator=averaged, command=SHORT, temperature_c=20.0).window
    assert _rms(healthy.i3eq - hf.i3eq) < AGREEMENT * _rms(hf.i3eq)
    # the positions agree far closer (measured 0.1 %): the same loops on the same mechanics
    assert _rms(healthy.theta_u - hf.theta_u) < 0.01 * _rms(hf.theta_u)


def test_a_friction_fault_raises_the_current(healthy):
    mot = _mot()
    faulty = mot.simulate(load_actuator(SMALL_PI), command=SHORT, faults=mot.Faults(friction=2.2))
    assert _rms(faulty.i3eq) > 1.5 * _rms(healthy.i3eq)
    np.testing.assert_allclose(faulty.k_true, k_with(friction=0.6))


def test_an_unmeasured_load_leaves_the_load_channel_nan_and_k_healthy():
    mot = _mot()
    w = mot.simulate(
        load_actuator(SMALL_PI), command=CommandSpec(duration=0.05), faults=mot.Faults(load_nm=3)
    )
    assert np.all(np.isnan(w.load))
    np.testing.assert_array_equal(w.k_true, NOMINAL)


def test_faults_map_to_k_only_where_k_has_an_entry():
    mot = _mot()
    np.testing.assert_allclose(
        mot.Faults(friction=1.6, gain=1.2).k_true(), k_with(friction=0.3, gain_drift=0.7)
    )
    np.testing.assert_array_equal(mot.Faults(damping=10.0, inertia=1.3).k_true(), NOMINAL)
    with pytest.raises(ConfigError):
        mot.Faults(friction=4.0).k_true()


def test_the_hysteresis_kind_is_refused():
    mot = _mot()
    with pytest.raises(ConfigError, match="pi_dq_current"):
        mot.simulate(load_actuator(None), command=SHORT)


def _row(kind: str, **kw) -> dict:
    row = {"kind": kind, "fault": kw.pop("fault", ""), "scenario": kw.pop("scenario", "x")}
    return row | {"adequate": True, "level": "OK", "named": "", "dominant": "friction"} | kw


def test_the_report_scores_named_withheld_and_outside_k_verdicts():
    bench = bench_external
    rows = [
        _row("healthy"),
        _row("healthy", level="WARN", named="friction"),
        _row(
            "in_k",
            fault="friction",
            level="WARN",
            named="friction",
            percent_err=2.0,
            k=list(k_with(friction=0.28)),
            k_true=list(k_with(friction=0.3)),
        ),
        _row("in_k", fault="gain_drift", level="WARN", named="friction", percent_err=9.0),
        _row("outside", scenario="viscous damping x10", adequate=False, percent_err=30.0),
        _row("outside", scenario="inertia x1.3", level="WARN", dominant="gain_drift"),
    ]
    s = bench.summary(rows)
    assert (s["healthy_ok"], s["healthy"]) == (1, 2)
    assert (s["named_right"], s["in_k"]) == (1, 2)
    assert s["err_median"] == pytest.approx(5.5)  # the in-k windows only
    assert s["own_median"] == pytest.approx(2.0)  # k1 alone, in points, where k is stored
    assert (s["withheld"], s["faulty"]) == (1, 4)
    assert s["outside"] == {"viscous": "not explained", "inertia": "WARN gain_drift"}
    assert bench.outcome({"error": "no excitation"}) == "refused (excitation)"
    assert math.isnan(bench.summary([_row("healthy")])["err_median"])


def _data(rows: list[dict], command: str, wall: float) -> dict:
    return {"rows": rows, "commissioning": {}, "current": {}, "command": command, "wall_s": wall}


def test_merge_adds_only_the_rows_it_lacks_and_sums_the_wall_times():
    bench = bench_external
    key = {"simulator": "hf", "config": "small_pi 800 Hz", "scenario": "healthy #1"}
    mine = _data([key | {"commissioned": False, "level": "OK"}], "a", 10.0)
    other = _data(
        [key | {"commissioned": False, "level": "WARN"}, key | {"commissioned": True}], "b", 5.0
    )
    merged = bench.merge(mine, other)
    assert [(r["commissioned"], r.get("level")) for r in merged["rows"]] == [
        (False, "OK"),
        (True, None),
    ]
    assert merged["wall_s"] == 15.0 and merged["merged"] == ["b"]


def test_the_report_renders_the_targets_from_stored_rows():
    bench = bench_external
    base = {"simulator": "motulator", "config": "small_pi 800 Hz", "commissioned": True}
    rows = [
        base | _row("healthy", scenario="healthy #1", percent_err=1.0, wall_s=2.0),
        base | _row("in_k", scenario="friction k1=0.3", fault="friction", level="WARN",
                    named="friction", percent_err=2.0, wall_s=2.0),
        base | _row("outside", scenario="viscous damping x10", level="WARN", dominant="friction",
                    named="friction", wall_s=2.0),
    ]  # fmt: skip
    data = _data(rows, ".venv/bin/python -m bench.bench_external", 60.0)
    data |= {"machine": {"cpu": "x", "cores": 2, "python": "3", "numba": "0", "numpy": "2"}}
    data |= {"motulator": "0.5.0", "commit": "abc", "dirty": False}
    text = bench.report(data)
    assert "| small_pi 800 Hz | met | met | met | **not met** |" in text
    assert "WARN friction" in text and "1 min of process wall time" in text


def test_the_thesis_pi_drive_is_described_by_a_user_file_without_levels(tmp_path, monkeypatch):
    """Issue 33 item 6: the monitor reads a file a user wrote (no high_fidelity, no levels)."""
    bench = bench_external
    monkeypatch.setattr(bench, "CACHE", tmp_path)
    actuator = bench.actuator_of("thesis_pi", 800.0)
    told = bench.described("thesis_pi", actuator)
    assert not told.simulable and told.current_loop.bandwidth_hz == 800.0
    assert told.controller_kind == actuator.controller_kind
    text = (tmp_path / "described" / "thesis_pi_800.yaml").read_text()
    assert "high_fidelity" not in text and "healthy_fitness" not in text
    assert MonitorBelief.for_actuator(told).own_levels == set()
    small = bench.actuator_of("small_pi", 800.0)
    assert bench.described("small_pi", small) is small  # the packaged file, its levels its own
