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

The model: "recorded" (the default) follows the recorded loop (model/recorded_loop.py),
the other names replay the command open-loop as the thesis does (`LOOPS`).

Hunting windows: where the telemetry's current carries more than HUNTING_A of RMS above
ENVELOPE_HZ, the loop hunts (a play's limit cycle).  The open-loop "thesis" weighting then
compares the current and position below ENVELOPE_HZ and adds a fourth term on the current's
high-band envelope (`Envelope`); "recorded" follows the cycle instead (its fed-back
position passes 200 Hz there) and compares sample by sample.  With nuisances
(`nuisance=True`) a row is k followed by the normalized nuisances the window's load channel
calls for (`nuisance.searched`: the unmeasured load, or the current offset where the load
is measured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np
from scipy.signal import butter, savgol_filter, sosfiltfilt

from ..domain.faults import N_K, NOMINAL
from ..domain.window import Window, current_logged, unseen_faults
from ..errors import ConfigError, WindowError
from ..model.belief import MonitorBelief
from ..model.monitor_model import MonitorModel
from ..model.recorded_loop import RecordedLoop
from ..physics.signals import noise_variance
from . import nuisance as nuisance_mod

#: The telemetry channels the monitor model predicts, in the order of its (n, 3) output
#: (`MonitorModel.simulate`): the residuals' first three columns.
PREDICTED_CHANNELS: tuple[str, ...] = ("i3eq", "theta_u", "omega_m")
#: Columns of residuals and terms: the predicted channels, then the current's envelope.
CURRENT, POSITION, SPEED, ENVELOPE = 0, 1, 2, 3


@dataclass(frozen=True)
class FitnessWeights:
    """Weights of the residuals: current TLS, user position, motor speed, current envelope."""

    current: float = 1.0
    position: float = 1.0
    speed: float = 0.0
    envelope: float = 0.0

    def __post_init__(self) -> None:
        vals = (self.current, self.position, self.speed, self.envelope)
        if any((not np.isfinite(v)) or v < 0 for v in vals) or sum(vals) <= 0:
            raise WindowError(f"fitness weights must be >= 0 and not all 0, got {vals}")


#: Reference scale (sigma) of each residual: I_3eq [A] (1 % of the 22.5 A full scale),
#: user position [rad], motor speed [rad/s].  Position/current ratio chosen by the bench
#: (1e-5 and 3e-6 rad over-weight position; 3e-5 and 1e-4 rad both beat nominal scaling).
#: The fourth, the current envelope (root mean square of the high band) [A], the current's.
REFERENCE_SCALES: tuple[float, float, float, float] = (0.225, 1.0e-4, 10.0, 0.225)
#: Current envelope: root mean square of the current above ENVELOPE_HZ (2nd-order Butterworth,
#: zero phase) over ENVELOPE_S.  A play wide enough makes the loop hunt (a limit cycle near
#: 80 Hz, in the simulated actuator as in the monitor): its phase drifts between any two
#: models, so a sample-by-sample residual cannot fit it, but its envelope can.
ENVELOPE_HZ = 40.0
#: The loop "hunts" when the telemetry's median high-band current RMS exceeds this [A].
#: Measured (two drawn units, noisy, bench_robust's environment): every window without a
#: play fault scores <= 0.39 A (eccentricity 0.7, short circuit 0.7, friction 0.75, gain
#: 0.2 and 0.7 included), k2 = 0.05 scores 0.73-0.95 A, k2 >= 0.1 scores >= 2.35 A.
HUNTING_A = 1.0
#: Added to the mean square before the root [A^2] (the current scale squared), so the
#: envelope stays smooth where the high band is empty.
ENVELOPE_FLOOR = 0.225**2
ENVELOPE_S = 0.05

#: The recorded channels a model following the loop reads (model/recorded_loop.py).
FOLLOWED_CHANNELS: tuple[str, ...] = ("theta_u", "theta_m", "omega_m")
#: `Fitness.fed_noise_fitness` averages this many draws of noise, from this seed (common
#: random numbers: every window and row meets the same draws).  Measured on the datasheet
#: unit, healthy and friction 0.3, position noise 5e-6..1e-4 rad: single draws differ by
#: up to 10 % at 1.5e-5 rad and more where the rise is small (0.14-0.46 at 5e-5 rad).
FED_NOISE_DRAWS = 3
FED_NOISE_SEED = 1_312

#: The fitness "default" names (`--fitness`, monitor_node's `fitness`): the monitor follows
#: the recorded loop (docs/recorded_loop.md measures it against "thesis").
DEFAULT_FITNESS = "recorded"
#: Named fitnesses the isolation accepts (`--fitness`): residual weights, and whether the
#: model follows the recorded loop (`LOOPS`) or replays the command open-loop (the rest).
WEIGHTINGS: dict[str, FitnessWeights] = {
    "recorded": FitnessWeights(1.0, 1.0, 0.0),  # follows the recorded loop (LOOPS)
    # open-loop output error, current, position and the hunting envelope (issue-18 default,
    # chosen by bench/bench_isolation.py)
    "thesis": FitnessWeights(1.0, 1.0, 0.0, 1.0),
    "current": FitnessWeights(1.0, 0.0, 0.0),  # the thesis's eq. 5.4: I_3eq only
    "position": FitnessWeights(1.0, 1.0, 0.0),  # issue-9 default: no envelope
    "all": FitnessWeights(1.0, 1.0, 1.0, 1.0),
}
#: The named fitnesses whose model follows the recorded loop (model/recorded_loop.py).
LOOPS: dict[str, RecordedLoop] = {"recorded": RecordedLoop()}
WEIGHTINGS["default"] = WEIGHTINGS[DEFAULT_FITNESS]
if DEFAULT_FITNESS in LOOPS:
    LOOPS["default"] = LOOPS[DEFAULT_FITNESS]


def fitness_name(name: str) -> str:
    """The fitness a name selects: "default" is DEFAULT_FITNESS, the others themselves."""
    return DEFAULT_FITNESS if name == "default" else name


class Envelope:
    """Split (P, n) rows at ENVELOPE_HZ: the low band, and the high band's sliding mean square."""

    def __init__(self, dt: float, n: int) -> None:
        nyq = 0.5 / dt
        self.sos = butter(2, min(ENVELOPE_HZ / nyq, 0.99), btype="lowpass", output="sos")
        self.width = max(1, min(n, int(round(ENVELOPE_S / dt))))
        self.pad = min(n - 1, 3 * 2 * 2)  # sosfiltfilt's default padding for 2 sections

    def low(self, rows: np.ndarray) -> np.ndarray:
        """The band below ENVELOPE_HZ (zero phase)."""
        return sosfiltfilt(self.sos, rows, axis=-1, padlen=self.pad)

    def __call__(self, rows: np.ndarray, low: np.ndarray | None = None) -> np.ndarray:
        """Sliding mean square of the high band of rows (`low`: their low band, if known)."""
        hp = rows - (self.low(rows) if low is None else low)
        c = np.cumsum(hp * hp, axis=-1)
        c = np.concatenate([np.zeros(c.shape[:-1] + (1,)), c], axis=-1)
        n, w = rows.shape[-1], self.width
        idx = np.arange(n)
        lo = np.clip(idx - w // 2, 0, n)
        hi = np.clip(lo + w, 0, n)
        lo = hi - w
        return (c[..., hi] - c[..., lo]) / w


def current_mask(n: int, logged: tuple[int, int] | None) -> np.ndarray:
    """Per-sample weight of the current: 1, or a current logged on every few samples only.

    Then `every` on the log's own samples and 0 on those interpolated between them (the
    term keeps its scale).
    """
    if logged is None:
        return np.ones(n)
    every, first = logged
    mask = np.zeros(n)
    mask[first::every] = float(every)
    return mask


def logged_samples(current: np.ndarray, logged: tuple[int, int] | None) -> np.ndarray:
    """The current's own samples (all of them unless it was logged on every few)."""
    return current if logged is None else current[logged[1] :: logged[0]]


def carried_noise_variance(current: np.ndarray, logged: tuple[int, int] | None) -> float:
    """The white-noise variance the window's current carries, on average over its samples.

    Logged on every m-th sample and interpolated linearly between, the log's own noise
    variance (measured on its samples: the interpolated ones have no second difference)
    times the mean of (1 - u)^2 + u^2 over the m positions u = i / m.
    """
    if logged is None:
        return noise_variance(current)
    u = np.arange(logged[0]) / logged[0]
    share = float(np.mean((1.0 - u) ** 2 + u**2))
    return noise_variance(logged_samples(current, logged)) * share


def tls_weights(current: np.ndarray, dt: float, derivative_rms: float) -> np.ndarray:
    """1 / sqrt(d^2 + 1) of eq. 5.4 with d = (dI/dt) / derivative_rms (smoothed derivative)."""
    n = current.shape[0]
    win = min(11, n - (1 - n % 2))
    if win >= 5:
        deriv = savgol_filter(current, win, 2, deriv=1, delta=dt)
    else:
        deriv = np.gradient(current, dt)
    return 1.0 / np.sqrt((deriv / derivative_rms) ** 2 + 1.0)


def resolve(
    weights: FitnessWeights | str, loop: RecordedLoop | None
) -> tuple[FitnessWeights, RecordedLoop | None]:
    """(weights, recorded loop) of a fitness name (`WEIGHTINGS`, `LOOPS`) or of weights.

    A `loop` given wins over the name's; WindowError for an unknown name.
    """
    if not isinstance(weights, str):
        return weights, loop
    if weights not in WEIGHTINGS:
        raise WindowError(
            f"unknown fitness weighting {weights!r}; choose from {sorted(WEIGHTINGS)}"
        )
    return WEIGHTINGS[weights], loop if loop is not None else LOOPS.get(weights)


class Fitness:
    """Scores populations against one recorded window (vectorized over rows).

    The prediction is the monitor model of `belief` (default: MonitorBelief.default()),
    or `model` when one is given (not both).  Without `nuisance` a row is k (N_K values);
    with it a row is k followed by the normalized `nuisances` (`nuisance.searched`: the
    unmeasured load, or the current offset where the window measures its load; `dim`
    values).  `weights` names a fitness (`WEIGHTINGS`); the model follows the recorded loop
    as `loop` says (default: the name's, `LOOPS`; a `model` has its own).
    """

    def __init__(
        self,
        window: Window,
        *,
        weights: FitnessWeights | str = "default",
        belief: MonitorBelief | None = None,
        model: MonitorModel | None = None,
        nuisance: bool = False,
        loop: RecordedLoop | None = None,
    ) -> None:
        if model is not None and belief is not None:
            raise ConfigError(
                "Fitness takes a belief or a model, not both (the model holds its own belief)"
            )
        weights, loop = resolve(weights, loop)
        self.weights = weights
        w = window.validated() if model is None else model.window
        self.ts = w.dt
        self.envelope = Envelope(self.ts, w.n)
        #: (every, first) of a current logged on every few samples only, else None
        self.current_logged = current_logged(w.meta, w.n)
        ms = self.envelope(w.i3eq[None])[0] - carried_noise_variance(w.i3eq, self.current_logged)
        #: median high-band current RMS of the telemetry, noise removed [A]
        self.hunting_rms = float(np.median(np.sqrt(np.maximum(ms, 0.0))))
        loop_hunts = self.hunting_rms > HUNTING_A
        self.model = model or MonitorModel(
            w, belief=belief, loop=None if loop is None else loop.at(loop_hunts)
        )
        self.window = self.model.window
        #: the model follows the recorded loop (its intervals and adequacy are scaled apart)
        self.follows = self.model.loop is not None and self.model.loop.follows
        self.nuisance = bool(nuisance)
        #: the nuisances a row carries after k (none without `nuisance`)
        self.nuisances: tuple[nuisance_mod.Nuisance, ...] = (
            nuisance_mod.searched(self.window) if self.nuisance else ()
        )
        self.dim = N_K + len(self.nuisances)
        #: entries the recording cannot show (`unseen_faults`): held healthy, whatever a row says
        self.unseen = unseen_faults(w.meta)
        self.tls = self._current_weights(w, self.model.simulate(NOMINAL))
        self.target = np.column_stack([getattr(w, c) for c in PREDICTED_CHANNELS])
        self.scales = self.ts * w.n * np.asarray(REFERENCE_SCALES) ** 2
        self.wv = np.array([weights.current, weights.position, weights.speed, weights.envelope])
        # the telemetry's envelope less its white noise (the model has none)
        self.target_low = np.column_stack(
            [self.envelope.low(w.i3eq), self.envelope.low(w.theta_u)]
        )
        self.target_envelope = np.sqrt(np.maximum(ms, 0.0) + ENVELOPE_FLOOR)
        #: the loop hunts and the weighting compares the high band by its envelope only
        #: (`residuals_of`); a recorded-loop fit follows the hunting instead
        self.hunting = bool(weights.envelope > 0 and loop_hunts)
        #: the telemetry's loop hunts (whatever the fitness does about it)
        self.loop_hunts = bool(loop_hunts)
        if not self.hunting:
            self.wv[ENVELOPE] = 0.0
        self.noise_fitness = self._noise_fitness()
        self.evaluations = 0
        #: the last Jacobian `uncertainty.jacobian` made: ((x, step, central), J)
        self.last_jacobian: tuple[tuple[bytes, float, bool], np.ndarray] | None = None

    def _current_weights(self, w: Window, nominal: np.ndarray) -> np.ndarray:
        """TLS weights of the current (eq. 5.4; 0 where a slower current was interpolated)."""
        d_nom = np.gradient(nominal[:, CURRENT], self.ts)
        d_rms = float(np.sqrt(np.mean(d_nom**2)))
        if not d_rms > 0:
            d_rms = 1.0
        return tls_weights(w.i3eq, self.ts, d_rms) * current_mask(w.n, self.current_logged)

    def _noise_fitness(self) -> float:
        """What the telemetry's own white noise adds to the fitness of a perfect model.

        Per channel: noise variance (`noise_variance`) over the reference scale squared,
        times the channel's weight (and the mean TLS weight on the current); below
        ENVELOPE_HZ only the band's share of the noise when the loop hunts.
        """
        w = self.window
        share = min(1.0, 2.0 * ENVELOPE_HZ * self.ts) if self.hunting else 1.0
        var = np.array(
            [
                noise_variance(logged_samples(w.i3eq, self.current_logged))
                * float(np.mean(self.tls))
                * share,
                noise_variance(w.theta_u) * share,
                noise_variance(w.omega_m),
            ]
        )
        ref = np.asarray(REFERENCE_SCALES[:3]) ** 2
        return float(np.sum(self.wv[:3] * var / ref))

    def fed_noise_fitness(self, xs: np.ndarray) -> float:
        """What the noise of the recorded channels the model follows adds to one row's fitness.

        A model following the recorded loop (`follows`) reads the position, motor angle and
        speed the sensors recorded, noise included; its response to that noise is error no
        k removes, and it grows with the noise (where a fine position sensor's deflection
        goes in unfiltered, 1.1-1.25 x the white-noise part itself at 1.5-2e-5 rad).
        Measured here: the row is run again with each followed channel carrying
        `FED_NOISE_DRAWS` further draws of white noise at the level measured in the window
        (`noise_variance`), processed as the window was; the mean rise of the fitness is
        what the window's own noise adds (independent noise adds in variance).  0 for an
        open-loop model.
        """
        if not self.follows:
            return 0.0
        x = np.atleast_2d(np.asarray(xs, dtype=np.float64))[:1]
        base = self._score(self.simulate(x))
        w = self.window
        var = {c: noise_variance(getattr(w, c)) for c in FOLLOWED_CHANNELS}
        sd = {c: math.sqrt(v) if v > 0.0 else 0.0 for c, v in var.items()}  # NaN: none
        rises = []
        for d in range(FED_NOISE_DRAWS):
            rng = np.random.default_rng((FED_NOISE_SEED, d))
            channels: dict[str, Any] = {
                c: np.asarray(getattr(w, c), dtype=np.float64) + sd[c] * rng.standard_normal(w.n)
                for c in FOLLOWED_CHANNELS
            }
            noisy = replace(w, **channels)
            rises.append(self._score(self.simulate(x, model=self.model.following(noisy))) - base)
        rise = float(np.mean(rises))
        return rise if math.isfinite(rise) and rise > 0.0 else 0.0

    def _score(self, sims: np.ndarray) -> float:
        """The fitness of one row's predictions, not counted in `evaluations`."""
        return float(((self._terms(sims) / self.scales[None]) @ self.wv)[0])

    def adequacy_fitness(self, xs: np.ndarray) -> float:
        """The fitness the adequacy statistic judges, of one row.

        The fitness itself, except that a hunting window's envelope term is left out: the
        envelope of a limit cycle is itself irregular, so its misfit measures the cycle,
        not whether the model explains the actuator (the low band still must fit).
        """
        t = self._terms(self.simulate(np.atleast_2d(xs)[:1])) / self.scales[None]
        wv = self.wv.copy()
        wv[ENVELOPE] = 0.0
        return float((t @ wv)[0])

    def split(self, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Rows -> (k (P, N_K), physical nuisances (P, m) or None without `nuisance`)."""
        xs = np.atleast_2d(np.asarray(xs, dtype=np.float64))
        if xs.shape[1] != self.dim:
            raise WindowError(f"fitness rows must have {self.dim} values, got shape {xs.shape}")
        k = self.held(xs)[:, :N_K]
        if not self.nuisance:
            return k, None
        return k, nuisance_mod.physical(np.clip(xs[:, N_K:], 0.0, 1.0), self.nuisances)

    def held(self, xs: np.ndarray) -> np.ndarray:
        """Rows with the entries the recording cannot show (`unseen`) at their healthy value."""
        if not self.unseen:
            return xs
        out = np.array(xs, dtype=np.float64)
        idx = sorted(self.unseen)
        out[..., idx] = NOMINAL[idx]
        return out

    @property
    def healthy_row(self) -> np.ndarray:
        """The healthy k with no nuisance (no unmeasured load, no offset), as a row."""
        return np.concatenate([NOMINAL, nuisance_mod.zero(self.nuisances)])

    def simulate(self, xs: np.ndarray, *, model: MonitorModel | None = None) -> np.ndarray:
        """(P, n, 3) predictions of rows, with each row's nuisances.

        `model`: another model of this window (`MonitorModel.following`); default its own.
        """
        k, nu = self.split(xs)
        if nu is None:
            return (model or self.model).simulate_batch(k)
        return self.predict(k, nu, model=model)

    def predict(
        self,
        ks: np.ndarray,
        nuisances: np.ndarray,
        *,
        scales: Sequence[tuple[Sequence[str], np.ndarray]] = (),
        model: MonitorModel | None = None,
    ) -> np.ndarray:
        """(P, n, 3) predictions of k rows with physical `nuisances` (P, len(self.nuisances)).

        `scales`: (belief quantities, (P,) factors) pairs scaling the model's parameters row
        by row (`MonitorModel.row_parameters`; commissioning's factors).  `model`: as in
        `simulate`.
        """
        model = model or self.model
        loads, offset = nuisance_mod.model_inputs(nuisances, self.nuisances)
        sims = model.simulate_rows(model.row_parameters(loads, scales=scales), ks)
        sims[:, :, CURRENT] += offset[:, None]  # the acquired current's offset: output only
        return sims

    def residuals_of(self, sims: np.ndarray) -> np.ndarray:
        """(P, n, 4) prediction minus telemetry: I_3eq, theta_u, omega_m, current envelope."""
        r = np.empty(sims.shape[:2] + (4,))
        r[:, :, :ENVELOPE] = sims - self.target[None]
        if self.wv[ENVELOPE] > 0:
            # a hunting loop: the current and position are compared below ENVELOPE_HZ
            # sample by sample and above it by the current's envelope only
            low = self.envelope.low(sims[:, :, CURRENT])
            env = np.sqrt(
                np.maximum(self.envelope(sims[:, :, CURRENT], low), 0.0) + ENVELOPE_FLOOR
            )
            r[:, :, ENVELOPE] = env - self.target_envelope[None]
            r[:, :, CURRENT] = low - self.target_low[None, :, CURRENT]
            r[:, :, POSITION] = (
                self.envelope.low(sims[:, :, POSITION]) - self.target_low[None, :, POSITION]
            )
        else:
            r[:, :, ENVELOPE] = 0.0
        return r

    def _terms(self, sims: np.ndarray) -> np.ndarray:
        """(P, 4): current TLS, position, speed and envelope squared errors (times Ts)."""
        return self._residual_terms(self.residuals_of(sims))

    def _residual_terms(self, r: np.ndarray) -> np.ndarray:
        """(P, 4) terms of residuals r (P, n, 3 or 4): current TLS, position, speed, envelope."""
        cur = self.ts * np.sum(self.tls[None] * r[:, :, CURRENT] ** 2, axis=1)
        pos = self.ts * np.sum(r[:, :, POSITION] ** 2, axis=1)
        spd = self.ts * np.sum(r[:, :, SPEED] ** 2, axis=1)
        env = (
            self.ts * np.sum(r[:, :, ENVELOPE] ** 2, axis=1)
            if r.shape[2] > ENVELOPE
            else 0.0 * cur
        )
        return np.column_stack([cur, pos, spd, env])

    def __call__(self, ks: np.ndarray) -> np.ndarray:
        """Fitness of each row (lower is better), shape (P,)."""
        sims = self.simulate(ks)
        self.evaluations += sims.shape[0]
        f = (self._terms(sims) / self.scales[None]) @ self.wv
        return np.where(np.isfinite(f), f, 1e30)

    def weighted_residuals(self, xs: np.ndarray) -> np.ndarray:
        """(P, n, 4) residuals e with sum(e**2) over (n, 4) equal to the fitness of each row.

        e = sqrt(weight * tls / scale * Ts) * r per channel (the TLS factor only on the
        current); the Jacobian of e gives the Gauss-Newton curvature of the fitness.
        """
        sims = self.simulate(xs)
        self.evaluations += sims.shape[0]
        return self.weigh(sims)

    def weigh(self, sims: np.ndarray) -> np.ndarray:
        """(P, n, 4) weighted residuals of predictions `sims` (see `weighted_residuals`)."""
        return self.residuals_of(sims) * self.residual_factors()[None]

    def residual_factors(self) -> np.ndarray:
        """(n, 4) factors turning residuals into `weighted_residuals`."""
        fac = np.empty((self.window.n, 4))
        fac[:, CURRENT] = np.sqrt(self.wv[CURRENT] * self.ts / self.scales[CURRENT] * self.tls)
        for c in (POSITION, SPEED, ENVELOPE):
            fac[:, c] = np.sqrt(self.wv[c] * self.ts / self.scales[c])
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
        r = self.residuals_of(sim[None])
        t = self._residual_terms(r)[0] / self.scales
        return float(t @ self.wv)
