"""The prognostics benchmark's --isolate phase: simulate and isolate every window, store rows.

Each window's row is appended to the raw JSON as soon as it is isolated, so an interrupted
run resumes where it stopped (same seed, same plan).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import machine, pool, write_rows
from bench.harness.scenarios import hangar, hangar_windows, sim_kw
from bench.prog.plan import environment, plan, run_seed, settings
from ema_phm.diagnosis.commissioning import commission
from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate
from ema_phm.domain.faults import NOMINAL, PREDICTED
from ema_phm.errors import ExcitationError
from ema_phm.model.belief import MonitorBelief
from ema_phm.monitor.estimator import IsolationEstimator
from ema_phm.monitor.policy import FitPolicy
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.degradation import Degradation
from ema_phm.simulator.unit import Unit

Emit = Callable[[str, dict], None]


def _vec(a: Any) -> list[float] | None:
    return None if a is None else [float(v) for v in np.asarray(a, dtype=np.float64).ravel()]


def commission_unit(unit_seed: int) -> tuple[Any, dict]:
    """The unit, its commissioned belief, and what to record about it."""
    base = ActuatorParameters.default()
    command, _ = default_specs()
    unit = Unit.draw(unit_seed)
    envs = hangar(unit_seed)
    com = commission(hangar_windows(unit_seed, unit, base, command))
    belief = MonitorBelief.default().commissioned_with(com.values)
    info = {
        "unit": unit.as_dict(),
        "hangar": envs,
        "factors": com.factors,
        "identifiable": com.identifiable,
        "commission_s": com.wall_s,
    }
    return (unit, base, command, belief), info


def tracked_fit_then_global_restart(
    window: Any, belief: Any, seed: int, policy: FitPolicy
) -> tuple[Any, dict]:
    """The live monitor's isolation of one window (`FitPolicy.fit`): tracked, global, or both.

    Tracked from the last explained fit the `policy` saw, global without one; a tracked fit
    the model does not explain is done again globally on the same window ("restarted").
    """
    common = dict(belief=belief, preset=DEFAULT_PRESET, seed=seed, nuisance=True, intervals=True)
    fit = policy.fit(window, IsolationEstimator(common, isolate))
    extra: dict[str, Any] = {"mode": fit.mode}
    if fit.tracked_attempt is not None:
        attempt = fit.tracked_attempt
        extra["tracked_attempt"] = {
            "k": _vec(attempt.k),
            "adequacy_statistic": float(attempt.adequacy.statistic),
            "evaluations": int(attempt.evaluations),
            "wall_s": float(attempt.wall_s),
        }
    return fit.result, extra


def isolated(row: dict, res: Any, extra: dict) -> bool:
    """Add an isolation's result to a window's row; whether the model explained the fit."""
    ok = bool(res.adequacy.ok)  # isolate(intervals=True) always tests adequacy
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
    return ok


def resume_from(done: list[dict]) -> np.ndarray | None:
    """The row to track from after the stored windows: the last one's, if explained."""
    if done:
        prev = max(done, key=lambda w: w["cycle"])
        if prev.get("adequacy_ok") and prev.get("row") is not None:
            return np.array(prev["row"], dtype=np.float64)
    return None


def run_trajectory(
    tr: dict, seed: int, done: list[dict], max_cycles: int | None, emit: Emit
) -> None:
    """Simulate and isolate trajectory `tr` from the first cycle not in `done`; emit rows."""
    t = tr["index"]
    (unit, base, command, belief), info = commission_unit(tr["unit_seed"])
    emit("unit", {"index": t, **info})
    deg = Degradation.from_mapping(tr["degradation"], source=f"trajectory {t}")
    last = tr["cycles"] if max_cycles is None else min(tr["cycles"], max_cycles)
    have = {w["cycle"] for w in done}
    policy = FitPolicy()
    policy.track_from(resume_from(done))
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
        fit_and_emit(row, window, belief, policy, emit)


def fit_and_emit(row: dict, window: Any, belief: Any, policy: FitPolicy, emit: Emit) -> None:
    """Isolate `window` as the live monitor does (seed: the row's run seed); emit its row.

    A window without excitation is emitted with its `error`.
    """
    try:
        res, extra = tracked_fit_then_global_restart(window, belief, row["run_seed"], policy)
    except ExcitationError as exc:
        row["error"] = str(exc)
    else:
        isolated(row, res, extra)
    emit("window", row)


#: What isolates one trajectory: (trajectory, seed, its stored windows, cycle cap, emit).
Runner = Callable[[dict, int, list[dict], "int | None", Emit], None]


def _worker(args: tuple) -> int:
    tr, seed, done, max_cycles, runner, queue = args
    runner(tr, seed, done, max_cycles, lambda kind, row: queue.put((kind, row)))
    queue.put(("end", {"index": tr["index"]}))
    return tr["index"]


def _warm_up() -> None:
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)


def _worker_init() -> None:
    _warm_up()


def _stored(args: argparse.Namespace, raw: Path, trs: list[dict], cmdline: str) -> dict:
    """The stored rows to resume (the same plan, or one extended), or a fresh record."""
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
            return data
        raise SystemExit(f"{raw} holds another plan (seed or counts); move it away first")
    return {
        "machine": machine(),
        "command": cmdline,
        "seed": args.seed,
        "settings": settings(),
        "plan": trs,
        "units": {},
        "windows": [],
        "isolate_s": 0.0,
    }


def emitter(data: dict, raw: Path, spent_before: float, t_start: float) -> Emit:
    """Store a unit's record, or store a window's row, rewrite the raw JSON and print it."""

    def emit(kind: str, row: dict) -> None:
        if kind == "unit":
            data["units"][str(row["index"])] = row
            return
        if kind != "window":
            return
        data["windows"].append(row)
        data["isolate_s"] = spent_before + time.perf_counter() - t_start
        write_rows(raw, data, text=dump(data))
        mode = row.get("mode", "error")
        print(
            f"traj {row['trajectory']:2d} cycle {row['cycle']:2d} {mode:9s} "
            f"wall {row.get('window_wall_s', float('nan')):5.2f}s "
            f"adequacy {row.get('adequacy_statistic', float('nan')):6.2f} "
            f"k {_fmt_k(row.get('k'))} true {_fmt_k(row['k_true'])}",
            flush=True,
        )

    return emit


def _todo(args: argparse.Namespace, trs: list[dict], data: dict) -> list[tuple]:
    """(trajectory, seed, its stored windows, cycle cap) of every trajectory left to isolate."""
    only = _only(args.only, len(trs))
    jobs = []
    for tr in trs:
        if tr["index"] not in only:
            continue
        done = [w for w in data["windows"] if w["trajectory"] == tr["index"]]
        need = tr["cycles"] if args.max_cycles is None else min(tr["cycles"], args.max_cycles)
        if len(done) >= need:
            continue
        jobs.append((tr, args.seed, done, args.max_cycles))
    return jobs


def run_jobs(jobs: list[tuple], n_jobs: int, emit: Emit, runner: Runner | None = None) -> None:
    """Isolate the trajectories in this process, or in `n_jobs` (rows through a queue).

    `jobs`: (trajectory, seed, its stored windows, cycle cap); `runner`: what isolates one
    (default `run_trajectory`, this benchmark's).
    """
    runner = run_trajectory if runner is None else runner
    if n_jobs <= 1:
        _warm_up()
        for tr, seed, done, mc in jobs:
            runner(tr, seed, done, mc, emit)
        return
    with mp.get_context("spawn").Manager() as manager:
        queue = manager.Queue()
        with pool(n_jobs, initializer=_worker_init, method="spawn") as workers:
            result = workers.map_async(_worker, [(*j, runner, queue) for j in jobs], chunksize=1)
            ended = 0
            while ended < len(jobs):
                kind, row = queue.get()
                if kind == "end":
                    ended += 1
                else:
                    emit(kind, row)
            result.get()


def run_isolation(args: argparse.Namespace, raw: Path, cmdline: str) -> None:
    """Isolate every planned window not yet in `raw`, storing each row as it comes."""
    trs = plan(args.seed, args.per_type, args.healthy, args.steady)
    data = _stored(args, raw, trs, cmdline)
    data["machine"] = machine()
    data["command"] = cmdline
    data["jobs"] = args.jobs
    t_start = time.perf_counter()
    spent_before = float(data.get("isolate_s", 0.0))
    jobs = _todo(args, trs, data)
    if not jobs:
        print(f"nothing to isolate: every planned window is in {raw}")
        return
    run_jobs(jobs, args.jobs, emitter(data, raw, spent_before, t_start))
    data["isolate_s"] = spent_before + time.perf_counter() - t_start
    raw.write_text(dump(data))
    print(f"isolation done: {len(data['windows'])} windows, {data['isolate_s'] / 60:.1f} min")


#: Significant digits a window's numbers are stored with (an estimate's own scatter is ~1e-2;
#: 17 digits made the 3001-window store 4.3 MB, over the repository's 3 MiB per file).
STORED_DIGITS = 6


def _rounded(x: Any) -> Any:
    if isinstance(x, float):
        return float(f"{x:.{STORED_DIGITS}g}")
    if isinstance(x, list):
        return [_rounded(v) for v in x]
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    return x


def dump(data: dict) -> str:
    """The raw JSON: indented, but one line per window, numbers to STORED_DIGITS digits."""
    head = json.dumps({**data, "windows": []}, indent=1)
    rows = ",\n".join(json.dumps(_rounded(w)) for w in data["windows"])
    return head.replace('"windows": []', '"windows": [\n' + rows + "\n ]", 1)


def _fmt_k(k: list[float] | None) -> str:
    if k is None:
        return "-"
    return "[" + " ".join(f"{k[i]:.3f}" for i in PREDICTED) + "]"


def _only(spec: str | None, n: int) -> set[int]:
    if not spec:
        return set(range(n))
    return {int(s) for s in spec.split(",") if s.strip()}
