"""The normalized fault vector k of section 5.5 and its physical meaning.

k has eight entries in [0, 1]; `FaultVector.from_k` validates one and maps it
to the physical multipliers both models use (`physical_factors`, also compiled
into the monitor model's kernel).  k = [0,0,0,0,0,0,0.5,0.5] is the
healthy actuator (eq. 5.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import FaultVectorError

NAMES: tuple[str, ...] = (
    "friction",
    "backlash",
    "short_circuit_a",
    "short_circuit_b",
    "short_circuit_c",
    "eccentricity",
    "eccentricity_phase",
    "gain_drift",
)
NOMINAL = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5])
#: Two fully shorted phases are clamped to this (section 5.5), else the LF diverges.
TWO_PHASE_CLAMP = 0.99


def validate(k: Sequence[float] | np.ndarray) -> np.ndarray:
    """Return k as a float64 array of 8, or raise FaultVectorError naming the bad entry."""
    try:
        arr = np.asarray(k, dtype=np.float64)
    except (TypeError, ValueError):
        raise FaultVectorError(f"fault vector k must be 8 numbers, got {k!r}") from None
    if arr.shape != (8,):
        raise FaultVectorError(
            f"fault vector k must have 8 entries, got {arr.size} (shape {arr.shape})"
        )
    for i, v in enumerate(arr):
        if not math.isfinite(v):
            raise FaultVectorError(
                f"k{i + 1} ({NAMES[i]}) is {v}, must be a finite number in [0, 1]"
            )
        if v < 0.0 or v > 1.0:
            raise FaultVectorError(f"k{i + 1} ({NAMES[i]}) = {v:g} is outside [0, 1]")
    return arr


def parse(text: str) -> np.ndarray:
    """Parse 'k1,k2,...,k8' (CLI form; spaces allowed) and validate it.

    Every field must hold a number: an empty field ('0,,0') is refused rather
    than dropped, so a mistyped vector is never read as a different one.
    """
    fields = text.replace(" ", "").split(",")
    for i, f in enumerate(fields):
        if f == "":
            raise FaultVectorError(
                f"fault vector {text!r}: field {i + 1} of {len(fields)} is empty; "
                f"give 8 comma-separated numbers"
            ) from None
    if len(fields) != 8:
        raise FaultVectorError(
            f"fault vector must have 8 entries, got {len(fields)} in {text!r}"
        ) from None
    try:
        values = [float(f) for f in fields]
    except ValueError:
        raise FaultVectorError(
            f"fault vector must be 8 comma-separated numbers, got {text!r}"
        ) from None
    return validate(values)


def clamp_shorts(k: np.ndarray) -> np.ndarray:
    """Section 5.5: when two or more phases are fully shorted, set them to 0.99."""
    k = np.array(k, dtype=np.float64)
    sc = k[2:5]
    full = sc >= 1.0
    if int(full.sum()) >= 2:
        sc[full] = TWO_PHASE_CLAMP
        k[2:5] = sc
    return k


def physical_factors(
    k: np.ndarray,
) -> tuple[float, float, float, float, float, float, float, float]:
    """Clamped k -> physical factors.

    Returns friction factor, backlash factor, N_A, N_B, N_C, zeta, phi [rad], gain factor.

    Plain arithmetic so the monitor model compiles this same function into its kernel.
    """
    return (
        1.0 + 2.0 * k[0],
        1.0 + 99.0 * k[1],
        1.0 - k[2],
        1.0 - k[3],
        1.0 - k[4],
        k[5],
        -math.pi + 2.0 * math.pi * k[6],
        0.5 + k[7],
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


def percent_err(
    k_est: Sequence[float] | np.ndarray, k_true: Sequence[float] | np.ndarray
) -> float:
    """%err of eq. 6.4: RMS-like distance, the phase term weighted by the true k6."""
    e, t = validate(k_est), validate(k_true)
    d = e - t
    # the eccentricity phase lives on a circle: -pi and pi are the same direction
    d7 = (d[6] + 0.5) % 1.0 - 0.5
    s = float(np.sum(d[:6] ** 2) + t[5] * d7**2 + d[7] ** 2)
    return 100.0 * math.sqrt(s)


def per_parameter_err(
    k_est: Sequence[float] | np.ndarray, k_true: Sequence[float] | np.ndarray
) -> np.ndarray:
    """Absolute error of each entry in percentage points (phase wrapped on the circle)."""
    d = np.abs(validate(k_est) - validate(k_true))
    d[6] = min(d[6], 1.0 - d[6])
    return 100.0 * d
