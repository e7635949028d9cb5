"""Which fitted k entries mean something: flags from the intervals and the sensitivities.

- k7, the eccentricity phase, is not identifiable when the interval of k6 reaches 0: with
  no eccentricity there is no direction (the thesis notes it in its chapter 7).  Its
  interval is then reported as the whole [0, 1].
- An entry whose 90 % interval spans more than `WIDE` of [0, 1] is flagged: the window
  does not pin it down.
- An entry whose Jacobian column is (numerically) zero does not move the prediction at all.
"""

from __future__ import annotations

import numpy as np

from ..physics.fault_vector import NAMES

#: An interval wider than this fraction of [0, 1] "spans most of [0, 1]".
WIDE = 0.8
#: Jacobian column norm below which an entry does not move the prediction.
FLAT = 1e-9
K6, K7 = 5, 6


def flags(
    k: np.ndarray, interval: np.ndarray, jacobian_norms: np.ndarray
) -> tuple[tuple[bool, str], ...]:
    """(identifiable, reason) per k entry; reason is "" when identifiable."""
    out: list[tuple[bool, str]] = []
    for i in range(8):
        lo, hi = float(interval[i, 0]), float(interval[i, 1])
        if i == K7 and interval[K6, 0] <= 0.0:
            out.append(
                (
                    False,
                    f"eccentricity phase without eccentricity: the k6 interval "
                    f"[{interval[K6, 0]:.3f}, {interval[K6, 1]:.3f}] reaches 0",
                )
            )
        elif jacobian_norms[i] < FLAT:
            out.append((False, f"{NAMES[i]} does not change the prediction on this window"))
        elif hi - lo > WIDE:
            out.append((False, f"interval [{lo:.3f}, {hi:.3f}] spans most of [0, 1]"))
        else:
            out.append((True, ""))
    return tuple(out)


def phase_interval(interval: np.ndarray) -> np.ndarray:
    """The k intervals with k7's set to [0, 1] when k6's reaches 0 (no phase without it)."""
    out = np.array(interval, dtype=np.float64)
    if out[K6, 0] <= 0.0:
        out[K7] = (0.0, 1.0)
    return out
