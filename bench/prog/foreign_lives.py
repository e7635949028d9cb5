"""Foreign lives: faults that grow off the prognostics benchmark's map, on foreign units.

The prognostics benchmark (`prog.plan`) grows friction and backlash linearly and short
circuit A and eccentricity exponentially, each at one constant rate, to an end of life of
25-45 cycles; its units are `Unit.draw`'s and its windows the envelope's.  Here:

- every fault with a remaining life (k1..k6) grows by each law in turn (`KINDS`), so a
  friction grows exponentially and a short circuit linearly as often as the other way;
- the rate takes a random walk (log rate, `RATE_WALK_SD` per cycle) and, on every other life,
  changes once in mid-life (`RATE_CHANGE`, at 30-70 % of the span): the law is the shape of
  the growth, not a straight line or a clean exponential;
- the true end of life (severity `THRESHOLD`) is uniform in `LIFE_CYCLES` (15-80), the onset in
  the first quarter of it;
- every trajectory runs on its own foreign unit (`harness.foreign.draw_unit`: corner, wide
  and inside units in turn), commissioned as `ema-phm calibrate --baseline` does (with
  --force where that refuses), and every cycle is a window of `harness.foreign.window_env`
  (-40..+85 degC, noise 0.5-2x per channel and the fine position sensor on every third,
  unmeasured and measured constant and sine loads);
- STEADY trajectories hold one fault at a constant severity (a RUL there is a false alarm).

Seeds: units FIRST_SEED + t (9500..; bench_foreign's are 9000..9015), noise and isolation
seeds SIM_SEED_BASE + 1000 t + cycle (>= 9,500,000), hangar baselines SIM_SEED_BASE + 1000 t
+ 900 + b, the laws from ``default_rng((FIRST_SEED + t, LAW_STREAM))``.  Nothing in the
package is chosen on these rows.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from bench.harness.foreign import commissioned_unit, simulate, window_env
from bench.prog.isolate import Emit, fit_and_emit, resume_from
from ema_phm.domain.faults import ERROR_SEVERITY, NAMES, NOMINAL, PREDICTED
from ema_phm.monitor.policy import FitPolicy

#: First unit seed (trajectory t runs on unit FIRST_SEED + t).
FIRST_SEED = 9500
#: Noise seed base (window `cycle` of trajectory t: SIM_SEED_BASE + 1000 t + cycle).
SIM_SEED_BASE = 9_500_000
#: numpy random stream of the laws (bench_foreign's streams are 41, 43, 47).
LAW_STREAM = 53
#: (fault, law) of the degrading trajectories, in turn: every fault with a RUL, both laws.
KINDS: tuple[tuple[str, str], ...] = tuple(
    (NAMES[i], law) for law in ("linear", "exponential") for i in PREDICTED
)
#: Degrading trajectories per kind (default run), and steady ones.
PER_KIND = 2
STEADY = 4
#: Faults a steady trajectory holds, in turn, and its severity (uniform) and length.
STEADY_FAULTS: tuple[str, ...] = ("friction", "backlash", "short_circuit_b", "eccentricity")
STEADY_SEVERITY = (0.1, 0.3)
STEADY_CYCLES = 30
#: True end of life [cycle], uniform whole numbers (inclusive).
LIFE_CYCLES = (15, 80)
#: The onset is uniform in [0, ONSET_SHARE x life].
ONSET_SHARE = 0.25
#: Severity at the onset: linear (uniform) and exponential (uniform, > 0).
INITIAL_LINEAR = (0.0, 0.03)
INITIAL_EXPONENTIAL = (0.01, 0.06)
#: Per-cycle sd of the random walk of the log rate.
RATE_WALK_SD = 0.15
#: A mid-life rate change on every other life: the rate times a log-uniform factor in this
#: range from a cycle uniform in RATE_CHANGE_AT of the span.
RATE_CHANGE = (0.4, 2.5)
RATE_CHANGE_AT = (0.3, 0.7)
#: Failure threshold of the severity (the fault table's ERROR severity, as `prog.plan`).
THRESHOLD = float(ERROR_SEVERITY)


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def severity_path(rng: np.random.Generator, law: str, changes: bool) -> tuple[list[float], dict]:
    """Severity per cycle 0..life (the last one at THRESHOLD), and how it was drawn.

    Linear: s(c) = s0 + r sum(m_i); exponential: s(c) = s0 exp(r sum(m_i)); the sums over
    the cycles from the onset to c - 1, m_i = exp(random walk) x (the change factor after
    the change), r set so that s(life) = THRESHOLD.  Before the onset the fault is absent.
    """
    life = int(rng.integers(LIFE_CYCLES[0], LIFE_CYCLES[1] + 1))
    onset = int(rng.integers(0, int(ONSET_SHARE * life) + 1))
    span = life - onset
    walk = np.exp(np.cumsum(rng.normal(0.0, RATE_WALK_SD, size=span)))
    info: dict[str, Any] = {"law": law, "life": life, "onset": onset, "walk_sd": RATE_WALK_SD}
    if changes:
        at = onset + int(round(rng.uniform(*RATE_CHANGE_AT) * span))
        factor = _log_uniform(rng, *RATE_CHANGE)
        walk[at - onset :] *= factor
        info.update(change_cycle=at, change_factor=factor)
    cum = np.concatenate([[0.0], np.cumsum(walk)])  # cum[j]: sum of the first j increments
    if law == "linear":
        s0 = float(rng.uniform(*INITIAL_LINEAR))
        rate = (THRESHOLD - s0) / cum[-1] * (1 + 1e-9)
        grown = s0 + rate * cum
    else:
        s0 = float(rng.uniform(*INITIAL_EXPONENTIAL))
        rate = math.log(THRESHOLD / s0) / cum[-1] * (1 + 1e-9)
        grown = s0 * np.exp(rate * cum)
    info.update(initial=s0, mean_rate=rate)
    path = [0.0] * onset + [float(v) for v in grown]
    return path, info


def plan(seed: int = FIRST_SEED, per_kind: int = PER_KIND, steady: int = STEADY) -> list[dict]:
    """Every trajectory: index, type, law, unit seed, true severity per cycle, end of life."""
    kinds = [KINDS[t % len(KINDS)] for t in range(per_kind * len(KINDS))]
    out = []
    for t in range(len(kinds) + steady):
        rng = np.random.default_rng((seed + t, LAW_STREAM))
        if t < len(kinds):
            name, law = kinds[t]
            path, info = severity_path(rng, law, changes=(t // len(KINDS) + t) % 2 == 1)
            tr = {"type": name, "law": law, "paths": {name: path}, "growth": info}
            tr["true_eol"] = {name: info["life"]}
            tr["cycles"] = info["life"]
        else:
            j = t - len(kinds)
            name = STEADY_FAULTS[j % len(STEADY_FAULTS)]
            level = float(rng.uniform(*STEADY_SEVERITY))
            tr = {"type": "steady", "law": None, "paths": {name: [level] * STEADY_CYCLES}}
            tr["growth"] = {"steady": name, "severity": level}
            tr["true_eol"] = {}
            tr["cycles"] = STEADY_CYCLES
        if "eccentricity" in tr["paths"]:
            tr["eccentricity_phase"] = float(rng.uniform(0.0, 1.0))
        out.append({"index": t, "unit_seed": seed + t, **tr})
    return out


def true_k(tr: dict, cycle: int) -> np.ndarray:
    """The true fault vector of trajectory `tr` at `cycle`."""
    k = NOMINAL.copy()
    for name, path in tr["paths"].items():
        i = NAMES.index(name)
        k[i] = NOMINAL[i] + path[min(cycle, len(path) - 1)]
    if "eccentricity_phase" in tr:
        k[NAMES.index("eccentricity_phase")] = tr["eccentricity_phase"]
    return k


def run_seed(t: int, cycle: int) -> int:
    """Noise (and isolation) seed of window `cycle` of trajectory `t`."""
    return SIM_SEED_BASE + 1000 * t + cycle


def run_trajectory(
    tr: dict, seed: int, done: list[dict], max_cycles: int | None, emit: Emit
) -> None:
    """Simulate and isolate trajectory `tr` as the live monitor does; emit its rows."""
    t = tr["index"]
    unit, belief, record = commissioned_unit(t, tr["unit_seed"] - t, SIM_SEED_BASE)
    emit("unit", {"index": t, **record})
    last = tr["cycles"] if max_cycles is None else min(tr["cycles"], max_cycles)
    have = {w["cycle"] for w in done}
    policy = FitPolicy()
    policy.track_from(resume_from(done))
    for cycle in range(last):
        if cycle in have:
            continue
        env = window_env(t, cycle, seed)
        k = true_k(tr, cycle)
        rs = run_seed(t, cycle)
        t0 = time.perf_counter()
        window = simulate(unit, k, env, rs)
        row: dict[str, Any] = {
            "trajectory": t,
            "cycle": cycle,
            "k_true": [float(v) for v in k],
            "temperature_c": env["temperature_c"],
            "noise": env["noise"],
            "load": env["load"],
            "run_seed": rs,
            "sim_s": time.perf_counter() - t0,
        }
        fit_and_emit(row, window, belief, policy, emit)


def settings() -> dict:
    """The plan's constants, recorded with the rows."""
    return {
        "kinds": KINDS,
        "per_kind_default": PER_KIND,
        "steady_default": STEADY,
        "steady_faults": STEADY_FAULTS,
        "steady_severity": STEADY_SEVERITY,
        "steady_cycles": STEADY_CYCLES,
        "life_cycles": LIFE_CYCLES,
        "onset_share": ONSET_SHARE,
        "initial_linear": INITIAL_LINEAR,
        "initial_exponential": INITIAL_EXPONENTIAL,
        "rate_walk_sd": RATE_WALK_SD,
        "rate_change": RATE_CHANGE,
        "rate_change_at": RATE_CHANGE_AT,
        "threshold": THRESHOLD,
    }
