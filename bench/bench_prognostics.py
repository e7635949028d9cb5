#!/usr/bin/env python3
"""Prognostics benchmark (issues 11, 21): run-to-failure trajectories of realistic units.

Usage (from the repo root):
    nohup .venv/bin/python -m bench.bench_prognostics --isolate --jobs 2 > /tmp/p.log 2>&1 &
    .venv/bin/python -m bench.bench_prognostics --score --jobs 2   # every method, minutes
    .venv/bin/python -m bench.bench_prognostics --isolate --only 0,1 --max-cycles 8 \
        --out /tmp/smoke                                          # a quick look

Two phases.

``--isolate`` simulates and isolates every window of every trajectory and writes the raw
per-window rows to bench/results/bench_prognostics.json after each window (an interrupted run
resumes where it stopped: same --seed, same plan; a plan that only grows extends it).
``--jobs N`` isolates N trajectories at once (same rows).

``--score`` (the default when the JSON exists and --isolate is not given) reads only those
rows and runs every RUL method on them through the live monitor's policy
(`monitor.policy.FitPolicy.count`: a window the model does not explain adds nothing):
the project's `rul.prognose` (with the shipped growth priors), the same without growth
priors (as before issue 21), straight lines through the last 5 and 10 severity estimates, a
log-linear fit through the last 10, and a particle filter on a damage-growth model
(`prog.particle`), then controls (the true k, other priors).  It scores them the way PHM
papers do (`prog.compare`: prognostic horizon, alpha-lambda at lambda 0.5 and 0.75, the
share of windows inside the +/-20 % cone, relative accuracy, coverage, false alarms on
healthy lives and on faults that do not grow, update time), learns the growth priors again
on the tuning half to show beside the shipped ones, draws the alpha-lambda plot, and writes
docs/benchmarks_prognostics.md (the hand-written analysis below KEEP_MARKER is kept).
``--jobs N`` scores N methods at once.

Plan (`prog.plan`): PER_TYPE trajectories per fault type (friction, backlash, short circuit
A, eccentricity, friction + eccentricity), interleaved so that each type has as many
even- as odd-numbered ones; then HEALTHY healthy ones; then STEADY ones with one fault
present at a constant severity.  Trajectory t runs on its own unit ``Unit.draw(seed + t)``
(default seed 100: units bench_robust.py never saw), commissioned from 2 healthy hangar
windows.  Degradation laws are drawn from ``default_rng((seed, t, 23))``: a target end of
life uniform in LIFE_CYCLES, an onset uniform in ONSET_CYCLES, an initial value and the
rate that brings the severity to the failure threshold (0.4) at that life; friction and
backlash linear, short circuit and eccentricity exponential.  Each cycle is one 2 s window
(a pre-flight test) with its own temperature, unmeasured load, hinge spring and noise seed.
Isolation as the live monitor (`FitPolicy.fit`): tracked from the last explained fit,
searched globally otherwise or when a tracked fit is not explained.

Even-numbered trajectories are the tuning half (the growth priors are learned on them);
odd-numbered ones are held out and give the headline.
"""

from __future__ import annotations

import sys

from bench.harness import OUT_HELP, cli, command_line, out_dirs
from bench.prog.isolate import run_isolation
from bench.prog.plan import HEALTHY, PER_TYPE, STEADY
from bench.prog.rescore import run_score


def main() -> int:
    """Isolate the planned windows (--isolate), score the stored rows (--score, the default)."""
    ap = cli(
        __doc__, seed=(100, None), jobs=(1, "processes over trajectories"), out=(None, OUT_HELP)
    )
    ap.add_argument("--isolate", action="store_true", help="simulate and isolate (resumes)")
    ap.add_argument("--score", action="store_true", help="prognose and score the stored rows")
    ap.add_argument("--per-type", type=int, default=PER_TYPE)
    ap.add_argument("--healthy", type=int, default=HEALTHY)
    ap.add_argument(
        "--steady", type=int, default=STEADY, help="trajectories with a fault that stays"
    )
    ap.add_argument("--only", default=None, help="comma-separated trajectory indices")
    ap.add_argument("--max-cycles", type=int, default=None, help="cap per trajectory (smoke)")
    args = ap.parse_args()
    rows_dir, report_dir = out_dirs(args.out)
    raw = rows_dir / "bench_prognostics.json"
    md = report_dir / "benchmarks_prognostics.md"
    if args.isolate:
        cmdline = command_line(
            "bench_prognostics",
            "--isolate",
            flags=[
                ("--seed", args.seed, 100),
                ("--per-type", args.per_type, PER_TYPE),
                ("--healthy", args.healthy, HEALTHY),
                ("--steady", args.steady, STEADY),
                ("--only", args.only, None),
                ("--max-cycles", args.max_cycles, None),
                ("--jobs", args.jobs, 1),
            ],
        )
        run_isolation(args, raw, cmdline)
    if args.score or not args.isolate:
        if not raw.exists():
            raise SystemExit(f"{raw} does not exist: run --isolate first")
        run_score(raw, md, args.jobs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
