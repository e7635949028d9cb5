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
from 2 healthy hangar windows (`harness.scenarios.hangar`).  Degradation laws are drawn from
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
harness.scenarios' ranges, noise NOISE on every channel, noise seed 1000 t + cycle + 1.

Isolation as the live monitor does it (`HealthMonitor._isolate`;
`prog.isolate.tracked_fit_then_global_restart`): commissioned belief,
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

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import DOCS, cli, command_line  # noqa: E402
from prog.isolate import run_isolation  # noqa: E402
from prog.plan import HEALTHY, PER_TYPE, STEADY  # noqa: E402
from prog.rescore import run_score  # noqa: E402


def main() -> int:
    """Isolate the planned windows (--isolate), score the stored rows (--score, the default)."""
    ap = cli(
        __doc__, seed=(100, None), jobs=(1, "processes over trajectories"), out=(str(DOCS), None)
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
    ap.add_argument(
        "--sweep",
        default="0.02,0.03",
        help="noise floors to re-score with for the sensitivity table ('' for none)",
    )
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    raw = out / "bench_prognostics.json"
    md = out / "benchmarks_prognostics.md"
    if args.isolate:
        cmdline = command_line(
            "bench_prognostics.py",
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
        sweep = [float(s) for s in args.sweep.split(",") if s.strip()]
        run_score(raw, md, sweep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
