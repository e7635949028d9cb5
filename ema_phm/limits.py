"""Allowed ranges of every user-settable number (CLI options, node parameters, run_info).

One table so the CLI, the nodes and the run_info reader reject the same values
with the same words.  A bound exists where a larger (or smaller) value would hang,
exhaust memory or fail only later; each says why beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .errors import ConfigError


@dataclass(frozen=True)
class Limit:
    """Range of one quantity, closed unless `low_open`/`high_open`; a bound may be infinite.

    `integer` ones must be whole numbers.  `check` is the one number validator of ema_phm:
    modules with a range of their own pass it as ``check(name, value, limit=Limit(...))``.
    """

    low: float
    high: float
    unit: str = ""
    integer: bool = False
    why: str = ""
    low_open: bool = False
    high_open: bool = False

    def describe(self) -> str:
        """The allowed range in words, e.g. "a number in [0, 1] s", "a number > 0"."""
        unit = f" {self.unit}" if self.unit else ""
        if math.isinf(self.low) and math.isinf(self.high):
            return f"a finite number{unit}"
        if math.isinf(self.high):
            kind = "a whole number" if self.integer else "a number"
            return f"{kind} {'>' if self.low_open else '>='} {self.low:g}{unit}"
        left, right = "(" if self.low_open else "[", ")" if self.high_open else "]"
        if self.integer:
            return f"an integer in {left}{int(self.low)}, {int(self.high)}{right}{unit}"
        return f"a number in {left}{self.low:g}, {self.high:g}{right}{unit}"

    def holds(self, x: float) -> bool:
        """Whether the finite number `x` is inside the range."""
        above = x > self.low if self.low_open else x >= self.low
        below = x < self.high if self.high_open else x <= self.high
        return above and below


#: Any number > 0 (a duration, a rate, a scale).
POSITIVE = Limit(0.0, math.inf, low_open=True)
#: Any number >= 0.
NON_NEGATIVE = Limit(0.0, math.inf)
#: Any finite number.
FINITE = Limit(-math.inf, math.inf)


#: Allowed range of each quantity, by the name callers pass to `check`.
LIMITS: dict[str, Limit] = {
    # cma (pymoo's CMA-ES) takes seeds < 2**32 and we hand it seed + 1
    "seed": Limit(
        0, 2**31 - 1, integer=True, why="seeds must fit the optimizers' 32-bit generators"
    ),
    # 0 = the preset's own budget; 200k LF evaluations of a 2 s window take ~70 s on 2 cores
    "max_evaluations": Limit(
        0, 200_000, integer=True, why="~70 s of LF evaluations on a 2 s window"
    ),
    "duration": Limit(
        0.05, 60.0, "s", why="a window needs >= 100 samples; 60 s is 120k samples per window"
    ),
    "samples_per_window": Limit(100, 120_000, integer=True, why="0.05 s .. 60 s at 2 kHz"),
    "sample_rate": Limit(
        1.0, 1.0e6, "Hz", why="the monitor's filters and steps need a physical rate"
    ),
    "samples_per_message": Limit(
        1, 10_000, integer=True, why="a message of more than 5 s at 2 kHz holds up a window"
    ),
    "realtime_factor": Limit(0.0, 1000.0, why="0 = as fast as possible"),
    "max_windows": Limit(0, 1_000_000_000, integer=True),
    "wait_for_subscribers": Limit(0, 1000, integer=True),
    "noise_current": Limit(0.0, 22.5, "A RMS", why="the drive's current limit"),
    "noise_position": Limit(0.0, 0.5, "rad RMS", why="the end-stop travel"),
    "noise_speed": Limit(0.0, 1000.0, "rad/s RMS", why="above the motor's 838 rad/s speed limit"),
    "amplitude": Limit(-0.5, 0.5, "rad", why="the user end stops are at +/-0.5 rad"),
    "frequency": Limit(0.0, 1000.0, "Hz", why="the Nyquist frequency of the 2 kHz telemetry"),
    "load": Limit(
        -1000.0, 1000.0, "N*m", why="far above the 845 N*m the motor can hold through the gear"
    ),
    # the hinge moment -spring*theta_u: at 0.01 rad of deflection 1e5 N*m/rad is 1000 N*m,
    # above the 845 N*m the motor can hold; a negative spring (an overbalanced surface) would
    # destabilize the position loop the thesis tuned for a passive load
    "load_spring": Limit(
        0.0, 1.0e5, "N*m/rad", why="1000 N*m at 0.01 rad, above what the motor can hold"
    ),
    # ema_node's unit_seed: -1 = no drawn unit, else a seed as above
    "unit_seed": Limit(
        -1, 2**31 - 1, integer=True, why="-1 = none; seeds fit the 32-bit generators"
    ),
    # a manufactured unit (simulator/unit.py): factors on its datasheet values
    "unit_factor": Limit(
        0.25, 4.0, why="a unit 4x off its datasheet is another design, not a tolerance"
    ),
    "sensor_gain": Limit(0.5, 1.5, why="a sensor reading 50 % off has failed, not drifted"),
    "current_offset": Limit(
        -2.25, 2.25, "A", why="10 % of the drive's 22.5 A range: beyond it the sensor has failed"
    ),
    "position_offset": Limit(
        -0.05, 0.05, "rad", why="10 % of the +/-0.5 rad travel: beyond it the rigging is wrong"
    ),
    # a tolerance band read as 3 sigma; below 1 every drawn factor stays > 0
    "unit_tolerance": Limit(0.0, 0.9, why="a factor band of 100 % would allow a zero"),
    "temperature": Limit(
        -60.0,
        180.0,
        "degC",
        why="aircraft equipment cold soak (-55 degC) .. class H winding insulation (180 degC)",
    ),
    # monitor_node: healthy windows it commissions itself from when it has no unit file
    "commission_windows": Limit(
        0, 20, integer=True, why="0 = off; 20 two-second windows fit in well under a minute"
    ),
    # monitor_node: windows waiting behind the running fit (a 2 s window is ~0.3 MB)
    "queue_depth": Limit(0, 100, integer=True, why="0 = skip every window that finds it busy"),
    # monitor_node ~/run_test: the tracking error and the silence that abort a test
    "position_error": Limit(0.0, 0.5, "rad", low_open=True, why="the end-stop travel"),
    "feedback_timeout": Limit(0.01, 60.0, "s"),
    "heartbeat_period": Limit(0.01, 3600.0, "s"),
    "stale_timeout": Limit(0.01, 3600.0, "s"),
    # smallest probe separation of a window (diagnosis/excitation.py); 0 accepts every window
    "excitation_threshold": Limit(0.0, 1.0e6, why="fitness units; the default window scores ~1"),
    # `ema-phm simulate --windows`: one HF window per operating cycle; a default 2 s window is
    # 4001 samples x 8 channels x 8 bytes = 0.26 MB of bag
    "windows": Limit(1, 2000, integer=True, why="2000 windows of 2 s are ~0.5 GB of bag"),
    # operating hours per cycle (window) of a degradation run: 1 s .. ~11 years
    "cycle_hours": Limit(
        1.0 / 3600.0, 1.0e5, "h", why="one cycle lasts at least a second and at most ~11 years"
    ),
    # monitor_node: a fault whose RUL 5th percentile stays below this horizon (rul_alarm_windows
    # prognoses) makes the status WARN
    "rul_horizon_cycles": Limit(
        1, 1_000_000, "cycles", integer=True, why="RUL is counted in whole cycles; 1e6 is ~a life"
    ),
    # monitor_node: consecutive prognoses with a RUL p5 below the horizon before the WARN
    "rul_alarm_windows": Limit(1, 100, "windows", integer=True, why="1 = warn at once"),
    # `ema-phm play --rate`: below 1e-3 a 2 s window takes over half an hour (looks hung); above
    # 1e3 a 60 s bag plays in 60 ms, as fast as publishing goes anyway
    "play_rate": Limit(
        1e-3, 1e3, why="1e-3 plays a 2 s window in 33 min; 1e3 is as fast as it goes"
    ),
    # how often BagRecorder writes its pending chunk: a SIGKILL loses at most this much recording
    "bag_flush_period": Limit(
        0.01, 3600.0, "s", why="below 10 ms every message becomes its own chunk"
    ),
}


def check(
    name: str, value: Any, *, limit: Limit | None = None, label: str | None = None
) -> float | int:
    """`value` as a number inside `limit` (default LIMITS[name]).

    Otherwise ConfigError naming it (`label`, default `name`), the value and the range.
    """
    lim = limit or LIMITS[name]
    shown = label or name
    if isinstance(value, bool):
        raise ConfigError(f"{shown} must be {lim.describe()}, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(f"{shown} must be {lim.describe()}, got {value!r}") from None
    if not math.isfinite(x) or not lim.holds(x):
        raise ConfigError(f"{shown} must be {lim.describe()}, got {value!r}")
    if lim.integer:
        if not x.is_integer():
            raise ConfigError(f"{shown} must be {lim.describe()}, got {value!r}")
        return int(x)
    return x
