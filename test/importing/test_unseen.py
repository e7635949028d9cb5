"""A fault the recording cannot show is never fitted, claimed or given a trend.

A rig without a motor encoder (`theta_m: {derive: through_gear}`) shows no backlash: the
import says so in run_info ``channels``, the fit holds the backlash healthy and flags why,
and the prognosis reads no trend from it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import k_with

from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import FAULTS, NAMES, NOMINAL
from ema_phm.domain.window import PROVENANCE_KEY, unseen_faults
from ema_phm.fleet.summary import no_rul_reasons
from ema_phm.monitor.estimates import Estimate, Estimates
from ema_phm.physics.commands import CommandSpec
from ema_phm.prognostics.rul import History, prognose
from ema_phm.simulator import real_ema as hf

BACKLASH = NAMES.index("backlash")
NO_ENCODER = {
    "theta_u": "recorded: column 'surface_rad'",
    "theta_m": "derived: theta_u / gear_ratio (no motor encoder)",
    "omega_m": "derived: central difference of theta_m",
}


def test_only_a_derived_or_missing_needed_channel_hides_a_fault():
    assert unseen_faults({}) == {}
    assert unseen_faults({PROVENANCE_KEY: "not a mapping"}) == {}
    hidden = unseen_faults({PROVENANCE_KEY: NO_ENCODER})
    assert set(hidden) == {BACKLASH} and "theta_m is derived" in hidden[BACKLASH]
    recorded = {**NO_ENCODER, "theta_m": "recorded: /joint_states field 'position'"}
    assert unseen_faults({PROVENANCE_KEY: recorded}) == {}
    # the rule is the fault table's: every fault that needs a channel names a real one
    for f in FAULTS:
        assert set(f.needs_recorded) <= {"theta_m", "omega_m", "i3eq", "theta_u", "command"}


def test_the_fit_holds_an_unseen_fault_healthy_and_says_why():
    """A window with a real backlash 0.6, read as if the motor angle came through the gear."""
    w = hf.simulate(k_with(backlash=0.6), command=CommandSpec(duration=0.5)).window
    blind = dataclasses.replace(w, meta={**w.meta, PROVENANCE_KEY: NO_ENCODER})
    res = isolate(blind, max_evaluations=200, intervals=True, check_excitation=False)
    assert res.k[BACKLASH] == NOMINAL[BACKLASH]
    ok, why = res.identifiable[BACKLASH]
    assert not ok and "no motor encoder" in why
    assert res.as_dict()["unseen"] == {"backlash": why}
    from ema_phm.diagnosis import health

    assert health.assess_isolation(res).unseen == {BACKLASH: why}  # what the tracker gets
    seen = isolate(w, max_evaluations=200, check_excitation=False)
    assert seen.unseen == {} and seen.k[BACKLASH] > 0.1  # the same window, encoder read


def test_a_history_with_an_unseen_fault_reads_no_trend_from_it():
    estimates = Estimates()
    for c in range(8):
        k = k_with(backlash=0.0, friction=0.05 * c)
        estimates.add(Estimate.of(c, k, np.column_stack([k, k + 0.02]), {BACKLASH: "no motor"}))
    history = estimates.history()
    assert history.unseen == {BACKLASH: "no motor"}
    p = prognose(history)
    backlash = p.faults[BACKLASH]
    assert backlash.status == "not_seen" and backlash.message == "no motor"
    assert p.faults[0].status == "degrading"  # the friction's trend is read as before
    plain = History.from_estimates(history.cycles, history.k, history.k_low, history.k_high)
    assert prognose(plain).faults[BACKLASH].status == "no_degradation"


def test_the_fleet_notes_say_a_fault_was_not_seen():
    prognosis = {
        "faults": [{"fault": "backlash", "status": "not_seen", "message": "no motor encoder"}]
    }
    notes = no_rul_reasons({"prognosis": prognosis})
    assert notes == {"backlash": "not seen: no motor encoder"}


@pytest.mark.parametrize("channel", ["theta_m"])
def test_the_import_records_how_each_channel_was_obtained(channel):
    from bench.harness.rig_forms import TABLE_MAP
    from ema_phm.importing.channel_map import parse_channel_map
    from ema_phm.importing.importer import provenance

    m = {**TABLE_MAP, "channels": {**TABLE_MAP["channels"], channel: {"derive": "through_gear"}}}
    how = provenance(parse_channel_map(m, where="m"))
    assert how[channel].startswith("derived:") and how["load"] == "unknown"
    assert how["theta_u"].startswith("recorded:")
    assert set(unseen_faults({PROVENANCE_KEY: how})) == {BACKLASH}


def test_the_live_monitor_and_the_fleet_read_no_trend_from_an_unseen_fault():
    """The tracker is handed `health.Assessment`s (monitor_node, fleet): `unseen` rides on."""
    from ema_phm.diagnosis import health
    from ema_phm.monitor.tracker import PrognosticTracker

    tracker = PrognosticTracker(cycle_hours=1.0)
    for c in range(8):
        k = k_with(friction=0.05 * c)
        a = health.assess(k, k_interval=np.column_stack([k, k + 0.02]), window_t0=2.0 * c)
        a = dataclasses.replace(a, window_t1=2.0 * c + 2.0, unseen={BACKLASH: "no motor encoder"})
        summary = tracker.observe(a)
    statuses = {f["fault"]: f["status"] for f in summary.as_dict()["prognosis"]["faults"]}
    assert statuses["backlash"] == "not_seen" and statuses["friction"] == "degrading"
