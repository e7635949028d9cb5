"""Resident memory and CPU time of Dask's worker processes, sampled by a background thread.

`RssSampler(pids)` samples, every `PERIOD_S`, the RSS and CPU time of the processes `pids()`
names (the workers) and of this process (the client, the scheduler and the nannies of an
embedded cluster live here), with psutil; `stop()` gives peak and median RSS per process in
MB, the CPU seconds these processes used, and the CPU seconds the whole machine was busy:
the difference is what other processes took meanwhile (a measurement on a machine that was
not idle says so).
"""

from __future__ import annotations

import os
import statistics
import threading
import time
from collections.abc import Callable
from typing import Any

import psutil

from bench.fleet.common import MB

PERIOD_S = 0.5


def spawned_workers() -> list[int]:
    """PIDs of this process's children started by multiprocessing's spawn (Dask's workers).

    An embedded LocalCluster runs its nannies in this process; each starts its worker with
    multiprocessing's spawn (``spawn_main`` on the command line); the resource tracker and
    other helpers have other command lines.
    """
    out = []
    for child in psutil.Process().children(recursive=True):
        try:
            if "spawn_main" in " ".join(child.cmdline()):
                out.append(child.pid)
        except psutil.Error:
            continue
    return out


class RssSampler:
    """RSS of worker processes and of this process, every `PERIOD_S` on a thread."""

    def __init__(self, pids: Callable[[], list[int]]) -> None:
        self.pids = pids
        self.workers: dict[int, list[int]] = {}
        self.main: list[int] = []
        self._me = psutil.Process(os.getpid())
        self._cpu0: dict[int, float] = {}  # CPU seconds of each process at the start
        self._cpu: dict[int, float] = {}  # ... at its last sample
        self._busy0 = self._t0 = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="rss-sampler", daemon=True)

    def start(self) -> RssSampler:
        """Take a first sample and go on in the background."""
        self._busy0, self._t0 = _machine_busy(), time.perf_counter()
        self._sample()
        self._cpu0 = dict(self._cpu)
        self._thread.start()
        return self

    def _loop(self) -> None:
        while not self._stop.wait(PERIOD_S):
            self._sample()

    def _sample(self) -> None:
        self.main.append(self._me.memory_info().rss)
        self._cpu[self._me.pid] = _cpu_s(self._me)
        for pid in self.pids():
            try:
                proc = psutil.Process(pid)
                rss, cpu = proc.memory_info().rss, _cpu_s(proc)
            except psutil.Error:  # a worker gone (ended, or restarted under another pid)
                continue
            self.workers.setdefault(pid, []).append(rss)
            self._cpu[pid] = cpu

    def _cpu_ledger(self) -> dict[str, float]:
        """CPU seconds of these processes and of the whole machine since `start`."""
        wall = time.perf_counter() - self._t0
        ours = sum(c - self._cpu0.get(pid, 0.0) for pid, c in self._cpu.items())
        busy = _machine_busy() - self._busy0
        return {
            "wall_s": wall,
            "cpu_s": ours,
            "machine_busy_s": busy,
            "others_cpu_s": max(0.0, busy - ours),
        }

    def stop(self) -> dict[str, Any]:
        """Stop sampling; peak and median RSS per worker and of this process, in MB."""
        self._stop.set()
        self._thread.join()
        self._sample()
        per = {
            str(pid): {
                "peak_mb": max(v) / MB,
                "median_mb": statistics.median(v) / MB,
                "samples": len(v),
            }
            for pid, v in sorted(self.workers.items())
        }
        return {
            "period_s": PERIOD_S,
            "workers": per,
            "worker_peak_mb": max((w["peak_mb"] for w in per.values()), default=None),
            "worker_median_mb": (
                statistics.median(w["median_mb"] for w in per.values()) if per else None
            ),
            "main_peak_mb": max(self.main) / MB,
            "main_median_mb": statistics.median(self.main) / MB,
            "samples": len(self.main),
            "cpu": self._cpu_ledger(),
        }


def _cpu_s(proc: psutil.Process) -> float:
    t = proc.cpu_times()
    return t.user + t.system


def _machine_busy() -> float:
    """CPU seconds every core of the machine has been busy (user, nice, system, interrupts)."""
    t = psutil.cpu_times()
    return sum(getattr(t, f, 0.0) for f in ("user", "nice", "system", "irq", "softirq"))
