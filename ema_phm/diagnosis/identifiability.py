"""Which fitted k entries mean something: flags from the intervals and the sensitivities.

- A phase (`Fault.phase_of`: k7, the eccentricity phase) is not identifiable when the
  interval of its fault (k6) reaches 0: with no eccentricity there is no direction (the
  thesis notes it in its chapter 7).  Its interval is then reported as the whole [0, 1].
- An entry whose 90 % interval spans more than `WIDE` of [0, 1] is flagged: the window
  does not pin it down.
- An entry whose Jacobian column is (numerically) zero does not move the prediction at all.
- An entry the recording cannot show (a channel it needs derived or missing: `ema-phm
  import`) is held at its healthy value by the fit and flagged with why.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..domain.faults import LABELS, N_K, NAMES, phase_pairs

#: An interval wider than this fraction of [0, 1] "spans most of [0, 1]".
WIDE = 0.8
#: Jacobian column norm below which an entry does not move the prediction.
FLAT = 1e-9


def flags(
    k: np.ndarray,
    interval: np.ndarray,
    jacobian_norms: np.ndarray,
    unseen: Mapping[int, str] | None = None,
) -> tuple[tuple[bool, str], ...]:
    """(identifiable, reason) per k entry; reason is "" when identifiable.

    `unseen`: entries the recording cannot show (`domain.window.unseen_faults`), with why.
    """
    amount_of = {phase: amount for amount, phase in phase_pairs()}
    out: list[tuple[bool, str]] = []
    for i in range(N_K):
        lo, hi = float(interval[i, 0]), float(interval[i, 1])
        a = amount_of.get(i)
        if unseen and i in unseen:
            out.append((False, unseen[i]))
        elif a is not None and interval[a, 0] <= 0.0:
            out.append(
                (
                    False,
                    f"{NAMES[i].replace('_', ' ')} without {NAMES[a]}: the {LABELS[a]} interval "
                    f"[{interval[a, 0]:.3f}, {interval[a, 1]:.3f}] reaches 0",
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
    """The k intervals with a phase's set to [0, 1] when its fault's reaches 0 (`phase_pairs`)."""
    out = np.array(interval, dtype=np.float64)
    for amount, phase in phase_pairs():
        if out[amount, 0] <= 0.0:
            out[phase] = (0.0, 1.0)
    return out
