"""ActuatorStream: message sizes, the end after max_windows, k changes on a window boundary."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.domain.faults import N_K, NOMINAL, k_with
from ema_phm.errors import FaultVectorError
from ema_phm.physics.commands import CommandSpec, LoadSpec
from ema_phm.simulator.actuator_stream import ActuatorStream

FRICTION = k_with(friction=0.5).tolist()


def make(**kw) -> ActuatorStream:
    opts = dict(
        command=CommandSpec(duration=0.1),
        load=LoadSpec(),
        seed=0,
        noise=(0.0, 0.0, 0.0),
        samples_per_message=64,
        max_windows=2,
        realtime_factor=0.0,
    )
    opts.update(kw)
    return ActuatorStream(NOMINAL, **opts)


def test_stream_ends_after_max_windows_plus_the_boundary_sample():
    stream = make()
    rows = []
    while (message := stream.next_message()) is not None:
        assert message.rows.shape[0] <= 64
        rows.append(message.rows)
    t = np.vstack(rows)[:, 0]
    assert t.size == 2 * stream.samples_per_window + 1 and stream.windows_complete == 2
    np.testing.assert_allclose(t, np.arange(t.size) / stream.sample_rate)


def test_new_k_applies_at_the_next_window_boundary():
    stream = make(max_windows=0)
    stream.next_message()
    stream.request_k(FRICTION)
    changed_at = None
    while changed_at is None:
        message = stream.next_message()
        if message.k_changed:
            changed_at = stream.k_since_t
    j = round(changed_at * stream.sample_rate)
    assert j == stream.samples_per_window and stream.k.tolist() == FRICTION
    assert stream.k_changes_applied == 1 and stream.run_info()["k_true"] == FRICTION


def test_bad_k_is_refused_and_nothing_pending():
    stream = make()
    with pytest.raises(FaultVectorError, match=f"{N_K} entries"):
        stream.request_k([0.5] * 7)
    assert not stream.apply_pending_k()


def test_run_info_describes_the_stream():
    info = make().run_info()
    assert info["samples_per_window"] == 200 and info["window_duration"] == pytest.approx(0.1)
    assert info["max_windows"] == 2 and info["command"]["duration"] == 0.1


WEAR = {
    "cycle_hours": 3.0,
    "faults": {"friction": {"law": "linear", "onset": 1, "initial": 0.1, "rate": 0.1}},
}


def test_a_degradation_gives_each_window_its_cycle_k_as_simulate_cycles_does():
    from ema_phm.simulator.degradation import Degradation, simulate_cycles

    deg = Degradation.from_mapping(WEAR, source="wear.yaml")
    stream = make(max_windows=4, degradation=deg)
    rows, changes = [], []
    while (message := stream.next_message()) is not None:
        rows.append(message.rows)
        if message.k_changed:
            changes.append((round(stream.k_since_t * stream.sample_rate), stream.k))
    n = stream.samples_per_window
    assert [j for j, _ in changes] == [n, 2 * n, 3 * n]  # at the boundaries of cycles 1, 2, 3
    np.testing.assert_allclose([k for _, k in changes], deg.trajectory([1, 2, 3]))
    # the same windows as `ema-phm simulate --windows 4` (cycle 0 holds N + 1 samples)
    expected = np.vstack(
        [r for _, _, r in simulate_cycles(deg, 4, command=CommandSpec(duration=0.1), seed=0)]
    )
    np.testing.assert_allclose(np.vstack(rows), expected, rtol=1e-12, atol=1e-12)
    info = stream.run_info()
    assert info["cycle_hours"] == 3.0 and info["degradation"] == deg.as_dict()
    assert info["degradation_file"] == "wear.yaml"
    assert make(degradation=deg, cycle_hours=0.5).run_info()["cycle_hours"] == 0.5


def test_with_a_degradation_k_cannot_be_requested_and_bad_laws_are_refused_up_front():
    from ema_phm.errors import ConfigError
    from ema_phm.simulator.degradation import Degradation

    stream = make(degradation=Degradation.from_mapping(WEAR, source="wear.yaml"))
    with pytest.raises(ConfigError, match="k follows the degradation wear.yaml cycle by cycle"):
        stream.request_k(FRICTION)
    steep = {"faults": {"friction": {"law": "linear", "onset": 0, "initial": 0.5, "rate": 0.3}}}
    with pytest.raises(FaultVectorError, match="reaches k1 = 1.1 at cycle 2"):
        make(max_windows=3, degradation=Degradation.from_mapping(steep))


def _all_rows(stream: ActuatorStream) -> np.ndarray:
    rows = []
    while (message := stream.next_message()) is not None:
        rows.append(message.rows)
    return np.vstack(rows)


def test_the_stream_runs_the_actuator_it_is_given():
    from ema_phm.physics.actuator_file import load_actuator

    packaged = _all_rows(make(actuator=load_actuator(None)))
    np.testing.assert_array_equal(packaged, _all_rows(make()))
    heavy = load_actuator(None).with_values({"mechanics.j_motor": 2.6e-5})
    assert not np.array_equal(_all_rows(make(actuator=heavy)), packaged)
