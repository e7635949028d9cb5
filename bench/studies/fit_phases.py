#!/usr/bin/env python3
"""Where a fit's time goes: the search, the Gauss-Newton polish, the intervals.

Usage (repo root):  .venv/bin/python -m bench.studies.fit_phases [--pairs 5]

The issue on speed ("Faster and sharper") assumed the polish makes 30 Jacobians; this
measures it.  For each of `--pairs` seeds: our HF, the datasheet actuator, friction k1 = 0.30
then 0.33 (the next window of a growing fault), the benchmarks' sensor noise (1 % of the
current range, 5e-5 rad, 2.5 resolver steps) drawn with that seed; the first window isolated
as monitor_node's first window is (global search, unmeasured load searched, intervals), the
second tracked from it (`start`).  Reported per fit kind: the wall time of the whole fit, of
the polish and of the intervals, and the polish's residual evaluations and Jacobians (scipy's
``nfev`` and ``njev``; each Jacobian is 2 x dim simulations).  Medians and ranges over the
pairs, one process, after a warm-up fit.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from typing import Any

from ema_phm.diagnosis import isolation, refinement
from ema_phm.domain.faults import k_with
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.tools.benchmark import machine

#: Phase name -> [seconds, ...] of the fit being measured; the polish's scipy counts.
TIMES: dict[str, float] = {}
COUNTS: dict[str, int] = {}


def _timed_polish(original: Any) -> Any:
    def run(fitness: Any, x: Any, f: float) -> Any:
        calls = {"fun": 0, "jac": 0}
        jac_of = refinement.jacobian

        def counted_jacobian(*args: Any, **kwargs: Any) -> Any:
            calls["jac"] += 1
            return jac_of(*args, **kwargs)

        refinement.jacobian = counted_jacobian
        before = fitness.evaluations
        t0 = time.perf_counter()
        try:
            out = original(fitness, x, f)
        finally:
            refinement.jacobian = jac_of
        TIMES["polish_s"] = time.perf_counter() - t0
        COUNTS["polish_jacobians"] = calls["jac"]
        COUNTS["polish_simulations"] = fitness.evaluations - before
        return out

    return run


def _timed_intervals(original: Any) -> Any:
    def run(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        out = original(*args, **kwargs)
        TIMES["intervals_s"] = time.perf_counter() - t0
        return out

    return run


def window(friction: float, seed: int) -> Any:
    """The HF window of the module docstring."""
    act = ActuatorParameters.default()
    return real_ema.simulate(
        k_with(friction=friction),
        actuator=act,
        seed=seed,
        noise_current=0.01 * act.controller.max_current,
        noise_position=5.0e-5,
        noise_speed=2.5 * act.high_fidelity.resolver_resolution * act.acquisition.sample_rate,
    ).window


def fit(w: Any, start: Any = None) -> dict[str, float]:
    """One fit as monitor_node makes it; its phases' times and counts."""
    TIMES.clear()
    COUNTS.clear()
    t0 = time.perf_counter()
    res = isolation.isolate(w, nuisance=True, intervals=True, start=start)
    total = time.perf_counter() - t0
    return {"total_s": total, **TIMES, **COUNTS, "row": res.row}


def summary(rows: list[dict[str, Any]]) -> dict[str, str]:
    """Median (min-max) of each measured figure."""
    out = {}
    for key in ("total_s", "polish_s", "intervals_s", "polish_simulations", "polish_jacobians"):
        v = [r[key] for r in rows]
        out[key] = f"{statistics.median(v):.3g} ({min(v):.3g}-{max(v):.3g})"
    return out


def main() -> int:
    """Print the medians per fit kind (JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5, help="window pairs (seeds 0..pairs-1)")
    pairs = ap.parse_args().pairs
    refinement_polish = refinement.polish
    isolation.refinement.polish = _timed_polish(refinement_polish)
    isolation._uncertainty_fields = _timed_intervals(isolation._uncertainty_fields)
    fit(window(0.30, 99))  # warm-up: loads the compiled kernels
    glob, tracked = [], []
    for seed in range(pairs):
        first = fit(window(0.30, seed))
        glob.append(first)
        tracked.append(fit(window(0.33, seed + 1000), start=first["row"]))
    print(
        json.dumps(
            {
                "machine": machine(),
                "pairs": pairs,
                "global": summary(glob),
                "tracked": summary(tracked),
            },
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
