"""Position commands and load profiles of a window (sec. 2.1.1-2.1.2).

Each returns samples at the telemetry instants; both models are then driven by
those recorded samples, never by a formula of their own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import ConfigError
from .params import config_dir, read_yaml

KINDS = ("chirp", "step", "ramp", "sine")


@dataclass(frozen=True)
class CommandSpec:
    kind: str = "chirp"
    amplitude: float = 0.03      # rad (user); for ramp: rate in rad/s
    f0: float = 0.5              # Hz (chirp start, sine frequency)
    f1: float = 4.5              # Hz (chirp end)
    duration: float = 2.0        # s
    offset: float = 0.0          # rad
    t_start: float = 0.0         # s, step / ramp start time

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigError(f"command kind must be one of {KINDS}, got {self.kind!r}")
        for name in ("amplitude", "f0", "f1", "duration", "offset", "t_start"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"command {name} must be a finite number, got {v!r}")
        if self.duration <= 0:
            raise ConfigError(f"command duration must be > 0 s, got {self.duration}")
        if self.kind in ("chirp", "sine") and (self.f0 < 0 or self.f1 < 0):
            raise ConfigError(f"command frequencies must be >= 0 Hz, got f0={self.f0}, f1={self.f1}")

    def as_dict(self) -> dict[str, Any]:
        return dict(kind=self.kind, amplitude=self.amplitude, f0=self.f0, f1=self.f1,
                    duration=self.duration, offset=self.offset, t_start=self.t_start)


@dataclass(frozen=True)
class LoadSpec:
    kind: str = "constant"
    value: float = 0.0           # N*m at the user shaft
    amplitude: float = 0.0
    frequency: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("constant", "sine"):
            raise ConfigError(f"load kind must be 'constant' or 'sine', got {self.kind!r}")
        for name in ("value", "amplitude", "frequency"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"load {name} must be a finite number, got {v!r}")

    def as_dict(self) -> dict[str, Any]:
        return dict(kind=self.kind, value=self.value, amplitude=self.amplitude, frequency=self.frequency)


def default_specs() -> tuple[CommandSpec, LoadSpec]:
    """The bundled default window (config/commands.yaml)."""
    data = read_yaml(config_dir() / "commands.yaml")
    try:
        return CommandSpec(**data.get("command", {})), LoadSpec(**data.get("load", {}))
    except TypeError as exc:
        raise ConfigError(f"config/commands.yaml: {exc}") from None


def calibration_spec() -> CommandSpec:
    """The calibration window (config/commands.yaml, `calibration`)."""
    data = read_yaml(config_dir() / "commands.yaml")
    try:
        return CommandSpec(**data.get("calibration", {}))
    except TypeError as exc:
        raise ConfigError(f"config/commands.yaml: calibration: {exc}") from None


def sample_times(duration: float, sample_rate: float) -> np.ndarray:
    n = int(round(duration * sample_rate)) + 1
    return np.arange(n, dtype=np.float64) / sample_rate


def command_samples(spec: CommandSpec, t: np.ndarray) -> np.ndarray:
    """Command (rad, user shaft) at times t."""
    a, off = spec.amplitude, spec.offset
    if spec.kind == "chirp":
        # linear chirp: instantaneous frequency f0 -> f1 over the duration
        k = (spec.f1 - spec.f0) / spec.duration
        return off + a * np.sin(2 * np.pi * (spec.f0 * t + 0.5 * k * t * t))
    if spec.kind == "sine":
        return off + a * np.sin(2 * np.pi * spec.f0 * t)
    if spec.kind == "step":
        return off + np.where(t >= spec.t_start, a, 0.0)
    return off + a * np.clip(t - spec.t_start, 0.0, None)  # ramp: amplitude is a rate


def load_samples(spec: LoadSpec, t: np.ndarray) -> np.ndarray:
    if spec.kind == "constant":
        return np.full_like(t, spec.value)
    return spec.value + spec.amplitude * np.sin(2 * np.pi * spec.frequency * t)
