"""The physical reading of the normalized fault vector k (section 5.5).

What each entry means is the fault table's (`domain.faults`); this module maps a
validated k to the physical multipliers both models use (`physical_factors`, also
compiled into the monitor model's kernel, hence its plain arithmetic on entries whose
positions are module constants taken from the table: numba compiles them in as numbers).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..domain.faults import fault, validate

#: Two fully shorted phases are clamped to this (section 5.5), else the LF diverges.
TWO_PHASE_CLAMP = 0.99
#: The k entries of the three phases' coil short circuits.
SHORTS = slice(fault("short_circuit_a").index, fault("short_circuit_c").index + 1)

# The entries physical_factors reads (plain ints, frozen into the compiled kernel).
_FRICTION = fault("friction").index
_BACKLASH = fault("backlash").index
_SHORT_A = fault("short_circuit_a").index
_SHORT_B = fault("short_circuit_b").index
_SHORT_C = fault("short_circuit_c").index
_ECCENTRICITY = fault("eccentricity").index
_ECCENTRICITY_PHASE = fault("eccentricity_phase").index
_GAIN = fault("gain_drift").index


def clamp_shorts(k: np.ndarray) -> np.ndarray:
    """Section 5.5: when two or more phases are fully shorted, set them to 0.99."""
    k = np.array(k, dtype=np.float64)
    sc = k[SHORTS]
    full = sc >= 1.0
    if int(full.sum()) >= 2:
        sc[full] = TWO_PHASE_CLAMP
        k[SHORTS] = sc
    return k


def physical_factors(
    k: np.ndarray,
) -> tuple[float, float, float, float, float, float, float, float]:
    """Clamped k -> physical factors.

    Returns friction factor, backlash factor, N_A, N_B, N_C, zeta, phi [rad], gain factor.

    Plain arithmetic so the monitor model compiles this same function into its kernel; the
    returned tuple is positional because a numba kernel unpacks it.
    """
    return (
        1.0 + 2.0 * k[_FRICTION],
        1.0 + 99.0 * k[_BACKLASH],
        1.0 - k[_SHORT_A],
        1.0 - k[_SHORT_B],
        1.0 - k[_SHORT_C],
        k[_ECCENTRICITY],
        -math.pi + 2.0 * math.pi * k[_ECCENTRICITY_PHASE],
        0.5 + k[_GAIN],
    )


@dataclass(frozen=True)
class FaultVector:
    """Physical reading of a validated k."""

    k: np.ndarray
    friction_factor: float  # multiplies static and dynamic dry friction
    backlash_factor: float  # multiplies the nominal backlash
    coils: np.ndarray  # working fraction N_A, N_B, N_C (eq. 4.3)
    zeta: float  # eccentricity amplitude
    phi: float  # eccentricity direction, rad (LF: electrical, eq. 3.22; HF: mechanical)
    gain_factor: float  # multiplies the position-loop gain

    @classmethod
    def from_k(cls, k: Sequence[float] | np.ndarray) -> "FaultVector":
        """Validate and clamp `k`; the physical factors it maps to."""
        kk = clamp_shorts(validate(k))
        friction, backlash, n_a, n_b, n_c, zeta, phi, gain = physical_factors(kk)
        return cls(
            k=kk,
            friction_factor=float(friction),
            backlash_factor=float(backlash),
            coils=np.array([n_a, n_b, n_c], dtype=np.float64),
            zeta=float(zeta),
            phi=float(phi),
            gain_factor=float(gain),
        )
