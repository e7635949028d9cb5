"""The units a channel map may name, and how each converts to the monitor's unit.

A monitor channel has one unit (`domain.window.CHANNEL_TABLE`); a map entry may name
another of the same kind, converted as ``value_in_monitor_unit = value * factor + shift``
(after the entry's own ``scale`` and ``offset``).
"""

from __future__ import annotations

import math

from ..errors import ConfigError

#: unit -> (monitor unit, factor, shift)
CONVERSIONS: dict[str, tuple[str, float, float]] = {
    "s": ("s", 1.0, 0.0),
    "ms": ("s", 1e-3, 0.0),
    "us": ("s", 1e-6, 0.0),
    "ns": ("s", 1e-9, 0.0),
    "rad": ("rad", 1.0, 0.0),
    "mrad": ("rad", 1e-3, 0.0),
    "deg": ("rad", math.pi / 180.0, 0.0),
    "rev": ("rad", 2.0 * math.pi, 0.0),
    "rad/s": ("rad/s", 1.0, 0.0),
    "deg/s": ("rad/s", math.pi / 180.0, 0.0),
    "rpm": ("rad/s", 2.0 * math.pi / 60.0, 0.0),
    "A": ("A", 1.0, 0.0),
    "mA": ("A", 1e-3, 0.0),
    "N*m": ("N*m", 1.0, 0.0),
    "mN*m": ("N*m", 1e-3, 0.0),
    "degC": ("degC", 1.0, 0.0),
    "K": ("degC", 1.0, -273.15),
    "1": ("1", 1.0, 0.0),
}


def conversion(unit: str, expected: str, *, where: str) -> tuple[float, float]:
    """(factor, shift) from `unit` to the monitor unit `expected`; ConfigError naming both."""
    if unit not in CONVERSIONS:
        raise ConfigError(f"{where}: unit {unit!r} is not one of {', '.join(sorted(CONVERSIONS))}")
    base, factor, shift = CONVERSIONS[unit]
    if base != expected:
        raise ConfigError(
            f"{where}: unit {unit!r} is a unit of {base}, this channel is in {expected}"
        )
    return factor, shift
