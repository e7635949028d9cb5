"""The field order of the numeric health vector (`/ema/health`), generated from the fault table."""

from __future__ import annotations

from .faults import FAULTS, LABELS

#: The fit's part (alone before the prognosis): k1..kN, then the fit's figures.
HEALTH_FIELDS_FIT: tuple[str, ...] = LABELS + (
    "percent_err",
    "fitness",
    "evaluations",
    "elapsed_s",
    "window_t0",
    "window_t1",
    "level",
)
#: The prognosis's part: RUL percentiles [cycles] of every fault with a RUL, then the
#: dominant fault.
HEALTH_RUL_FIELDS: tuple[str, ...] = tuple(
    f"rul_{f.label}_{p}" for f in FAULTS if f.has_rul for p in ("p5", "p50", "p95")
) + ("rul_dominant",)
#: Field order of the numeric health vector.
HEALTH_FIELDS: tuple[str, ...] = HEALTH_FIELDS_FIT + HEALTH_RUL_FIELDS
#: The single MultiArrayDimension label of `/ema/health`: the field names, comma-separated.
HEALTH_LABEL = ",".join(HEALTH_FIELDS)
