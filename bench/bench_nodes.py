#!/usr/bin/env python3
"""Benchmark the ROS 2 nodes; writes docs/benchmarks_nodes.md.

1. ema_node CPU at realtime_factor 1.0: the node runs as its own process
   (`python -m ema_phm.ros.ema_node`) with one subscriber; its CPU time
   (utime + stime from /proc/<pid>/stat) over ~10 s of wall time.
   Target: < 50 % of one core.
2. Latency: the same ema_node (realtime) with monitor_node (default preset) in this
   process.  For each fitted window: time from the arrival of the telemetry message
   holding the window's last sample to the arrival of its /ema/health, against the
   isolation time the monitor reports (elapsed_s).  Target: latency <= isolation + 1 s.
3. 20 consecutive fitted windows, realtime_factor 0, max_evaluations 100, both nodes
   in this process: OS thread count and RSS before (after a warm-up run) and after.
   Target: RSS growth < 50 MB, no thread left behind.

    .venv/bin/python -m bench.bench_nodes [--cpu-seconds 10] [--latency-windows 3] \
        [--out docs/benchmarks_nodes.md]
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
DOMAIN = random.randint(1, 100)
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN)

import numpy as np  # noqa: E402
from rclpy.node import Node  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

from bench.harness import DOCS, cli, machine  # noqa: E402
from ema_phm.diagnosis import health  # noqa: E402
from ema_phm.diagnosis.isolation import DEFAULT_PRESET  # noqa: E402
from ema_phm.ros.common import OUTPUT_QOS, TELEMETRY_QOS  # noqa: E402
from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402
from ema_phm.telemetry.wire import HEALTH_TOPIC, TELEMETRY_TOPIC  # noqa: E402

CLK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK  # utime, stime (fields 14, 15)


def status(key: str, pid: str = "self") -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    raise KeyError(key)


class Probe:
    """Arrival times of telemetry messages (with their sample span) and of health results."""

    def __init__(self, g: InProcessGraph) -> None:
        self.node = Node("bench_probe", context=g.context)
        g.nodes.append(self.node)
        g.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.telemetry: list[tuple[float, float, float]] = []  # (arrival, t first, t last)
        self.health: list[tuple[float, dict]] = []
        self.node.create_subscription(Float64MultiArray, TELEMETRY_TOPIC, self._tel, TELEMETRY_QOS)
        self.node.create_subscription(Float64MultiArray, HEALTH_TOPIC, self._health, OUTPUT_QOS)

    def _tel(self, msg) -> None:
        now = time.monotonic()
        d = np.frombuffer(msg.data, dtype=np.float64)
        with self.lock:
            self.telemetry.append((now, float(d[0]), float(d[-7])))

    def _health(self, msg) -> None:
        now = time.monotonic()
        with self.lock:
            self.health.append(
                (now, dict(zip(health.HEALTH_FIELDS, np.asarray(msg.data), strict=True)))
            )


def start_ema_process(rf: float) -> subprocess.Popen:
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "ema_phm.ros.ema_node",
            "--ros-args",
            "-p",
            f"realtime_factor:={rf}",
            "--log-level",
            "warn",
        ],
        env=dict(os.environ),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def bench_cpu_and_latency(cpu_s: float, n_windows: int) -> dict:
    out: dict = {}
    proc = start_ema_process(1.0)
    try:
        with InProcessGraph(DOMAIN) as g:
            probe = Probe(g)
            end = time.monotonic() + 60
            while not probe.telemetry and time.monotonic() < end:
                time.sleep(0.05)
            if not probe.telemetry:
                raise SystemExit("ema_node process never published")
            time.sleep(1.0)
            c0, w0, n0 = cpu_seconds(proc.pid), time.monotonic(), len(probe.telemetry)
            time.sleep(cpu_s)
            c1, w1, n1 = cpu_seconds(proc.pid), time.monotonic(), len(probe.telemetry)
            out["cpu_idle_monitor"] = (c1 - c0) / (w1 - w0)
            out["msg_rate"] = (n1 - n0) / (w1 - w0)
            out["cpu_window_s"] = w1 - w0
            # latency: add the monitor (default preset) to this process
            monitor = g.add(MonitorNode)
            c0, w0 = cpu_seconds(proc.pid), time.monotonic()
            monitor.wait_for_results(n_windows, timeout=60 * n_windows)
            time.sleep(0.2)
            c1, w1 = cpu_seconds(proc.pid), time.monotonic()
            out["cpu_with_monitor"] = (c1 - c0) / (w1 - w0)
            with probe.lock:
                tel, hl = list(probe.telemetry), list(probe.health)
            lat = []
            for arrival, h in hl:
                t1 = h["window_t1"]
                holder = [a for a, tf, tl in tel if tf - 1e-9 <= t1 <= tl + 1e-9]
                if holder:
                    lat.append((arrival - holder[0], h["elapsed_s"], t1))
            out["latency"] = lat
            out["monitor_counters"] = dict(monitor.counters)
    finally:
        stop(proc)
    return out


def run_windows(n: int, max_evaluations: int) -> dict:
    with InProcessGraph(DOMAIN) as g:
        monitor = g.add(MonitorNode, max_evaluations=max_evaluations)
        g.add(EmaNode, realtime_factor=0.0, wait_for_subscribers=1)
        t0 = time.monotonic()
        res = monitor.wait_for_results(n, timeout=600)
        wall = time.monotonic() - t0
        peak = status("VmRSS")
        return {
            "done": len(res),
            "wall": wall,
            "counters": dict(monitor.counters),
            "rss_peak_kb": peak,
        }


def bench_windows(n: int, max_evaluations: int) -> dict:
    run_windows(2, max_evaluations)  # warm-up: JIT caches, DDS, imports
    time.sleep(0.5)
    before = {
        "threads": status("Threads"),
        "py_threads": threading.active_count(),
        "rss_kb": status("VmRSS"),
    }
    r = run_windows(n, max_evaluations)
    time.sleep(0.5)
    after = {
        "threads": status("Threads"),
        "py_threads": threading.active_count(),
        "rss_kb": status("VmRSS"),
    }
    return {"before": before, "after": after, **r}


def _latency_rows(lat: list[tuple[float, float, float]]) -> str:
    """The latency table's rows: one per (latency, isolation, window end) measured."""
    return "\n".join(
        f"| {t1:g} | {iso:.2f} | {latency:.2f} | {latency - iso:+.2f} | "
        f"{'yes' if latency <= iso + 1.0 else 'NO'} |"
        for latency, iso, t1 in lat
    )


def write(out: Path, m: dict, a: dict, b: dict, args: argparse.Namespace) -> str:
    over = [latency - iso for latency, iso, _ in a["latency"]]
    before, after = b["before"], b["after"]
    rss_growth = (after["rss_kb"] - before["rss_kb"]) / 1024
    c = b["counters"]
    cpu_idle, cpu_busy = 100 * a["cpu_idle_monitor"], 100 * a["cpu_with_monitor"]
    versions = f"Python {m['python']}, numba {m['numba']} ({m['numba_threads']} threads)"
    text = f"""# Node benchmarks

Made by `bench/bench_nodes.py` ({time.strftime("%Y-%m-%d")}).  Machine: {m["cores"]} cores, \
{m["cpu"]},
{versions}, numpy {m["numpy"]}; ROS 2 Kilted
PyPI wheels (rclpy, rmw_fastrtps_cpp), one host, discovery limited to localhost.

## ema_node CPU at realtime_factor 1.0

ema_node as its own process (`python -m ema_phm.ros.ema_node`, defaults: 2 kHz, 100
samples per message), CPU time (user + system) of that process over wall time.

| phase | wall (s) | messages/s | CPU (% of one core) | target |
|---|---|---|---|---|
| one plain subscriber | {a["cpu_window_s"]:.1f} | {a["msg_rate"]:.1f} | {cpu_idle:.1f} | < 50 % |
| while monitor_node (the bench process) fits windows on the same cores | - | - | \
{cpu_busy:.1f} | < 50 % |

## Latency: window end -> health

ema_node at realtime_factor 1.0 (other process), monitor_node with the default preset
(preset `{b["preset"]}`, full budget) in the bench process.
Latency = arrival of `/ema/health` minus arrival of the telemetry message holding the
window's last sample; isolation = the monitor's own `elapsed_s`.  Windows that end while
the monitor is busy are skipped (counted), so only every few windows is fitted.

| window end t1 (s) | isolation (s) | latency (s) | latency - isolation (s) | <= isolation + 1 s |
|---|---|---|---|---|
{_latency_rows(a["latency"])}

Overhead (latency - isolation): median {statistics.median(over):+.3f} s, max {max(over):+.3f} s.
Monitor counters: {a["monitor_counters"]}.

## {args.windows} consecutive fitted windows, realtime_factor 0, max_evaluations \
{args.max_evaluations}

Both nodes in one process; measured after a warm-up run of the same kind; the graph is
shut down (executor joined, nodes destroyed) before "after".  At realtime_factor 0 the
EMA can outrun the monitor: windows that complete while it is busy are skipped (counted).

| | OS threads | Python threads | RSS (MB) |
|---|---|---|---|
| before | {before["threads"]} | {before["py_threads"]} | {before["rss_kb"] / 1024:.1f} |
| peak (running) | - | - | {b["rss_peak_kb"] / 1024:.1f} |
| after | {after["threads"]} | {after["py_threads"]} | {after["rss_kb"] / 1024:.1f} |

RSS growth {rss_growth:+.1f} MB (target < 50 MB); {b["done"]} windows fitted in {b["wall"]:.1f} s;
skipped while busy {c["windows_skipped_busy"]}, discarded {c["windows_discarded"]}, \
failures {c["isolation_failures"]}.
"""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return text


def main() -> int:
    ap = cli(
        __doc__.split("\n\n")[0],
        raw_description=False,
        out=(str(DOCS / "benchmarks_nodes.md"), None),
    )
    ap.add_argument("--cpu-seconds", type=float, default=10.0)
    ap.add_argument("--latency-windows", type=int, default=3)
    ap.add_argument("--windows", type=int, default=20)
    ap.add_argument("--max-evaluations", type=int, default=100)
    args = ap.parse_args()
    m = machine()
    print(f"domain {DOMAIN}; {m['cores']} cores, {m['cpu']}", flush=True)
    a = bench_cpu_and_latency(args.cpu_seconds, args.latency_windows)
    print("cpu/latency:", {k: v for k, v in a.items()}, flush=True)
    b = bench_windows(args.windows, args.max_evaluations)
    b["preset"] = DEFAULT_PRESET
    print("windows:", b, flush=True)
    print(write(Path(args.out), m, a, b, args))
    return 0


if __name__ == "__main__":
    sys.exit(main())
