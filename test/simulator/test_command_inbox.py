"""A rig commanded from outside: the command inbox's hold, and the HF driven by given commands."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import COLUMN
from ema_phm.errors import ConfigError
from ema_phm.physics.commands import CommandSpec, LoadSpec, command_samples
from ema_phm.simulator import command_inbox
from ema_phm.simulator.actuator_stream import ActuatorStream
from ema_phm.simulator.command_inbox import CommandInbox, TrajectoryInbox
from ema_phm.simulator.real_ema import HFStream

SHORT = CommandSpec(duration=0.1)


def test_held_each_command_stands_from_its_arrival_until_the_next():
    inbox = CommandInbox(start=0.01, mode="hold")
    inbox.put(0.02, at=1.0)
    inbox.put(-0.03, at=2.0)
    got = inbox.at(np.array([0.5, 1.0, 1.5, 2.0, 9.0]))
    assert got.tolist() == [0.01, 0.02, 0.02, -0.03, -0.03]
    assert inbox.received == 2


def test_interpolated_the_command_ramps_to_each_set_point_over_the_last_interval():
    inbox = CommandInbox(start=0.0)
    inbox.put(0.01, at=1.0)  # the first is held: no interval before it
    inbox.put(0.02, at=1.01)
    inbox.put(0.0, at=1.015)
    inbox.put(0.5, at=2.0)  # after a silence longer than MAX_SPAN_S (0.1 s): a jump
    t = np.array([0.5, 1.0, 1.005, 1.01, 1.015, 1.0175, 1.02, 1.5, 2.0, 2.1])
    want = [0.0, 0.01, 0.01, 0.01, 0.02, 0.01, 0.0, 0.0, 0.5, 0.5]
    np.testing.assert_allclose(inbox.at(t), want, atol=1e-12)
    with pytest.raises(ConfigError, match="one of linear, hold"):
        CommandInbox(start=0.0, mode="cubic")


def test_forgetting_old_commands_keeps_the_one_in_force(monkeypatch):
    monkeypatch.setattr(command_inbox, "KEEP_S", 1.0)
    inbox = CommandInbox(start=0.0, mode="hold")
    for i in range(10):
        inbox.put(float(i), at=float(i))
    assert inbox.at(np.array([8.5])).tolist() == [8.0]  # forgets all before 7.5
    assert inbox.at(np.array([7.6, 9.5])).tolist() == [7.0, 9.0]


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), True])
def test_a_command_that_is_not_a_finite_number_is_refused(bad):
    with pytest.raises(ConfigError, match="finite number"):
        CommandInbox(start=0.0).put(bad, at=0.0)


def test_the_hf_driven_by_given_commands_is_the_hf_driven_by_its_window():
    # the same command samples given from outside: bit for bit the same telemetry
    own = HFStream(NOMINAL, command=SHORT)
    given = HFStream(NOMINAL, command=SHORT)
    ts = 1.0 / own.sample_rate
    a = np.vstack([own.advance(50), own.advance(70)])
    t1 = np.arange(0, 50) * ts
    t2 = np.arange(50, 120) * ts
    b = np.vstack(
        [
            given.advance(50, command_samples(SHORT, t1)),
            given.advance(70, command_samples(SHORT, t2)),
        ]
    )
    assert np.array_equal(a, b, equal_nan=True)  # the temperature is not measured: NaN


def test_given_commands_are_what_the_telemetry_says_was_commanded():
    stream = ActuatorStream(
        NOMINAL,
        command=SHORT,
        load=LoadSpec(),
        seed=0,
        noise=(0.0, 0.0, 0.0),
        samples_per_message=64,
        max_windows=0,
        realtime_factor=1.0,
        command_at=lambda t: np.where(t >= 0.01, 0.02, 0.0),
    )
    assert stream.next_times() == (0.0, 63 / stream.sample_rate)
    rows = np.vstack([stream.next_message().rows for _ in range(4)])
    cmd = rows[:, COLUMN["command"]]
    assert np.array_equal(cmd, np.where(rows[:, 0] >= 0.01, 0.02, 0.0))
    assert abs(rows[-1, COLUMN["theta_u"]] - 0.02) < 0.002  # the actuator went there


def test_bad_given_commands_are_refused():
    s = HFStream(NOMINAL, command=SHORT)
    with pytest.raises(ConfigError, match="finite commands"):
        s.advance(3, np.array([0.0, np.nan, 0.0]))
    with pytest.raises(ConfigError, match="finite commands"):
        s.advance(3, np.zeros(2))


def test_a_trajectory_replaces_the_last_from_its_start_and_holds_its_end():
    inbox = TrajectoryInbox(start=0.0)
    inbox.put(10.0, np.array([0.0, 1.0]), np.array([0.0, 1.0]))  # 0 -> 1 over 1 s
    inbox.put(10.5, np.array([0.0, 0.5]), np.array([0.2, 0.2]))  # at 0.5 s: jump to 0.2
    got = inbox.at(np.array([9.0, 10.4, 10.49, 10.75, 12.0]))
    np.testing.assert_allclose(got, [0.0, 0.4, 0.49, 0.2, 0.2], atol=1e-9)  # the past kept
    with pytest.raises(ConfigError, match="increasing times"):
        inbox.put(11.0, np.array([0.2, 0.1]), np.array([0.0, 0.0]))
    with pytest.raises(ConfigError, match="finite"):
        inbox.put(11.0, np.array([0.1]), np.array([np.nan]))
