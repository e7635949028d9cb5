"""Fitness of a fault vector: how far the monitor's prediction is from the telemetry.

Current term (section 5.4, eq. 5.4): the total-least-squares error
    Ts * sum_t (I_HF - I_LF)^2 / sqrt(d(t)^2 + 1),
where d is dI_HF/dt divided by its RMS in normal conditions (the thesis replaces
the derivative by its nominal RMS so that the two terms under the root have the
same unit).  "Normal conditions" here is the monitor's own nominal prediction on
the same window, so any recorded window works, not only the default chirp.

Position and speed terms: Ts * sum (x_HF - x_LF)^2, the same for omega.  Each
term is divided by n * Ts * sigma^2 with a fixed reference scale sigma per channel
(`REFERENCE_SCALES`), a chi-square-like weighting that does not depend on the
fault being fitted.  (Scaling by the nominal prediction's residual, our first
choice, down-weights the position term exactly when a gain fault makes the
nominal residual large: bench mean %err 0.40 -> 0.20 noise-free with the fixed scales.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from ..errors import ConfigError, WindowError
from ..physics.fault_vector import NOMINAL
from ..physics.monitor_model import MonitorModel
from ..physics.parameters import MonitorBelief
from ..telemetry.window import Window
from . import nuisance as nuisance_mod


@dataclass(frozen=True)
class FitnessWeights:
    """Weights of the three residuals (current TLS, user position, motor speed)."""

    current: float = 1.0
    position: float = 1.0
    speed: float = 0.0

    def __post_init__(self) -> None:
        vals = (self.current, self.position, self.speed)
        if any((not np.isfinite(v)) or v < 0 for v in vals) or sum(vals) <= 0:
            raise WindowError(f"fitness weights must be >= 0 and not all 0, got {vals}")


#: Reference scale (sigma) of each residual: I_3eq [A] (1 % of the 22.5 A full scale),
#: user position [rad], motor speed [rad/s].  Position/current ratio chosen by the bench
#: (1e-5 and 3e-6 rad over-weight position; 3e-5 and 1e-4 rad both beat nominal scaling).
REFERENCE_SCALES: tuple[float, float, float] = (0.225, 1.0e-4, 10.0)

#: Named weightings the isolation accepts (`--fitness`); "default" chosen by
#: bench/bench_isolation.py.
WEIGHTINGS: dict[str, FitnessWeights] = {
    "current": FitnessWeights(1.0, 0.0, 0.0),  # the thesis: I_3eq only
    "default": FitnessWeights(1.0, 1.0, 0.0),
    "all": FitnessWeights(1.0, 1.0, 1.0),
}


def tls_weights(current: np.ndarray, dt: float, derivative_rms: float) -> np.ndarray:
    """1 / sqrt(d^2 + 1) of eq. 5.4 with d = (dI/dt) / derivative_rms (smoothed derivative)."""
    n = current.shape[0]
    win = min(11, n - (1 - n % 2))
    if win >= 5:
        deriv = savgol_filter(current, win, 2, deriv=1, delta=dt)
    else:
        deriv = np.gradient(current, dt)
    return 1.0 / np.sqrt((deriv / derivative_rms) ** 2 + 1.0)


class Fitness:
    """Scores populations against one recorded window (vectorized over rows).

    The prediction is the monitor model of `belief` (default: MonitorBelief.default()),
    or `model` when one is given (not both).  Without `nuisance` a row is k (8 values);
    with it a row is k followed by the normalized nuisances of nuisance.NUISANCES
    (`dim` values).
    """

    def __init__(
        self,
        window: Window,
        *,
        weights: FitnessWeights | str = "default",
        belief: MonitorBelief | None = None,
        model: MonitorModel | None = None,
        nuisance: bool = False,
    ) -> None:
        if model is not None and belief is not None:
            raise ConfigError(
                "Fitness takes a belief or a model, not both (the model holds its own belief)"
            )
        if isinstance(weights, str):
            if weights not in WEIGHTINGS:
                raise WindowError(
                    f"unknown fitness weighting {weights!r}; choose from {sorted(WEIGHTINGS)}"
                )
            weights = WEIGHTINGS[weights]
        self.weights = weights
        self.model = model or MonitorModel(window, belief=belief)
        self.window = self.model.window
        self.nuisance = bool(nuisance)
        self.dim = 8 + (len(nuisance_mod.NUISANCES) if self.nuisance else 0)
        w = self.window
        self.ts = w.dt
        nominal = self.model.simulate(NOMINAL)
        d_nom = np.gradient(nominal[:, 0], self.ts)
        d_rms = float(np.sqrt(np.mean(d_nom**2)))
        if not d_rms > 0:
            d_rms = 1.0
        self.tls = tls_weights(w.i3eq, self.ts, d_rms)
        self.target = np.column_stack([w.i3eq, w.theta_u, w.omega_m])
        self.scales = self.ts * w.n * np.asarray(REFERENCE_SCALES) ** 2
        self.wv = np.array([weights.current, weights.position, weights.speed])
        self.evaluations = 0

    def split(self, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Rows -> (k (P, 8), physical nuisances (P, m) or None without `nuisance`)."""
        xs = np.atleast_2d(np.asarray(xs, dtype=np.float64))
        if xs.shape[1] != self.dim:
            raise WindowError(f"fitness rows must have {self.dim} values, got shape {xs.shape}")
        if not self.nuisance:
            return xs, None
        return xs[:, :8], nuisance_mod.physical(np.clip(xs[:, 8:], 0.0, 1.0))

    def simulate(self, xs: np.ndarray) -> np.ndarray:
        """(P, n, 3) predictions of rows, with each row's nuisance load."""
        k, nu = self.split(xs)
        return self.model.simulate_batch(k, nuisance=nu)

    def residuals_of(self, sims: np.ndarray) -> np.ndarray:
        """(P, n, 3) prediction minus telemetry."""
        return sims - self.target[None]

    def _terms(self, sims: np.ndarray) -> np.ndarray:
        """(P, 3): current TLS error, position and speed squared errors (times Ts)."""
        return self._residual_terms(self.residuals_of(sims))

    def _residual_terms(self, r: np.ndarray) -> np.ndarray:
        """(P, 3) terms of residuals r (P, n, 3) in the channel order of `target`."""
        cur = self.ts * np.sum(self.tls[None] * r[:, :, 0] ** 2, axis=1)
        pos = self.ts * np.sum(r[:, :, 1] ** 2, axis=1)
        spd = self.ts * np.sum(r[:, :, 2] ** 2, axis=1)
        return np.column_stack([cur, pos, spd])

    def __call__(self, ks: np.ndarray) -> np.ndarray:
        """Fitness of each row (lower is better), shape (P,)."""
        sims = self.simulate(ks)
        self.evaluations += sims.shape[0]
        f = (self._terms(sims) / self.scales[None]) @ self.wv
        return np.where(np.isfinite(f), f, 1e30)

    def weighted_residuals(self, xs: np.ndarray) -> np.ndarray:
        """(P, n, 3) residuals e with sum(e**2) over (n, 3) equal to the fitness of each row.

        e = sqrt(weight * tls / scale * Ts) * r per channel (the TLS factor only on the
        current); the Jacobian of e gives the Gauss-Newton curvature of the fitness.
        """
        sims = self.simulate(xs)
        self.evaluations += sims.shape[0]
        return self.weigh(sims)

    def weigh(self, sims: np.ndarray) -> np.ndarray:
        """(P, n, 3) weighted residuals of predictions `sims` (see `weighted_residuals`)."""
        return self.residuals_of(sims) * self.residual_factors()[None]

    def residual_factors(self) -> np.ndarray:
        """(n, 3) factors turning residuals into `weighted_residuals`."""
        fac = np.empty((self.window.n, 3))
        fac[:, 0] = np.sqrt(self.wv[0] * self.ts / self.scales[0] * self.tls)
        fac[:, 1] = np.sqrt(self.wv[1] * self.ts / self.scales[1])
        fac[:, 2] = np.sqrt(self.wv[2] * self.ts / self.scales[2])
        return fac

    def separation(self, ks: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """Fitness each row of ks would score if the telemetry were the prediction of `reference`.

        Same residual weights, TLS weights and reference scales as `__call__`, so the
        values share its units (about 1 when one weighted channel moves by its reference
        scale RMS).  A non-finite value (diverged prediction) becomes 1e30, as in `__call__`.
        Not counted in `evaluations`: it is not part of a search.  Rows are k only.
        """
        sims = self.model.simulate_batch(np.vstack([np.atleast_2d(reference), np.atleast_2d(ks)]))
        t = self._residual_terms(sims[1:] - sims[0][None]) / self.scales[None]
        f = t @ self.wv
        return np.where(np.isfinite(f), f, 1e30)

    def one(self, k: np.ndarray) -> float:
        """Row-by-row reference path (unbatched LF, k only), for tests."""
        sim = self.model.simulate(k)
        t = self._residual_terms(sim[None] - self.target[None])[0] / self.scales
        return float(t @ self.wv)
