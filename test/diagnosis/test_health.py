"""rclpy-free decision logic of the monitor: health levels, messages and values.

ema_phm.diagnosis.health; no node is spun here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import STATUS_VALUE_KEYS, k_with

from ema_phm.diagnosis import health
from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.errors import ConfigError, FaultVectorError
from ema_phm.monitor import status_texts

K_NOM = NOMINAL.tolist()


# ----------------------------------------------------------------------------- health


def test_severity_is_distance_from_nominal_and_ignores_phase():
    s = health.severity(k_with(k1=0.3, k7=0.0, k8=0.2))
    assert s[0] == pytest.approx(0.3)
    assert s[6] == 0.0  # k7 is a phase: never a severity
    assert s[7] == pytest.approx(0.3)  # |0.2 - 0.5|
    assert health.severity(K_NOM).max() == 0.0
    assert health.severity(k_with(k7=1.0)).max() == 0.0


def test_nominal_is_ok_with_values_for_every_k_and_percent_err():
    a = health.assess(
        K_NOM,
        k_true=K_NOM,
        fitness=0.01,
        evaluations=100,
        elapsed_s=1.5,
        window_t0=2.0,
        window_t1=4.0,
    )
    assert a.level == health.OK
    assert a.message.startswith("OK")
    assert a.percent_err == pytest.approx(0.0)
    st = status_texts.result_status(
        a,
        status_texts.StatusContext(
            hardware_id="hw", counters={"windows_done": 3}, settings={"preset": "de", "seed": 4}
        ),
    )
    keys = [k for k, _ in st.values]
    assert keys[:9] == [f"k{i}" for i in range(1, 9)] + ["percent_err"]
    for key in (*STATUS_VALUE_KEYS, "preset", "seed"):
        assert key in keys
    assert st.value("windows_done") == "3"
    assert st.value("k7") == "0.5"
    assert st.hardware_id == "hw" and st.name == status_texts.STATUS_NAME
    parsed = status_texts.parse_values(st.values)
    assert parsed["evaluations"] == 100 and parsed["seed"] == 4 and parsed["elapsed_s"] == 1.5


@pytest.mark.parametrize(
    "k,level,name",
    [
        (k_with(k1=0.2), health.WARN, "friction"),
        (k_with(k1=0.5), health.ERROR, "friction"),
        (k_with(k2=0.16), health.WARN, "backlash"),
        (k_with(k4=0.9), health.ERROR, "short_circuit_b"),
        (k_with(k6=0.45), health.ERROR, "eccentricity"),
        (k_with(k8=0.38), health.WARN, "gain_drift"),
        (k_with(k8=0.8), health.ERROR, "gain_drift"),
        (k_with(k1=0.1, k7=0.0), health.OK, None),
    ],
)
def test_levels_and_dominant_fault(k, level, name):
    a = health.assess(k)
    assert a.level == level
    assert a.message.startswith(health.LEVEL_NAMES[level])
    if name is not None:
        assert name in a.message.split(";")[0]
        assert a.as_dict()["dominant_fault"] == name
    assert math.isnan(a.percent_err)  # no ground truth
    assert a.as_dict()["percent_err"] is None


def test_message_names_dominant_by_threshold_ratio_and_lists_others():
    # gain drift 0.2 over warn 0.1 (ratio 2) dominates friction 0.25 over warn 0.15 (ratio 1.7)
    a = health.assess(k_with(k1=0.25, k8=0.7))
    assert a.level == health.WARN
    assert a.message.startswith("WARN: gain_drift")
    assert "also friction (WARN)" in a.message


def test_custom_thresholds_and_validation():
    th = health.Thresholds(warn=[0.05] * N_K, error=[0.1] * N_K)
    assert health.assess(k_with(k3=0.07), th).level == health.WARN
    assert health.assess(k_with(k3=0.12), th).level == health.ERROR
    for warn, error, match in [
        ([0.1] * (N_K - 1), [0.2] * N_K, f"{N_K} entries"),
        ([0.3] * N_K, [0.2] * N_K, "warn <= error"),
        ([0.0] * N_K, [0.2] * N_K, "0 < warn"),
        ([math.nan] * N_K, [0.2] * N_K, "finite"),
        (["a"] * N_K, [0.2] * N_K, f"{N_K} numbers"),
    ]:
        with pytest.raises(ConfigError, match=match):
            health.Thresholds(warn, error)
    health.Thresholds(
        [0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -5.0, 0.1], [0.2] * N_K
    )  # k7 entries are ignored


def test_bad_k_is_a_fault_vector_error():
    with pytest.raises(FaultVectorError):
        health.assess([0.1] * (N_K - 1))


def test_failure_busy_waiting_statuses():
    ctx = status_texts.StatusContext(counters={"isolation_failures": 1})
    last = health.assess(k_with(k1=0.2))
    f = status_texts.failure_status("RuntimeError: boom\nsecond line", ctx, last, 0.0, 2.0)
    assert f.level == health.ERROR
    assert "isolation failed" in f.message and "RuntimeError: boom second line" in f.message
    assert f.value("k1") == "0.2" and f.value("isolation_failures") == "1"
    assert "RuntimeError" in f.value("last_error")
    f0 = status_texts.failure_status("x", ctx)
    assert f0.value("k1") == "nan" and f0.value("percent_err") == "nan"
    w = status_texts.waiting_status(ctx)
    assert w.level == health.OK and "waiting" in w.message
    prev = status_texts.result_status(last, ctx)
    b = status_texts.busy_status(prev, last, ctx, window_t0=2.0, window_t1=4.0, evaluations=120)
    assert (
        b.level == health.WARN
        and b.message.startswith("isolating…")
        and "120 evaluations" in b.message
    )
    assert (
        status_texts.busy_status(None, None, ctx, window_t0=0, window_t1=2, evaluations=0).level
        == health.OK
    )


def test_health_vector_layout():
    a = health.assess(
        k_with(k2=0.3),
        k_true=k_with(k2=0.3),
        fitness=0.5,
        evaluations=7,
        elapsed_s=0.25,
        window_t0=4.0,
        window_t1=6.0,
    )
    v = a.vector()
    assert v.shape == (len(health.HEALTH_FIELDS),) == (34,)
    d = dict(zip(health.HEALTH_FIELDS, v, strict=True))
    assert d["k2"] == 0.3 and d["percent_err"] == 0.0 and d["evaluations"] == 7
    assert d["window_t0"] == 4.0 and d["window_t1"] == 6.0 and d["level"] == health.WARN
    assert health.HEALTH_LABEL.split(",") == list(health.HEALTH_FIELDS)
    # without a prognosis the RUL fields are NaN and no fault dominates
    assert all(np.isnan(d[f]) for f in health.HEALTH_RUL_FIELDS[:-1]) and d["rul_dominant"] == 0.0
    d = dict(
        zip(health.HEALTH_FIELDS, a.vector({"rul_k1_p50": 7.0, "rul_dominant": 1.0}), strict=True)
    )
    assert d["rul_k1_p50"] == 7.0 and d["rul_dominant"] == 1.0 and np.isnan(d["rul_k1_p5"])


# ------------------------------------------------------------ issue 7: staleness, excitation


def test_stale_decision_is_a_function_of_telemetry_age():
    assert not status_texts.is_stale(0.0, 5.0)
    assert not status_texts.is_stale(5.0, 5.0)
    assert status_texts.is_stale(5.01, 5.0)
    assert status_texts.is_stale(math.nan, 5.0)  # unknown age: stale


def test_current_status_goes_stale_and_back_to_the_last_result():
    ctx = status_texts.StatusContext(hardware_id="hw", counters={"windows_done": 1})
    a = health.assess(k_with(k1=0.5), window_t0=0.0, window_t1=2.0)
    last = status_texts.result_status(a, ctx)
    fresh = status_texts.current_status(
        last, telemetry_age_s=1.0, stale_timeout_s=5.0, ctx=ctx, last=a
    )
    assert fresh is last
    stale = status_texts.current_status(
        last, telemetry_age_s=7.25, stale_timeout_s=5.0, ctx=ctx, last=a
    )
    assert stale.level == health.STALE and stale.message.startswith(
        "STALE: no telemetry for 7.2 s"
    )
    assert "stale_timeout 5 s" in stale.message
    assert stale.value("stale") == "true" and stale.value("k1") == last.value("k1")
    back = status_texts.current_status(
        last, telemetry_age_s=0.1, stale_timeout_s=5.0, ctx=ctx, last=a
    )
    assert back is last and back.level == health.ERROR


def test_not_excited_status_is_ok_and_claims_nothing():
    ctx = status_texts.StatusContext(counters={"windows_not_excited": 2})
    st = status_texts.not_excited_status("command RMS 0 rad < 1e-3 rad", ctx, 2.0, 4.0)
    assert st.level == health.OK
    assert st.message == (
        "not enough excitation on window t = 2..4 s, not assessed: command RMS 0 rad < 1e-3 rad"
    )
    assert st.value("assessed") == "false" and st.value("k1") == "nan"
    assert st.value("window_t0") == "2" and st.value("windows_not_excited") == "2"
    with pytest.raises(KeyError):
        st.value("dominant_fault")
    assert [k for k, _ in st.values].count("window_t0") == 1


def test_fault_status_is_error_with_the_reason():
    st = status_texts.fault_status(
        "ignoring /ema/run_info", "ConfigError: bad\n value", status_texts.StatusContext()
    )
    assert (
        st.level == health.ERROR
        and st.message == "ERROR: ignoring /ema/run_info: ConfigError: bad value"
    )
    assert st.value("last_error") == "ConfigError: bad\n value"


def test_lower_bound_rule_claims_a_fault_only_when_its_whole_interval_is_past_it():
    k = k_with(friction=0.3)
    wide = np.tile([0.0, 0.05], (N_K, 1))
    wide[7] = (0.45, 0.55)
    wide[0] = (0.1, 0.5)  # holds severities under the 0.15 warn threshold: not claimed
    a = health.assess(k, k_interval=wide, decision="lower_bound")
    assert a.level == health.OK and "lower bound" in a.message
    narrow = wide.copy()
    narrow[0] = (0.2, 0.4)
    b = health.assess(k, k_interval=narrow, decision="lower_bound")
    assert b.level == health.WARN and b.dominant == 0 and "[0.200, 0.400]" in b.message
    narrow[0] = (0.45, 0.6)
    assert health.assess(k_with(friction=0.5), k_interval=narrow).level == health.ERROR
    assert health.assess(k).level == health.WARN  # without an interval: k itself decides


def test_significant_rule_needs_the_estimate_past_the_threshold_and_the_interval_off_healthy():
    k = k_with(friction=0.3)
    iv = np.tile([0.0, 0.05], (N_K, 1))
    iv[7] = (0.45, 0.55)
    iv[0] = (0.1, 0.5)  # excludes 0: the estimate 0.3 >= 0.15 counts
    a = health.assess(k, k_interval=iv)
    assert a.level == health.WARN and a.dominant == 0 and "excludes healthy" in a.message
    iv[0] = (0.0, 0.5)  # holds the healthy value: nothing is claimed, however large k1
    assert health.assess(k, k_interval=iv).level == health.OK
    with pytest.raises(ConfigError, match="decision rule"):
        health.assess(k, k_interval=iv, decision="vote")


def test_gain_severity_lower_bound_is_the_distance_of_the_interval_from_nominal():
    iv = np.tile([0.0, 0.0], (N_K, 1))
    iv[7] = (0.62, 0.70)
    assert health.severity_lower_bound(iv)[7] == pytest.approx(0.12)
    iv[7] = (0.30, 0.38)
    assert health.severity_lower_bound(iv)[7] == pytest.approx(0.12)
    iv[7] = (0.45, 0.55)
    assert health.severity_lower_bound(iv)[7] == 0.0
    iv[6] = (0.9, 1.0)  # the phase carries no severity
    assert health.severity_lower_bound(iv)[6] == 0.0


def test_an_inadequate_window_is_a_warn_without_phantom_faults():
    k = k_with(friction=0.9, sc_a=0.8)
    a = health.assess(k, adequacy={"statistic": 40.0, "threshold": 3.0, "ok": False})
    assert a.level == health.WARN
    assert a.message.startswith("WARN: model does not explain this window")
    assert "40" in a.message and "friction" not in a.message
    assert (a.levels == health.OK).all()
    d = a.as_dict()
    assert d["adequacy"] == {"statistic": 40.0, "threshold": 3.0, "ok": False}
    status = status_texts.result_status(a, status_texts.StatusContext())
    assert status.value("adequacy_ok") == "false" and status.value("adequacy_statistic") == "40"


def test_status_carries_intervals_flags_and_nuisances():
    iv = np.tile([0.0, 0.1], (N_K, 1))
    flags = tuple((i != 6, "" if i != 6 else "no eccentricity") for i in range(N_K))
    a = health.assess(NOMINAL, k_interval=iv, identifiable=flags, nuisance={"load_torque": 12.5})
    s = status_texts.result_status(a, status_texts.StatusContext())
    assert s.value("k1_low") == "0" and s.value("k1_high") == "0.1"
    assert s.value("identifiable_k7") == "false: no eccentricity"
    assert s.value("identifiable_k1") == "true"
    assert s.value("nuisance_load_torque") == "12.5"


def test_the_thesis_medium_gain_fault_is_claimed_whichever_way_its_estimate_leans():
    """k8 = 0.4 (the thesis's medium gain fault) once sat on its warn threshold exactly."""
    for estimate in (0.395, 0.405, 0.412):  # foreign units read 0.400-0.412, tuned 0.388-0.402
        assert health.assess(k_with(k8=estimate)).level == health.WARN
    assert health.assess(k_with(k8=0.515)).level == health.OK  # healthy strays <= 0.015
