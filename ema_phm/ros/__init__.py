"""ROS 2 nodes around ema_phm (the only part of the package that imports rclpy).

- `ema_node`: the simulated "real" EMA (HF model) publishing telemetry.
- `monitor_node`: assembles windows, isolates faults, publishes health and diagnostics;
  with `monitor_outputs` (its publishers), `monitor_recording` (its bag) and
  `monitor_settings` (parameters -> its HealthMonitor).
- `parameters`: each node's parameter table (default, type, range, description), declared once.
- `common`: QoS profiles, the rclpy message conversion and the executables' main.
- `runtime`: `InProcessGraph`, nodes on a private graph inside one process.
- `demo`: `run_demo`, both nodes in one process for one window (used by `ema-phm demo`).
- `player`: `play_bag`, a recorded bag published into a live graph (`ema-phm play`).

Importing this package does not import rclpy; its modules do.

When the process is one of the node executables (`ema_node`, `monitor_node`, or
`python -m ema_phm.ros.<node>`), importing this package first takes over SIGINT and
SIGTERM: a signal that arrives while the heavy modules (numba, pymoo, rclpy) are
still loading ends the process at once with exit code 0 (nothing is built yet, so
nothing needs closing; the imports take seconds under load).  `STOP_REQUESTED` is
set first, for a handler that cannot exit (`common.spin_main` reads it).  In any
other process (tests, the CLI) the handlers are left alone.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

#: Executables whose start-up may be interrupted by a stop signal.
EXECUTABLES: tuple[str, ...] = ("ema_node", "monitor_node", "monitor_lifecycle_node")
#: Set by a SIGINT/SIGTERM that arrived before `spin_main` took over the signals.
STOP_REQUESTED = threading.Event()


def is_node_executable() -> bool:
    """Whether this process is one of the node executables (see the module docstring)."""
    return _NODE_EXECUTABLE


def _is_node_executable() -> bool:
    argv = list(getattr(sys, "orig_argv", []))
    if "-m" in argv:
        i = argv.index("-m")
        return i + 1 < len(argv) and argv[i + 1] in {f"ema_phm.ros.{name}" for name in EXECUTABLES}
    return os.path.basename(sys.argv[0] if sys.argv else "") in EXECUTABLES


def _early_stop(_signum: int, _frame: object) -> None:
    STOP_REQUESTED.set()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(0)  # still importing: no node, no file, no thread of ours to close


_NODE_EXECUTABLE = _is_node_executable()

if _NODE_EXECUTABLE and threading.current_thread() is threading.main_thread():
    for _sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(_sig, _early_stop)
