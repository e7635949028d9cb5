"""~/run_test without a node: what a test may command, when it stops, the window it cuts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ema_phm.domain.window import CHANNELS, COLUMN
from ema_phm.errors import ConfigError, WindowError
from ema_phm.monitor import rig_test
from ema_phm.monitor.rig_test import RigTest, RigTestLimits, plan_rig_test
from ema_phm.physics.commands import CommandSpec, command_samples, default_specs
from ema_phm.physics.parameters import ActuatorParameters

DEFAULT = default_specs()[0]
LIMITS = RigTestLimits.of(
    ActuatorParameters.default(), max_position_error_rad=0.01, feedback_timeout_s=0.5
)
FS = 2000.0


def test_the_limits_are_the_actuator_file_s_end_stop_and_top_speed():
    assert LIMITS.end_stop_rad == 0.5
    assert LIMITS.max_rate_rad_s == pytest.approx(8000 * 2 * math.pi / 60 * 0.002)


def test_an_empty_request_is_the_packaged_chirp_around_the_start():
    spec = plan_rig_test({}, DEFAULT, 0.1, LIMITS)
    assert (spec.kind, spec.amplitude, spec.f0, spec.f1, spec.duration) == (
        DEFAULT.kind,
        DEFAULT.amplitude,
        DEFAULT.f0,
        DEFAULT.f1,
        DEFAULT.duration,
    )
    assert spec.offset == 0.1


@pytest.mark.parametrize(
    ("request_", "start", "words"),
    [
        ({"kind": "step"}, 0.0, "must be one of chirp, sine"),
        ({"amplitude_rad": 0.1}, 0.4, "beyond 0.9 x the end stop 0.5 rad"),
        ({"amplitude_rad": 0.3, "f1_hz": 4.5}, 0.0, "beyond 0.9 x the top speed"),
        ({"kind": "sine", "amplitude_rad": 0.05, "f0_hz": 5.0}, 0.0, "peak rate 1.571 rad/s"),
        ({"amplitude_rad": -0.02}, 0.0, "amplitude must be > 0"),
        ({"duration_s": 1e6}, 0.0, "command duration"),
        ({"kind": "sine", "amplitude_rad": 1e-4, "f0_hz": 25.0}, 0.0, "beyond 20 Hz"),
    ],
)
def test_a_request_off_the_limits_is_refused_naming_why(request_, start, words):
    with pytest.raises(ConfigError, match=words.replace(".", r"\.")):
        plan_rig_test(request_, DEFAULT, start, LIMITS)


def test_a_chirp_that_ends_off_the_start_returns_to_it_at_a_bounded_rate():
    spec = CommandSpec(kind="chirp", amplitude=0.03, f0=0.5, f1=4.0, duration=1.3, offset=0.05)
    run = RigTest(spec, LIMITS, started=10.0)
    assert run.command(9.0) == 0.05 and run.phase(10.5) == "commanding"
    t = 10.0 + np.arange(0.0, run.ends - 10.0 + 0.5, 1e-3)
    cmd = np.array([run.command(x) for x in t])
    inside = t - 10.0 <= spec.duration
    assert np.allclose(cmd[inside], command_samples(spec, t[inside] - 10.0))
    back = ~inside
    rate = np.abs(np.diff(cmd[back])) / 1e-3
    assert rate.max() <= rig_test.RETURN_RATE_SHARE * LIMITS.max_rate_rad_s * 1.0001
    assert cmd[-1] == 0.05 and run.phase(run.ends + 0.01) == "done"
    assert run.phase(run.ends - 0.01) == "settling"


def _rows(t: np.ndarray, command: np.ndarray, position: np.ndarray) -> np.ndarray:
    rows = np.zeros((t.size, len(CHANNELS)))
    rows[:, COLUMN["t"]] = t
    rows[:, COLUMN["command"]] = command
    rows[:, COLUMN["theta_u"]] = position
    rows[:, COLUMN["i3eq"]] = 0.1
    rows[:, COLUMN["temperature"]] = np.nan
    rows[:, COLUMN["load"]] = np.nan
    return rows


def test_silence_aborts_after_the_feedback_timeout_and_not_before():
    run = RigTest(plan_rig_test({}, DEFAULT, 0.0, LIMITS), LIMITS, started=0.0)
    assert run.abort_reason(0.4) is None
    run.on_rows(_rows(np.array([0.0]), np.full(1, 0.02), np.full(1, 0.02)), now=0.4)
    assert run.abort_reason(0.8) is None
    reason = run.abort_reason(0.95)
    assert reason is not None and "no telemetry for 0.55 s" in reason


def test_a_tracking_error_beyond_the_limit_aborts():
    run = RigTest(plan_rig_test({}, DEFAULT, 0.0, LIMITS), LIMITS, started=0.0)
    run.on_rows(_rows(np.array([0.0, 5e-4]), np.array([0.0, 0.01]), np.array([0.0, 0.005])), 0.1)
    assert run.abort_reason(0.1) is None and run.position_error == pytest.approx(0.005)
    run.on_rows(_rows(np.array([1e-3]), np.array([0.02]), np.array([0.0])), 0.2)
    assert "position error of 0.02 rad" in (run.abort_reason(0.2) or "")


def test_the_window_is_the_excitation_heard_in_any_order():
    spec = plan_rig_test({}, DEFAULT, 0.02, LIMITS)
    run = RigTest(spec, LIMITS, started=0.0)
    t = np.arange(0.0, 3.0, 1.0 / FS) + 100.0  # the rig's own clock
    cmd = np.where(
        (t >= 100.5) & (t <= 102.5), command_samples(spec, np.clip(t - 100.5, 0, None)), 0.02
    )
    rows = _rows(t, cmd, cmd)
    for part in (rows[3000:], rows[:3000]):  # heard out of order
        run.on_rows(part, 0.1)
    w = run.window(FS, {"sample_rate": FS})
    moving = t[np.flatnonzero(np.abs(np.diff(cmd)) > 0)]
    assert w.t[0] <= moving[0] and w.t[-1] >= moving[-1]
    assert w.duration == pytest.approx(spec.duration + 2 * 0.1, abs=2e-3)


def test_no_telemetry_or_no_excitation_is_no_window():
    run = RigTest(plan_rig_test({}, DEFAULT, 0.0, LIMITS), LIMITS, started=0.0)
    with pytest.raises(WindowError, match="no telemetry"):
        run.window(FS, {})
    t = np.arange(0.0, 3.0, 1.0 / FS)
    run.on_rows(_rows(t, np.zeros(t.size), np.zeros(t.size)), 0.1)
    with pytest.raises(WindowError, match="did not follow the test command"):
        run.window(FS, {})


def test_a_rig_whose_command_does_not_move_aborts_once_the_test_s_has():
    spec = plan_rig_test({}, DEFAULT, 0.0, LIMITS)
    run = RigTest(spec, LIMITS, started=0.0)
    still = _rows(np.arange(10) * 5e-4, np.zeros(10), np.zeros(10))
    half = np.flatnonzero(np.abs(command_samples(spec, np.arange(0, 2, 1e-3))) >= 0.015)[0] * 1e-3
    for now in np.arange(0.05, half + rig_test.FOLLOW_S, 0.05):
        run.on_rows(still, now)
        assert run.abort_reason(now) is None
    now = half + rig_test.FOLLOW_S + 0.01
    run.on_rows(still, now)
    assert "does not follow the test's commands" in (run.abort_reason(now) or "")
    moving = RigTest(spec, LIMITS, started=0.0)
    moving.on_rows(_rows(np.zeros(1), np.full(1, 0.004), np.full(1, 0.004)), now)
    assert moving.abort_reason(now) is None  # 0.004 rad > 0.1 x 0.03 rad: it follows


def test_a_test_whose_tolerated_error_could_reach_the_end_stop_is_refused():
    loose = RigTestLimits.of(
        ActuatorParameters.default(), max_position_error_rad=0.1, feedback_timeout_s=0.5
    )
    assert plan_rig_test({}, DEFAULT, 0.3, LIMITS).offset == 0.3  # 0.33 + 0.01 < 0.5
    with pytest.raises(ConfigError, match="plus the tracking error it tolerates"):
        plan_rig_test({}, DEFAULT, 0.4, loose)  # 0.43 < 0.45, but 0.43 + 0.1 > 0.5


@pytest.mark.parametrize("column", ["theta_u", "command"])
def test_a_non_finite_reading_aborts(column):
    run = RigTest(plan_rig_test({}, DEFAULT, 0.0, LIMITS), LIMITS, started=0.0)
    rows = _rows(np.array([0.0, 5e-4]), np.array([0.0, 1e-3]), np.array([0.0, 1e-3]))
    rows[1, COLUMN[column]] = np.nan
    run.on_rows(rows, 0.1)
    assert "non-finite" in (run.abort_reason(0.1) or "")
