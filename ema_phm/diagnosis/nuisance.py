"""Nuisances: what changes between windows without being a fault, estimated beside k.

Searched with k (normalized to [0, 1] like k; each `Nuisance` gives its physical range).
Which ones depends on the window's load channel (`searched`):

- load not measured (any NaN sample; the model then assumes no load there): `NUISANCES`,
  ``load_torque`` [N*m, user shaft], an unmeasured constant hinge moment (with any
  current-offset drift, below), and ``load_stiffness`` [N*m/rad, user shaft], an unmeasured
  moment proportional to the deflection (aerodynamic hinge spring; negative = overbalanced
  surface);
- load measured (every sample finite): `MEASURED_LOAD_NUISANCES`, ``current_offset`` [A]
  only.  The measured channel is the load; a fitted one beside it would contradict it.

The current-sensor offset.  A constant current offset and a constant load are the same
signature in the current (load * gear / gt amperes), apart from the load's static twist of
the transmission (about 2e-5 rad per 50 N*m, under the position noise), so where the load is
not measured the fitted constant load absorbs any offset drift since commissioning (1 A
reads as about gt / gear = 28 N*m).  Where it is measured the offset is searched itself:
an offset on the acquired I_3eq (as simulator/sensors.SensorSpec's, which the loops do not
read), added to the predicted current on top of the belief's monitor.current_offset.

Compensated, not estimated: the temperature (monitor_model.lf_parameters moves R, ke
and gt to the measured temperature).  The load ranges are wide on purpose (about 18 % and
18 % of the 845 N*m the motor holds through the gear at the 0.03 rad chirp); they are
not the benchmark's draws.  The offset's range is about 7 times the +/-0.15 A of a drawn
unit's current-sensor zero (config/unit_tolerances.yaml).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..domain.window import Window
from ..errors import WindowError


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


#: The nuisances searched where the load is not measured, in the order of the columns after k.
NUISANCES: tuple[Nuisance, ...] = (
    Nuisance("load_torque", "N*m", -150.0, 150.0),
    Nuisance("load_stiffness", "N*m/rad", -5000.0, 5000.0),
)
#: The current-sensor offset drift searched where the load is measured [A, on I_3eq].
CURRENT_OFFSET = Nuisance("current_offset", "A", -1.0, 1.0)
#: The nuisances searched where the load is measured, in the order of the columns after k.
MEASURED_LOAD_NUISANCES: tuple[Nuisance, ...] = (CURRENT_OFFSET,)
#: Every reported nuisance with its unit (searched, profiled, measured).
REPORTED_UNITS: dict[str, str] = {
    **{n.name: n.unit for n in NUISANCES},
    CURRENT_OFFSET.name: f"{CURRENT_OFFSET.unit} (current-sensor offset, searched when the "
    "load is measured)",
    "temperature_c": "degC (measured; R, ke, gt compensated)",
}


def load_measured(window: Window) -> bool:
    """True when every sample of the window's load channel is finite (NaN: not measured)."""
    return bool(np.all(np.isfinite(window.load)))


def searched(window: Window) -> tuple[Nuisance, ...]:
    """The nuisances searched on `window`: the unmeasured load, or the current offset."""
    return MEASURED_LOAD_NUISANCES if load_measured(window) else NUISANCES


def zero(nuisances: tuple[Nuisance, ...]) -> np.ndarray:
    """Normalized values of "no nuisance" (no load, no offset) of `nuisances`."""
    return np.array([n.normalized(0.0) for n in nuisances])


def physical(u: np.ndarray, nuisances: tuple[Nuisance, ...] = NUISANCES) -> np.ndarray:
    """(P, len(nuisances)) normalized -> physical values (same shape)."""
    u = np.atleast_2d(np.asarray(u, dtype=np.float64))
    if u.shape[1] != len(nuisances):
        raise WindowError(f"nuisance rows must have {len(nuisances)} values, got {u.shape[1]}")
    return np.column_stack([n.physical(u[:, j]) for j, n in enumerate(nuisances)])


def model_inputs(
    values: np.ndarray, nuisances: tuple[Nuisance, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """Physical (P, len(nuisances)) values -> (loads (P, 2), current offsets (P,)).

    The loads are the monitor model's nuisance columns (`NUISANCES`' order: constant load,
    hinge stiffness), zero where `nuisances` does not search them; the offsets are added to
    the predicted current, zero unless `CURRENT_OFFSET` is searched.
    """
    values = np.atleast_2d(np.asarray(values, dtype=np.float64))
    loads = np.zeros((values.shape[0], len(NUISANCES)))
    offset = np.zeros(values.shape[0])
    for j, n in enumerate(nuisances):
        if n == CURRENT_OFFSET:
            offset = values[:, j]
        else:
            loads[:, NUISANCES.index(n)] = values[:, j]
    return loads, offset
