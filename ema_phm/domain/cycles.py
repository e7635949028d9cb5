"""Cycles: the actuator's life is counted in them; a RUL in cycles becomes hours through this."""

from __future__ import annotations

from typing import Any

from ..limits import check

#: Operating hours per cycle when neither the caller nor the description gives any.
DEFAULT_CYCLE_HOURS = 1.0


def check_cycle_hours(value: Any, *, label: str = "--cycle-hours") -> float:
    """Operating hours per cycle inside `limits.LIMITS["cycle_hours"]`, or ConfigError."""
    return float(check("cycle_hours", value, label=label))
