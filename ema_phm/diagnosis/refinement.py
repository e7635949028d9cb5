"""Local least-squares polish of a fitted vector (bounded trust-region Gauss-Newton).

After the global search, scipy's `least_squares` (method "trf", bounds [0, 1]) works on
the weighted residual vector whose sum of squares is the fitness; its Jacobian is the
batched central difference of uncertainty.jacobian.  It keeps the polished vector only
when its fitness is lower: the LF is not smooth everywhere (stick-slip friction, backlash,
end stops), so a Gauss-Newton step can fail where the search did not.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .fitness import Fitness
from .uncertainty import jacobian

#: Evaluations of the residual function allowed (each central Jacobian is 2 * dim more).
MAX_NFEV = 30
#: Stopping tolerances on the step (scipy's trf: |step| < XTOL (XTOL + |x|)) and on the
#: cost's change.  With scipy's 1e-8 a tracked fit's polish ran 4-9 Jacobians; at 1e-3 and
#: 1e-5 a tracked fit takes about a fifth less time (0.37 s median against 0.46-0.48 s), k
#: moves by at most 0.003, median and mean %err not at all, one window's by 0.15 points
#: (bench/studies/tracked_polish.py, docs/fit_budget.md; 1e-4 and 1e-6 measured too).
XTOL = 1e-3
FTOL = 1e-5
#: central-difference Jacobians (2 dim simulations each); False: forward (dim + 1), which
#: moved k by up to 0.8 and the fitness up by up to 2.4 % on some tracked windows (the same
#: study): a different point, not a better fit
CENTRAL = True


def polish(fitness: Fitness, x: np.ndarray, f: float) -> tuple[np.ndarray, float]:
    """(x, f) after a bounded Gauss-Newton polish from x; the input when no better."""
    keep = fitness.wv > 0

    def fun(z: np.ndarray) -> np.ndarray:
        return fitness.weighted_residuals(z[None])[0][:, keep].ravel()

    def jac(z: np.ndarray) -> np.ndarray:
        j, _ = jacobian(fitness, z, central=CENTRAL)
        return j[:, keep, :].reshape(-1, z.size)

    x0 = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    try:
        res = least_squares(
            fun,
            x0,
            jac=jac,
            bounds=(0.0, 1.0),
            method="trf",
            max_nfev=MAX_NFEV,
            x_scale=1.0,
            xtol=XTOL,
            ftol=FTOL,
        )
    except (ValueError, np.linalg.LinAlgError):
        return x0, f
    x1 = np.clip(res.x, 0.0, 1.0)
    f1 = float(fitness(x1[None])[0])
    return (x1, f1) if f1 < f else (x0, f)
