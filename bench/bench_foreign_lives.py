#!/usr/bin/env python3
"""Foreign lives: remaining life on faults and units the prognostics benchmark never drew.

Usage (from the repo root):
    nice -n 10 .venv/bin/python -m bench.bench_foreign_lives --isolate --jobs 2  # ~40 min
    .venv/bin/python -m bench.bench_foreign_lives --score --jobs 2   # the report, minutes
    .venv/bin/python -m bench.bench_foreign_lives --isolate --only 6,24 --max-cycles 3 \
        --out DIR                                                     # a quick look

The plan (`prog.foreign_lives`): every fault with a remaining life grows by each law (a
friction exponentially, a short circuit linearly as often as the other way), its rate on a
random walk and, on every other life, changed once in mid-life; true lives of 15-80 cycles;
each trajectory on its own foreign unit (`harness.foreign`: corner, wide and inside units,
commissioned as `ema-phm calibrate --baseline` does, forced where it refuses), each cycle a
window at -40..+85 degC with its own noise per channel and load.  Nothing in the package is
chosen on these rows: it is reported, not tuned on, and there is no tuning half.

``--isolate`` simulates and isolates every window as the live monitor does (tracked from the
last explained fit, searched again when not explained; `prog.isolate`), storing each row as
it comes in bench/results/bench_foreign_lives.json (an interrupted run resumes).  ``--score``
(the default when the rows exist) prognoses them through the live monitor's policy
(`FitPolicy.count`: a window the model does not explain adds nothing) with the shipped growth
priors, with none (no fleet history) and with the straight line through the last 5
estimates, each over `seeds.SEEDS` with bootstrap intervals over trajectories, and scores
them as the prognostics benchmark does (`prog.compare`); the tuned population's held-out
rows (bench/results/bench_prognostics.json) are scored the same way beside them.  Report:
docs/benchmarks_foreign_lives.md (the hand-written analysis below KEEP_MARKER is kept).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from bench.harness import OUT_HELP, RESULTS, cli, command_line, machine, out_dirs, pool, read_rows
from bench.prog import compare, foreign_lives, ideal, own_fleet, seeds
from bench.prog.baseline import Line
from bench.prog.isolate import dump, emitter, run_jobs
from bench.prog.report import KEEP_MARKER
from bench.prog.rescore import Prognose
from ema_phm.domain.faults import NAMES, PREDICTED

#: (short name, label, predictor) of the methods scored at every seed.
METHODS: tuple[tuple[str, str, Any], ...] = (
    ("ema_phm", "ema_phm (shipped growth priors)", Prognose("ema_phm")),
    ("no fleet", "ema_phm, no fleet history", Prognose("no fleet", {"growth_priors": {}})),
    (
        "constant rate",
        "ema_phm, constant rate (no rate walk)",
        Prognose("constant rate", {"rate_walk": False}),
    ),
    ("line 5", "straight line, last 5", Line(5)),
    (
        "oracle",
        "control: ema_phm on the true k (no severity scale)",
        Prognose("oracle", {"severity_scale": {NAMES[i]: (0.0, 0.0) for i in PREDICTED}}),
    ),
)
PAIRS = [("ema_phm", "line 5"), ("no fleet", "line 5"), ("ema_phm", "constant rate")]
#: Methods that do not sample (one scoring stands for every seed), and the controls scored
#: on the true k (the isolation's intervals moved onto it, `compare.fitted_row`), at one seed.
UNSEEDED = ("line 5", "oracle")
ORACLE = ("oracle",)
TUNED_FILE = "bench_prognostics.json"


# ----------------------------------------------------------------------------- isolation
def _stored(raw: Path, seed: int, trs: list[dict], cmdline: str) -> dict:
    """The stored rows to resume (the same plan, or one it extends), or a fresh record."""
    if raw.exists():
        old = read_rows(raw)
        planned = json.loads(json.dumps(trs))
        stored = old.get("plan") or []
        if old.get("seed") == seed and planned[: len(stored)] == stored:
            print(f"resuming: {len(old['windows'])} windows in {raw}", flush=True)
            return {**old, "plan": planned}
        raise SystemExit(f"{raw} holds another plan (seed or counts); move it away first")
    return {
        "command": cmdline,
        "seed": seed,
        "settings": foreign_lives.settings(),
        "plan": trs,
        "units": {},
        "windows": [],
        "isolate_s": 0.0,
    }


def run_isolation(args: argparse.Namespace, raw: Path, cmdline: str) -> None:
    """Isolate every planned window not yet in `raw`, storing each row as it comes."""
    trs = foreign_lives.plan(args.seed, args.per_kind, args.steady)
    data = _stored(raw, args.seed, trs, cmdline)
    data.update(machine=machine(), command=cmdline, jobs=args.jobs)
    only = {int(i) for i in args.only.split(",")} if args.only else None
    jobs = []
    for tr in trs:
        if only is not None and tr["index"] not in only:
            continue
        done = [w for w in data["windows"] if w["trajectory"] == tr["index"]]
        need = tr["cycles"] if args.max_cycles is None else min(tr["cycles"], args.max_cycles)
        if len(done) < need:
            jobs.append((tr, args.seed, done, args.max_cycles))
    if not jobs:
        print(f"nothing to isolate: every planned window is in {raw}")
        return
    t0, before = time.perf_counter(), float(data["isolate_s"])
    run_jobs(jobs, args.jobs, emitter(data, raw, before, t0), foreign_lives.run_trajectory)
    data["isolate_s"] = before + time.perf_counter() - t0
    raw.write_text(dump(data))
    print(f"isolation done: {len(data['windows'])} windows, {data['isolate_s'] / 60:.1f} min")


# ----------------------------------------------------------------------------- scoring
_ROWS: dict[str, Any] = {}


def _score(task: tuple[str, str, int]) -> list[compare.Scored]:
    which, name, seed = task
    predictor = next(m for n, _, m in METHODS if n == name)
    return compare.score_all(_ROWS[which], predictor, oracle=name in ORACLE, seed=seed)


def score(rows: dict[str, dict], jobs: int) -> dict[str, dict[str, dict[int, list]]]:
    """{population: {method: {seed: scored trajectories}}} of every method at every seed."""
    tasks = [
        (which, name, seed)
        for which in rows
        for name, _, _ in METHODS
        for seed in (seeds.SEEDS[:1] if name in UNSEEDED else seeds.SEEDS)
    ]
    _ROWS.update(rows)  # forked workers inherit it
    if jobs > 1:
        with pool(jobs) as workers:
            results = workers.map(_score, tasks, chunksize=1)
    else:
        results = [_score(t) for t in tasks]
    out: dict[str, dict[str, dict[int, list]]] = {}
    for (which, name, seed), res in zip(tasks, results, strict=True):
        out.setdefault(which, {}).setdefault(name, {})[seed] = res
    return out


def controls(data: dict, foreign: dict[str, dict[int, list]]) -> dict[str, Any]:
    """The controls beside the methods, at the first sampling seed.

    The ceiling (`prog.ideal`) on ema_phm's windows, and ema_phm with priors learned from
    the other lives (`prog.own_fleet`).
    """
    seed = seeds.SEEDS[0]
    return {
        "ceiling": ideal.ceiling(data, foreign["ema_phm"][seed]),
        "own fleet": own_fleet.score(data, seed),
    }


# ----------------------------------------------------------------------------- report
def _rate(n: int, d: int) -> str:
    return f"{n}/{d} ({n / d:.0%})" if d else "-"


def _per_kind(data: dict, scored: list[compare.Scored]) -> list[str]:
    """Per (fault, law): histories, alpha-lambda 0.5, coverage from lambda 0.5, PH (stays)."""
    plan = {tr["index"]: tr for tr in data["plan"]}
    groups: dict[tuple[str, str], list] = {}
    for s in scored:
        tr = plan[s.index]
        if tr["type"] != "steady":
            groups.setdefault((tr["type"], tr["law"]), []).append(seeds.trajectory_numbers(s))
    lines = [
        "| fault | law | lives | alpha-lambda 0.5 | 90 % coverage from lambda 0.5 "
        "(no RUL = miss) | PH (stays) median |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for (fault, law), ts in sorted(groups.items()):
        al = [x for t in ts for x in t.al50]
        stays = [x for t in ts for x in t.ph_stays]
        cov = _rate(sum(t.covered_late for t in ts), sum(t.windows_late for t in ts))
        med = f"{statistics.median(stays):.0%}" if stays else "-"
        lines.append(
            f"| {fault} | {law} | {len(ts)} | {_rate(sum(al), len(al))} | {cov} | {med} |"
        )
    return lines


def _population(data: dict) -> list[str]:
    """Commissioning verdicts and the windows the monitor explained."""
    units = list(data["units"].values())
    accepted = sum(bool(u["commissioning"]["accepted"]) for u in units)
    inspec = [u for u in units if u["in_spec"]]
    inspec_ok = sum(bool(u["commissioning"]["accepted"]) for u in inspec)
    ws = [w for w in data["windows"] if "k" in w]
    explained = sum(bool(w["adequacy_ok"]) for w in ws)
    errors = sum("error" in w for w in data["windows"])
    return [
        f"- Units: {len(units)}, {len(inspec)} in-spec; commissioning accepted {accepted}/"
        f"{len(units)} ({inspec_ok}/{len(inspec)} in-spec; the others commissioned with "
        "--force, as a user would to watch them).",
        f"- Windows: {len(data['windows'])}; isolated {len(ws)} ({errors} without "
        f"excitation); explained {_rate(explained, len(ws))}: a window the model does not "
        "explain adds nothing to the history.",
    ]


def _intro(data: dict, cmdline: str, score_s: float) -> list[str]:
    """The title, what was drawn, the machine and commands, the population's figures."""
    isolated = {int(w["trajectory"]) for w in data["windows"]}
    trs = [tr for tr in data["plan"] if tr["index"] in isolated]
    grow = [tr for tr in trs if tr["type"] != "steady"]
    kinds = {(tr["type"], tr["law"]) for tr in grow}
    lives = [tr["cycles"] for tr in grow]
    m = data.get("machine", {})
    return [
        "# Foreign lives: remaining life off the prognostics benchmark's map",
        "",
        f"{len(grow)} run-to-failure trajectories isolated ({len(kinds)} kinds: faults with "
        "a remaining life, each growing by both laws) and "
        f"{len(trs) - len(grow)} with a fault held steady, each on its own foreign unit.  "
        f"True lives {min(lives, default=0)}-{max(lives, default=0)} cycles; the growth rate on a "
        f"random walk (log sd {foreign_lives.RATE_WALK_SD} per cycle) and, on every other "
        f"life, changed once by x{foreign_lives.RATE_CHANGE[0]}-{foreign_lives.RATE_CHANGE[1]} "
        "in mid-life.  How it is drawn: the docstrings of bench/bench_foreign_lives.py and "
        "bench/prog/foreign_lives.py.  Nothing in the package was chosen on these rows, and "
        "none of them is tuned on: every trajectory is held out.",
        "",
        f"Machine: {m.get('cpu', 'unknown')}, {m.get('cores', '?')} cores, Python "
        f"{m.get('python', '?')}, numba {m.get('numba', '?')}.  Isolation: "
        f"`{data.get('command', '')}` ({data.get('isolate_s', 0) / 60:.0f} min); scoring: "
        f"`{cmdline}` ({score_s:.0f} s).  Raw rows: bench/results/bench_foreign_lives.json.",
        "",
        *_population(data),
    ]


def _ceiling(c: dict[str, Any]) -> list[str]:
    """The ideal forecaster's figures (`ideal.ceiling`) on the windows ema_phm predicted at."""
    return [
        "## The ceiling: a forecaster that knows all but the future",
        "",
        "`bench/prog/ideal.py`: at each window it knows the true severity, the law, the rate "
        "and its present multiplier, the walk's sd, and whether and when a rate change is "
        "to come (not its factor), and simulates the plan's own future "
        f"({ideal.IDEAL_SAMPLES} futures; seed 0).  On the cycles ema_phm predicted at "
        "(seed 0, shipped priors):",
        "",
        "| figure | ideal forecaster |",
        "|---|---:|",
        f"| alpha-lambda at lambda 0.5 | {_rate(*c['al50'])} |",
        f"| alpha-lambda at lambda 0.75 | {_rate(*c['al75'])} |",
        f"| 90 % coverage, windows from lambda 0.5 | {_rate(*c['coverage_late'])} |",
        f"| windows from lambda 0.5 with {compare.BETA:g} of the RUL inside the "
        f"+/-{compare.ALPHA:g} cone | {_rate(*c['cone_late'])} |",
    ]


def _own_fleet(shipped: list[compare.Scored], own: list[compare.Scored]) -> list[str]:
    """The shipped priors against priors learned from the other lives (`prog.own_fleet`)."""
    seed = seeds.SEEDS[0]
    pair = {"ema_phm": {seed: shipped}, "own fleet": {seed: own}}
    labels = {"ema_phm": "ema_phm (shipped growth priors)", "own fleet": own_fleet.LABEL}
    return [
        "## A fleet that learns from its own lives",
        "",
        "`bench/prog/own_fleet.py`: for each trajectory the growth priors (rates, law split, "
        "how much the rate moves) are learned from every other trajectory's lives in these "
        f"rows, never from its own (seed {seed}; the interval over trajectories as above).",
        "",
        *seeds.table(pair, labels, [("own fleet", "ema_phm")], keep=lambda s: True),
    ]


def report(
    data: dict, tuned: dict | None, by: dict, extra: dict, *, cmdline: str, score_s: float
) -> str:
    """The Markdown report (`extra`: `controls`)."""
    labels = {n: label for n, label, _ in METHODS}
    out = [
        *_intro(data, cmdline, score_s),
        "",
        "## Targets (issue 31)",
        "",
        "RUL: the truth inside the 90 % interval in >= 85 % of windows from lambda 0.5; "
        "alpha-lambda at lambda 0.5 >= 60 %; RUL WARN on faults that do not grow <= 2 %; "
        "with no fleet history, at least the straight line's PH (stays) and alpha-lambda; "
        "an exponentially growing friction followed with the truth inside its interval.",
        "",
        "## Headline figures over seeds, with 95 % intervals",
        "",
        f"Each figure is the mean over sampling seeds {', '.join(map(str, seeds.SEEDS))} of "
        "the prognosis (the straight line does not sample), over every foreign trajectory.  "
        f"In brackets the 95 % interval: percentile bootstrap over trajectories ({seeds.BOOT} "
        "resamples, paired across methods); in parentheses the range over seeds.  'every "
        "window' coverage counts a window without a RUL as not holding the truth.",
        "",
        *seeds.table(by["foreign"], labels, PAIRS, keep=lambda s: True),
        "",
        *_ceiling(extra["ceiling"]),
        "",
        *_own_fleet(by["foreign"]["ema_phm"][seeds.SEEDS[0]], extra["own fleet"]),
    ]
    if tuned is not None:
        out += [
            "",
            "## The tuned population beside it",
            "",
            "The prognostics benchmark's held-out (odd) trajectories "
            f"(bench/results/{TUNED_FILE}: `Unit.draw` units, one law per fault, a constant "
            "rate, lives 25-45 cycles, the envelope's windows), scored by the same code in "
            "the same run.",
            "",
            *seeds.table(by["tuned"], labels, PAIRS, keep=lambda s: s.index % 2 == 1),
        ]
    out += [
        "",
        "## Per fault and law (seed 0, shipped priors)",
        "",
        *_per_kind(data, by["foreign"]["ema_phm"][seeds.SEEDS[0]]),
        "",
    ]
    return "\n".join(out)


def main() -> int:
    """Isolate the planned windows (--isolate), score the stored rows (--score, the default)."""
    ap = cli(
        __doc__,
        seed=(foreign_lives.FIRST_SEED, "first unit seed"),
        jobs=(1, "processes (over trajectories when isolating, over methods when scoring)"),
        out=(None, OUT_HELP),
    )
    ap.add_argument("--isolate", action="store_true", help="simulate and isolate (resumes)")
    ap.add_argument("--score", action="store_true", help="prognose and score the stored rows")
    ap.add_argument("--per-kind", type=int, default=foreign_lives.PER_KIND)
    ap.add_argument("--steady", type=int, default=foreign_lives.STEADY)
    ap.add_argument("--max-cycles", type=int, default=None, help="cap per trajectory (smoke)")
    ap.add_argument("--only", default=None, help="comma-separated trajectory indices (smoke)")
    ap.add_argument(
        "--without-tuned", action="store_true", help="score the foreign rows only (faster)"
    )
    args = ap.parse_args()
    rows_dir, report_dir = out_dirs(args.out)
    raw = rows_dir / "bench_foreign_lives.json"
    md = report_dir / "benchmarks_foreign_lives.md"
    flags = [
        ("--seed", args.seed, foreign_lives.FIRST_SEED),
        ("--per-kind", args.per_kind, foreign_lives.PER_KIND),
        ("--steady", args.steady, foreign_lives.STEADY),
        ("--max-cycles", args.max_cycles, None),
        ("--only", args.only, None),
        ("--jobs", args.jobs, 1),
    ]
    if args.isolate:
        run_isolation(args, raw, command_line("bench_foreign_lives", "--isolate", flags=flags))
    if args.score or not args.isolate:
        if not raw.exists():
            raise SystemExit(f"{raw} does not exist: run --isolate first")
        t0 = time.perf_counter()
        rows = {"foreign": read_rows(raw)}
        tuned_path = RESULTS / TUNED_FILE
        if tuned_path.exists() and not args.without_tuned:
            rows["tuned"] = read_rows(tuned_path)
        by = score(rows, args.jobs)
        extra = controls(rows["foreign"], by["foreign"])
        cmd = command_line("bench_foreign_lives", "--score", flags=[("--jobs", args.jobs, 1)])
        score_s = time.perf_counter() - t0
        text = report(rows["foreign"], rows.get("tuned"), by, extra, cmdline=cmd, score_s=score_s)
        if md.exists() and KEEP_MARKER in md.read_text():
            text += "\n" + KEEP_MARKER + md.read_text().split(KEEP_MARKER, 1)[1]
        md.write_text(text)
        print(f"wrote {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
