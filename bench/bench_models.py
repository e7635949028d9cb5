#!/usr/bin/env python3
"""Model benchmark: HF speed, LF throughput, LF step accuracy on the default window.

Usage (repo root): .venv/bin/python -m bench.bench_models [--runs 5]
Runs `ema_phm.tools.benchmark.measure_models` several times (each already a median),
takes the median of each figure and writes docs/benchmarks_models.md.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

from bench.harness import DOCS, cli
from ema_phm.tools.benchmark import measure_models

TARGETS = {
    "hf_wall_per_sim_s": (
        "HF wall seconds per simulated second (1 core, 1 us step)",
        "<= 0.067",
        lambda v: v <= 0.067,
    ),
    "hf_realtime_factor": ("HF speed vs real time", ">= 15x", lambda v: v >= 15),
    "hf_cold_start_s": (
        "HF cold start, fresh interpreter, cached JIT (s)",
        "< 2",
        lambda v: v < 2,
    ),
    "lf_evals_per_s": (
        "LF window evaluations per second (2 cores)",
        ">= 2000",
        lambda v: v >= 2000,
    ),
    "lf_fine_step_rel_rms": (
        "LF current, relative RMS vs a 10x finer step",
        "<= 0.02",
        lambda v: v <= 0.02,
    ),
}


def main() -> int:
    ap = cli(__doc__, raw_description=False, out=(str(DOCS / "benchmarks_models.md"), None))
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    runs = [measure_models(cold_start=(i == 0)) for i in range(args.runs)]
    med = {k: statistics.median(r[k] for r in runs if k in r) for k in TARGETS}
    first = runs[0]
    m = first["machine"]
    lines = [
        "# Model benchmark",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores ({m['numba_threads']} numba threads), "
        f"Python {m['python']}, "
        f"numba {m['numba']}, numpy {m['numpy']}.",
        f"Default window: {first['window_s']:g} s, {first['window_samples']} samples; LF step "
        f"{first['lf_step_s'] * 1e6:g} us. "
        f"Command: `.venv/bin/python -m bench.bench_models --runs {args.runs}` (median of "
        f"{args.runs} runs, "
        "each itself a median of repeated timings after JIT warm-up).",
        "",
        "| figure | median | target | met |",
        "|---|---:|---:|:---:|",
    ]
    for key, (label, target, ok) in TARGETS.items():
        v = med[key]
        lines.append(f"| {label} | {v:.4g} | {target} | {'yes' if ok(v) else 'NO'} |")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(
        "\n".join(lines) + "\n\nRaw: `" + json.dumps({k: med[k] for k in TARGETS}) + "`\n"
    )
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
