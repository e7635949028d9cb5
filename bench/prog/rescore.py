"""The prognostics benchmark's --score phase: every method on the stored rows, then the report.

Reads only the raw rows (bench/results/bench_prognostics.json), so changing the RUL model and
re-running ``--score`` re-scores the same isolations in minutes.  Each method runs through
the live monitor's policy (`prog.compare`); the growth priors are learned again on the
tuning half (even trajectories) and shown beside the shipped ones.
"""

from __future__ import annotations

import math
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bench.harness import ROOT, pool, read_rows
from bench.prog import compare, plots, seeds
from bench.prog.baseline import Line
from bench.prog.lives import tuning_lives
from bench.prog.particle import ParticleFilter
from bench.prog.report import KEEP_MARKER, report
from ema_phm.domain.faults import GROWTH_PRIORS, NAMES
from ema_phm.prognostics.learn import learn_growth_priors
from ema_phm.prognostics.rul import PREDICTED, History, Prognosis, prognose


@dataclass(frozen=True)
class Prognose:
    """`rul.prognose` with keyword settings, as a `Predictor`."""

    label: str
    kw: dict[str, Any] = field(default_factory=dict)

    def predict(self, history: History, *, seed: int = 0) -> Prognosis:
        """`rul.prognose(history, seed=seed, **kw)`."""
        return prognose(history, seed=seed, **self.kw)


#: (short name, predictor) of the methods of the comparison table, the project's first.
def methods() -> list[tuple[str, Any]]:
    """The project's model, its predecessor and the baselines a practitioner tries first."""
    return [
        ("ema_phm", Prognose("ema_phm: rul.prognose defaults (learned growth priors)")),
        (
            "ema_phm before",
            Prognose("ema_phm before issue 21 (flat growth prior)", {"growth_priors": {}}),
        ),
        (
            "ema_phm constant rate",
            Prognose("ema_phm with a constant rate (before the rate walk)", {"rate_walk": False}),
        ),
        ("line 5", Line(5)),
        ("line 10", Line(10)),
        ("log-line 10", Line(10, log=True)),
        ("particle filter", ParticleFilter()),
    ]


def _scaled_priors(factor: float) -> dict[str, dict[str, Any]]:
    """The shipped growth priors with every rate times `factor` (a fleet unlike the lives)."""
    out = {}
    for name, g in GROWTH_PRIORS.items():
        out[name] = {
            "linear": (g["linear"][0] * factor, g["linear"][1]),
            "exponential": (g["exponential"][0] * factor, g["exponential"][1]),
            "p_exponential": g.get("p_exponential"),
        }
    return out


def controls() -> list[tuple[str, Any, bool]]:
    """(label, predictor, oracle) of the control and sensitivity scorings."""
    unbiased = {NAMES[i]: (0.0, 0.0) for i in PREDICTED}
    return [
        (
            "oracle: ema_phm on the true k (the isolation's intervals moved onto it, no "
            "severity scale)",
            Prognose("oracle", {"severity_scale": unbiased}),
            True,
        ),
        ("oracle: line 5 on the true k", Line(5), True),
        (
            "ema_phm, growth priors' rates x 0.5",
            Prognose("x0.5", {"growth_priors": _scaled_priors(0.5)}),
            False,
        ),
        (
            "ema_phm, growth priors' rates x 2",
            Prognose("x2", {"growth_priors": _scaled_priors(2.0)}),
            False,
        ),
        (
            "ema_phm, no memory (every counted estimate alike)",
            Prognose("memory inf", {"memory_cycles": math.inf}),
            False,
        ),
        ("ema_phm, p_detect 0.9", Prognose("p0.9", {"p_detect": 0.9}), False),
    ]


_DATA: dict[str, Any] = {}


def _score(task: tuple[Any, bool, int]) -> list[compare.Scored]:
    predictor, oracle, seed = task
    return compare.score_all(_DATA["rows"], predictor, oracle=oracle, seed=seed)


#: Methods scored at every seed of `seeds.SEEDS` (short name of `methods()`, label there),
#: and the paired differences reported.
SEEDED = {
    "ema_phm": "ema_phm",
    "ema_phm before": "ema_phm, no fleet history",
    "ema_phm constant rate": "ema_phm, constant rate (no rate walk)",
    "line 5": "straight line, last 5",
}
SEEDED_PAIRS = [
    ("ema_phm", "line 5"),
    ("ema_phm before", "line 5"),
    ("ema_phm", "ema_phm constant rate"),
]
#: Methods that do not sample (one scoring stands for every seed).
UNSEEDED = ("line 5",)


def run_score(raw: Path, md: Path, jobs: int = 1) -> None:
    """Score every method and control on the stored rows; write the report and the plots.

    `jobs` processes score methods side by side (each method's update times are then those
    of one core among `jobs` busy ones).
    """
    data = read_rows(raw)
    t0 = time.perf_counter()
    seed0 = compare.SEED
    tasks = [(m, False, seed0) for _, m in methods()] + [(m, o, seed0) for _, m, o in controls()]
    more = [
        (name, m, seed)
        for name, m in methods()
        if name in SEEDED and name not in UNSEEDED
        for seed in seeds.SEEDS
        if seed != seed0
    ]
    tasks += [(m, False, seed) for _, m, seed in more]
    _DATA["rows"] = data  # forked workers inherit it
    if jobs > 1:
        with pool(jobs) as workers:
            results = workers.map(_score, tasks, chunksize=1)
    else:
        results = [_score(t) for t in tasks]
    scored = {name: r for (name, _), r in zip(methods(), results, strict=False)}
    labels = {name: getattr(m, "label", name) for name, m in methods()}
    n_ctl = len(controls())
    ctl = [
        (c[0], r)
        for c, r in zip(controls(), results[len(scored) : len(scored) + n_ctl], strict=True)
    ]
    by_seed: dict[str, dict[int, list[compare.Scored]]] = {n: {seed0: scored[n]} for n in SEEDED}
    for (name, _, seed), r in zip(more, results[len(scored) + n_ctl :], strict=True):
        by_seed[name][seed] = r
    learned = learn_growth_priors(tuning_lives(data))
    extra = {
        "score_s": time.perf_counter() - t0,
        "jobs": jobs,
        "rul_version": _rul_version(),
        "labels": labels,
        "controls": ctl,
        "learned": learned,
        "shipped": GROWTH_PRIORS,
        "plots": plots.alpha_lambda(scored["ema_phm"], scored["line 5"], md.parent),
        "seeds": seeds.section(by_seed, SEEDED, SEEDED_PAIRS),
    }
    text = report(data, scored, extra)
    if md.exists():  # the hand-written analysis below the marker survives a re-score
        old = md.read_text()
        if KEEP_MARKER in old:
            text += "\n" + KEEP_MARKER + old.split(KEEP_MARKER, 1)[1]
    md.write_text(text)
    n, s = len(scored), extra["score_s"]
    print(f"scored {n} methods and {len(ctl)} controls in {s:.0f} s; wrote {md}")


def _rul_version() -> str:
    """The last commit of the RUL model's files, and whether they differ from it."""
    files = [
        "ema_phm/prognostics/rul.py",
        "ema_phm/prognostics/trend.py",
        "ema_phm/prognostics/diffusion.py",
        "ema_phm/domain/faults.py",
    ]
    try:
        commit = subprocess.run(
            ["git", "log", "-1", "--format=%h", "--", *files],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", *files],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "an unknown commit (no git)"
    return f"commit {commit}" + (" with uncommitted changes" if dirty else "")
