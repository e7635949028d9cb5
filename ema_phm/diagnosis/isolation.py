"""Fault isolation: fit the monitor model's k to a recorded window with pymoo.

Problem (vectorized LF over the whole population) / algorithm presets /
termination are kept apart as in pymoo.  `isolate()` is seeded, reports
progress once per generation and can be cancelled from another thread.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from pymoo.algorithms.soo.nonconvex.cmaes import CMAES
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.algorithms.soo.nonconvex.nelder import NelderMead
from pymoo.algorithms.soo.nonconvex.pattern import PatternSearch
from pymoo.algorithms.soo.nonconvex.pso import PSO
from pymoo.core.callback import Callback
from pymoo.core.problem import Problem
from pymoo.optimize import minimize
from pymoo.termination import get_termination
from pymoo.termination.default import DefaultSingleObjectiveTermination

from ..domain.faults import N_K, NAMES, per_parameter_err, percent_err, validate
from ..domain.window import Window
from ..errors import EmaPhmError, IsolationCancelled
from ..limits import check
from ..model.belief import MonitorBelief
from . import adequacy as adequacy_mod
from . import excitation, identifiability, refinement, uncertainty, unit_spread
from . import nuisance as nuisance_mod
from .fitness import Fitness, FitnessWeights, fitness_name


class FaultProblem(Problem):
    """k (and nuisances) in [0, 1]^dim -> fitness, the whole population in one LF batch."""

    def __init__(self, fitness: Fitness, cancel: threading.Event | None = None) -> None:
        d = fitness.dim
        super().__init__(n_var=d, n_obj=1, xl=np.zeros(d), xu=np.ones(d), elementwise=False)
        self.fitness = fitness
        self.cancel = cancel

    def _evaluate(self, x: np.ndarray, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
        _check_cancel(self.cancel, self.fitness)
        out["F"] = self.fitness(np.clip(x, 0.0, 1.0))[:, None]


def _check_cancel(cancel: threading.Event | None, fitness: Fitness) -> None:
    # raising unwinds pymoo at once: no further batch is simulated after the request
    if cancel is not None and cancel.is_set():
        raise IsolationCancelled(f"isolation cancelled after {fitness.evaluations} evaluations")


@dataclass(frozen=True)
class Preset:
    """A global search (algorithm + termination), optionally followed by a local refinement."""

    name: str
    make: Callable[[int], Any]  # dimension -> algorithm
    termination: Callable[[], Any]
    local: Callable[[np.ndarray], Any] | None = None
    local_termination: Callable[[], Any] | None = None
    description: str = ""


def _ga_thesis() -> Preset:
    # MATLAB ga as used in the thesis: population 20, 200 generations, FunctionTolerance 1e-9
    return Preset(
        "ga-thesis",
        lambda d: GA(pop_size=20, eliminate_duplicates=True),
        lambda: DefaultSingleObjectiveTermination(ftol=1e-9, period=50, n_max_gen=200),
        description="thesis GA: pop 20, 200 generations, ftol 1e-9",
    )


def _de(d: int = N_K) -> DE:
    return DE(pop_size=40, variant="DE/rand/1/bin", CR=0.9, F=0.6)


def _evals(n: int) -> Callable[[], Any]:
    return lambda: get_termination("n_eval", n)


def _hybrid(
    name: str, global_evals: int, local: Callable[[np.ndarray], Any], local_evals: int, what: str
) -> Preset:
    """DE for `global_evals`, then the local method from DE's best for `local_evals`."""
    return Preset(
        name,
        _de,
        _evals(global_evals),
        local=local,
        local_termination=_evals(local_evals),
        description=f"DE ({global_evals} evals) then {what} from its best ({local_evals} evals)",
    )


def hybrid_cma(
    global_evals: int = 4000, local_evals: int = 2000, name: str = "hybrid-cma"
) -> Preset:
    """DE, then CMA-ES (sigma 0.03, population 16) from its best: the default's shape."""
    return _hybrid(
        name,
        global_evals,
        lambda x0: CMAES(x0=x0, sigma=0.03, restarts=0, popsize=16),
        local_evals,
        "CMA-ES (sigma 0.03, population 16)",
    )


PRESETS: dict[str, Callable[[], Preset]] = {
    "ga-thesis": _ga_thesis,
    "de": lambda: Preset(
        "de", _de, _evals(8000), description="differential evolution, 8000 evals"
    ),
    "pso": lambda: Preset(
        "pso", lambda d: PSO(pop_size=40), _evals(8000), description="particle swarm, 8000 evals"
    ),
    "cmaes": lambda: Preset(
        "cmaes",
        lambda d: CMAES(x0=np.full(d, 0.5), sigma=0.3, restarts=0),
        _evals(8000),
        description="CMA-ES from the centre, 8000 evals",
    ),
    "hybrid": lambda: _hybrid(
        "hybrid",
        5000,
        lambda x0: PatternSearch(x0=x0, init_delta=0.05),
        3000,
        "Hooke-Jeeves pattern search",
    ),
    "hybrid-cma": hybrid_cma,
    "hybrid-nm": lambda: _hybrid(
        "hybrid-nm",
        5000,
        lambda x0: NelderMead(x0=x0, init_simplex_scale=0.05),
        3000,
        "Nelder-Mead",
    ),
}
#: Chosen by bench/bench_isolation.py (docs/benchmarks.md).
DEFAULT_PRESET = "hybrid-cma"


def preset_budget(name: str) -> int:
    """Nominal number of LF evaluations of a preset (for progress bars)."""
    p = PRESETS[name]()
    total = 0
    for term in (p.termination(), p.local_termination() if p.local_termination else None):
        total += int(getattr(term, "n_max_evals", 0) or 0) or (20 * 200 if term is not None else 0)
    return total


@dataclass(frozen=True)
class Progress:
    """The state of an isolation after one optimizer generation."""

    stage: str  # "global" or "local"
    generation: int
    evaluations: int
    best_fitness: float
    best_k: np.ndarray


@dataclass(frozen=True)
class IsolationResult:
    """The fitted k, its fitness, the cost and the settings of one isolation."""

    k: np.ndarray
    fitness: float
    evaluations: int
    wall_s: float
    preset: str
    seed: int
    history: list[tuple[int, float]] = field(default_factory=list)  # (evaluations, best fitness)
    k_true: np.ndarray | None = None
    #: name -> estimated value (nuisance.REPORTED_UNITS); empty unless searched
    nuisance: dict[str, float] = field(default_factory=dict)
    #: (N_K, 2) 90 % interval of each k entry; None unless asked for
    k_interval: np.ndarray | None = None
    #: (N_K,) standard error of each k entry before the interval scale (uncertainty.py)
    k_std: np.ndarray | None = None
    #: per entry: (identifiable, reason)
    identifiable: tuple[tuple[bool, str], ...] | None = None
    adequacy: adequacy_mod.Adequacy | None = None
    #: median high-band current RMS of the window [A] and whether the loop hunts (fitness.py)
    hunting_rms: float = float("nan")
    hunting: bool = False
    #: the fitted search row (k, then the normalized nuisances): a next window's `start`
    row: np.ndarray | None = None
    #: True when the fit started from a previous one (`start`) instead of a global search
    tracked: bool = False
    #: the named fitness fitted with ("default" resolved; "custom" for weights given as
    #: numbers): whether the model followed the recorded loop (fitness.LOOPS)
    fitness_name: str = "custom"
    #: whether the belief was commissioned on this unit (`MonitorBelief.commissioned`); when
    #: not, the intervals also hold what an unknown unit within its tolerances adds
    #: (`unit_spread`), and a verdict says so
    commissioned: bool = False
    #: entries the window's recording cannot show, held at their healthy value: index -> why
    #: (`domain.window.unseen_faults`)
    unseen: dict[int, str] = field(default_factory=dict)

    @property
    def percent_err(self) -> float | None:
        """%err of eq. 6.4 against `k_true`; None without a truth."""
        return None if self.k_true is None else percent_err(self.k, self.k_true)

    @property
    def per_parameter_err(self) -> np.ndarray | None:
        """Per-entry error against `k_true`; None without a truth."""
        return None if self.k_true is None else per_parameter_err(self.k, self.k_true)

    def as_dict(self) -> dict[str, Any]:
        """The result as JSON-ready values."""
        per_parameter = self.per_parameter_err
        return {
            "k": [float(v) for v in self.k],
            "percent_err": self.percent_err,
            "per_parameter_err": None
            if per_parameter is None
            else [float(v) for v in per_parameter],
            "k_true": None if self.k_true is None else [float(v) for v in self.k_true],
            "fitness": self.fitness,
            "evaluations": self.evaluations,
            "wall_s": self.wall_s,
            "preset": self.preset,
            "seed": self.seed,
            "nuisance": dict(self.nuisance),
            "k_interval": None
            if self.k_interval is None
            else [[float(a), float(b)] for a, b in self.k_interval],
            "k_std": None if self.k_std is None else [float(v) for v in self.k_std],
            "identifiable": None
            if self.identifiable is None
            else [{"ok": bool(ok), "reason": why} for ok, why in self.identifiable],
            "adequacy": None if self.adequacy is None else self.adequacy.as_dict(),
            "loop_hunting": {"high_band_rms_a": self.hunting_rms, "hunting": self.hunting},
            "tracked": self.tracked,
            "fitness_name": self.fitness_name,
            "commissioned": self.commissioned,
            "unseen": {NAMES[i]: why for i, why in sorted(self.unseen.items())},
        }


class _GenerationObserver(Callback):
    """Per-generation progress + cancellation + convergence history."""

    def __init__(
        self,
        stage: str,
        fitness: Fitness,
        on_progress: Callable[[Progress], None] | None,
        cancel: threading.Event | None,
        history: list[tuple[int, float]],
    ) -> None:
        super().__init__()
        self.stage, self.fitness, self.on_progress, self.cancel, self.history = (
            stage,
            fitness,
            on_progress,
            cancel,
            history,
        )

    def notify(self, algorithm: Any) -> None:
        opt = algorithm.opt
        f = float(opt.get("F").min()) if opt is not None and len(opt) else float("inf")
        x = (
            opt.get("X")[int(np.argmin(opt.get("F")[:, 0]))]
            if opt is not None and len(opt)
            else np.full(N_K, np.nan)
        )
        prev = self.history[-1][1] if self.history else float("inf")
        self.history.append((self.fitness.evaluations, min(f, prev)))
        if self.on_progress is not None:
            self.on_progress(
                Progress(
                    self.stage, int(algorithm.n_gen), self.fitness.evaluations, f, np.array(x)
                )
            )
        _check_cancel(self.cancel, self.fitness)


def _checked_options(preset: str, seed: Any, max_evaluations: Any) -> tuple[int, int]:
    """(seed, max_evaluations) as ints inside LIMITS (None budget -> 0).

    Raises EmaPhmError naming the bad one.
    """
    if preset not in PRESETS:
        raise EmaPhmError(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}")
    budget = 0 if max_evaluations is None else int(check("max_evaluations", max_evaluations))
    return int(check("seed", seed)), budget


def _best(res: Any) -> tuple[np.ndarray, float]:
    """The best k (clipped to [0, 1]) of a pymoo result, and its fitness."""
    return (
        np.clip(np.asarray(res.X, dtype=np.float64).ravel(), 0, 1),
        float(np.asarray(res.F).ravel()[0]),
    )


def _local_stage(
    problem: FaultProblem,
    preset: Preset,
    x: np.ndarray,
    f: float,
    *,
    seed: int,
    observer: Callback,
    termination: Any = None,
) -> tuple[np.ndarray, float]:
    """Run the preset's local stage from `x`; its best when no worse than `f`, else (x, f)."""
    if preset.local is None or preset.local_termination is None:
        return x, f
    res = minimize(
        problem,
        preset.local(x),
        termination if termination is not None else preset.local_termination(),
        seed=seed,
        verbose=False,
        callback=observer,
    )
    x_local, f_local = _best(res)
    return (x_local, f_local) if f_local <= f else (x, f)


def isolate(
    window: Window,
    *,
    belief: MonitorBelief | None = None,
    preset: str = DEFAULT_PRESET,
    seed: int = 0,
    weights: FitnessWeights | str = "default",
    on_progress: Callable[[Progress], None] | None = None,
    cancel: threading.Event | None = None,
    max_evaluations: int | None = None,
    check_excitation: bool = True,
    nuisance: bool = False,
    intervals: bool = False,
    start: np.ndarray | None = None,
) -> IsolationResult:
    """Fit k of the monitor model of `belief` (default: MonitorBelief.default()) to `window`.

    `weights` names the fitness (fitness.WEIGHTINGS; "default" is fitness.DEFAULT_FITNESS,
    which follows the recorded loop).  With `nuisance` the unmeasured load is searched with
    k and the result polished by bounded Gauss-Newton (refinement.py); with `intervals` it
    carries 90 % intervals, identifiability flags and the adequacy statistic.  With `start`
    (a previous result's `row`, or a k) the global stage is skipped: the preset's local stage
    for TRACK_EVALUATIONS evaluations from there, then the polish (tracking, issue 11).
    `max_evaluations` None or 0 runs the preset's own budget; a positive value runs only the
    global stage, stopped after that many evaluations.  With `check_excitation` the window's
    probe separation (excitation.py) is measured first and ExcitationError raised if it is
    below the threshold.  Raises ConfigError for a seed or budget outside
    ema_phm.limits.LIMITS and IsolationCancelled if `cancel` is set before the end.
    """
    seed, max_evaluations = _checked_options(preset, seed, max_evaluations)
    t0 = time.perf_counter()
    truth, window = window.k_true, window.without_truth()  # the truth is for %err only
    fitness = Fitness(window, weights=weights, belief=belief, nuisance=nuisance)
    if check_excitation:
        excitation.require(window, belief=belief)
    history: list[tuple[int, float]] = []
    search = _Search.of(fitness, PRESETS[preset](), seed, (on_progress, cancel, history))
    x, f = search.track(start) if start is not None else search.global_then_local(max_evaluations)
    if nuisance:  # also after a capped search: the polish has its own small budget
        _check_cancel(cancel, fitness)
        x, f = refinement.polish(fitness, x, f)
    x = fitness.held(x)  # what the recording cannot show stays healthy
    extra = _uncertainty_fields(fitness, x, f, belief) if intervals else {}
    return IsolationResult(
        k=validate(x[:N_K]),
        nuisance=_nuisance_values(fitness, x),
        row=np.array(x, dtype=np.float64),
        tracked=start is not None,
        **_fitted_with(fitness, weights),
        **extra,
        fitness=f,
        evaluations=fitness.evaluations,
        wall_s=time.perf_counter() - t0,
        preset=preset,
        seed=int(seed),
        history=history,
        k_true=truth,
    )


@dataclass(frozen=True)
class _Search:
    """The stages of one isolation's search: global then local, or tracking."""

    problem: FaultProblem
    preset: Preset
    fitness: Fitness
    rng_seed: int
    #: stage name -> the pymoo callback recording its progress
    observer: Callable[[str], Callback]

    @classmethod
    def of(
        cls,
        fitness: Fitness,
        preset: Preset,
        seed: int,
        observed: tuple[
            Callable[[Progress], None] | None, threading.Event | None, list[tuple[int, float]]
        ],
    ) -> _Search:
        """The search of `fitness` by `preset`; `observed`: (on_progress, cancel, history)."""
        on_progress, cancel, history = observed
        return cls(
            FaultProblem(fitness, cancel),
            preset,
            fitness,
            # pymoo hands the seed to the `cma` package, which reads 0 as "seed from the
            # clock": shift by one so every stage is reproducible for every user seed, 0 too
            rng_seed=int(seed) + 1,
            observer=lambda stage: _GenerationObserver(
                stage, fitness, on_progress, cancel, history
            ),
        )

    def track(self, start: np.ndarray) -> tuple[np.ndarray, float]:
        """The preset's local stage from `start` for TRACK_EVALUATIONS evaluations."""
        x = _start_row(start, self.fitness)
        f = float(self.fitness(x[None])[0])
        track = get_termination("n_eval", TRACK_EVALUATIONS)
        return _local_stage(
            self.problem,
            self.preset,
            x,
            f,
            seed=self.rng_seed,
            observer=self.observer("local"),
            termination=track,
        )

    def global_then_local(self, max_evaluations: int) -> tuple[np.ndarray, float]:
        """The global search (capped at `max_evaluations` if > 0, then no local stage)."""
        p = self.preset
        term = get_termination("n_eval", max_evaluations) if max_evaluations else p.termination()
        algorithm = p.make(self.fitness.dim)
        _start_from_healthy(algorithm, self.fitness, self.rng_seed)
        res = minimize(
            self.problem,
            algorithm,
            term,
            seed=self.rng_seed,
            verbose=False,
            callback=self.observer("global"),
        )
        x, f = _best(res)
        if max_evaluations:
            return x, f
        return _local_stage(
            self.problem, p, x, f, seed=self.rng_seed, observer=self.observer("local")
        )


def _fitted_with(fitness: Fitness, weights: FitnessWeights | str) -> dict[str, Any]:
    """What a fit was made with: the loop's hunting, the fitness, the belief, what was held."""
    return {
        "hunting_rms": fitness.hunting_rms,
        "hunting": fitness.loop_hunts,
        "fitness_name": fitness_name(weights) if isinstance(weights, str) else "custom",
        "commissioned": fitness.model.belief.commissioned,
        "unseen": dict(fitness.unseen),
    }


def _nuisance_values(fitness: Fitness, x: np.ndarray) -> dict[str, float]:
    """The nuisances of a fitted row (empty without nuisance search) and the temperature."""
    if not fitness.nuisance:
        return {}
    _, nu = fitness.split(x[None])
    assert nu is not None  # a nuisance search has nuisances
    out = {n.name: float(v) for n, v in zip(fitness.nuisances, nu[0], strict=True)}
    t = fitness.model.temperature_c
    out["temperature_c"] = float("nan") if t is None else float(t)
    return out


def _uncertainty_fields(
    fitness: Fitness, x: np.ndarray, f: float, belief: MonitorBelief | None
) -> dict[str, Any]:
    """k_interval, identifiable and adequacy of a fitted row."""
    follows = fitness.follows  # a recorded-loop fit: its own interval scale and adequacy
    scale = uncertainty.FOLLOWED_SCALE if follows else uncertainty.DEFAULT_SCALE
    # an uncommissioned belief: the unit is any one made to the description
    spread = () if fitness.model.belief.commissioned else unit_spread.FACTORS
    unc = uncertainty.estimate(fitness, x, scale=scale, spread=spread)
    k_interval = unc.interval[:N_K].copy()
    flags = identifiability.flags(x[:N_K], k_interval, unc.jacobian_norms[:N_K], fitness.unseen)
    k_interval = identifiability.phase_interval(k_interval)
    return {
        "k_interval": k_interval,
        "k_std": unc.std[:N_K].copy(),
        "identifiable": flags,
        "adequacy": adequacy_mod.judge(
            fitness.adequacy_fitness(x) if fitness.hunting else f,
            belief=belief or fitness.model.belief,
            noise_fitness=fitness.noise_fitness,
            followed=follows,
            fed_noise_fitness=fitness.fed_noise_fitness(x),
        ),
    }


def _start_from_healthy(algorithm: Any, fitness: Fitness, seed: int) -> None:
    """Put the healthy row in a differential evolution's first population (the rest uniform).

    The healthy state is the likeliest single point; with a small budget a search that
    never visits it can stop in a far basin (measured: a healthy window fitted at
    statistic 122 with 500 evaluations, 1.2 with its healthy row in the population).
    """
    if not isinstance(algorithm, DE):
        return
    pop = int(algorithm.pop_size)
    rows = np.random.default_rng(seed).random((pop, fitness.dim))
    rows[0] = fitness.healthy_row
    algorithm.initialization.sampling = rows


#: Evaluations of the local stage when tracking from a previous fit (`isolate(start=...)`).
#: 800 until issue 19.  With the recorded-loop fitness, one friction, backlash and short-circuit
#: step each (docs/recorded_loop.md, %err at 200 / 400 / 800 evaluations): friction 3.4 / 5.0
#: / 4.3, backlash 4.8 / 3.6 / 3.0, short circuit 1.5 / 1.5 / 1.4, in 0.50-0.71 (200) and
#: 0.71-0.77 (400) of the time of 800.  300 lies between the two measured.  On the benchmarks
#: it halved a tracked fit's evaluations (bench_prognostics: 508 median against 918) but not
#: its wall time (0.66 s against 0.60 s): the polish and fixed costs dominate
#: (docs/recorded_loop.md).  "thesis" was not re-measured.
TRACK_EVALUATIONS = 300


#: Sizes of a search row: k alone, or k with either set of nuisances (`nuisance.searched`).
_ROW_SIZES = frozenset(
    N_K + len(s) for s in ((), nuisance_mod.NUISANCES, nuisance_mod.MEASURED_LOAD_NUISANCES)
)


def _start_row(start: np.ndarray, fitness: Fitness) -> np.ndarray:
    """A start as a search row of `fitness`: k, then its nuisances.

    A row of another size in `_ROW_SIZES` keeps its k and starts the nuisances at none: a
    bare k, or a row of a window whose load channel was measured where this one's is not
    (or the other way round: `nuisance.searched`), so its nuisances mean something else.
    """
    x = np.asarray(start, dtype=np.float64).ravel()
    dim = fitness.dim
    if x.size != dim and x.size in _ROW_SIZES:
        x = np.concatenate([x[:N_K], fitness.healthy_row[N_K:]])
    if x.size != dim or not np.all(np.isfinite(x)):
        raise EmaPhmError(f"start must be {dim} finite values (k, then nuisances), got {x.size}")
    return np.clip(x, 0.0, 1.0)
