"""Whether a window excites the actuator enough for k to be identified from it.

The measure is the *probe separation*: the monitor model is run on the window's
recorded command and load for the healthy k and for a few probe vectors (each
fault family alone at a moderate level), and each probe's prediction is scored
against the healthy prediction with the isolation's default fitness (current and
position residuals, same reference scales), whatever weighting the fit itself
uses: excitation is a property of the window (with the current-only weighting a
gain drift moves the score ~10x less, bench).  A probe whose score is tiny predicts the
same telemetry as the healthy actuator on this window, so that fault cannot be told apart from
health, and any k the optimizer returns is arbitrary in that direction.  The
window's excitation is the smallest score over the probes.

It depends on the command, the load and the recorded initial state only, not on
the telemetry noise or the true fault.  The threshold was chosen by
bench/studies/bench_excitation.py (docs/excitation.md).  No rclpy here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..domain.faults import FAULTS, NOMINAL, k_with
from ..domain.window import Window
from ..errors import ExcitationError
from ..limits import check
from ..model.belief import MonitorBelief
from .fitness import Fitness

#: One probe per fault at the table's moderate levels (`Fault.probes`; the gain drift both
#: ways, 75 % and 125 %); a phase is not probed: it means nothing without its fault.
PROBES: dict[str, np.ndarray] = {
    (f.title if len(f.probes) == 1 else f"{f.title} {p - f.nominal:+.0%}"): k_with(**{f.name: p})
    for f in FAULTS
    for p in f.probes
}

#: Smallest probe separation (fitness units) a window must reach.  Measured
#: (bench/studies/bench_excitation.py, docs/excitation.md): chirps of <= 3e-4 rad score <= 0.031
#: and fit no better than a random k; 1e-3 rad and above score >= 0.14; the default
#: 0.03 rad chirp scores 1.1-1.4.
THRESHOLD = 0.1


@dataclass(frozen=True)
class Excitation:
    """Measured excitation of one window against a threshold."""

    separation: float  # smallest probe separation (fitness units)
    weakest: str  # the probe that reached it
    threshold: float
    command_rms: float  # RMS of the command about its mean [rad], for the message
    per_probe: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the separation reaches the threshold."""
        return self.separation >= self.threshold

    def _weakest_text(self) -> str:
        if len(self.per_probe) > 1 and len(set(self.per_probe.values())) == 1:
            return f"all {len(self.per_probe)} probes score the same"  # no single weakest to name
        return f"weakest probe: {self.weakest}"

    @property
    def reason(self) -> str:
        """One line saying what was measured and how it compares with the threshold."""
        measured = (
            f"probe separation {self.separation:.3g} ({self._weakest_text()}; "
            f"command RMS {self.command_rms:.3g} rad)"
        )
        if self.ok:
            return f"excitation ok: {measured} >= threshold {self.threshold:g}"
        return (
            f"not enough excitation to identify k: {measured} is below the threshold "
            f"{self.threshold:g}"
        )


def measure(
    window: Window, *, belief: MonitorBelief | None = None, threshold: float = THRESHOLD
) -> Excitation:
    """Probe separation of `window` under the monitor model of `belief`.

    `belief` defaults to MonitorBelief.default(); 1 + len(PROBES) LF runs, a few ms on a
    2 s window.
    """
    threshold = float(check("excitation_threshold", threshold))
    fit = Fitness(window, weights="thesis", belief=belief)
    scores = fit.separation(np.vstack(list(PROBES.values())), NOMINAL)
    per_probe = {name: float(s) for name, s in zip(PROBES, scores, strict=True)}
    weakest = min(per_probe, key=per_probe.__getitem__)
    command = fit.window.command
    return Excitation(
        separation=per_probe[weakest],
        weakest=weakest,
        threshold=threshold,
        command_rms=float(np.sqrt(np.mean((command - command.mean()) ** 2))),
        per_probe=per_probe,
    )


def require(
    window: Window, *, belief: MonitorBelief | None = None, threshold: float = THRESHOLD
) -> Excitation:
    """`measure`, raising ExcitationError (one line: measured value and threshold) if below it."""
    result = measure(window, belief=belief, threshold=threshold)
    if not result.ok:
        raise ExcitationError(result.reason) from None
    return result
