#!/usr/bin/env python3
"""Where the foreign lives' RUL coverage goes: the rate change, the diffusion, its learning.

Usage (from the repo root; reads bench/results/bench_foreign_lives.json, isolates nothing):
    .venv/bin/python -m bench.studies.coverage_gap          # ~10 min on 2 cores

Coverage of the 90 % RUL interval over every window from lambda 0.5 (a window without a
RUL counts as a miss, as `seeds.trajectory_numbers` counts it), sampling seed 0, split by
whether the life's rate changes in mid-life, for:

- the shipped predictor on the estimates and on the true k (the control of the report);
- the ideal forecaster (`prog.ideal`) on the same windows;
- the shipped predictor with every fault's diffusion prior put at the lives' walk (0.1 and
  0.2 per sqrt(cycle), or 0.2 alone; the walk's sd is 0.15): what a predictor that knew how
  much the rate moves would cover;
- the log-uniform walking prior the design first tried;
- the diffusion prior learned leave-one-out from the other lives' estimates
  (`prog.own_fleet`), as shipped (the mean of each life's posterior) and as the product of
  the lives' likelihoods (one diffusion shared by the fleet).

A diagnosis, not a tuning: nothing here sets a constant of the package.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from bench.harness import RESULTS, read_rows
from bench.prog import compare, ideal, own_fleet, seeds
from bench.prog.rescore import Prognose
from ema_phm.domain.faults import GROWTH_PRIORS, NAMES, PREDICTED
from ema_phm.prognostics import learn

NO_SCALE = {NAMES[i]: (0.0, 0.0) for i in PREDICTED}
#: (label, weights over diffusion.DIFFUSIONS) of the priors tried.
PRIORS = (
    ("diffusion prior at 0.1 and 0.2", (0, 0, 0, 0.5, 0.5, 0)),
    ("diffusion prior at 0.2", (0, 0, 0, 0, 1, 0)),
    ("log-uniform walking prior, P(constant) 0.5", (0.5, 0.1, 0.1, 0.1, 0.1, 0.1)),
)


def split(data: dict, scored: Iterable[compare.Scored]) -> str:
    """'all (no change, change)' coverage from lambda 0.5 of `scored`."""
    plan = {tr["index"]: tr for tr in data["plan"]}
    n = {True: [0, 0], False: [0, 0]}
    for s in scored:
        tr = plan[s.index]
        if tr["type"] == "steady":
            continue
        t = seeds.trajectory_numbers(s)
        n["change_cycle" in tr["growth"]][0] += t.covered_late
        n["change_cycle" in tr["growth"]][1] += t.windows_late
    a, b = n[False][0] + n[True][0], n[False][1] + n[True][1]
    return (
        f"{a}/{b} ({a / b:.0%}); no rate change {n[False][0]}/{n[False][1]} "
        f"({n[False][0] / n[False][1]:.0%}), a change {n[True][0]}/{n[True][1]} "
        f"({n[True][0] / n[True][1]:.0%})"
    )


def product(lives: Any) -> dict[str, dict[str, Any]]:
    """`learn_growth_priors` with the diffusion prior the product of the lives' likelihoods."""
    lives = list(lives)
    out = learn.learn_growth_priors(lives)
    per: dict[str, list] = {}
    for name, history, index in lives:
        per.setdefault(name, []).append(learn.life_rates(history, index, name)[3:])
    for name, prior in out.items():
        logp = np.log(np.maximum(np.array(per[name]), 1e-300)).sum(axis=0)
        w = np.exp(logp - logp.max())
        w /= w.sum()
        f = learn.MIN_DIFFUSION_SHARE
        prior["diffusion"] = [float(v) for v in f + (1 - f * w.size) * w]
    return out


def _fleet(data: dict, learner: Callable[..., Any]) -> list[compare.Scored]:
    saved = own_fleet.learn_growth_priors
    own_fleet.learn_growth_priors = learner
    try:
        return own_fleet.score(data, 0)
    finally:
        own_fleet.learn_growth_priors = saved


def main() -> int:
    data = read_rows(RESULTS / "bench_foreign_lives.json")
    plan = {tr["index"]: tr for tr in data["plan"]}
    shipped = compare.score_all(data, Prognose("shipped"), seed=0)
    print("shipped, estimates:", split(data, shipped), flush=True)
    truth = compare.score_all(data, Prognose("true k", {"severity_scale": NO_SCALE}), oracle=True)
    print("shipped, true k:", split(data, truth), flush=True)
    for change in (False, True):
        subset = [s for s in shipped if ("change_cycle" in plan[s.index]["growth"]) is change]
        subset = [s for s in subset if plan[s.index]["type"] != "steady"]
        a, b = ideal.ceiling(data, subset)["coverage_late"]
        print(f"ideal, {'a change' if change else 'no rate change'}: {a}/{b} ({a / b:.0%})")
    for label, weights in PRIORS:
        gp = {n: {**dict(v), "diffusion": list(weights)} for n, v in GROWTH_PRIORS.items()}
        for oracle in (False, True):
            kw: dict[str, Any] = {"growth_priors": gp}
            if oracle:
                kw["severity_scale"] = NO_SCALE
            scored = compare.score_all(data, Prognose(label, kw), oracle=oracle, seed=0)
            which = "true k" if oracle else "estimates"
            print(f"{label}, {which}:", split(data, scored), flush=True)
    print("learned leave-one-out, mean:", split(data, _fleet(data, learn.learn_growth_priors)))
    print("learned leave-one-out, product:", split(data, _fleet(data, product)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
