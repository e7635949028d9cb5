"""How sure a fit is: 90 % intervals on k and the nuisances from the residuals.

Gauss-Newton (Laplace) approximation at the optimum x of the fitness F(x) = sum e(x)^2
(e: `Fitness.weighted_residuals`), with the Jacobian J = de/dx by central differences,
evaluated as one LF batch.  The residuals of a monitor are not white: most of them are
model error, correlated over hundreds of samples.  So the covariance is the sandwich

    C = H^-1 S H^-1,   H = J'J,   S = sum_l w_l (G_l + G_l'),   G_l = sum_t g_t g_{t+l}'

with g_t = sum_channels J_ct e_ct the per-sample score and Bartlett weights w_l up to a
bandwidth of `bandwidth_fraction` of the window (Newey & West 1987, the
heteroskedasticity-and-autocorrelation-consistent estimate).  Then the interval of
entry i is x_i -/+ z * scale * sqrt(C_ii), clipped to [0, 1], with z the normal 95 %
quantile (two-sided 90 %) and `scale` an inflation chosen by measured coverage
(docs/benchmarks_robust.md).  It covers noise and the part of the model error that
behaves like correlated noise; a bias the LF cannot express at all is not covered, which
is why coverage is measured, not assumed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import unit_spread
from .fitness import Fitness

#: Two-sided 90 %: the normal 0.95 quantile.
Z90 = 1.6448536269514722
#: Central-difference step in normalized units (k and nuisances live in [0, 1]).
STEP = 2e-3
#: HAC bandwidth as a fraction of the window's samples (0.05 of a 2 s window = 0.1 s,
#: a few periods of the chirp's highest frequency).
BANDWIDTH_FRACTION = 0.05
#: Inflation of the sandwich standard errors, chosen by coverage on the realistic benchmark:
#: the smallest scale giving 90 % coverage on its even units (docs/benchmarks_robust.md; on
#: the held-out odd units it gives 92.4 %).  It is large because most of a fit's error is
#: model bias, which the sandwich sees only through the residuals' correlation.
DEFAULT_SCALE = 13.2
#: The same choice for a fit that follows the recorded loop (fitness "recorded"):
#: docs/benchmarks_robust_recorded.md (90.9 % on its held-out odd units).
FOLLOWED_SCALE = 8.12


@dataclass(frozen=True)
class Uncertainty:
    """Standard errors and 90 % intervals of every fitted value (k then nuisances)."""

    std: np.ndarray  # (d,) in normalized units; inf where the data says nothing
    interval: np.ndarray  # (d, 2) clipped to [0, 1]
    jacobian_norms: np.ndarray  # (d,) |de/dx_i|: 0 = the entry does not move the prediction
    condition: float  # of J'J
    evaluations: int
    #: (d,) the part of std an unknown unit adds (`unit_spread`); None unless asked for
    unit_std: np.ndarray | None = None


def jacobian(
    fitness: Fitness, x: np.ndarray, *, step: float = STEP, central: bool = True
) -> tuple[np.ndarray, int]:
    """(n, 3, d) Jacobian of the weighted residuals at x, one batch; and its simulations.

    Central differences (2 d simulations; a step that would leave [0, 1] is one-sided), or
    with `central` False forward ones (d + 1: x itself, then a step up, down at the bound).
    The same call at the same x again (the intervals at the polish's last point) is the
    Jacobian already made, at no simulation.
    """
    key = (np.asarray(x, dtype=np.float64).tobytes(), float(step), bool(central))
    if fitness.last_jacobian is not None and fitness.last_jacobian[0] == key:
        return fitness.last_jacobian[1], 0
    jac, sims = _differences(fitness, x, step, central)
    fitness.last_jacobian = (key, jac)
    return jac, sims


def _differences(
    fitness: Fitness, x: np.ndarray, step: float, central: bool
) -> tuple[np.ndarray, int]:
    d = x.size
    if not central:
        h = np.where(x + step <= 1.0, step, -step)
        rows = np.repeat(x[None], d + 1, axis=0)
        rows[1:] += np.diag(h)
        e = fitness.weighted_residuals(rows)
        return (e[1:] - e[0][None]).transpose(1, 2, 0) / h[None, None, :], d + 1
    lo = np.clip(x - step, 0.0, 1.0)
    hi = np.clip(x + step, 0.0, 1.0)
    rows = np.repeat(x[None], 2 * d, axis=0)
    for i in range(d):
        rows[2 * i, i] = hi[i]
        rows[2 * i + 1, i] = lo[i]
    e = fitness.weighted_residuals(rows)
    span = (hi - lo)[None, None, :]
    jac = (e[0::2] - e[1::2]).transpose(1, 2, 0) / np.where(span > 0, span, 1.0)
    return jac, 2 * d


def hac_score_covariance(g: np.ndarray, bandwidth: int) -> np.ndarray:
    """Newey-West S of scores g (n, d) with Bartlett weights up to `bandwidth` lags (FFT)."""
    n, d = g.shape
    m = 1 << int(np.ceil(np.log2(2 * n)))
    spec = np.fft.rfft(g, m, axis=0)
    # cross-correlation of every pair at every lag: corr[l, i, j] = sum_t g_t,i g_{t+l},j
    corr = np.fft.irfft(np.conj(spec)[:, :, None] * spec[:, None, :], m, axis=0)
    lags = np.arange(1, min(bandwidth, n - 1) + 1)
    w = 1.0 - lags / (bandwidth + 1.0)
    s = corr[0] + np.tensordot(w, corr[lags] + corr[lags].transpose(0, 2, 1), axes=1)
    return 0.5 * (s + s.T)


def estimate(
    fitness: Fitness,
    x: np.ndarray,
    *,
    scale: float = DEFAULT_SCALE,
    bandwidth_fraction: float = BANDWIDTH_FRACTION,
    step: float = STEP,
    spread: tuple[unit_spread.SpreadFactor, ...] = (),
) -> Uncertainty:
    """Sandwich standard errors and 90 % intervals at the fitted x (see the module doc).

    `spread`: the factors of a unit the belief does not know (an uncommissioned belief,
    `unit_spread.FACTORS`); the row's shift from them adds its variance, unscaled, to the
    scaled sandwich one: half-width z sqrt(scale^2 var + var_unit).
    """
    x = np.asarray(x, dtype=np.float64)
    jac, evals = jacobian(fitness, x, step=step)
    e = fitness.weighted_residuals(x[None])[0]
    evals += 1
    n, _, d = jac.shape
    flat = jac.reshape(-1, d)
    hess = flat.T @ flat
    g = np.einsum("tcd,tc->td", jac, e)
    s = hac_score_covariance(g, max(1, int(bandwidth_fraction * n)))
    # pseudo-inverse: a direction the data does not constrain gets an infinite error
    u, sv, _ = np.linalg.svd(hess)
    tol = sv[0] * 1e-10 if sv[0] > 0 else 1.0
    inv = (u[:, sv > tol] / sv[sv > tol]) @ u[:, sv > tol].T
    cov = inv @ s @ inv
    var = np.clip(np.diag(cov), 0.0, None)
    std = np.sqrt(var)
    unconstrained = np.abs(u[:, sv <= tol]).max(axis=1) > 1e-6 if np.any(sv <= tol) else None
    if unconstrained is not None:
        std = np.where(unconstrained, np.inf, std)
    unit_std = None
    half = Z90 * scale * std
    if spread:
        unit_jac = unit_spread.unit_jacobian(fitness, x, spread)
        evals += 2 * len(spread)
        sd = np.array([f.sd() for f in spread])
        unit_var = unit_spread.bias_variance(x, jac, unit_jac, sd)
        unit_std = np.sqrt(unit_var)
        half = Z90 * np.sqrt((scale * std) ** 2 + unit_var)
    interval = np.column_stack([np.clip(x - half, 0.0, 1.0), np.clip(x + half, 0.0, 1.0)])
    return Uncertainty(
        std=std,
        interval=interval,
        jacobian_norms=np.sqrt(np.sum(flat**2, axis=0)),
        condition=float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf"),
        evaluations=evals,
        unit_std=unit_std,
    )
