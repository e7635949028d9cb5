#!/usr/bin/env python3
"""`ema-phm import` of long bags: peak memory and speed against the recording's length.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_import_memory                 # 2, 8 and 24 minutes
    .venv/bin/python -m bench.bench_import_memory --minutes 2 8   # other lengths
    .venv/bin/python -m bench.bench_import_memory --report-only   # report from the saved rows

Each bag is a ros2_control rig's log (`rig_forms.joint_states_bag`: JointState, Float64
current and command, Temperature, one message each per 2 kHz sample) of one HF chirp
window (2 s, healthy) with 1 s of rest before it, repeated for the length asked: 24 minutes
make a bag of about 1 GB (MCAP).  Each is imported by the ``ema-phm import`` command in a
process of its own, with the map that reads it (`rig_forms.JOINT_STATES_MAP`, windows by
excitation), twice: whole-log (the default) and with ``--stream``; its peak resident
memory is that process's own (``VmHWM``), its wall time the command's.  Both imports
must give the same windows (count and source start times); the largest difference of
their samples is kept.  Rows: bench/results/bench_import_memory.json; report:
docs/benchmarks_import_memory.md.
"""

# ruff: noqa: S603 - the import command is this repository's own, with paths it made

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    out_dirs,
    read_rows,
    rig_forms,
    stamp,
    write_report,
    write_rows,
)
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import Window
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema
from ema_phm.telemetry.bags import read_window

#: Runs the import command in this process and prints its own peak resident memory [kB]:
#: VmHWM, which starts again at exec (getrusage's maxrss keeps the forking parent's peak).
_MEASURED = (
    "import sys\n"
    "from ema_phm.tools.cli import main\n"
    "try:\n"
    "    code = main(sys.argv[1:])\n"
    "except SystemExit as exc:\n"
    "    code = exc.code\n"
    "with open('/proc/self/status') as f:\n"
    "    peak = next(line.split()[1] for line in f if line.startswith('VmHWM:'))\n"
    "print('PEAK_KB', peak, file=sys.stderr)\n"
    "sys.exit(code)\n"
)


def long_log(minutes: float) -> Window:
    """One healthy chirp with 1 s of rest before it, repeated over `minutes`."""
    w = real_ema.simulate(NOMINAL, command=CommandSpec(duration=2.0)).window.without_truth()
    w = rig_forms.with_rest(w, 1.0)
    reps = max(1, round(minutes * 60.0 / (w.n * w.dt)))
    names = ("command", "load", "theta_u", "theta_m", "omega_m", "i3eq")
    cols = {c: np.tile(getattr(w, c), reps) for c in names}
    n = cols["command"].size
    return Window(t=np.arange(n) * w.dt, **cols, temperature=np.full(n, 30.0), meta={})


MODES = ("whole", "stream")


def measure(minutes: float, folder: Path) -> list[dict[str, Any]]:
    """Write a bag of `minutes`, import it both ways, each in a process of its own."""
    bag = rig_forms.joint_states_bag(folder / f"rig_{minutes:g}min", long_log(minutes))
    size = sum(p.stat().st_size for p in bag.rglob("*") if p.is_file())
    (folder / "map.yaml").write_text(yaml.safe_dump(rig_forms.JOINT_STATES_MAP))
    rows = [_imported(bag, size, minutes, folder, mode) for mode in MODES]
    rows[1]["largest_difference"] = _difference(folder / "out_whole", folder / "out_stream")
    return rows


def _difference(whole: Path, streamed: Path) -> float:
    """The largest difference of two imports' samples; RuntimeError if their windows differ."""
    a = sorted(p.parent for p in whole.rglob("metadata.yaml"))
    b = sorted(p.parent for p in streamed.rglob("metadata.yaml"))
    if [p.relative_to(whole) for p in a] != [p.relative_to(streamed) for p in b]:
        raise RuntimeError(f"the imports differ: {len(a)} windows whole-log, {len(b)} streamed")
    worst = 0.0
    for pa, pb in zip(a, b, strict=True):
        wa, wb = read_window(pa), read_window(pb)
        if wa.n != wb.n or abs(wa.meta["source_start_s"] - wb.meta["source_start_s"]) > 1e-9:
            raise RuntimeError(f"{pa.name} differs: {wa.n} and {wb.n} samples")
        for c in ("command", "theta_u", "theta_m", "omega_m", "i3eq", "temperature"):
            worst = max(worst, float(np.max(np.abs(getattr(wa, c) - getattr(wb, c)))))
    return worst


def _imported(bag: Path, size: int, minutes: float, folder: Path, mode: str) -> dict[str, Any]:
    """Import `bag` (`mode`: whole or stream) in a process of its own; its figures."""
    out = folder / f"out_{mode}"
    args = [str(bag), "--map", str(folder / "map.yaml"), "--out", str(out)]
    args += ["--stream"] * (mode == "stream")
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _MEASURED, "import", *args],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"import of {bag} failed: {done.stderr.strip()[-400:]}")
    peak = next(int(x.split()[1]) for x in done.stderr.splitlines() if x.startswith("PEAK_KB"))
    windows = sum(1 for _ in out.rglob("metadata.yaml"))
    return {
        "minutes": minutes,
        "mode": mode,
        "bag_mb": size / 1e6,
        "windows": windows,
        "import_s": wall,
        "peak_mb": peak / 1024.0,
    }


def report(data: dict[str, Any]) -> str:
    """The Markdown report of the saved rows."""
    rows = sorted(data["rows"], key=lambda r: (r.get("mode", "whole"), r["minutes"]))
    m = data["stamp"]["machine"]
    lines = [
        "# Importing long bags: memory and speed",
        "",
        "How they are made and measured: the docstring of bench/bench_import_memory.py.",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, numpy {m['numpy']}; "
        f"one process (the import uses one core).  Command: `{data['stamp']['command']}`.",
        "",
        "| import | recording [min] | bag [MB] | windows | import [s] | MB/s | windows/s "
        "| peak memory [MB] | largest difference from whole-log |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        diff = r.get("largest_difference")
        lines.append(
            f"| {r.get('mode', 'whole')} | {r['minutes']:g} | {r['bag_mb']:.0f} | "
            f"{r['windows']} | {r['import_s']:.1f} | {r['bag_mb'] / r['import_s']:.1f} | "
            f"{r['windows'] / r['import_s']:.2f} | {r['peak_mb']:.0f} | "
            + ("-" if diff is None else f"{diff:.1e}")
            + " |"
        )
    lines.append("")
    for mode in MODES:
        mine = [r for r in rows if r.get("mode", "whole") == mode]
        if len(mine) >= 2:
            x = [r["bag_mb"] for r in mine]
            slope = np.polyfit(x, [r["peak_mb"] for r in mine], 1)[0]
            lines.append(
                f"- {mode}: peak memory grows by {slope:.3f} MB per MB of bag (least squares "
                "over its rows)."
            )
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = cli(__doc__, out=(None, OUT_HELP))
    ap.add_argument(
        "--minutes", type=float, nargs="+", default=[2.0, 8.0, 24.0], help="recording lengths"
    )
    ap.add_argument("--report-only", action="store_true", help="report from the saved rows")
    args = ap.parse_args()
    rows_dir, docs_dir = out_dirs(args.out)
    raw = rows_dir / "bench_import_memory.json"
    if not args.report_only:
        minutes = [float(m) for m in args.minutes]
        cmd = command_line(
            "bench_import_memory",
            flags=[("--minutes", " ".join(f"{m:g}" for m in minutes), "2 8 24")],
        )
        rows = []
        for m in minutes:
            with tempfile.TemporaryDirectory() as tmp:
                rows += measure(m, Path(tmp))
            print(rows[-2:], flush=True)
        write_rows(raw, {"stamp": stamp(cmd), "rows": rows})
    text = report(read_rows(raw))
    write_report(docs_dir / "benchmarks_import_memory.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
