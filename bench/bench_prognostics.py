#!/usr/bin/env python3
"""Prognostics benchmark (issue 11 item 5): run-to-failure trajectories of realistic units.

Usage (from the repo root):
    nohup .venv/bin/python bench/bench_prognostics.py --isolate > /tmp/bench_prog.log 2>&1 &
    .venv/bin/python bench/bench_prognostics.py --score      # prognoses + report, seconds
    .venv/bin/python bench/bench_prognostics.py --isolate --only 0,1 --max-cycles 8 \
        --out /tmp/smoke                                     # a quick look

Two phases.

``--isolate`` simulates and isolates every window of every trajectory and writes the raw
per-window rows to docs/bench_prognostics.json after each window (an interrupted run
resumes where it stopped: same --seed, same plan).  ``--score`` (the default when the JSON
exists and --isolate is not given) reads only those rows, prognoses every trajectory at
every counted window (see Scoring below) with the current
`ema_phm.prognostics.rul.prognose`, scores it with `ema_phm.monitor.replay.score` (the
metrics of `metrics.py`) against the true end of life, and writes
docs/benchmarks_prognostics.md.  Changing rul.py / trend.py and re-running ``--score``
re-scores the same isolations; the hand-written analysis below KEEP_MARKER in the report is
kept.  ``--jobs N`` isolates N trajectories at once (same rows; on 2 cores each fit then
takes about twice as long, so the per-window walls of the report are those of --jobs 1).

Plan (PER_TYPE trajectories per fault type, interleaved so that each type has as many
even- as odd-numbered trajectories; then HEALTHY healthy ones).  Trajectory t runs on its
own unit ``Unit.draw(seed + t)`` (default seed 100: units bench_robust.py, which chose the
interval scale and the adequacy threshold, never saw), commissioned like bench_robust.py
from 2 healthy hangar windows (`bench_robust.hangar`).  Degradation laws are drawn from
``numpy.random.default_rng((seed, t, 23))``: a target end of life T uniform in
LIFE_CYCLES, an onset uniform in ONSET_CYCLES, an initial value (INITIAL_LINEAR or
INITIAL_EXPONENTIAL) and the rate that brings the severity to the failure threshold
(health.DEFAULT_ERROR, 0.4) at T:

- friction, backlash: linear (wear);
- short_circuit_a: exponential (a coil-coil short propagates);
- eccentricity: exponential (bearing wear), the phase a step at cycle 0, uniform in [0, 1];
- multi_fault: friction (linear) and eccentricity (exponential), each with its own T.

The true end of life of a fault is `Degradation.first_cycle_at(name, 0.4)`; a trajectory
runs cycles 0 .. (last true end of life - 1), a healthy one HEALTHY_CYCLES cycles.  Each
cycle is one pre-flight test: a 2 s window (the default command) simulated by
`real_ema.simulate` with its own environment drawn from
``default_rng((seed, t, cycle, 7))``: temperature, unmeasured load and hinge spring in
bench_realistic's ranges, noise NOISE on every channel, noise seed 1000 t + cycle + 1.

Isolation as the live monitor does it (`HealthMonitor._isolate`): commissioned belief,
nuisances searched, 90 % intervals; a window is tracked (`isolate(start=row)`) from the
last window whose fit the model explained (adequacy ok) and searched globally otherwise;
a tracked fit that is not explained is done again globally on the same window
("restarted").  Isolation seed = the window's noise seed.

Scoring as the live monitor (`monitor.tracker`): a window whose fit the model explains
(adequacy ok) enters the history and is a prediction time (rul.prognose defaults, seed
SCORE_SEED); a window it does not explain adds nothing.  Controls in the report: the same
scoring on the true k (the isolation's own error removed), on every isolated window (as
`replay` does), and with other noise floors.

Headline targets (issue 11): alpha-lambda (alpha 0.2) met at every prediction from lambda
0.5 of life on in >= 80 % of trajectories; prognostic horizon (alpha 0.2) >= 50 % of the
true life on median; 90 % RUL interval coverage 80-97 %; no RUL alarm on healthy
trajectories.  Figures are given on all trajectories and separately
on the even-numbered (the RUL model is tuned on them) and odd-numbered (held out) ones.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_realistic import LOAD_NM, NOISE, SPRING_NM_PER_RAD, TEMPERATURE_C  # noqa: E402
from bench_robust import BASELINES, hangar, sim_kw  # noqa: E402

from ema_phm.diagnosis.health import DEFAULT_ERROR  # noqa: E402
from ema_phm.domain.faults import NAMES, NOMINAL  # noqa: E402
from ema_phm.monitor import replay as replay_mod  # noqa: E402
from ema_phm.physics.degradation import Degradation  # noqa: E402
from ema_phm.prognostics import metrics  # noqa: E402
from ema_phm.prognostics.rul import PREDICTED, History, prognose  # noqa: E402


def _tracker_alarm_windows() -> int:
    import inspect

    try:
        from ema_phm.monitor.tracker import PrognosticTracker
    except ImportError:
        return 1
    p = inspect.signature(PrognosticTracker.__init__).parameters.get("alarm_windows")
    return 1 if p is None or p.default is inspect.Parameter.empty else int(p.default)


#: Fault types, in the order trajectories cycle through them.
TYPES: tuple[str, ...] = ("friction", "backlash", "short_circuit_a", "eccentricity", "multi_fault")
#: The faults that grow in each type.
TYPE_FAULTS: dict[str, tuple[str, ...]] = {
    "friction": ("friction",),
    "backlash": ("backlash",),
    "short_circuit_a": ("short_circuit_a",),
    "eccentricity": ("eccentricity",),
    "multi_fault": ("friction", "eccentricity"),
    "healthy": (),
}
#: Growth law of each fault (degradation.py's reasons: wear linear, propagation exponential).
LAW: dict[str, str] = {
    "friction": "linear",
    "backlash": "linear",
    "short_circuit_a": "exponential",
    "eccentricity": "exponential",
}
PER_TYPE = 4
HEALTHY = 12
HEALTHY_CYCLES = 30
#: Target true end of life [cycle], uniform whole numbers (inclusive).
LIFE_CYCLES = (25, 45)
#: Onset cycle, uniform whole numbers (inclusive).
ONSET_CYCLES = (0, 10)
#: Severity at the onset: linear laws (uniform) and exponential laws (uniform, > 0).
INITIAL_LINEAR = (0.0, 0.02)
INITIAL_EXPONENTIAL = (0.02, 0.05)
#: Failure threshold of the severity (health.DEFAULT_ERROR of k1..k6).
THRESHOLD = float(DEFAULT_ERROR[0])
#: Seed of rul.prognose's posterior-predictive sampling.
SCORE_SEED = 0
#: RUL WARN: the RUL's 5th percentile below this many cycles (rul.prognose's horizon).
HORIZON_CYCLES = 10.0
#: True RULs this small [cycle] leave the +/-20 % alpha-lambda cone around one whole cycle
#: at most (4 +/- 0.8: only 4 itself), reported apart.
SMALL_RUL = 4
#: The monitor's WARN: the RUL p5 below the horizon in this many consecutive prognoses
#: (`monitor.tracker.PrognosticTracker`'s default, read from it; 1 when it has none).
ALARM_WINDOWS = _tracker_alarm_windows()
#: Issue 11 targets.
TARGET_AL_SHARE = 0.80
TARGET_PH_SHARE = 0.50
TARGET_COVERAGE = (0.80, 0.97)
#: Everything in the report below this line is hand-written and kept by --score.
KEEP_MARKER = "<!-- kept by --score: hand-written analysis below, dated by its commit -->"


# ----------------------------------------------------------------------------- plan


def _law(rng: np.random.Generator, name: str) -> tuple[dict, int]:
    """One fault's growth (as its YAML mapping) and the target end of life it was drawn for."""
    life = int(rng.integers(LIFE_CYCLES[0], LIFE_CYCLES[1] + 1))
    onset = int(rng.integers(ONSET_CYCLES[0], ONSET_CYCLES[1] + 1))
    span = life - onset
    if LAW[name] == "linear":
        initial = float(rng.uniform(*INITIAL_LINEAR))
        rate = (THRESHOLD - initial) / span
    else:
        initial = float(rng.uniform(*INITIAL_EXPONENTIAL))
        rate = math.log(THRESHOLD / initial) / span
    rate *= 1.0 + 1e-9  # reach the threshold at `life` itself, not one cycle later by rounding
    spec = {"law": LAW[name], "onset": onset, "initial": initial, "rate": rate, "cap": True}
    return spec, life


def plan(seed: int, per_type: int = PER_TYPE, healthy: int = HEALTHY) -> list[dict]:
    """Every trajectory: index, type, unit seed, degradation, true end of life, cycles."""
    out = []
    kinds = [TYPES[t % len(TYPES)] for t in range(per_type * len(TYPES))]
    kinds += ["healthy"] * healthy
    for t, kind in enumerate(kinds):
        rng = np.random.default_rng((seed, t, 23))
        faults: dict[str, dict] = {}
        targets: dict[str, int] = {}
        for name in TYPE_FAULTS[kind]:
            faults[name], targets[name] = _law(rng, name)
        if "eccentricity" in faults:
            faults["eccentricity_phase"] = {
                "law": "step",
                "onset": 0,
                "initial": float(rng.uniform(0.0, 1.0)),
                "cap": False,
            }
        deg = Degradation.from_mapping({"faults": faults}, source=f"trajectory {t}")
        eol = {name: deg.first_cycle_at(name, THRESHOLD) for name in TYPE_FAULTS[kind]}
        cycles = max(eol.values()) if eol else HEALTHY_CYCLES
        out.append(
            {
                "index": t,
                "type": kind,
                "unit_seed": seed + t,
                "degradation": deg.as_dict(),
                "target_life": targets,
                "true_eol": eol,
                "cycles": int(cycles),
            }
        )
    return out


def environment(seed: int, t: int, cycle: int) -> dict:
    """The cycle's temperature and unmeasured load (bench_realistic's ranges)."""
    rng = np.random.default_rng((seed, t, cycle, 7))
    return {
        "temperature_c": float(rng.uniform(*TEMPERATURE_C)),
        "load_nm": float(rng.uniform(*LOAD_NM)),
        "spring_nm_per_rad": float(rng.uniform(*SPRING_NM_PER_RAD)),
    }


def run_seed(t: int, cycle: int) -> int:
    """Noise seed of a window, also its isolation seed."""
    return 1000 * t + cycle + 1


# ----------------------------------------------------------------------------- isolate


def _vec(a: Any) -> list[float] | None:
    return None if a is None else [float(v) for v in np.asarray(a, dtype=np.float64).ravel()]


def commission_unit(unit_seed: int) -> tuple[Any, dict]:
    """The unit, its commissioned belief, and what to record about it."""
    from ema_phm.diagnosis.commissioning import commission
    from ema_phm.physics import real_ema
    from ema_phm.physics.commands import default_specs
    from ema_phm.physics.parameters import ActuatorParameters, MonitorBelief
    from ema_phm.physics.unit import Unit

    base = ActuatorParameters.default()
    command, _ = default_specs()
    unit = Unit.draw(unit_seed)
    envs = hangar(unit_seed)
    baselines = [
        real_ema.simulate(
            NOMINAL, seed=1000 * unit_seed + 900 + b, **sim_kw(unit, base, command, e)
        ).window
        for b, e in enumerate(envs)
    ]
    com = commission(baselines)
    belief = MonitorBelief.default().with_values(com.values)
    info = {
        "unit": unit.as_dict(),
        "hangar": envs,
        "factors": com.factors,
        "identifiable": com.identifiable,
        "commission_s": com.wall_s,
    }
    return (unit, base, command, belief), info


def isolate_window(
    window: Any, belief: Any, seed: int, start: np.ndarray | None
) -> tuple[Any, dict]:
    """The live monitor's isolation of one window (tracked, global, or tracked then global)."""
    from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate

    common = dict(belief=belief, preset=DEFAULT_PRESET, seed=seed, nuisance=True, intervals=True)
    res = isolate(window, start=start, **common)
    extra: dict[str, Any] = {"mode": "tracked" if start is not None else "global"}
    if start is not None and res.adequacy is not None and not res.adequacy.ok:
        extra.update(
            mode="restarted",
            tracked_attempt={
                "k": _vec(res.k),
                "adequacy_statistic": float(res.adequacy.statistic),
                "evaluations": int(res.evaluations),
                "wall_s": float(res.wall_s),
            },
        )
        res = isolate(window, **common)
    return res, extra


def run_trajectory(
    tr: dict,
    seed: int,
    done: list[dict],
    max_cycles: int | None,
    emit: Callable[[str, dict], None],
) -> None:
    """Simulate and isolate trajectory `tr` from the first cycle not in `done`; emit rows."""
    from ema_phm.errors import ExcitationError
    from ema_phm.physics import real_ema

    t = tr["index"]
    (unit, base, command, belief), info = commission_unit(tr["unit_seed"])
    emit("unit", {"index": t, **info})
    deg = Degradation.from_mapping(tr["degradation"], source=f"trajectory {t}")
    last = tr["cycles"] if max_cycles is None else min(tr["cycles"], max_cycles)
    have = {w["cycle"] for w in done}
    track_from = None
    if done:
        prev = max(done, key=lambda w: w["cycle"])
        if prev.get("adequacy_ok") and prev.get("row") is not None:
            track_from = np.array(prev["row"], dtype=np.float64)
    for cycle in range(last):
        if cycle in have:
            continue
        env = environment(seed, t, cycle)
        k_true = deg.k(cycle)
        rs = run_seed(t, cycle)
        t0 = time.perf_counter()
        window = real_ema.simulate(k_true, seed=rs, **sim_kw(unit, base, command, env)).window
        sim_s = time.perf_counter() - t0
        row: dict[str, Any] = {
            "trajectory": t,
            "cycle": cycle,
            "k_true": _vec(k_true),
            **env,
            "run_seed": rs,
            "sim_s": sim_s,
        }
        try:
            res, extra = isolate_window(window, belief, rs, track_from)
        except ExcitationError as exc:
            row["error"] = str(exc)
            track_from = None
            emit("window", row)
            continue
        ok = bool(res.adequacy is None or res.adequacy.ok)
        row.update(
            k=_vec(res.k),
            k_interval=[_vec(r) for r in res.k_interval],
            k_std=_vec(res.k_std),
            adequacy_statistic=float(res.adequacy.statistic),
            adequacy_ok=ok,
            nuisance={k: float(v) for k, v in res.nuisance.items()},
            fitness=float(res.fitness),
            evaluations=int(res.evaluations),
            wall_s=float(res.wall_s),
            **extra,
            window_wall_s=float(res.wall_s + extra.get("tracked_attempt", {}).get("wall_s", 0.0)),
            row=_vec(res.row),
        )
        track_from = res.row if ok else None
        emit("window", row)


def _worker(args: tuple) -> int:
    tr, seed, done, max_cycles, queue = args
    run_trajectory(tr, seed, done, max_cycles, lambda kind, row: queue.put((kind, row)))
    queue.put(("end", {"index": tr["index"]}))
    return tr["index"]


def _warm_up() -> None:
    from ema_phm.diagnosis.isolation import isolate
    from ema_phm.physics import real_ema

    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)


def _worker_init() -> None:
    _warm_up()


def run_isolation(args: argparse.Namespace, raw: Path, cmdline: str) -> None:
    from ema_phm.tools.benchmark import machine

    trs = plan(args.seed, args.per_type, args.healthy)
    only = _only(args.only, len(trs))
    data: dict[str, Any] = {}
    if raw.exists():
        old = json.loads(raw.read_text())
        planned = json.loads(json.dumps(trs))
        stored = old.get("plan") or []
        # the same plan, or one extended by more trajectories (--per-type / --healthy are
        # drawn in order, so a larger count keeps every earlier trajectory as it was)
        if old.get("seed") == args.seed and stored == planned[: len(stored)]:
            data = old
            data["plan"] = planned
            print(f"resuming: {len(old['windows'])} windows in {raw}", flush=True)
        else:
            raise SystemExit(f"{raw} holds another plan (seed or counts); move it away first")
    if not data:
        data = {
            "machine": machine(),
            "command": cmdline,
            "seed": args.seed,
            "settings": settings(),
            "plan": trs,
            "units": {},
            "windows": [],
            "isolate_s": 0.0,
        }
    data["machine"] = machine()
    data["command"] = cmdline
    data["jobs"] = args.jobs
    t_start = time.perf_counter()
    spent_before = float(data.get("isolate_s", 0.0))

    def emit(kind: str, row: dict) -> None:
        if kind == "unit":
            data["units"][str(row["index"])] = row
            return
        if kind != "window":
            return
        data["windows"].append(row)
        data["isolate_s"] = spent_before + time.perf_counter() - t_start
        tmp = raw.with_suffix(".json.tmp")
        tmp.write_text(dump(data))
        tmp.replace(raw)
        mode = row.get("mode", "error")
        print(
            f"traj {row['trajectory']:2d} cycle {row['cycle']:2d} {mode:9s} "
            f"wall {row.get('window_wall_s', float('nan')):5.2f}s "
            f"adequacy {row.get('adequacy_statistic', float('nan')):6.2f} "
            f"k {_fmt_k(row.get('k'))} true {_fmt_k(row['k_true'])}",
            flush=True,
        )

    jobs = []
    for tr in trs:
        if tr["index"] not in only:
            continue
        done = [w for w in data["windows"] if w["trajectory"] == tr["index"]]
        need = tr["cycles"] if args.max_cycles is None else min(tr["cycles"], args.max_cycles)
        if len(done) >= need:
            continue
        jobs.append((tr, args.seed, done, args.max_cycles))
    if not jobs:
        print(f"nothing to isolate: every planned window is in {raw}")
        return
    if args.jobs <= 1:
        _warm_up()
        for tr, seed, done, mc in jobs:
            run_trajectory(tr, seed, done, mc, emit)
    else:
        ctx = mp.get_context("spawn")
        with ctx.Manager() as manager:
            queue = manager.Queue()
            with ctx.Pool(args.jobs, initializer=_worker_init) as pool:
                result = pool.map_async(_worker, [(*j, queue) for j in jobs], chunksize=1)
                ended = 0
                while ended < len(jobs):
                    kind, row = queue.get()
                    if kind == "end":
                        ended += 1
                    else:
                        emit(kind, row)
                result.get()
    data["isolate_s"] = spent_before + time.perf_counter() - t_start
    raw.write_text(dump(data))
    print(f"isolation done: {len(data['windows'])} windows, {data['isolate_s'] / 60:.1f} min")


def dump(data: dict) -> str:
    """The raw JSON: indented, but one line per window (1.2 MB instead of 1.6)."""
    head = json.dumps({**data, "windows": []}, indent=1)
    rows = ",\n".join(json.dumps(w) for w in data["windows"])
    return head.replace('"windows": []', '"windows": [\n' + rows + "\n ]", 1)


def _fmt_k(k: list[float] | None) -> str:
    if k is None:
        return "-"
    return "[" + " ".join(f"{v:.3f}" for v in k[:6]) + "]"


def _only(spec: str | None, n: int) -> set[int]:
    if not spec:
        return set(range(n))
    return {int(s) for s in spec.split(",") if s.strip()}


def settings() -> dict:
    """The plan's constants, recorded with the rows."""
    return {
        "per_type_default": PER_TYPE,
        "healthy_default": HEALTHY,
        "healthy_cycles": HEALTHY_CYCLES,
        "life_cycles": LIFE_CYCLES,
        "onset_cycles": ONSET_CYCLES,
        "initial_linear": INITIAL_LINEAR,
        "initial_exponential": INITIAL_EXPONENTIAL,
        "threshold": THRESHOLD,
        "noise": NOISE,
        "temperature_c": TEMPERATURE_C,
        "load_nm": LOAD_NM,
        "spring_nm_per_rad": SPRING_NM_PER_RAD,
        "baselines": BASELINES,
        "law": LAW,
    }


# ----------------------------------------------------------------------------- score


def counts(w: dict, every_window: bool = False) -> bool:
    """Whether a window enters the prognostic history.

    As the live monitor (`monitor.tracker`): an isolated window whose fit the model
    explains (adequacy ok); with `every_window` every isolated window (as `replay` and
    `ema-phm prognose` do).
    """
    return "k" in w and (every_window or bool(w.get("adequacy_ok", True)))


def history_of(
    windows: list[dict], *, oracle: bool = False, every_window: bool = False
) -> tuple[History, list[dict]]:
    """The History of a trajectory's counted windows (`counts`, in cycle order), those windows.

    Intervals as replay.replay builds them: the isolation's 90 % k_interval, widened to
    hold k when k lies outside it.  With `oracle` the estimates are the true k and each
    interval the isolation's, moved to sit around the truth as it sat around the estimate
    (clipped to [0, 1]): the RUL model's own error, without the isolation's.
    """
    ws = sorted((w for w in windows if counts(w, every_window)), key=lambda w: w["cycle"])
    k = np.array([w["k"] for w in ws], dtype=np.float64).reshape(-1, 8)
    iv = np.array([w["k_interval"] for w in ws], dtype=np.float64).reshape(-1, 8, 2)
    lo, hi = np.minimum(iv[..., 0], k), np.maximum(iv[..., 1], k)
    if oracle:
        kt = np.array([w["k_true"] for w in ws], dtype=np.float64).reshape(-1, 8)
        lo, hi = np.clip(kt - (k - lo), 0.0, 1.0), np.clip(kt + (hi - k), 0.0, 1.0)
        k = kt
    return History.from_estimates([w["cycle"] for w in ws], k, lo, hi), ws


def score_trajectory(
    tr: dict,
    windows: list[dict],
    *,
    prognose_kw: dict | None = None,
    oracle: bool = False,
    every_window: bool = False,
) -> dict[str, Any]:
    """Prognoses at every window of one trajectory and their scores.

    Returns per fault with a true end of life `replay.score`'s metrics plus the first
    cycle with a RUL, and for every predicted fault the windows at which it was
    ``degrading`` and at which the RUL 5th percentile was below HORIZON_CYCLES ("WARN").
    `prognose_kw` goes to rul.prognose (default: its defaults, seed SCORE_SEED); `oracle`
    prognoses from the true k instead of the estimates (`history_of`).  A prediction is
    made at each counted window (`counts`): a window the model does not explain adds no
    estimate and makes no new prediction, as in the live monitor.
    """
    kw = {"seed": SCORE_SEED, "horizon_cycles": HORIZON_CYCLES, **(prognose_kw or {})}
    out: dict[str, Any] = {"index": tr["index"], "type": tr["type"], "faults": {}, "alarms": {}}
    if not any(counts(w, every_window) for w in windows):
        return out
    hist, ws = history_of(windows, oracle=oracle, every_window=every_window)
    replayed = []
    for n, w in enumerate(ws, start=1):
        prog = prognose(hist.upto(n), **kw)
        replayed.append(
            replay_mod.ReplayedWindow(
                cycle=int(w["cycle"]),
                k=hist.k[n - 1],
                k_low=hist.k_low[n - 1],
                k_high=hist.k_high[n - 1],
                interval_source="isolate",
                k_true=np.array(w["k_true"]),
                prognosis=prog,
            )
        )
    for i in PREDICTED:
        name = NAMES[i]
        deg, below, warn, streak = [], [], [], 0
        for r in replayed:
            f = r.prognosis.fault(name)
            low = f.status == "degrading" and f.rul_cycles.p5 < HORIZON_CYCLES
            streak = streak + 1 if low else 0
            if f.status == "degrading":
                deg.append(r.cycle)
            if low:
                below.append(r.cycle)
            if streak >= ALARM_WINDOWS:
                warn.append(r.cycle)
        # degrading: a RUL given; below: its p5 under the horizon at that prognosis; warn:
        # the monitor's WARN (below in ALARM_WINDOWS consecutive prognoses, as the tracker)
        out["alarms"][name] = {"degrading": deg, "below": below, "warn": warn}
    eol = {name: c for name, c in tr["true_eol"].items() if c is not None}
    scores = replay_mod.score(replayed, eol)
    t_first = float(replayed[0].cycle)
    for name, s in scores.items():
        t_eol = eol[name]
        t_lam = t_first + replay_mod.LAMBDA * (t_eol - t_first)
        rul, al_met, al_n, al_checks = [], 0, 0, []
        for r in replayed:
            if r.cycle >= t_eol:
                continue
            f = r.prognosis.fault(name)
            r_true = t_eol - r.cycle
            degrading = f.status == "degrading" and f.samples is not None
            if degrading:
                rul.append((r.cycle, f.rul_cycles.p5, f.rul_cycles.p50, f.rul_cycles.p95))
            if r.cycle >= t_lam:  # the alpha-lambda check of metrics.alpha_lambda_from
                al_n += 1
                a = replay_mod.ALPHA
                ok = bool(
                    degrading
                    and metrics.mass_within(f.samples, (1 - a) * r_true, (1 + a) * r_true) >= 0.5
                )
                al_met += ok
                # (true RUL, median RUL or inf without a RUL, met)
                al_checks.append((r_true, f.rul_cycles.p50 if degrading else math.inf, ok))
        s = dict(s)
        s["rul"] = rul  # (cycle, p5, p50, p95) where degrading, before the end of life
        s["first_rul_cycle"] = rul[0][0] if rul else None
        s["first_warn_cycle"] = next((c for c in out["alarms"][name]["warn"] if c < t_eol), None)
        s["al_windows"] = (al_met, al_n)  # windows from t_lambda meeting alpha-lambda, all
        s["al_checks"] = al_checks
        out["faults"][name] = s
    return out


def score_all(
    data: dict, prognose_kw: dict | None = None, oracle: bool = False, every_window: bool = False
) -> list[dict]:
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        by_t.setdefault(w["trajectory"], []).append(w)
    return [
        score_trajectory(
            tr,
            by_t.get(tr["index"], []),
            prognose_kw=prognose_kw,
            oracle=oracle,
            every_window=every_window,
        )
        for tr in data["plan"]
        if tr["index"] in by_t
    ]


def _median(v: list[float]) -> float:
    return float(statistics.median(v)) if v else math.nan


def _pct(v: list[float], q: float) -> float:
    return float(np.percentile(v, q)) if v else math.nan


def headline(scored: list[dict], plan_by_t: dict[int, dict]) -> dict[str, Any]:
    """The four target figures over `scored` trajectories."""
    fault_scores = [
        (s["index"], name, f)
        for s in scored
        if s["type"] != "healthy"
        for name, f in s["faults"].items()
    ]
    traj = [s for s in scored if s["type"] != "healthy" and s["faults"]]
    al_traj = [
        all(f.get("alpha_lambda_from_lambda") is True for f in s["faults"].values()) for s in traj
    ]
    al_fault = [f.get("alpha_lambda_from_lambda") is True for _, _, f in fault_scores]
    al_at = [f.get("alpha_lambda") is True for _, _, f in fault_scores]
    ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for _, _, f in fault_scores]
    n_cov = sum(f.get("windows_with_rul", 0) for _, _, f in fault_scores)
    hit = sum(
        f["interval_coverage_90"] * f["windows_with_rul"]
        for _, _, f in fault_scores
        if f.get("windows_with_rul")
    )
    al_w_met = sum(f["al_windows"][0] for _, _, f in fault_scores)
    al_w_n = sum(f["al_windows"][1] for _, _, f in fault_scores)
    missed = [(r, p) for _, _, f in fault_scores for r, p, ok in f["al_checks"] if not ok]
    healthy = [s for s in scored if s["type"] == "healthy"]
    h_deg = [s for s in healthy if any(a["degrading"] for a in s["alarms"].values())]
    h_warn = [s for s in healthy if any(a["warn"] for a in s["alarms"].values())]
    h_below = [s for s in healthy if any(a["below"] for a in s["alarms"].values())]
    # faults that do not grow in a degrading trajectory: a RUL there is spurious
    spurious_deg, spurious_warn, spurious_below, others = 0, 0, 0, 0
    for s in traj:
        for name, a in s["alarms"].items():
            if name in s["faults"]:
                continue
            others += 1
            spurious_deg += bool(a["degrading"])
            spurious_warn += bool(a["warn"])
            spurious_below += bool(a["below"])
    return {
        "trajectories": len(traj),
        "fault_histories": len(fault_scores),
        "al_traj_met": sum(al_traj),
        "al_fault_met": sum(al_fault),
        "al_at_lambda_met": sum(al_at),
        "ph_share_median": _median(ph),
        "ph_share_min": min(ph) if ph else math.nan,
        "al_windows_met": al_w_met,
        "al_windows": al_w_n,
        "al_missed_small": sum(1 for r, _ in missed if r <= SMALL_RUL),
        "al_missed_none": sum(1 for _, p in missed if math.isinf(p)),
        "al_missed_long": sum(1 for r, p in missed if math.isfinite(p) and p > 1.2 * r),
        "al_missed_short": sum(1 for r, p in missed if p < 0.8 * r),
        "al_missed_wide": sum(1 for r, p in missed if 0.8 * r <= p <= 1.2 * r),
        "coverage": hit / n_cov if n_cov else math.nan,
        "coverage_windows": n_cov,
        "healthy": len(healthy),
        "healthy_degrading": len(h_deg),
        "healthy_warn": len(h_warn),
        "healthy_below": len(h_below),
        "others": others,
        "spurious_degrading": spurious_deg,
        "spurious_warn": spurious_warn,
        "spurious_below": spurious_below,
    }


def _rate(n: int, d: int) -> str:
    return f"{n}/{d} ({100.0 * n / d:.0f} %)" if d else "-"


def _f(v: float, fmt: str = ".2f") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)


def _severity_errors(windows: list[dict], tr: dict, name: str) -> dict[str, list[float]]:
    """Estimate - truth of a fault's severity, interval half-width, covered, per life half."""
    i = NAMES.index(name)
    eol = tr["true_eol"][name]
    out: dict[str, list[float]] = {
        "err_early": [],
        "err_late": [],
        "half": [],
        "covered": [],
        "true_early": [],
    }
    for w in windows:
        if not counts(w) or w["cycle"] >= eol:
            continue
        e = abs(w["k"][i] - NOMINAL[i]) - abs(w["k_true"][i] - NOMINAL[i])
        late = w["cycle"] >= 0.5 * eol
        out["err_late" if late else "err_early"].append(e)
        lo, hi = w["k_interval"][i]
        lo, hi = min(lo, w["k"][i]), max(hi, w["k"][i])
        out["half"].append((hi - lo) / 2)
        out["covered"].append(float(lo - 1e-12 <= w["k_true"][i] <= hi + 1e-12))
    return out


def _rul_errors(f: dict, eol: int) -> dict[str, list[float]]:
    """RUL errors of one fault history.

    From lambda 0.5 on: relative error of the median and the 5-95 % width over the true RUL;
    over every window with a RUL: misses of the 90 % interval (too long, too short).
    """
    out: dict[str, list[float]] = {"rel": [], "width": [], "long": [], "short": [], "all": []}
    for c, p5, p50, p95 in f["rul"]:
        r = eol - c
        if c >= 0.5 * eol:
            out["rel"].append((p50 - r) / r)
            out["width"].append((p95 - p5) / r)
        out["all"].append(1.0)
        out["long"].append(float(p5 > r))
        out["short"].append(float(p95 < r))
    return out


def report(data: dict, scored: list[dict], extra: dict[str, Any]) -> str:
    trs = {tr["index"]: tr for tr in data["plan"]}
    windows = data["windows"]
    by_t: dict[int, list[dict]] = {}
    for w in windows:
        by_t.setdefault(w["trajectory"], []).append(w)
    mach = data["machine"]
    n_deg = sum(1 for s in scored if s["type"] != "healthy")
    n_h = sum(1 for s in scored if s["type"] == "healthy")
    iso = [w for w in windows if "k" in w]
    walls = [w["window_wall_s"] for w in iso]
    modes = {m: sum(1 for w in iso if w["mode"] == m) for m in ("tracked", "global", "restarted")}
    first_windows = sum(1 for w in iso if w["cycle"] == 0)
    errors = [w for w in windows if "error" in w]
    lines = [
        "# Prognostics benchmark: run-to-failure trajectories of realistic units",
        "",
        f"{n_deg} degrading trajectories ({', '.join(f'{_count(scored, t)} {t}' for t in TYPES)}) "
        f"and {n_h} healthy ones, each on its own manufactured unit (`Unit.draw(s)`, s = "
        f"{_cycles(sorted(trs[s['index']]['unit_seed'] for s in scored))}), commissioned from "
        f"{BASELINES} healthy hangar windows as in bench_robust.py.  One window (2 s, the default "
        "command) per cycle, a pre-flight test: every cycle draws its own temperature "
        f"({TEMPERATURE_C[0]:g}..{TEMPERATURE_C[1]:+g} degC), unmeasured load "
        f"({LOAD_NM[0]:g}..{LOAD_NM[1]:+g} N*m) and hinge spring ({SPRING_NM_PER_RAD[0]:g}.."
        f"{SPRING_NM_PER_RAD[1]:g} N*m/rad); noise on every channel (bench_realistic.NOISE).  "
        "Degradation laws per trajectory (seeded): friction and backlash linear, short circuit "
        "(phase A) and eccentricity exponential, multi-fault = friction linear + eccentricity "
        f"exponential; onset {ONSET_CYCLES[0]}..{ONSET_CYCLES[1]}, target end of life "
        f"{LIFE_CYCLES[0]}..{LIFE_CYCLES[1]} cycles at severity {THRESHOLD:g} "
        "(`health.DEFAULT_ERROR`).  A trajectory runs up to the cycle before its (last) true "
        f"end of life; healthy ones {HEALTHY_CYCLES} cycles.  Isolation as the live monitor: "
        "commissioned belief, nuisances, 90 % intervals, tracked from the last explained fit, "
        "global otherwise, a tracked fit not explained redone globally.  Prognostics as the "
        "live monitor (`monitor.tracker`): a window whose fit the model explains "
        "(adequacy ok) enters the history and makes a prediction (`rul.prognose` defaults, "
        f"seed {SCORE_SEED}); one it does not explain adds nothing.  Scored by "
        "`replay.score` (alpha 0.2, lambda counted from the first window, cycle 0, so lambda "
        "is a fraction of the true life).",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores ({mach['numba_threads']} numba "
        f"threads), Python {mach['python']}, numba {mach['numba']}, shared with another "
        f"session running tests.  Isolation: `{data['command']}` "
        f"({data.get('isolate_s', math.nan) / 60:.0f} min wall for {len(windows)} windows); "
        f"scoring: `.venv/bin/python bench/bench_prognostics.py --score` "
        f"({extra['score_s']:.0f} s) with the RUL model (rul.py, trend.py) of "
        f"{extra.get('rul_version', 'an unknown commit')}.  Raw rows: "
        "docs/bench_prognostics.json.",
        "",
        "## Targets (issue 11)",
        "",
        "| target | all | even (tuned on) | odd (held out) | met? (all) | gap |",
        "|---|---:|---:|---:|---|---|",
    ]
    pops = {
        "all": scored,
        "even": [s for s in scored if s["index"] % 2 == 0],
        "odd": [s for s in scored if s["index"] % 2 == 1],
    }
    hs = {k: headline(v, trs) for k, v in pops.items()}
    a = hs["all"]
    al_share = a["al_traj_met"] / a["trajectories"] if a["trajectories"] else math.nan
    cov = a["coverage"]
    lines += [
        "| alpha-lambda (alpha 0.2) met at every window from lambda 0.5, share of trajectories "
        ">= 80 % | "
        + " | ".join(_rate(hs[k]["al_traj_met"], hs[k]["trajectories"]) for k in pops)
        + f" | {_yes(al_share, al_share >= TARGET_AL_SHARE)} | "
        + (
            "-"
            if math.isnan(al_share) or al_share >= TARGET_AL_SHARE
            else f"{100 * (TARGET_AL_SHARE - al_share):.0f} points short"
        )
        + " |",
        "| prognostic horizon (alpha 0.2) / true life, median >= 50 % | "
        + " | ".join(f"{100 * hs[k]['ph_share_median']:.0f} %" for k in pops)
        + f" | {_yes(a['ph_share_median'], a['ph_share_median'] >= TARGET_PH_SHARE)} | "
        + (
            "-"
            if math.isnan(a["ph_share_median"]) or a["ph_share_median"] >= TARGET_PH_SHARE
            else f"{100 * (TARGET_PH_SHARE - a['ph_share_median']):.0f} points short"
        )
        + " |",
        "| 90 % RUL interval coverage 80-97 % (windows with a RUL, before the end of life) | "
        + " | ".join(
            f"{100 * hs[k]['coverage']:.0f} % ({hs[k]['coverage_windows']})" for k in pops
        )
        + f" | {_yes(cov, TARGET_COVERAGE[0] <= cov <= TARGET_COVERAGE[1])} | "
        + (
            "-"
            if math.isnan(cov) or TARGET_COVERAGE[0] <= cov <= TARGET_COVERAGE[1]
            else (
                f"{100 * (TARGET_COVERAGE[0] - cov):.0f} points under 80 %"
                if cov < TARGET_COVERAGE[0]
                else f"{100 * (cov - TARGET_COVERAGE[1]):.0f} points over 97 %"
            )
        )
        + " |",
        "| no RUL alarm on healthy trajectories (the monitor's RUL WARN: 5th percentile < "
        f"{HORIZON_CYCLES:g} cycles in {ALARM_WINDOWS} consecutive prognoses) | "
        + " | ".join(_rate(hs[k]["healthy_warn"], hs[k]["healthy"]) for k in pops)
        + f" | {_yes(a['healthy'] or math.nan, a['healthy_warn'] == 0)} | "
        + ("-" if a["healthy_warn"] == 0 else f"{a['healthy_warn']} healthy trajectories alarmed")
        + " |",
        "",
        "Also: alpha-lambda per fault history (a multi-fault trajectory holds two): "
        + ", ".join(f"{k} {_rate(hs[k]['al_fault_met'], hs[k]['fault_histories'])}" for k in pops)
        + "; alpha-lambda at the first window at or after lambda 0.5 only (`replay.score`'s "
        "`alpha_lambda`), per fault history: "
        + ", ".join(
            f"{k} {_rate(hs[k]['al_at_lambda_met'], hs[k]['fault_histories'])}" for k in pops
        )
        + "; prognostic horizon / life, worst: "
        + ", ".join(f"{k} {100 * hs[k]['ph_share_min']:.0f} %" for k in pops)
        + ".  Healthy trajectories with any fault `degrading` at any window: "
        + ", ".join(f"{k} {_rate(hs[k]['healthy_degrading'], hs[k]['healthy'])}" for k in pops)
        + "; with a RUL 5th percentile below the horizon at any single prognosis: "
        + ", ".join(f"{k} {_rate(hs[k]['healthy_below'], hs[k]['healthy'])}" for k in pops)
        + ".  Faults that do not grow in a degrading trajectory (5 per single-fault "
        "trajectory, 4 per multi-fault one) given a RUL at some window before the end: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_degrading'], hs[k]['others'])}" for k in pops)
        + "; with a RUL p5 below the horizon at a single prognosis: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_below'], hs[k]['others'])}" for k in pops)
        + "; with the monitor's RUL WARN: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_warn'], hs[k]['others'])}" for k in pops)
        + ".",
        "",
        "## Per fault type",
        "",
        "PH: prognostic horizon as a share of the true life.  alpha-lambda: met at every "
        "window from lambda 0.5.  RA: relative accuracy at lambda 0.5.  Coverage: the 90 % "
        "RUL interval holds the true RUL, over the windows with a RUL before the end of life.",
        "",
        "| fault type (fault) | histories | true life, median (min-max) | first RUL cycle, "
        "median (share of life) | true RUL at the first RUL WARN, median (min-max) | PH median | "
        "PH min | alpha-lambda from 0.5 | RA at 0.5, median (min) | coverage (windows) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for kind in TYPES:
        for name in TYPE_FAULTS[kind]:
            fs = [
                (s, s["faults"][name]) for s in scored if s["type"] == kind and name in s["faults"]
            ]
            if not fs:
                continue
            life = [f["true_eol_cycle"] for _, f in fs]
            first = [f["first_rul_cycle"] for _, f in fs if f["first_rul_cycle"] is not None]
            first_share = [
                f["first_rul_cycle"] / f["true_eol_cycle"]
                for _, f in fs
                if f["first_rul_cycle"] is not None
            ]
            ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for _, f in fs]
            al = sum(f.get("alpha_lambda_from_lambda") is True for _, f in fs)
            ra = [
                f["relative_accuracy_at_lambda"]
                for _, f in fs
                if f.get("relative_accuracy_at_lambda") is not None
            ]
            n = sum(f["windows_with_rul"] for _, f in fs)
            c = sum(
                f["interval_coverage_90"] * f["windows_with_rul"]
                for _, f in fs
                if f["windows_with_rul"]
            )
            warn = [
                f["true_eol_cycle"] - f["first_warn_cycle"]
                for _, f in fs
                if f["first_warn_cycle"] is not None
            ]
            warn_txt = (f"{_median(warn):.0f} ({min(warn)}-{max(warn)})" if warn else "-") + (
                f", {len(fs) - len(warn)} never" if len(warn) < len(fs) else ""
            )
            label = kind if kind == name else f"{kind} ({name})"
            never = len(fs) - len(first)
            lines.append(
                f"| {label} | {len(fs)} | {_median(life):.0f} ({min(life)}-{max(life)}) | "
                f"{_f(_median(first), '.0f')} ({_f(100 * _median(first_share), '.0f')} %)"
                + (f", {never} never" if never else "")
                + f" | {warn_txt} | {100 * _median(ph):.0f} % | {100 * min(ph):.0f} % | "
                f"{_rate(al, len(fs))} | "
                f"{_f(_median(ra))} ({_f(min(ra) if ra else math.nan)}) | "
                f"{_f(100 * c / n if n else math.nan, '.0f')} % ({n}) |"
            )
    lines += [
        "",
        "## Per trajectory",
        "",
        "| # | type | unit | fault | law | onset | true EoL | first RUL | PH cycles | "
        "alpha-lambda from 0.5 (windows met) | RA at 0.5 | coverage | final-window RUL 5/50/95 "
        "(true) |",
        "|---:|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for s in scored:
        tr = trs[s["index"]]
        for name, f in s["faults"].items():
            g = tr["degradation"]["faults"][name]
            eol = f["true_eol_cycle"]
            al_windows = f["al_windows"]
            last = f["rul"][-1] if f["rul"] else None
            first_rul = "-" if f["first_rul_cycle"] is None else str(f["first_rul_cycle"])
            last_txt = (
                f"{_f(last[1], '.0f')}/{_f(last[2], '.0f')}/{_f(last[3], '.0f')} ({eol - last[0]})"
                if last
                else "-"
            )
            lines.append(
                f"| {s['index']} | {s['type']} | {tr['unit_seed']} | {name} | {g['law']} "
                f"{g['rate']:.3g} | {g['onset']} | {eol} | {first_rul} | "
                f"{f['prognostic_horizon_cycles']:.0f} | "
                f"{_yes_none(f.get('alpha_lambda_from_lambda'))} "
                f"({al_windows[0]}/{al_windows[1]}) | "
                f"{_f(f.get('relative_accuracy_at_lambda'))} | "
                f"{_f(100 * f['interval_coverage_90'], '.0f') if f['windows_with_rul'] else '-'}"
                " % "
                f"| {last_txt} |"
            )
    lines += [
        "",
        "## Healthy trajectories",
        "",
        "| # | unit | windows counted (isolated) | faults ever `degrading` (cycles) | RUL p5 "
        "below the horizon (cycles) | RUL WARN (cycles) |",
        "|---:|---:|---:|---|---|---|",
    ]
    for s in scored:
        if s["type"] != "healthy":
            continue
        deg = [
            f"{n} ({_cycles(a['degrading'])})" for n, a in s["alarms"].items() if a["degrading"]
        ]
        below = [f"{n} ({_cycles(a['below'])})" for n, a in s["alarms"].items() if a["below"]]
        warn = [f"{n} ({_cycles(a['warn'])})" for n, a in s["alarms"].items() if a["warn"]]
        ww = by_t.get(s["index"], [])
        lines.append(
            f"| {s['index']} | {trs[s['index']]['unit_seed']} | "
            f"{sum(counts(w) for w in ww)} ({sum('k' in w for w in ww)}) | "
            f"{'; '.join(deg) or 'none'} | {'; '.join(below) or 'none'} | "
            f"{'; '.join(warn) or 'none'} |"
        )
    spur = []
    for s in scored:
        if s["type"] == "healthy":
            continue
        for n, a in s["alarms"].items():
            if n not in s["faults"] and a["degrading"]:
                spur.append(
                    f"| {s['index']} | {s['type']} | {n} | {_cycles(a['degrading'])} | "
                    f"{_cycles(a['below']) or 'none'} | {_cycles(a['warn']) or 'none'} |"
                )
    if spur:
        lines += [
            "",
            "Spurious RULs in degrading trajectories (a fault that does not grow, given a RUL):",
            "",
            "| # | type | fault | cycles `degrading` | RUL p5 below the horizon | RUL WARN |",
            "|---:|---|---|---|---|---|",
            *spur,
        ]
    lines += [
        "",
        "## Isolation per window",
        "",
        f"{len(iso)} windows isolated ({len(errors)} refused for excitation).  Wall per window "
        f"(a restarted window counts both fits): median {_median(walls):.2f} s, p90 "
        f"{_pct(walls, 90):.2f} s, worst {max(walls) if walls else math.nan:.2f} s.  Tracked "
        f"from the previous fit: {_rate(modes['tracked'], len(iso))}; global search: "
        f"{_rate(modes['global'], len(iso))} (of which {first_windows} first windows); tracked "
        "then redone globally (tracked fit not explained): "
        f"{_rate(modes['restarted'], len(iso))}.",
        "",
        "| fault type | windows | tracked | global | restarted | not explained (final fit) | "
        "wall median (p90) s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for kind in (*TYPES, "healthy"):
        ww = [w for s in scored if s["type"] == kind for w in by_t.get(s["index"], []) if "k" in w]
        if not ww:
            continue
        wl = [w["window_wall_s"] for w in ww]
        lines.append(
            f"| {kind} | {len(ww)} | "
            + " | ".join(
                _rate(sum(w["mode"] == m for w in ww), len(ww))
                for m in ("tracked", "global", "restarted")
            )
            + f" | {_rate(sum(not w['adequacy_ok'] for w in ww), len(ww))} | "
            f"{_median(wl):.2f} ({_pct(wl, 90):.2f}) |"
        )
    sev_bins = (0.0, 0.1, 0.2, 0.3)
    lines += [
        "",
        "Windows the model does not explain (adequacy over its threshold: no estimate enters "
        "the history), by the true severity of the growing fault (multi-fault: the larger):",
        "",
        "| fault type | "
        + " | ".join(
            f"{lo:g}-{sev_bins[j + 1]:g}" if j + 1 < len(sev_bins) else f">= {lo:g}"
            for j, lo in enumerate(sev_bins)
        )
        + " |",
        "|---|" + "---:|" * len(sev_bins),
    ]
    for kind in TYPES:
        idx = [NAMES.index(n) for n in TYPE_FAULTS[kind]]
        ww = [w for s in scored if s["type"] == kind for w in by_t.get(s["index"], []) if "k" in w]
        cells = []
        for j, lo in enumerate(sev_bins):
            hi = sev_bins[j + 1] if j + 1 < len(sev_bins) else math.inf
            sel = [w for w in ww if lo <= max(abs(w["k_true"][i] - NOMINAL[i]) for i in idx) < hi]
            cells.append(_rate(sum(not w["adequacy_ok"] for w in sel), len(sel)))
        lines.append(f"| {kind} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "## Causes, measured",
        "",
        "Severity estimates of the growing fault against the truth, counted (explained) "
        "windows before the end of life, split at half of the true life; RUL errors from "
        "lambda 0.5 on (relative error of the median, (p50 - r*) / r*), and the 90 % RUL "
        "interval misses over the windows with a RUL: 'too long' = the 5th percentile above "
        "the true RUL, 'too short' = the 95th below it.",
        "",
        "| fault type (fault) | severity error, 1st half: median (p10, p90) | 2nd half: "
        "median (p10, p90) | k 90 % interval: median half-width, holds truth | RUL median "
        "rel. error from lambda 0.5: median (p10, p90) | RUL interval misses: too long / too "
        "short |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for kind in TYPES:
        for name in TYPE_FAULTS[kind]:
            acc: dict[str, list[float]] = {}
            racc: dict[str, list[float]] = {}
            for s in scored:
                if s["type"] != kind or name not in s["faults"]:
                    continue
                for key, v in _severity_errors(by_t[s["index"]], trs[s["index"]], name).items():
                    acc.setdefault(key, []).extend(v)
                for key, v in _rul_errors(
                    s["faults"][name], s["faults"][name]["true_eol_cycle"]
                ).items():
                    racc.setdefault(key, []).extend(v)
            if not acc:
                continue
            label = kind if kind == name else f"{kind} ({name})"
            e1, e2 = acc["err_early"], acc["err_late"]
            n_r = len(racc.get("all", []))
            rel = racc.get("rel", [])
            lines.append(
                f"| {label} | {_f(_median(e1), '+.3f')} ({_f(_pct(e1, 10), '+.3f')}, "
                f"{_f(_pct(e1, 90), '+.3f')}) | {_f(_median(e2), '+.3f')} "
                f"({_f(_pct(e2, 10), '+.3f')}, {_f(_pct(e2, 90), '+.3f')}) | "
                f"{_f(_median(acc['half']), '.3f')}, "
                f"{_f(100 * np.mean(acc['covered']), '.0f')} % | "
                f"{_f(_median(rel), '+.2f')} ({_f(_pct(rel, 10), '+.2f')}, "
                f"{_f(_pct(rel, 90), '+.2f')}) | "
                f"{_rate(int(sum(racc.get('long', []))), n_r)} / "
                f"{_rate(int(sum(racc.get('short', []))), n_r)} |"
            )
    a = hs["all"]
    lines += [
        "",
        "Windows from lambda 0.5 to the end of life (every fault history): "
        + ", ".join(f"{k} {_rate(hs[k]['al_windows_met'], hs[k]['al_windows'])}" for k in pops)
        + f" meet alpha-lambda.  The misses (all): {a['al_windows'] - a['al_windows_met']}: "
        f"{a['al_missed_none']} without a RUL, {a['al_missed_long']} with the median RUL above "
        f"the +/-20 % cone (too long), {a['al_missed_short']} below it (too short), "
        f"{a['al_missed_wide']} with the median inside but less than half the distribution "
        f"(too wide); {a['al_missed_small']} of the misses are at a true RUL of {SMALL_RUL} "
        "cycles or less, where the cone holds one whole cycle at most.",
    ]
    variants = extra.get("variants", [])
    if variants:
        lines += [
            "",
            "## Controls and sensitivity (same isolations, scored again)",
            "",
            "The oracle control prognoses from the true k with the isolation's intervals "
            "moved onto it (and, when `rul.prognose` has one, without the severity scale: the "
            "truth has no bias to correct): what the RUL model does with unbiased estimates; "
            "the gap to the headline is the isolation's share.  'law known' makes the prior "
            "of each fault's true growth-law family nearly certain (every trajectory of a "
            "fault grows by the same family here): an upper bound of what a law prior can "
            "give, not a fair setting.  The noise-floor rows re-score the estimates with "
            "another `rul.prognose(noise_floor=)`.",
            "",
            "| scoring | alpha-lambda (trajectories): all / even / odd | alpha-lambda windows "
            "from 0.5 (all) | PH median: all / even / odd | coverage: all / even / odd | healthy "
            "WARN | spurious RUL / p5 below / WARN on faults that do not grow |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for label, hh in [("isolation estimates, rul.prognose defaults (headline)", hs)] + [
            (lab, h) for lab, _short, h, _sc in variants
        ]:
            al = hh["all"]
            lines.append(
                f"| {label} | "
                + " / ".join(_rate(hh[k]["al_traj_met"], hh[k]["trajectories"]) for k in pops)
                + f" | {_rate(al['al_windows_met'], al['al_windows'])} | "
                + " / ".join(f"{_f(100 * hh[k]['ph_share_median'], '.0f')} %" for k in pops)
                + " | "
                + " / ".join(f"{_f(100 * hh[k]['coverage'], '.0f')} %" for k in pops)
                + f" | {_rate(al['healthy_warn'], al['healthy'])} | "
                f"{_rate(al['spurious_degrading'], al['others'])} / "
                f"{_rate(al['spurious_below'], al['others'])} / "
                f"{_rate(al['spurious_warn'], al['others'])} |"
            )
        compared = [(short, sc) for _lab, short, _h, sc in variants if short]
        if compared:
            names = " / ".join(["estimates"] + [short for short, _ in compared])
            lines += [
                "",
                f"Per fault type, {names} (PH: median share of life; alpha-lambda: windows "
                "from lambda 0.5 meeting it; coverage of the 90 % RUL interval; RUL median "
                "relative error and 5-95 % width / true RUL, medians from lambda 0.5):",
                "",
                "| fault type (fault) | PH | alpha-lambda windows | coverage | RUL median rel. "
                "error | RUL 5-95 % width / true RUL |",
                "|---|---:|---:|---:|---:|---:|",
            ]
            for kind in TYPES:
                for name in TYPE_FAULTS[kind]:
                    cells = [
                        _type_cells(sc, kind, name) for sc in [scored] + [c for _, c in compared]
                    ]
                    if cells[0] is None:
                        continue
                    label = kind if kind == name else f"{kind} ({name})"
                    cols = list(zip(*cells))
                    lines.append(
                        f"| {label} | " + " | ".join(" / ".join(col) for col in cols) + " |"
                    )
            lines += [
                "",
                "alpha-lambda windows (from lambda 0.5) met, by true RUL [cycles]:",
                "",
                "| scoring | " + " | ".join(_bin_names()) + " |",
                "|---|" + "---:|" * len(RUL_BINS),
                "| estimates | " + " | ".join(_al_by_bin(scored)) + " |",
            ]
            for short, sc in compared:
                lines.append(f"| {short} | " + " | ".join(_al_by_bin(sc)) + " |")
    return "\n".join(lines).rstrip() + "\n"


def _type_cells(scored: list[dict], kind: str, name: str) -> tuple[str, ...] | None:
    """PH, alpha-lambda windows, coverage, RUL error and width of one fault type, as text."""
    fs = [s["faults"][name] for s in scored if s["type"] == kind and name in s["faults"]]
    if not fs:
        return None
    ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for f in fs]
    met = sum(f["al_windows"][0] for f in fs)
    n_al = sum(f["al_windows"][1] for f in fs)
    n = sum(f["windows_with_rul"] for f in fs)
    c = sum(f["interval_coverage_90"] * f["windows_with_rul"] for f in fs if f["windows_with_rul"])
    errs = [_rul_errors(f, f["true_eol_cycle"]) for f in fs]
    rel = [v for e in errs for v in e["rel"]]
    width = [v for e in errs for v in e["width"]]
    return (
        f"{100 * _median(ph):.0f} %",
        f"{100 * met / n_al:.0f} %" if n_al else "-",
        f"{_f(100 * c / n if n else math.nan, '.0f')} %",
        _f(_median(rel), "+.2f"),
        _f(_median(width), ".2f"),
    )


#: True-RUL bins [cycle] of the alpha-lambda window table (lower bounds, inclusive).
RUL_BINS = (1, 5, 10, 15, 20)


def _al_by_bin(scored: list[dict]) -> list[str]:
    """Share of windows from lambda 0.5 meeting alpha-lambda, per true-RUL bin (RUL_BINS)."""
    checks = [c for s in scored for f in s["faults"].values() for c in f["al_checks"]]
    out = []
    for j, lo in enumerate(RUL_BINS):
        hi = RUL_BINS[j + 1] if j + 1 < len(RUL_BINS) else math.inf
        sel = [ok for r, _p, ok in checks if lo <= r < hi]
        out.append(_rate(sum(sel), len(sel)))
    return out


def _bin_names() -> list[str]:
    names = []
    for j, lo in enumerate(RUL_BINS):
        hi = RUL_BINS[j + 1] if j + 1 < len(RUL_BINS) else None
        names.append(f"{lo}-{hi - 1}" if hi is not None else f">= {lo}")
    return names


def _yes_none(v: bool | None) -> str:
    """alpha-lambda's verdict: yes / no / 'no prediction' (None: none from lambda on)."""
    return "no prediction" if v is None else ("yes" if v else "no")


def _yes(value: float, ok: bool) -> str:
    """'yes' / 'no', '-' when there is nothing to judge (NaN)."""
    return "-" if isinstance(value, float) and math.isnan(value) else ("yes" if ok else "no")


def _count(scored: list[dict], kind: str) -> int:
    return sum(1 for s in scored if s["type"] == kind)


def _cycles(cs: list[int]) -> str:
    """A list of cycles as ranges: 3-7, 9."""
    if not cs:
        return ""
    out, start, prev = [], cs[0], cs[0]
    for c in cs[1:] + [None]:
        if c is not None and c == prev + 1:
            prev = c
            continue
        out.append(f"{start}" if start == prev else f"{start}-{prev}")
        if c is not None:
            start = prev = c
    return ", ".join(out)


def _rul_version() -> str:
    """The last commit of rul.py / trend.py, and whether they differ from it."""
    import subprocess

    files = ["ema_phm/prognostics/rul.py", "ema_phm/prognostics/trend.py"]
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


def run_score(raw: Path, md: Path, sweep: list[float]) -> None:
    import inspect

    data = json.loads(raw.read_text())
    trs = {tr["index"]: tr for tr in data["plan"]}
    t0 = time.perf_counter()
    scored = score_all(data)
    score_s = time.perf_counter() - t0
    extra: dict[str, Any] = {"score_s": score_s, "variants": [], "rul_version": _rul_version()}

    def heads(sc: list[dict]) -> dict:
        return {
            "all": headline(sc, trs),
            "even": headline([s for s in sc if s["index"] % 2 == 0], trs),
            "odd": headline([s for s in sc if s["index"] % 2 == 1], trs),
        }

    params = inspect.signature(prognose).parameters
    # the truth has no bias to correct: the oracle projects to the threshold itself
    unbiased = (
        {"severity_scale": {NAMES[i]: (0.0, 0.0) for i in PREDICTED}}
        if "severity_scale" in params
        else {}
    )
    sc = score_all(data, unbiased, oracle=True)
    extra["variants"].append(
        (
            "oracle: true k, the isolation's intervals moved onto it"
            + (", no severity scale" if unbiased else ""),
            "oracle",
            heads(sc),
            sc,
        )
    )
    if "law_priors" in params:
        known = {
            name: {
                "none": 0.5,
                law: 0.499,
                ("exponential" if law == "linear" else "linear"): 0.001,
            }
            for name, law in LAW.items()
        }
        sc = score_all(data, {"law_priors": known})
        extra["variants"].append(
            (
                "estimates, growth law known (law_priors: the true family 0.499, the other 0.001)",
                "law known",
                heads(sc),
                sc,
            )
        )
    sc = score_all(data, every_window=True)
    extra["variants"].append(
        (
            "every isolated window counted, explained or not "
            "(as `ema-phm prognose --count-unexplained`)",
            "",
            heads(sc),
            sc,
        )
    )
    if sweep and "noise_floor" in params:
        for floor in sweep:
            sc = score_all(data, {"noise_floor": floor})
            extra["variants"].append((f"estimates, noise_floor {floor:g}", "", heads(sc), sc))
    text = report(data, scored, extra)
    if md.exists():  # the hand-written analysis below the marker survives a re-score
        old = md.read_text()
        if KEEP_MARKER in old:
            text += "\n" + KEEP_MARKER + old.split(KEEP_MARKER, 1)[1]
    md.write_text(text)
    print(f"scored {len(scored)} trajectories in {score_s:.1f} s; wrote {md}")


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--isolate", action="store_true", help="simulate and isolate (resumes)")
    ap.add_argument("--score", action="store_true", help="prognose and score the stored rows")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--per-type", type=int, default=PER_TYPE)
    ap.add_argument("--healthy", type=int, default=HEALTHY)
    ap.add_argument("--only", default=None, help="comma-separated trajectory indices")
    ap.add_argument("--max-cycles", type=int, default=None, help="cap per trajectory (smoke)")
    ap.add_argument("--jobs", type=int, default=1, help="processes over trajectories")
    ap.add_argument(
        "--sweep",
        default="0.02,0.03",
        help="noise floors to re-score with for the sensitivity table ('' for none)",
    )
    ap.add_argument("--out", default=str(ROOT / "docs"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    raw = out / "bench_prognostics.json"
    md = out / "benchmarks_prognostics.md"
    if args.isolate:
        cmdline = " ".join(
            [".venv/bin/python bench/bench_prognostics.py --isolate"]
            + ([f"--seed {args.seed}"] if args.seed != 100 else [])
            + ([f"--per-type {args.per_type}"] if args.per_type != PER_TYPE else [])
            + ([f"--healthy {args.healthy}"] if args.healthy != HEALTHY else [])
            + ([f"--only {args.only}"] if args.only else [])
            + ([f"--max-cycles {args.max_cycles}"] if args.max_cycles else [])
            + ([f"--jobs {args.jobs}"] if args.jobs != 1 else [])
        )
        run_isolation(args, raw, cmdline)
    if args.score or not args.isolate:
        if not raw.exists():
            raise SystemExit(f"{raw} does not exist: run --isolate first")
        sweep = [float(s) for s in args.sweep.split(",") if s.strip()]
        run_score(raw, md, sweep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
