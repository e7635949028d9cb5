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


def test_a_burst_of_samples_in_a_short_block_is_resampled_not_refused():
    """A bunch of samples in a short live block is resampled, not refused.

    A topic timed by when it was received comes in bunches after a stall; a live block
    covering one such bunch in a series just above the grid's rate once made the
    anti-aliasing filter refuse a uniform grid shorter than its padding (ValueError).
    """
    from ema_phm.importing import resample
    from ema_phm.importing.sources import Series

    before = np.arange(0.0, 0.1, 0.00045)  # 2.2 kHz: just oversampled for a 2 kHz grid
    burst = 0.1 + np.arange(40) * 2.5e-5
    after = np.arange(0.1015, 0.2, 0.00045)
    t = np.concatenate([before, burst, after])
    s = Series(t, np.sin(2 * np.pi * 5 * t))
    grid = resample.grid((0.1, 0.101), 2000.0)
    got = resample.on_grid(s, grid, 2000.0)
    assert np.allclose(got, np.sin(2 * np.pi * 5 * grid), atol=1e-3)


def test_windows_start_where_each_stretch_starts():
    """Windows start where each stretch starts, as the import cuts them.

    The current's first sample of each stretch comes one step late: the stretch starts at
    grid index 1 (and 3001 after a gap), and so do the windows, not at the next multiple of
    the window's 800 samples.
    """
    from types import SimpleNamespace

    from ema_phm.telemetry.window_assembler import Completed, WindowAssembler

    live = LiveChannels(parse_channel_map(_float_map(), where="m"), ACTUATOR, window_samples=800)
    rows = []
    for a, b in ((0, 2000), (3000, 5000)):  # 1 s, a gap of 0.5 s, 1 s
        for i in range(a, b):
            for topic in live.topics:
                if topic != "/i3eq" or i > a:
                    live.add(topic, SimpleNamespace(data=0.001 * i), round(i / 2000.0 * 1e9))
            rows.append(live.rows())
    events = WindowAssembler(2000.0, 800).feed(np.vstack(rows))
    firsts = [e.data[0, CHANNELS.index("command")] for e in events if isinstance(e, Completed)]
    assert np.allclose(firsts, [0.001, 0.801, 3.001, 3.801])
