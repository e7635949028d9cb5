"""`LiveChannels`: a rig's messages, one at a time, give the rows the import gives offline."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from bench.harness import rig_forms
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import BagError
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.live import HOLD_S, MIN_BLOCK_S, LiveChannels
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf

ACTUATOR = ActuatorParameters.default()


@pytest.fixture(scope="module")
def window():
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window.without_truth()
    return dataclasses.replace(w, temperature=np.full(w.n, 30.0))


def _feed(live: LiveChannels, w, every: int = 37, **kw) -> np.ndarray:
    out = []
    for i, (topic, msg, receive_ns) in enumerate(rig_forms.rig_messages(w, **kw)):
        live.add(topic, msg, receive_ns)
        if i % every == 0:
            out.append(live.rows())
    out.append(live.rows())
    return np.vstack(out)


def test_rows_come_out_on_the_grid_as_the_window_was_recorded(window):
    live = LiveChannels(parse_channel_map(rig_forms.JOINT_STATES_MAP, where="m"), ACTUATOR)
    assert set(live.topics) == set(rig_forms.RIG_TOPICS)
    rows = _feed(live, window)
    assert rows.shape[1] == len(CHANNELS)
    steps = np.diff(rows[:, 0])
    assert np.allclose(steps, 1 / 2000.0)  # each grid time once, in order
    # all but the held-back tail (and a last block too small to give), sample for sample
    # (the grid starts on the first sample)
    n = rows.shape[0]
    assert n >= window.n - round((HOLD_S + MIN_BLOCK_S) * 2000) - 2
    for c in ("command", "theta_u", "theta_m", "omega_m", "i3eq", "temperature"):
        i = CHANNELS.index(c)
        assert np.allclose(rows[:, i], getattr(window, c)[:n], atol=1e-9), c


def test_a_derived_speed_is_the_offline_central_difference_away_from_the_ends(window):
    m = copy.deepcopy(rig_forms.JOINT_STATES_MAP)
    m["channels"]["omega_m"] = {"derive": "rate_of_theta_m"}
    rows = _feed(LiveChannels(parse_channel_map(m, where="m"), ACTUATOR), window)
    n = rows.shape[0]
    offline = np.gradient(window.theta_m, 1 / 2000.0)[: n - 1]
    got = rows[: n - 1, CHANNELS.index("omega_m")]
    assert np.allclose(got[1:], offline[1:], atol=1e-6)


def test_a_late_message_is_dropped_and_counted(window):
    live = LiveChannels(parse_channel_map(rig_forms.JOINT_STATES_MAP, where="m"), ACTUATOR)
    msgs = list(rig_forms.rig_messages(window))
    for topic, msg, ns in msgs[:400]:
        live.add(topic, msg, ns)
    topic, msg, ns = msgs[0]  # the first message again, long after
    live.add(topic, msg, ns)
    assert live.out_of_order >= 1


def test_a_message_without_the_mapped_joint_names_it(window):
    m = copy.deepcopy(rig_forms.JOINT_STATES_MAP)
    m["channels"]["theta_u"] = {"topic": "/joint_states", "joint": "flap", "field": "position"}
    live = LiveChannels(parse_channel_map(m, where="m"), ACTUATOR)
    topic, msg, ns = next(rig_forms.rig_messages(window))
    with pytest.raises(BagError, match="topic /joint_states: .*joint 'flap'"):
        live.add(topic, msg, ns)


def _float_map() -> dict:
    """Every channel on its own std_msgs/Float64-like topic; temperature on /temperature."""
    chans = {c: {"topic": f"/{c}", "field": "data"} for c in ("command", "theta_u", "theta_m")}
    chans |= {c: {"topic": f"/{c}", "field": "data"} for c in ("omega_m", "i3eq")}
    chans |= {"load": "unknown", "temperature": {"topic": "/temperature", "field": "data"}}
    return {"version": 1, "channels": chans}


def _feed_floats(live: LiveChannels, seconds: float, rate: float, *, t0_ns: int = 0, skip=()):
    from types import SimpleNamespace

    for i in range(round(seconds * rate)):
        ns = t0_ns + round(i / rate * 1e9)
        for topic in live.topics:
            if topic not in skip:
                live.add(topic, SimpleNamespace(data=0.001 * i), ns)
        live.rows()


def test_a_silent_topic_does_not_grow_the_others_buffers():
    from ema_phm.importing.live import MAX_BUFFER_S

    live = LiveChannels(parse_channel_map(_float_map(), where="m"), ACTUATOR)
    _feed_floats(live, 3 * MAX_BUFFER_S, 100.0, skip={"/temperature"})
    longest = max(len(v) for v in live._t.values())  # noqa: SLF001 - the buffers themselves
    assert longest <= 2 * MAX_BUFFER_S * 100.0 + 2


def test_time_going_back_starts_the_stream_over():
    live = LiveChannels(parse_channel_map(_float_map(), where="m"), ACTUATOR)
    _feed_floats(live, 2.0, 2000.0)
    before = live.emitted_until
    assert before > 1.5
    _feed_floats(live, 2.0, 2000.0)  # the same clock again: a restarted rig
    assert live.restarts == 1 and 1.5 < live.emitted_until < before + 0.01
