"""What an unknown unit adds to the uncertainty of a fit made with an uncommissioned belief.

A belief nobody commissioned is the actuator's description: its datasheet values.  The unit
it watches is one manufactured within config/unit_tolerances.yaml's bands, anywhere inside
them: a datasheet's +/-10 % is a limit, not a standard deviation, so each factor is taken
uniform over its band (sd = band / sqrt(3)), which holds a unit at a band's corner 1.7 sd
out.  (The benchmark generator's own reading, 3 sigma = the band, would put a corner at
3 sd, outside every 90 % interval.)  A unit whose friction sits
10 % above the datasheet's shows, to that belief, what a small friction fault shows; the
search then reads the unit's difference as k.  The fitted row x moves, to first order, by

    dx = -(J'J)^+ J' J_u du

(Gauss-Newton at the optimum: J the Jacobian of the weighted residuals in the row, J_u the
one in the unit's relative factors du), so du with sds `sd` adds the variance of A du,
A = -(J'J)^+ J' J_u, to the residual-based one (`uncertainty.estimate`); entries held at a
bound are handled as `bias_variance` says.
No constant is tuned here: the factors are those commissioning would fit, and the sds are
the declared bands / sqrt(3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.tolerances import Tolerances
from .fitness import Fitness


@dataclass(frozen=True)
class SpreadFactor:
    """One relative factor of the unit on belief quantities, and its spread.

    `keys`: the unit keys of config/unit_tolerances.yaml whose bands it carries (combined in
    quadrature: independent spreads; a product of two is close enough to their sum).
    """

    name: str
    quantities: tuple[str, ...]
    keys: tuple[str, ...]

    def sd(self, tolerances: Tolerances | None = None) -> float:
        """Relative standard deviation: uniform over the bands of `keys` (in quadrature)."""
        bands = (tolerances or Tolerances.load()).bands
        return math.sqrt(sum(float(bands[k]) ** 2 for k in self.keys) / 3.0)


#: The unit's factors a fit made with its datasheet belief does not know.  Commissioning's
#: (`commissioning.FACTORS`) and the torque per measured ampere (the torque constant and the
#: current sensor's gain reach the data only as this product).  Left out: resistance,
#: inductance and the back-EMF act only at the voltage limit; the sensors' zeros are
#: nuisances or measured per window.
FACTORS: tuple[SpreadFactor, ...] = (
    SpreadFactor("inertia", ("mechanics.j_motor", "mechanics.j_user"), ("inertia",)),
    SpreadFactor(
        "friction",
        (
            "mechanics.friction_static_motor",
            "mechanics.friction_dynamic_motor",
            "mechanics.friction_static_user",
            "mechanics.friction_dynamic_user",
        ),
        ("friction",),
    ),
    SpreadFactor("damping", ("mechanics.c_motor", "mechanics.c_user"), ("damping",)),
    SpreadFactor("stiffness", ("monitor.stiffness",), ("stiffness",)),
    SpreadFactor(
        "torque per measured ampere", ("monitor.gt",), ("torque_constant", "current_gain")
    ),
)
#: Relative step of the central differences in the factors.
STEP = 0.02


def unit_jacobian(
    fitness: Fitness, x: np.ndarray, factors: tuple[SpreadFactor, ...] = FACTORS
) -> np.ndarray:
    """(n, 4, m) derivative of the weighted residuals at row x in each factor (relative).

    One batch of 2 m rows, each with one factor at 1 -/+ STEP (`Fitness.predict`'s scales,
    as commissioning scales its factors; a belief rebuilt with the factor would also
    re-derive the current's TLS weights and the model's start: 1-6 % apart, measured).
    """
    m = len(factors)
    rows = np.repeat(np.asarray(x, dtype=np.float64)[None], 2 * m, axis=0)
    k, nu = fitness.split(rows)
    if nu is None:
        nu = np.zeros((2 * m, 0))
    scales = []
    for j, f in enumerate(factors):
        col = np.ones(2 * m)
        col[2 * j], col[2 * j + 1] = 1.0 + STEP, 1.0 - STEP
        scales.append((f.quantities, col))
    e = fitness.weigh(fitness.predict(k, nu, scales=scales))
    return (e[0::2] - e[1::2]).transpose(1, 2, 0) / (2.0 * STEP)


#: Row entries this close to 0 or 1 are also taken as held there (see `bias_variance`).
AT_BOUND = 0.05


def _shift(flat: np.ndarray, unit_flat: np.ndarray, free: np.ndarray) -> np.ndarray:
    """(d, m) least-squares shift of the free entries per unit factor (held ones: 0)."""
    a = np.zeros((flat.shape[1], unit_flat.shape[1]))
    if np.any(free):
        a[free] = np.linalg.lstsq(flat[:, free], unit_flat, rcond=1e-10)[0]
    return np.where(np.isfinite(a), a, 0.0)


def bias_variance(
    x: np.ndarray, jac: np.ndarray, unit_jac: np.ndarray, sd: np.ndarray
) -> np.ndarray:
    """(d,) variance of each row entry's shift from unit factors of relative sds `sd`.

    `jac` (n, 4, d) as `uncertainty.jacobian` gives it, `unit_jac` (n, 4, m) from
    `unit_jacobian`.  A fault at 0 cannot go below it: where the unconstrained shift would
    push entries at a bound (within AT_BOUND) past it, the others take it up instead (a unit
    with more friction fitted at short circuits 0 reads as more k1).  The shift is a
    least-squares one with those entries free and with them held; each entry gets the larger
    of the two variances, so either sign of the unit's difference is covered.
    """
    x = np.asarray(x, dtype=np.float64)
    d, m = jac.shape[2], unit_jac.shape[2]
    flat, unit_flat = jac.reshape(-1, d), unit_jac.reshape(-1, m)
    var2 = np.asarray(sd, dtype=np.float64) ** 2
    free = np.ones(d, dtype=bool)
    out = (_shift(flat, unit_flat, free) ** 2) @ var2
    held = (x <= AT_BOUND) | (x >= 1.0 - AT_BOUND)
    if np.any(held):
        out = np.maximum(out, (_shift(flat, unit_flat, ~held) ** 2) @ var2)
    return out
