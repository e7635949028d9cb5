"""Nuisances: what changes between windows without being a fault, estimated beside k.

Searched with k (normalized to [0, 1] like k, `NUISANCES` gives the physical range):
- ``load_torque`` [N*m, user shaft]: an unmeasured constant hinge moment (with any
  current-offset drift, below);
- ``load_stiffness`` [N*m/rad, user shaft]: an unmeasured moment proportional to the
  deflection (aerodynamic hinge spring; negative = overbalanced surface).

Not estimated: the current-sensor offset.  A constant current offset and a constant
load are the same signature in the current (load * gear / gt amperes), apart from the load's
static twist of the transmission (about 2e-5 rad per 50 N*m, under the position noise), so
the fitted constant load absorbs any offset drift since commissioning (1 A reads as about
gt / gear = 28 N*m).  The offset itself is the drive's job: it zeroes its current sensors
at power-up with the inverter off; the monitor uses monitor.current_offset.

Compensated, not estimated: the temperature (monitor_model.lf_parameters moves R, ke
and gt to the measured temperature).  The ranges are wide on purpose (about 18 % and
18 % of the 845 N*m the motor holds through the gear at the 0.03 rad chirp); they are
not the benchmark's draws.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Nuisance:
    """A searched nuisance: name, unit and physical range mapped from [0, 1]."""

    name: str
    unit: str
    low: float
    high: float

    def physical(self, u: np.ndarray) -> np.ndarray:
        """Normalized u in [0, 1] -> physical value."""
        return self.low + (self.high - self.low) * np.asarray(u, dtype=np.float64)

    def normalized(self, value: float) -> float:
        """Physical value -> u in [0, 1] (clipped)."""
        return float(np.clip((value - self.low) / (self.high - self.low), 0.0, 1.0))


#: The searched nuisances, in the order of the columns after k.
NUISANCES: tuple[Nuisance, ...] = (
    Nuisance("load_torque", "N*m", -150.0, 150.0),
    Nuisance("load_stiffness", "N*m/rad", -5000.0, 5000.0),
)
#: Normalized value of "no unmeasured load" (the search starts from it).
ZERO_LOAD: np.ndarray = np.array([n.normalized(0.0) for n in NUISANCES])
#: Every reported nuisance with its unit (searched, profiled, measured).
REPORTED_UNITS: dict[str, str] = {
    **{n.name: n.unit for n in NUISANCES},
    "temperature_c": "degC (measured; R, ke, gt compensated)",
}


def physical(u: np.ndarray) -> np.ndarray:
    """(P, len(NUISANCES)) normalized -> physical values (same shape)."""
    u = np.atleast_2d(np.asarray(u, dtype=np.float64))
    return np.column_stack([n.physical(u[:, j]) for j, n in enumerate(NUISANCES)])
