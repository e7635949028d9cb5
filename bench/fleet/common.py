"""Shared pieces of the fleet benchmark: sizes, settings, the raw JSON, timings, progress.

The raw JSON (`RAW` in bench/results/, or under --out) accumulates: each phase replaces its
own key and the file is written through a temporary one after the phase
(`harness.write_rows`).  A quick run (`QUICK` sizes) is marked ``"quick": true`` and never
mixes with a measurement's JSON.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.harness import ROOT, machine, write_rows
from ema_phm.fleet.generate import TRUTH_FILE
from ema_phm.fleet.settings import DiagnosisSettings

#: Sizes of a measurement and of a quick run (checks the script works; not a measurement).
FULL = {"units": 40, "windows": 10, "subset": 8, "max_evaluations": None}
QUICK = {"units": 3, "windows": 3, "subset": 3, "max_evaluations": 200}
RAW, MD = "bench_fleet.json", "benchmarks_fleet.md"
#: Where a quick run writes when --out is not given.
QUICK_OUT = Path(tempfile.gettempdir()) / "ema_phm_bench_fleet_quick"
#: The raw JSON should stay under this size (bench/results/ holds it).
MAX_JSON_BYTES = 1_000_000
MB = 1024 * 1024


@dataclass(frozen=True)
class Run:
    """One invocation: quick or not, the seed, the fleet folder, where rows and stores go."""

    quick: bool
    seed: int
    fleet_dir: Path | None
    out: Path  # raw JSON
    report: Path  # the Markdown report
    work: Path  # stores and the HTML report of this invocation
    out_given: bool = False  # --out named on the command line

    def command(self, *parts: str) -> str:
        """The command line that runs `parts` again the way this run did."""
        words = [".venv/bin/python -m bench.bench_fleet", *(["--quick"] if self.quick else [])]
        words += parts
        if self.seed != 0:
            words.append(f"--seed {self.seed}")
        if self.out_given:
            words.append(f"--out {self.out}")
        return " ".join(words)


def sizes(quick: bool) -> dict[str, Any]:
    """The fleet and budget sizes of a run."""
    return dict(QUICK if quick else FULL)


def settings(quick: bool) -> DiagnosisSettings:
    """The diagnosis settings every ingest of the run uses (quick: a tiny budget)."""
    return DiagnosisSettings(max_evaluations=sizes(quick)["max_evaluations"])


def commit() -> str:
    """The repository's commit, '+dirty' when ema_phm/ or bench/ differ from it."""
    try:
        head = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(ROOT), "status", "--porcelain", "--", "ema_phm", "bench"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def load(path: Path, quick: bool) -> dict[str, Any]:
    """The raw JSON so far (a new one when absent); SystemExit when quick and full would mix."""
    if not path.exists():
        return {"quick": quick}
    data = json.loads(path.read_text())
    if bool(data.get("quick")) != quick:
        kind = "a quick run's" if data.get("quick") else "a measurement's"
        raise SystemExit(f"{path} holds {kind} rows; use another --out (quick and full never mix)")
    return data


def save(path: Path, data: dict[str, Any]) -> None:
    """Write the raw JSON whole (through a temporary file), stamped with machine and commit."""
    data["machine"] = machine()
    data["commit"] = commit()
    text = json.dumps(data, indent=1)
    write_rows(path, data, text=text)
    if len(text) > MAX_JSON_BYTES:
        print(f"warning: {path} is {len(text) / MB:.2f} MB (over 1 MB)", file=sys.stderr)


def read_truth(fleet_dir: Path) -> dict[str, Any]:
    """The generated fleet's truth (fleet_truth.json)."""
    return json.loads((fleet_dir / TRUTH_FILE).read_text())


def check_fleet(fleet_dir: Path, quick: bool, seed: int) -> dict[str, Any]:
    """The fleet's truth; SystemExit when the folder is not the fleet this run expects."""
    if not (fleet_dir / TRUTH_FILE).is_file():
        raise SystemExit(f"{fleet_dir} holds no generated fleet (run --generate {fleet_dir})")
    truth = read_truth(fleet_dir)
    want = sizes(quick)
    got = (len(truth["units"]), truth["windows"], truth["seed"])
    if got != (want["units"], want["windows"], seed):
        raise SystemExit(
            f"{fleet_dir} holds {got[0]} units x {got[1]} windows, seed {got[2]}; this run "
            f"wants {want['units']} x {want['windows']}, seed {seed} (another folder?)"
        )
    return truth


def unit_folders(fleet_dir: Path) -> list[Path]:
    """The fleet's unit folders, sorted."""
    return sorted(p for p in fleet_dir.iterdir() if p.is_dir())


def folder_bytes(folder: Path) -> int:
    """Bytes of every file under `folder`."""
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def _stats(values: Sequence[float]) -> dict[str, Any]:
    if not values:
        return {"n": 0, "median": math.nan, "mean": math.nan, "sum": 0.0}
    return {
        "n": len(values),
        "median": statistics.median(values),
        "mean": statistics.fmean(values),
        "sum": math.fsum(values),
    }


def timing(rows: Mapping[str, Sequence[Mapping[str, Any]]]) -> dict[str, Any]:
    """Per-window isolation wall times of stored rows: all, by fit mode, first vs later.

    `first`: each unit's first fitted window (a global search); `later`: the unit's other
    fitted windows (tracked, or restarted / searched again when a tracked fit was not
    explained), the windows of a fleet in steady state.
    """
    fitted = {
        u: [r for r in rs if r["status"] != "skipped" and math.isfinite(r["wall_s"])]
        for u, rs in rows.items()
    }
    every = [r for rs in fitted.values() for r in rs]
    modes = sorted({r["fit_mode"] for r in every})
    return {
        "all": _stats([r["wall_s"] for r in every]),
        "by_mode": {m: _stats([r["wall_s"] for r in every if r["fit_mode"] == m]) for m in modes},
        "first": _stats([rs[0]["wall_s"] for rs in fitted.values() if rs]),
        "later": _stats([r["wall_s"] for rs in fitted.values() for r in rs[1:]]),
        "skipped": sum(r["status"] == "skipped" for rs in rows.values() for r in rs),
    }


def compact_rows(rows: Mapping[str, Sequence[Mapping[str, Any]]]) -> list[list[Any]]:
    """Stored rows as short lists: unit, cycle, status, fit mode, level, wall s, evaluations."""
    out = []
    for unit, rs in sorted(rows.items()):
        for r in rs:
            wall = r["wall_s"]
            out.append(
                [
                    unit,
                    int(r["cycle"]),
                    r["status"],
                    r["fit_mode"],
                    r["level"],
                    round(wall, 3) if math.isfinite(wall) else None,
                    int(r["evaluations"]),
                ]
            )
    return out


#: The columns of `compact_rows`.
ROW_COLUMNS = ["unit", "cycle", "status", "fit_mode", "level", "wall_s", "evaluations"]


def flat(rows: Mapping[str, Iterable[Mapping[str, Any]]]) -> list[Mapping[str, Any]]:
    """Every unit's rows in one list."""
    return [r for rs in rows.values() for r in rs]


class Progress:
    """Windows done of an ingest, printed every twentieth of the total (for long runs' logs)."""

    def __init__(self, label: str) -> None:
        self.label, self.t0, self.last = label, time.perf_counter(), -1

    def __call__(self, done: int, total: int) -> None:
        """Print a line when another twentieth of the windows is done."""
        step = max(1, total // 20)
        if done == total or done // step != self.last:
            self.last = done // step
            dt = time.perf_counter() - self.t0
            print(f"[{self.label}] {done}/{total} windows, {dt:.0f} s", flush=True)
