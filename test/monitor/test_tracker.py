"""The live prognostics of a monitor, without a node: history, prognosis, what is reported."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest

from ema_phm.diagnosis import health
from ema_phm.domain.faults import NAMES, NOMINAL
from ema_phm.errors import ConfigError
from ema_phm.monitor import status_texts
from ema_phm.monitor.status_cause import StatusCause
from ema_phm.monitor.tracker import WARN, PrognosticTracker, cycle_of
from ema_phm.prognostics.rul import Percentiles

DURATION = 2.0  # s per window
HALF_WIDTH = 0.03  # of each k's 90 % interval


def fitted(cycle: int, friction: float, *, explained: bool = True, t0: float | None = None):
    """An assessment of window `cycle` with k1 = friction, intervals +-HALF_WIDTH."""
    k = NOMINAL.copy()
    k[0] = friction
    interval = np.column_stack([np.clip(k - HALF_WIDTH, 0, 1), np.clip(k + HALF_WIDTH, 0, 1)])
    start = cycle * DURATION if t0 is None else t0
    return health.assess(
        k,
        k_interval=interval,
        adequacy={"statistic": 1.0 if explained else 9.0, "threshold": 1.43, "ok": explained},
        window_t0=start,
        window_t1=start + DURATION,
    )


def growing(tracker: PrognosticTracker, cycles: int, rate: float = 0.02):
    """Feed k1 = rate * cycle for cycles 0 .. cycles-1; the last summary."""
    summary = None
    for c in range(cycles):
        summary = tracker.observe(fitted(c, rate * c))
    return summary


def test_a_growing_fault_is_the_dominant_prognosis_and_warns_inside_the_horizon():
    # k1 = 0.02 c reaches the 0.4 threshold at cycle 20: at cycle 14, 6 cycles remain
    s = growing(PrognosticTracker(cycle_hours=2.0, horizon_cycles=10), 15)
    f = s.dominant
    assert f is not None and f.name == "friction" and s.degrading == (f,)
    assert f.rul_cycles.p5 <= f.rul_cycles.p50 <= f.rul_cycles.p95
    assert 3 <= f.rul_cycles.p50 <= 9, f.rul_cycles
    assert f.rul_hours.p50 == pytest.approx(2.0 * f.rul_cycles.p50)
    assert s.level == health.WARN and s.warning.startswith("friction RUL p5 ")
    assert "< horizon 10 cycles" in s.warning
    assert s.headline.startswith("friction degrading: RUL ") and not s.no_degradation_detected
    values = s.diagnostic_values()
    assert values["prognosis"] == s.headline and values["prognosis_dominant_fault"] == "friction"
    assert values["prognosis_windows"] == 15 and values["prognosis_cycle"] == 14.0
    assert values["prognosis_status_friction"] == "degrading"
    assert values["prognosis_status_gain_drift"] == "not_applicable"
    assert values["rul_friction_cycles_p50"] == f.rul_cycles.p50
    assert values["rul_friction_hours_p95"] == f.rul_hours.p95
    assert values["rul_friction_p_within_horizon"] == f.p_within_horizon
    assert not any(key.startswith("rul_backlash") for key in values)
    rul = s.remaining_life()
    assert len(rul) == 8 and rul[0].cycles_p50 == f.rul_cycles.p50
    assert rul[0].horizon_hours == pytest.approx(20.0)
    assert all(math.isnan(r.cycles_p50) for r in rul[1:])
    out = json.loads(json.dumps(s.as_dict()))
    assert out["dominant_fault"] == "friction" and out["level"] == "WARN"


def test_a_far_end_of_life_is_degrading_without_a_warning():
    s = growing(PrognosticTracker(horizon_cycles=2), 15, rate=0.01)  # threshold at cycle 40
    assert s.dominant is not None and s.dominant.rul_cycles.p5 >= 2
    assert s.level == health.OK and s.warning == ""


def test_a_healthy_history_says_no_degradation_detected():
    tracker = PrognosticTracker()
    for c in range(8):
        s = tracker.observe(fitted(c, 0.0))
    assert s.no_degradation_detected and s.dominant is None and s.level == health.OK
    assert s.headline == "no degradation detected"
    assert s.diagnostic_values()["prognosis_dominant_fault"] == ""
    assert all(math.isnan(r.cycles_p5) for r in s.remaining_life())


def test_before_enough_windows_there_is_no_prognosis_and_no_claim():
    tracker = PrognosticTracker()
    assert tracker.summary.prognosis is None and "no explained window" in tracker.summary.headline
    s = growing(tracker, 3)
    assert not s.no_degradation_detected and s.level == health.OK
    assert s.headline == "no prognosis yet: 3 estimates; a trend needs at least 5"


def test_an_unexplained_fit_does_not_count():
    tracker = PrognosticTracker()
    growing(tracker, 6)
    before = tracker.summary
    s = tracker.observe(fitted(6, 0.9, explained=False))
    assert tracker.windows == 6 and s.not_counted == 1 and s.prognosis is before.prognosis


def test_cycles_come_from_the_window_start_and_a_new_run_begins_a_new_history():
    assert cycle_of(0.0, 2.0) == 0 and cycle_of(6.0, 8.0) == 3
    with pytest.raises(ConfigError, match="span must be > 0"):
        cycle_of(2.0, 2.0)
    tracker = PrognosticTracker()
    tracker.note_run_info({"hardware_id": "ema-1", "run_id": "a", "cycle_hours": 2.0})
    for c in (0, 1, 4):  # cycles 2 and 3 skipped: a gap, not a shift
        s = tracker.observe(fitted(c, 0.0))
    assert s.prognosis.cycle == 4.0 and tracker.windows == 3 and tracker.cycle_hours == 1.0
    tracker.note_run_info({"hardware_id": "ema-1", "run_id": "b"})  # a new run at t = 0
    s = tracker.observe(fitted(0, 0.0))
    assert tracker.windows == 1 and s.prognosis.cycle == 0.0 and s.not_counted == 0


@pytest.mark.parametrize(
    ("cycle", "words"),
    [(4, r"cycle 4 again \(duplicate\)"), (2, "cycle 2 steps back from cycle 4 of the same run")],
)
def test_a_duplicate_or_a_step_back_in_one_run_is_skipped_with_its_reason(cycle, words):
    # it used to clear the history silently (a step back was taken for a restart)
    tracker = PrognosticTracker()
    for c in range(5):
        tracker.observe(fitted(c, 0.0))
    before = tracker.summary
    s = tracker.observe(fitted(cycle, 0.9))
    assert tracker.windows == 5 and s.prognosis is before.prognosis
    assert s.not_counted == 1 and re.search(words, s.last_skipped), s.last_skipped
    assert re.search(words, s.diagnostic_values()["prognosis_last_skipped"])
    s = tracker.observe(fitted(5, 0.0))  # the next cycle counts again
    assert tracker.windows == 6 and s.prognosis.cycle == 5.0 and s.not_counted == 1


def test_the_history_is_capped():
    tracker = PrognosticTracker(max_windows=6)
    s = growing(tracker, 10)
    assert tracker.windows == 6 and s.windows == 6


@pytest.mark.parametrize(
    "kwargs,words",
    [
        ({"thresholds": [0.4] * 7}, "8 entries"),
        ({"thresholds": [0.0] * 8}, r"failure threshold of k1 \(friction\) must be in \(0, 1\]"),
        ({"cycle_hours": 0.0}, r"cycle_hours must be a number in .*, got 0.0"),
        ({"horizon_cycles": 0}, r"rul_horizon_cycles must be an integer in \[1, 1000000\]"),
        ({"max_windows": 1}, "max_windows must be a whole number >= 2, got 1"),
    ],
)
def test_bad_settings_are_named(kwargs, words):
    with pytest.raises(ConfigError, match=words):
        PrognosticTracker(**kwargs)


def test_from_parameter_values():
    values = {
        "prognostics": True,
        "failure_thresholds": [0.3] * 8,
        "cycle_hours": 0.5,
        "rul_horizon_cycles": 4,
        "rul_alarm_windows": 3,
    }
    tracker = PrognosticTracker.from_values(values)
    assert tracker.thresholds[0] == 0.3 and tracker.cycle_hours == 0.5
    assert tracker.horizon_cycles == 4 and tracker.alarm_windows == 3
    assert PrognosticTracker.from_values({**values, "prognostics": False}) is None


def test_cycle_hours_zero_follows_the_stream():
    values = {"prognostics": True, "failure_thresholds": [0.4] * 8, "cycle_hours": 0.0}
    tracker = PrognosticTracker.from_values(
        {**values, "rul_horizon_cycles": 10, "rul_alarm_windows": 2}
    )
    assert tracker.follows_stream and tracker.cycle_hours == 1.0  # until the stream tells
    tracker.note_stream_cycle_hours(2.5)
    s = growing(tracker, 15)
    assert s.cycle_hours == 2.5
    f = s.dominant
    assert f is not None and f.rul_hours.p50 == pytest.approx(2.5 * f.rul_cycles.p50)
    with pytest.raises(ConfigError, match="cycle_hours .*got -1"):
        tracker.note_stream_cycle_hours(-1)
    own = PrognosticTracker(cycle_hours=0.5)
    own.note_stream_cycle_hours(2.5)  # its own value stands
    assert own.cycle_hours == 0.5


def test_the_prognosis_raises_a_status_to_warn_and_never_lowers_one():
    s = growing(PrognosticTracker(), 15)
    ctx = status_texts.StatusContext(hardware_id="hw", prognostics=s)
    ok = StatusCause("result", fitted(14, 0.1)).render(ctx)  # k1 0.1 < warn 0.15: OK alone
    assert ok.level == health.WARN and ok.message.startswith("WARN: prognosis: friction RUL p5")
    assert ok.message.endswith(fitted(14, 0.1).message)
    assert ok.value("prognosis_dominant_fault") == "friction"
    assert float(ok.value("rul_friction_cycles_p50")) == s.dominant.rul_cycles.p50
    error = StatusCause("result", fitted(14, 0.45)).render(ctx)
    assert error.level == health.ERROR and error.message.startswith("ERROR: friction")
    stale = status_texts.current_status(ok, telemetry_age_s=9.0, stale_timeout_s=5.0, ctx=ctx)
    assert stale.level == health.STALE and "prognosis" in dict(stale.values)
    healthy = growing(PrognosticTracker(), 8, rate=0.0)
    plain = StatusCause("result", fitted(7, 0.0)).render(
        status_texts.StatusContext(hardware_id="hw", prognostics=healthy)
    )
    assert plain.level == health.OK and plain.value("prognosis") == "no degradation detected"


def test_an_infinite_percentile_is_shown_as_inf_not_nan():
    s = growing(PrognosticTracker(), 15)
    f = s.dominant
    never = dataclasses.replace(f, rul_cycles=Percentiles(3.0, 8.0, math.inf))
    faults = tuple(never if g is f else g for g in s.prognosis.faults)
    s = dataclasses.replace(s, prognosis=dataclasses.replace(s.prognosis, faults=faults))
    status = StatusCause().render(status_texts.StatusContext(prognostics=s))
    assert status.value("rul_friction_cycles_p95") == "inf"
    values = status_texts.parse_values(status.values)
    assert values["rul_friction_cycles_p95"] == math.inf and values["rul_friction_cycles_p5"] == 3
    assert s.remaining_life()[0].cycles_p95 == math.inf
    assert set(NAMES) == {key[len("prognosis_status_") :] for key in values if "status_" in key}


def test_the_warn_needs_the_rul_below_the_horizon_in_consecutive_prognoses():
    # k1 = 0.02 c reaches 0.4 at cycle 20: p5 falls below 10 cycles somewhere before cycle 14
    once = PrognosticTracker(horizon_cycles=10, alarm_windows=1)
    twice = PrognosticTracker(horizon_cycles=10, alarm_windows=2)
    first = {}
    for c in range(15):
        for name, tr in (("once", once), ("twice", twice)):
            s = tr.observe(fitted(c, 0.02 * c))
            if s.level == WARN and name not in first:
                first[name] = c
    assert "once" in first and first["twice"] == first["once"] + 1
    with pytest.raises(ConfigError, match="rul_alarm_windows must be an integer in"):
        PrognosticTracker(alarm_windows=0)


def test_health_fields_carry_the_rul_of_degrading_faults_only():
    s = growing(PrognosticTracker(horizon_cycles=10), 15)
    fields = s.health_fields()
    f = s.dominant
    assert f is not None and f.name == "friction" and fields["rul_dominant"] == 1.0
    assert fields["rul_k1_p50"] == f.rul_cycles.p50 and fields["rul_k1_p5"] == f.rul_cycles.p5
    assert all(math.isnan(fields[f"rul_k{i}_p50"]) for i in range(2, 7))
    quiet = PrognosticTracker().summary.health_fields()
    assert quiet["rul_dominant"] == 0.0 and math.isnan(quiet["rul_k1_p50"])


@pytest.mark.parametrize("cut", [3, 9, 12, 14])
def test_resume_leaves_the_state_observe_left(cut):
    """A tracker rebuilt from the first `cut` windows (a fleet store's) goes on as the original.

    Among the windows: one not explained (not counted) and a duplicate cycle; the alarm
    streak stands at the cut for the later cuts.
    """
    windows = [fitted(c, 0.025 * c, explained=c != 5) for c in range(15)]
    windows.insert(8, fitted(7, 0.9))  # cycle 7 again: not counted
    run = ("EMA-1", "life-1")
    whole = PrognosticTracker(horizon_cycles=10)
    whole.run = run
    summaries = [whole.observe(a, seed=3) for a in windows]
    first = PrognosticTracker(horizon_cycles=10)
    first.run = run
    for a in windows[:cut]:
        first.observe(a, seed=3)
    resumed = PrognosticTracker(horizon_cycles=10)
    got = resumed.resume([(run, a) for a in windows[:cut]], first.streak, seed=3)
    want = summaries[cut - 1]
    assert got.as_dict() == want.as_dict()
    assert (got.windows, got.not_counted, got.persisting) == (
        want.windows,
        want.not_counted,
        want.persisting,
    )
    for a, expected in zip(windows[cut:], summaries[cut:], strict=True):
        assert resumed.observe(a, seed=3).as_dict() == expected.as_dict()
    assert summaries[-1].level == WARN  # the late cuts resume a standing alarm


@pytest.mark.parametrize("cut", [4, 7, 9])
def test_resume_across_runs_leaves_the_state_observe_left(cut):
    """Run A ends with a window not explained; run B (a new life) starts a new summary."""
    a = [(("U", "life-1"), fitted(c, 0.03 * c, explained=c != 3)) for c in range(4)]
    b = [(("U", "life-2"), fitted(c, 0.02 * c)) for c in range(6)]
    seq = a + b
    whole = PrognosticTracker(horizon_cycles=10)
    summaries = []
    for run, w in seq:
        whole.run = run
        summaries.append(whole.observe(w, seed=1))
    first = PrognosticTracker(horizon_cycles=10)
    for run, w in seq[:cut]:
        first.run = run
        first.observe(w, seed=1)
    resumed = PrognosticTracker(horizon_cycles=10)
    got = resumed.resume(seq[:cut], first.streak, seed=1)
    assert got.as_dict() == summaries[cut - 1].as_dict()
    for (run, w), expected in zip(seq[cut:], summaries[cut:], strict=True):
        resumed.run = run
        assert resumed.observe(w, seed=1).as_dict() == expected.as_dict()
