#!/usr/bin/env python3
"""Does the monitor keep up with ema_node at realtime_factor 1.0?  Windows skipped, per mode.

Usage (repo root):  .venv/bin/python -m bench.bench_tracking [--windows N]
                    [--degradation FILE | --degradation ''] [--modes tracking,global] [--out docs]

ema_node plays the actuator at realtime_factor 1.0 for N windows of 2 s
(`harness.scenarios.NOISE` on every channel), by default with a friction fault that grows
every window
(config/degradation_friction_slow.yaml: one cycle per window, severity 0.4 at cycle 105;
`--degradation ''`: a fixed k1 = 0.3); monitor_node (warm-up on, its default) fits them with
the packaged belief, nuisances and intervals and prognoses after each, once with tracking
(each window starts from the last explained fit) and once without (a global search per
window).  Reported: the warm-up, windows fitted, skipped while busy, tracking restarts, the
fit's wall time and %err, and the last prognosis.  One in-process graph on this machine,
traffic on loopback.  Writes docs/benchmarks_tracking.md.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from bench.harness import DOCS, cli, machine  # noqa: E402
from bench.harness.scenarios import NOISE  # noqa: E402
from ema_phm.domain.faults import k_with  # noqa: E402
from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402

K = k_with(friction=0.3).tolist()
DEGRADATION = ROOT / "config" / "degradation_friction_slow.yaml"


def run(windows: int, tracking: bool, degradation: str) -> dict:
    fault = {"degradation": degradation} if degradation else {"k": K}
    with InProcessGraph(num_threads=4) as graph:
        t0 = time.perf_counter()
        monitor = graph.add(MonitorNode, tracking=tracking)
        ema = graph.add(
            EmaNode,
            realtime_factor=1.0,
            max_windows=windows,
            wait_for_subscribers=1,
            **fault,
            **NOISE,
        )
        ema.finished.wait(timeout=4.0 * windows + 120.0)
        time.sleep(8.0)  # the last window's fit
        wall = time.perf_counter() - t0
        results = list(monitor.service.results)
        counters = dict(monitor.service.counters)
        warm_up_s = monitor.service.warm_up_s
    fits = [r["elapsed_s"] for r in results]
    errs = [r["percent_err"] for r in results if r["percent_err"] is not None]
    last = results[-1].get("prognosis") if results else None
    levels = [(r.get("prognosis") or {}).get("level") for r in results]
    cycles = [((r.get("prognosis") or {}).get("prognosis") or {}).get("cycle") for r in results]
    warned = [c for c, level in zip(cycles, levels, strict=True) if level == "WARN"]
    return {
        "tracking": tracking,
        "warm_up_s": warm_up_s,
        "last_prognosis": None if last is None else last.get("headline"),
        "first_rul_warn_window": warned[0] if warned else None,
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
    ap = cli(__doc__.splitlines()[0], raw_description=False, out=(str(DOCS), None))
    ap.add_argument("--windows", type=int, default=30)
    ap.add_argument("--degradation", default=str(DEGRADATION), help="'' = fixed k1 = 0.3")
    ap.add_argument("--modes", default="tracking,global")
    args = ap.parse_args()
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    if not modes or any(m not in ("tracking", "global") for m in modes):
        print(f"bench_tracking: --modes must list tracking and/or global, got {args.modes!r}")
        return 2
    rows = [run(args.windows, m == "tracking", args.degradation) for m in modes]
    m = machine()
    scenario = (
        f"`{Path(args.degradation).relative_to(ROOT)}` (one cycle per window)"
        if args.degradation
        else "a fixed friction fault k1 = 0.3"
    )
    lines = [
        "# Keeping up with the stream (`bench/bench_tracking.py`)",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}.  Command: "
        f"`.venv/bin/python -m bench.bench_tracking --windows {args.windows}"
        + (f" --degradation {args.degradation!r}" if args.degradation != str(DEGRADATION) else "")
        + (f" --modes {args.modes}" if args.modes != "tracking,global" else "")
        + f"`.  ema_node at realtime_factor 1.0 (2 s windows), {scenario}, noise on every "
        "channel; monitor_node (warm-up on) with the packaged belief, nuisances, intervals "
        "and prognostics.",
        "",
        "| mode | warm-up s | windows played | fitted | skipped while busy | tracking restarts | "
        "fit median (max) s | %err median | first RUL WARN (window) | last prognosis |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        warm = "-" if r["warm_up_s"] is None else f"{r['warm_up_s']:.1f}"
        lines.append(
            f"| {'tracking' if r['tracking'] else 'global search every window'} | {warm} | "
            f"{r['windows']} | {r['fitted']} | {r['skipped']} | {r['restarts']} | "
            f"{r['fit_median_s']:.2f} ({r['fit_max_s']:.2f}) | {r['err_median']:.2f} | "
            f"{'-' if r['first_rul_warn_window'] is None else r['first_rul_warn_window']} | "
            f"{r['last_prognosis']} |"
        )
        print(r, flush=True)
    lines += [
        "",
        "Fitted + skipped < played: windows still queued when the run ended (it waits 8 s "
        "after ema_node's last window).  The first RUL WARN is the stream's window (cycle) "
        "number, from 0; "
        "with the default degradation the true end of life is cycle 105.",
    ]
    Path(args.out, "benchmarks_tracking.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
