"""A test window asked of the rig (monitor_node's ``~/run_test``), free of rclpy.

`plan_rig_test` turns a request into the excitation around the actuator's present position and
refuses one that leaves the actuator file's limits; `RigTest` says what to command at each
instant (the excitation, a rate-limited return to the start, a hold while the response
settles), watches the rig's reports (no telemetry for `feedback_timeout_s`, a tracking error
beyond `max_position_error_rad`, a non-finite reading, or a rig whose command does not follow
the test's, aborts) and cuts the window it recorded.  The node
(`ros.run_test_action`) only publishes, listens and fits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..domain.excitation_spans import excitation_spans
from ..domain.window import COLUMN, Window
from ..errors import ConfigError, WindowError
from ..physics.commands import CommandSpec, command_samples
from ..physics.parameters import ActuatorParameters

#: The excitations a test may be: bounded in rate and travel (a step's rate is unbounded,
#: a ramp's travel).
TEST_KINDS: tuple[str, ...] = ("chirp", "sine")
#: The highest frequency a test may hold: ten set-points a period at 200 Hz.
MAX_FREQUENCY_HZ = 20.0
#: Share of the end stop and of the top speed a test may use (a margin for the response).
LIMIT_SHARE = 0.9
#: s the command is held at the start position after the return, so the response settles.
SETTLE_S = 0.3
#: The return to the start runs at this share of the top rate.
RETURN_RATE_SHARE = 0.25
#: A recorded window shorter than this share of the excitation is not the test's.
MIN_RECORDED_SHARE = 0.8
#: The recorded window: the excitation, pauses this short joined, widened by SETTLE_PAD_S [s].
MAX_PAUSE_S = 0.25
SETTLE_PAD_S = 0.1
#: s the rig may take to show the test's command in its telemetry (a simulated rig on a busy
#: machine runs up to 1 s behind the wall clock before it catches up).
FOLLOW_S = 1.5
#: Share of the amplitude the rig's command must have moved once the test's moved half of it.
FOLLOW_SHARE = 0.1


@dataclass(frozen=True)
class RigTestLimits:
    """What a test may command and when it stops (from the actuator file and parameters)."""

    end_stop_rad: float  # user shaft
    max_rate_rad_s: float  # user shaft, the motor's top speed through the gear
    max_position_error_rad: float  # |user position - command| the rig may report
    feedback_timeout_s: float  # s without telemetry before the test is aborted

    @classmethod
    def of(
        cls,
        actuator: ActuatorParameters,
        *,
        max_position_error_rad: float,
        feedback_timeout_s: float,
    ) -> RigTestLimits:
        """The limits of `actuator` (end stop, top speed) with the node's watch limits."""
        top = actuator.controller.max_speed_rpm * 2.0 * math.pi / 60.0
        return cls(
            end_stop_rad=float(actuator.mechanics.end_stop),
            max_rate_rad_s=float(top * actuator.mechanics.gear_ratio),
            max_position_error_rad=float(max_position_error_rad),
            feedback_timeout_s=float(feedback_timeout_s),
        )


def plan_rig_test(
    request: dict[str, Any], default: CommandSpec, start: float, limits: RigTestLimits
) -> CommandSpec:
    """The excitation of `request` around `start` [rad]; ConfigError naming what is refused.

    `request`: kind, amplitude_rad, f0_hz, f1_hz, duration_s; '' or 0 take `default`'s.
    """
    kind = str(request.get("kind") or default.kind)
    if kind not in TEST_KINDS:
        raise ConfigError(
            f"a test excitation must be one of {', '.join(TEST_KINDS)} (a bounded rate), "
            f"got kind {kind!r}"
        )
    spec = CommandSpec(
        kind=kind,
        amplitude=float(request.get("amplitude_rad") or default.amplitude),
        f0=float(request.get("f0_hz") or default.f0),
        f1=float(request.get("f1_hz") or default.f1),
        duration=float(request.get("duration_s") or default.duration),
        offset=float(start),
    )
    if not spec.amplitude > 0:
        raise ConfigError(f"the test amplitude must be > 0 rad, got {spec.amplitude:g}")
    reach = abs(spec.offset) + spec.amplitude
    if reach > LIMIT_SHARE * limits.end_stop_rad:
        raise ConfigError(
            f"the test would reach {reach:.4g} rad from the start position {start:.4g} rad: "
            f"beyond {LIMIT_SHARE:g} x the end stop {limits.end_stop_rad:g} rad"
        )
    if reach + limits.max_position_error_rad > limits.end_stop_rad:
        raise ConfigError(
            f"the test's reach {reach:.4g} rad plus the tracking error it tolerates "
            f"(run_test_max_position_error_rad {limits.max_position_error_rad:g}) is beyond the "
            f"end stop {limits.end_stop_rad:g} rad"
        )
    top_hz = max(spec.f0, spec.f1) if kind == "chirp" else spec.f0
    if top_hz > MAX_FREQUENCY_HZ:
        raise ConfigError(
            f"the test's highest frequency {top_hz:g} Hz is beyond {MAX_FREQUENCY_HZ:g} Hz "
            "(ten set-points a period at 200 Hz)"
        )
    rate = 2.0 * math.pi * top_hz * spec.amplitude
    if rate > LIMIT_SHARE * limits.max_rate_rad_s:
        raise ConfigError(
            f"the test's peak rate {rate:.4g} rad/s (2 pi x {top_hz:g} Hz x "
            f"{spec.amplitude:g} rad) is beyond {LIMIT_SHARE:g} x the top speed "
            f"{limits.max_rate_rad_s:.4g} rad/s at the user shaft (max_speed_rpm x gear_ratio)"
        )
    return spec


class RigTest:
    """One test under way: the command at each instant, the rig's reports, the window."""

    def __init__(self, spec: CommandSpec, limits: RigTestLimits, started: float) -> None:
        """`started`: when the excitation starts [s, the caller's monotonic clock]."""
        self.spec, self.limits, self.started = spec, limits, started
        self.start = spec.offset
        end = float(command_samples(spec, np.array([spec.duration]))[0])
        self._end_value = end
        self._return_s = self.return_time(end)
        self.ends = started + spec.duration + self._return_s + SETTLE_S
        self.last_heard = started
        self.position_error = 0.0
        self._too_far: float | None = None  # the worst tracking error beyond the limit
        self.rig_moved = 0.0  # the largest |command - start| the rig reported
        self._unreadable = False  # the rig reported a non-finite command or position
        t = np.arange(0.0, spec.duration, 1e-3)
        half = np.abs(command_samples(spec, t) - self.start) >= 0.5 * spec.amplitude
        #: when the test's own command has moved half its amplitude [s after the start]
        self._half_at = float(t[np.argmax(half)]) if half.any() else math.inf
        self._rows: list[np.ndarray] = []

    def command(self, now: float) -> float:
        """The position command [rad] at `now`: excitation, return to the start, hold."""
        t = now - self.started
        if t <= 0:
            return self.start
        if t <= self.spec.duration:
            return float(command_samples(self.spec, np.array([t]))[0])
        back = t - self.spec.duration
        if back < self._return_s:
            return self._end_value + (self.start - self._end_value) * back / self._return_s
        return self.start

    def return_time(self, position: float) -> float:
        """The time [s] from `position` back to the start at the return rate."""
        rate = RETURN_RATE_SHARE * self.limits.max_rate_rad_s
        return abs(position - self.start) / rate if rate > 0 else 0.0

    def ramp_back(self, position: float, points_per_s: float) -> np.ndarray:
        """Commands from `position` to the start at the return rate, `points_per_s` apart."""
        steps = int(np.ceil(self.return_time(position) * points_per_s))
        return np.linspace(position, self.start, steps + 1)

    def phase(self, now: float) -> str:
        """Commanding (the excitation), settling (return and hold) or done."""
        t = now - self.started
        if t <= self.spec.duration:
            return "commanding"
        return "settling" if now < self.ends else "done"

    def on_rows(self, rows: np.ndarray, now: float) -> None:
        """Telemetry rows (telemetry layout) heard at `now`: kept, and the tracking error read."""
        if rows.shape[0] == 0:
            return
        self._rows.append(np.array(rows, dtype=np.float64, copy=True))
        self.last_heard = now
        if not (
            np.all(np.isfinite(rows[:, COLUMN["command"]]))
            and np.all(np.isfinite(rows[:, COLUMN["theta_u"]]))
        ):
            self._unreadable = True
        moved = np.abs(rows[:, COLUMN["command"]] - self.start)
        self.rig_moved = max(self.rig_moved, float(np.max(moved)))
        err = np.abs(rows[:, COLUMN["theta_u"]] - rows[:, COLUMN["command"]])
        self.position_error = float(err[-1])
        worst = float(np.max(err))
        if worst > self.limits.max_position_error_rad and self._too_far is None:
            self._too_far = worst

    def abort_reason(self, now: float) -> str | None:
        """Why the test must stop now (None: it may go on)."""
        quiet = now - self.last_heard
        if quiet > self.limits.feedback_timeout_s:
            return (
                f"no telemetry for {quiet:.2f} s (feedback_timeout_s "
                f"{self.limits.feedback_timeout_s:g}): the rig's feedback is stale"
            )
        if (
            now - self.started > self._half_at + FOLLOW_S
            and self.rig_moved < FOLLOW_SHARE * self.spec.amplitude
        ):
            return (
                f"the rig's command moved {self.rig_moved:.3g} rad from the start within "
                f"{now - self.started:.2f} s of a {self.spec.amplitude:g} rad test: the rig does "
                "not follow the test's commands (run_test_command_topic, run_test_command_type)"
            )
        if self._unreadable:
            return "the rig reported a non-finite command or user position"
        worst = self._too_far
        if worst is not None:
            return (
                f"the rig reported a position error of {worst:.4g} rad (|user position - "
                f"command|), beyond max_position_error_rad {self.limits.max_position_error_rad:g}"
            )
        return None

    def window(self, sample_rate: float, meta: dict[str, Any]) -> Window:
        """The excitation's window in what was heard; WindowError when it is not there whole."""
        if not self._rows:
            raise WindowError("no telemetry was heard during the test")
        rows = np.vstack(self._rows)
        rows = rows[np.argsort(rows[:, 0], kind="stable")]
        shortest = MIN_RECORDED_SHARE * self.spec.duration
        found = excitation_spans(
            rows[:, COLUMN["command"]],
            sample_rate,
            max_pause_s=MAX_PAUSE_S,
            settle_s=SETTLE_PAD_S,
            min_duration_s=shortest,
        )
        if not found:
            raise WindowError(
                f"the recorded command holds no excitation of at least {shortest:g} s: the "
                "rig did not follow the test command"
            )
        first, last = max(found, key=lambda ab: ab[1] - ab[0])
        return Window.from_matrix(rows[first : last + 1], meta=meta).validated()
