"""A telemetry window: what the real EMA reports and the monitor consumes.

One row per sample, eight channels (`CHANNELS`), SI units except the temperature:

====  ===========  ======  =====================================================
col   channel      unit    meaning
====  ===========  ======  =====================================================
0     t            s       sample time
1     command      rad     position command at the user shaft
2     load         N*m     external load at the user shaft; NaN = not measured
3     theta_u      rad     user (surface) position, as the position sensor reads it
4     theta_m      rad     motor position
5     omega_m      rad/s   motor speed, as the speed sensor reads it
6     i3eq         A       equivalent single-phase current (acquisition output)
7     temperature  degC    measured winding/magnet temperature; NaN = unknown
====  ===========  ======  =====================================================

Recordings made before the temperature channel existed have the first seven
columns only (`LEGACY_CHANNELS`); `telemetry_rows` reads them with a NaN
temperature.  The same layout travels in `std_msgs/Float64MultiArray` messages
(see README, "Topics"), so the CLI, the nodes and the bags all speak one format.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import WindowError
from .faults import FAULTS, N_K


@dataclass(frozen=True)
class Channel:
    """One telemetry column."""

    name: str
    unit: str
    meaning: str
    #: NaN means "not measured" (every other channel must be finite).
    may_be_unmeasured: bool = False


#: The channel table, in column order (the module docstring's table).
CHANNEL_TABLE: tuple[Channel, ...] = (
    Channel("t", "s", "sample time"),
    Channel("command", "rad", "position command at the user shaft"),
    Channel("load", "N*m", "external load at the user shaft", may_be_unmeasured=True),
    Channel("theta_u", "rad", "user (surface) position, as the position sensor reads it"),
    Channel("theta_m", "rad", "motor position"),
    Channel("omega_m", "rad/s", "motor speed, as the speed sensor reads it"),
    Channel("i3eq", "A", "equivalent single-phase current (acquisition output)"),
    Channel("temperature", "degC", "measured winding/magnet temperature", may_be_unmeasured=True),
)
#: Channel names, in column order.
CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNEL_TABLE)
#: Column of each channel by name.
COLUMN: dict[str, int] = {c.name: i for i, c in enumerate(CHANNEL_TABLE)}
#: Column of the sample time.
TIME_COLUMN = COLUMN["t"]
#: The layout before the temperature channel: the first seven of `CHANNELS`.
LEGACY_CHANNELS: tuple[str, ...] = CHANNELS[: COLUMN["temperature"]]
#: Channels where NaN means "not measured" (every other channel must be finite).
MAY_BE_UNMEASURED: tuple[str, ...] = tuple(c.name for c in CHANNEL_TABLE if c.may_be_unmeasured)

#: run_info key saying how each channel was obtained (`ema-phm import`): a text starting
#: with `RECORDED` when the channel is a recorded series, else "derived: ..." or "unknown".
PROVENANCE_KEY = "channels"
RECORDED = "recorded"
#: run_info key of a current logged on every few grid samples only (`ema-phm import`):
#: ``{"every": m, "first": i}``, the window's samples i, i + m, ... are the log's own and
#: the others interpolated between them; the fit compares the current at the log's own.
CURRENT_LOGGED_KEY = "current_logged"

#: Fewest samples a window may have to be fitted.
MIN_SAMPLES = 50


#: What a simulated window's metadata may tell that a real drive never records: the true k
#: and its history, the degradation plan, the drawn unit and the sensors' errors.
TRUTH_META_KEYS: frozenset[str] = frozenset(
    {
        "k_true",
        "k_since_t",
        "degradation",
        "unit",
        "sensors",
        "noise_current",
        "noise_position",
        "noise_speed",
    }
)


@dataclass(frozen=True)
class Window:
    """A recorded stretch of telemetry at a fixed sample rate."""

    t: np.ndarray
    command: np.ndarray
    load: np.ndarray
    theta_u: np.ndarray
    theta_m: np.ndarray
    omega_m: np.ndarray
    i3eq: np.ndarray
    k_true: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    #: Measured temperature [degC]; None (the default) becomes all NaN: unknown.
    temperature: np.ndarray | None = field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        if self.temperature is None:
            unknown = np.full(np.shape(self.t), np.nan, dtype=np.float64)
            object.__setattr__(self, "temperature", unknown)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def dt(self) -> float:
        """Sample period in seconds."""
        return float((self.t[-1] - self.t[0]) / (self.n - 1))

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    def without_truth(self) -> "Window":
        """This window as a real drive records it: no true k, no `TRUTH_META_KEYS` in meta.

        What the monitor fits: a simulated window's truth stays with the caller (for %err).
        """
        meta = {k: v for k, v in self.meta.items() if k not in TRUTH_META_KEYS}
        return dataclasses.replace(self, k_true=None, meta=meta)

    def matrix(self) -> np.ndarray:
        """Samples as an (n, len(CHANNELS)) array in `CHANNELS` order."""
        return np.column_stack([getattr(self, c) for c in CHANNELS]).astype(np.float64)

    @classmethod
    def from_matrix(
        cls,
        data: np.ndarray,
        *,
        k_true: np.ndarray | None = None,
        meta: dict[str, Any] | None = None,
    ) -> "Window":
        """A Window from an (n, len(CHANNELS)) array in `CHANNELS` order, or a legacy (n, 7) one.

        WindowError otherwise (see `telemetry_rows`).
        """
        data = telemetry_rows(data)
        cols = {c: np.ascontiguousarray(data[:, i]) for i, c in enumerate(CHANNELS)}
        return cls(
            **cols,
            k_true=None if k_true is None else np.asarray(k_true, dtype=np.float64),
            meta=dict(meta or {}),
        )

    def validated(self, *, min_samples: int = MIN_SAMPLES) -> "Window":
        """Return self if usable for fitting, else raise WindowError naming the problem."""
        n = self.n
        for c in CHANNELS:
            a = getattr(self, c)
            if a.shape != (n,):
                raise WindowError(f"channel {c!r} has shape {a.shape}, expected ({n},)")
        if n < min_samples:
            raise WindowError(f"window too short: {n} samples, need at least {min_samples}")
        for c in CHANNELS:
            a = getattr(self, c)
            bad = np.isinf(a) if c in MAY_BE_UNMEASURED else ~np.isfinite(a)
            if bad.any():
                i = int(np.argmax(bad))
                what = "infinite" if c in MAY_BE_UNMEASURED else "non-finite"
                raise WindowError(
                    f"channel {c!r} has {int(bad.sum())} {what} samples (first at index "
                    f"{i}, t={self.t[i] if np.isfinite(self.t[i]) else 'nan'})"
                )
        steps = np.diff(self.t)
        dt = self.dt
        if not dt > 0:
            raise WindowError(f"time does not increase: first t={self.t[0]}, last t={self.t[-1]}")
        worst = float(np.max(np.abs(steps - dt)))
        if worst > 1e-6 * max(1.0, abs(self.t[-1])) + 1e-3 * dt:
            i = int(np.argmax(np.abs(steps - dt)))
            raise WindowError(
                f"uneven time base: step {i} is {steps[i]:.9g} s, mean step {dt:.9g} s (gap "
                "or reordered samples)"
            )
        if self.k_true is not None and self.k_true.shape != (N_K,):
            raise WindowError(f"ground-truth k must have {N_K} entries, got {self.k_true.shape}")
        return self


def unseen_faults(meta: Mapping[str, Any]) -> dict[int, str]:
    """Faults a recording cannot show: k index -> why (`Fault.needs_recorded`).

    A fault is unseen when a channel it needs is derived or unknown in the run_info's
    `PROVENANCE_KEY`; a window without that key (ema_phm's own) hides nothing.
    """
    how = meta.get(PROVENANCE_KEY)
    if not isinstance(how, Mapping):
        return {}
    out: dict[int, str] = {}
    for f in FAULTS:
        missing = [
            f"{c} is {how[c]}"
            for c in f.needs_recorded
            if isinstance(how.get(c), str) and not how[c].startswith(RECORDED)
        ]
        if missing:
            out[f.index] = f"the recording cannot show it: {'; '.join(missing)}"
    return out


def current_logged(meta: Mapping[str, Any], n: int) -> tuple[int, int] | None:
    """(every, first) of a current logged on every few samples (`CURRENT_LOGGED_KEY`).

    None when every sample is the current's own (no key); WindowError naming a key that
    is not two whole numbers with every >= 2 and 0 <= first < min(every, n).
    """
    got = meta.get(CURRENT_LOGGED_KEY)
    if got is None:
        return None
    try:
        every, first = got["every"], got["first"]
        ok = all(isinstance(v, int) and not isinstance(v, bool) for v in (every, first))
    except (TypeError, KeyError):
        ok = False
    if not ok or every < 2 or not 0 <= first < min(every, n):
        raise WindowError(
            f"run_info {CURRENT_LOGGED_KEY} must be {{every: m >= 2, first: 0 <= i < m}} "
            f"with i inside the window's {n} samples, got {got!r}"
        )
    return int(every), int(first)


def telemetry_rows(data: np.ndarray) -> np.ndarray:
    """`data` as n x len(CHANNELS) float64 rows in `CHANNELS` order.

    Legacy n x 7 rows (`LEGACY_CHANNELS`, recorded before the temperature channel)
    get a NaN temperature column (a new array); n x len(CHANNELS) rows are returned as float64
    (not copied if they already are).  Any other shape: WindowError naming it.
    """
    a = np.asarray(data, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == len(CHANNELS):
        return a
    if a.ndim == 2 and a.shape[1] == len(LEGACY_CHANNELS):
        return np.column_stack([a, np.full(a.shape[0], np.nan)])
    raise WindowError(
        f"telemetry must have {len(CHANNELS)} columns {CHANNELS} (or the legacy "
        f"{len(LEGACY_CHANNELS)} without temperature), got shape {a.shape}"
    )
