"""Position commands and load profiles of a window (sec. 2.1.1-2.1.2).

Each returns samples at the telemetry instants; both models are then driven by
those recorded samples, never by a formula of their own.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..limits import LIMITS, Limit, check
from .parameters import packaged_config_dir, read_yaml

KINDS = ("chirp", "step", "ramp", "sine")
#: The forms a rig's position commands take on ROS: whole trajectories (a joint trajectory
#: controller's input) or a stream of set-points (a forward position controller's).
COMMAND_TYPES: tuple[str, ...] = ("trajectory", "position")
#: A step or ramp starts inside the window (0 .. the longest window).
_T_START = Limit(0.0, LIMITS["duration"].high, "s")
#: A ramp's amplitude is a rate: the amplitude bounds per second.
_RAMP_RATE = Limit(LIMITS["amplitude"].low, LIMITS["amplitude"].high, "rad/s")


@dataclass(frozen=True)
class CommandSpec:
    """The position command of a window: kind, amplitude, frequencies, duration, offset."""

    kind: str = "chirp"
    amplitude: float = 0.03  # rad (user); for ramp: rate in rad/s
    f0: float = 0.5  # Hz (chirp start, sine frequency)
    f1: float = 4.5  # Hz (chirp end)
    duration: float = 2.0  # s
    offset: float = 0.0  # rad
    t_start: float = 0.0  # s, step / ramp start time

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigError(f"command kind must be one of {KINDS}, got {self.kind!r}")
        for name in ("amplitude", "f0", "f1", "duration", "offset", "t_start"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"command {name} must be a finite number, got {v!r}")
        # one table of ranges (limits.py) for every caller: CLI, nodes, benches
        check("duration", self.duration, label="command duration")
        if self.kind == "ramp":  # amplitude is a rate here: the same numbers, in rad/s
            check(
                "amplitude",
                self.amplitude,
                limit=_RAMP_RATE,
                label="command amplitude (ramp rate)",
            )
        else:
            check("amplitude", self.amplitude, label="command amplitude")
        check("amplitude", self.offset, label="command offset")
        check("duration", self.t_start, limit=_T_START, label="command t_start")
        if self.kind in ("chirp", "sine"):
            check("frequency", self.f0, label="command f0")
            check("frequency", self.f1, label="command f1")

    def check_sample_rate(self, sample_rate: float) -> None:
        """ConfigError unless every frequency of the command is below `sample_rate` / 2."""
        if self.kind not in ("chirp", "sine"):
            return
        nyquist = 0.5 * sample_rate
        for name in ("f0", "f1") if self.kind == "chirp" else ("f0",):
            f = getattr(self, name)
            if not f < nyquist:
                raise ConfigError(
                    f"command {name} = {f:g} Hz must be below {nyquist:g} Hz, half the "
                    f"{sample_rate:g} Hz telemetry sample rate (config/ema.yaml, acquisition)"
                )

    def as_dict(self) -> dict[str, Any]:
        """The fields as a dict."""
        return asdict(self)


@dataclass(frozen=True)
class LoadSpec:
    """The external load at the user shaft.

    The hinge moment is ``value + amplitude*sin(2*pi*frequency*t)`` (``kind="sine"``;
    ``"constant"`` has no sine) plus ``-spring * theta_u``, a moment proportional to the
    user deflection (an aerodynamic hinge moment, sec. 2.1.2).  `measured` says whether the
    telemetry's load channel carries it: when False the load acts on the actuator but the
    channel holds NaN (not measured), so the monitor is not handed a load a real monitor
    would not have.
    """

    kind: str = "constant"
    value: float = 0.0  # N*m at the user shaft
    amplitude: float = 0.0
    frequency: float = 0.0
    spring: float = 0.0  # N*m/rad at the user shaft: moment -spring * theta_u
    measured: bool = True  # False: the telemetry's load channel is NaN

    def __post_init__(self) -> None:
        if self.kind not in ("constant", "sine"):
            raise ConfigError(f"load kind must be 'constant' or 'sine', got {self.kind!r}")
        for name in ("value", "amplitude", "frequency", "spring"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"load {name} must be a finite number, got {v!r}")
        if not isinstance(self.measured, bool):
            raise ConfigError(f"load measured must be true or false, got {self.measured!r}")
        check("load", self.value, label="load value")
        check("load", self.amplitude, label="load amplitude")
        check("frequency", self.frequency, label="load frequency")
        check("load_spring", self.spring, label="load spring")

    def as_dict(self) -> dict[str, Any]:
        """The fields as a dict."""
        return asdict(self)


def default_specs() -> tuple[CommandSpec, LoadSpec]:
    """The bundled default window (config/commands.yaml)."""
    data = read_yaml(packaged_config_dir() / "commands.yaml")
    try:
        return CommandSpec(**data.get("command", {})), LoadSpec(**data.get("load", {}))
    except TypeError as exc:
        raise ConfigError(f"config/commands.yaml: {exc}") from None


def calibration_spec() -> CommandSpec:
    """The calibration window (config/commands.yaml, `calibration`)."""
    data = read_yaml(packaged_config_dir() / "commands.yaml")
    try:
        return CommandSpec(**data.get("calibration", {}))
    except TypeError as exc:
        raise ConfigError(f"config/commands.yaml: calibration: {exc}") from None


def sample_times(duration: float, sample_rate: float) -> np.ndarray:
    """Times 0, 1/sample_rate, ... up to `duration` inclusive."""
    n = int(round(duration * sample_rate)) + 1
    return np.arange(n, dtype=np.float64) / sample_rate


def command_samples(spec: CommandSpec, t: np.ndarray) -> np.ndarray:
    """Command (rad, user shaft) at times t."""
    a, off = spec.amplitude, spec.offset
    if spec.kind == "chirp":
        # linear chirp: instantaneous frequency f0 -> f1 over the duration
        chirp_rate = (spec.f1 - spec.f0) / spec.duration  # Hz/s
        return off + a * np.sin(2 * np.pi * (spec.f0 * t + 0.5 * chirp_rate * t * t))
    if spec.kind == "sine":
        return off + a * np.sin(2 * np.pi * spec.f0 * t)
    if spec.kind == "step":
        return off + np.where(t >= spec.t_start, a, 0.0)
    return off + a * np.clip(t - spec.t_start, 0.0, None)  # ramp: amplitude is a rate


def load_samples(spec: LoadSpec, t: np.ndarray) -> np.ndarray:
    """The load of `spec` at times `t` [N*m]."""
    if spec.kind == "constant":
        return np.full_like(t, spec.value)
    return spec.value + spec.amplitude * np.sin(2 * np.pi * spec.frequency * t)
