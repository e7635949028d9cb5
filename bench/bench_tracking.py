#!/usr/bin/env python3
"""Does the monitor keep up with ema_node at realtime_factor 1.0?  Windows skipped, per mode.

Usage (repo root):  .venv/bin/python bench/bench_tracking.py [--windows N] [--out docs]

ema_node plays a unit with a friction fault (k1 = 0.3; bench_realistic's noise on every
channel) at realtime_factor 1.0 for N windows of 2 s; monitor_node fits them with the packaged
belief, nuisances and intervals, once with tracking (each window starts from the last
explained fit) and once without (a global search per window).  Reported: windows fitted,
skipped while busy, tracking restarts, the fit's wall time and %err.  One in-process graph on
this machine, traffic on loopback.  Writes docs/benchmarks_tracking.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from bench_realistic import NOISE  # noqa: E402

from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402
from ema_phm.tools.benchmark import machine  # noqa: E402

K = [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]


def run(windows: int, tracking: bool) -> dict:
    with InProcessGraph(num_threads=4) as graph:
        monitor = graph.add(MonitorNode, tracking=tracking)
        ema = graph.add(
            EmaNode,
            k=K,
            realtime_factor=1.0,
            max_windows=windows,
            wait_for_subscribers=1,
            **NOISE,
        )
        t0 = time.perf_counter()
        ema.finished.wait(timeout=4.0 * windows + 60.0)
        time.sleep(8.0)  # the last window's fit
        wall = time.perf_counter() - t0
        results = list(monitor.service.results)
        counters = dict(monitor.service.counters)
    fits = [r["elapsed_s"] for r in results]
    errs = [r["percent_err"] for r in results if r["percent_err"] is not None]
    return {
        "tracking": tracking,
        "windows": windows,
        "fitted": len(results),
        "skipped": counters["windows_skipped_busy"],
        "discarded": counters["windows_discarded"],
        "restarts": counters.get("tracking_restarts", 0),
        "fit_median_s": statistics.median(fits) if fits else float("nan"),
        "fit_max_s": max(fits) if fits else float("nan"),
        "err_median": statistics.median(errs) if errs else float("nan"),
        "wall_s": wall,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=int, default=30)
    ap.add_argument("--out", default=str(ROOT / "docs"))
    args = ap.parse_args()
    rows = [run(args.windows, True), run(args.windows, False)]
    m = machine()
    lines = [
        "# Keeping up with the stream (`bench/bench_tracking.py`)",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}.  Command: "
        f"`.venv/bin/python bench/bench_tracking.py --windows {args.windows}`.  ema_node at "
        "realtime_factor 1.0 (2 s windows), friction k1 = 0.3, noise on every channel; "
        "monitor_node with the packaged belief, nuisances and intervals.",
        "",
        "| mode | windows played | fitted | skipped while busy | tracking restarts | "
        "fit median (max) s | %err median |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {'tracking' if r['tracking'] else 'global search every window'} | "
            f"{r['windows']} | {r['fitted']} | {r['skipped']} | {r['restarts']} | "
            f"{r['fit_median_s']:.2f} ({r['fit_max_s']:.2f}) | {r['err_median']:.2f} |"
        )
        print(r, flush=True)
    Path(args.out, "benchmarks_tracking.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
