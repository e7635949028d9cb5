"""Shared harness of the bench/ scripts: CLI flags, machine stamp, process pool, raw rows.

The benchmarks that keep raw rows (bench_isolation, bench_realistic, bench_robust,
bench_prognostics, bench_external, bench_fleet, bench_commissioning_misfit; the study
bench_severity_bias) write them first (JSON, in bench/results/ unless --out says otherwise) and
render their report from them, so a report can be rewritten from stored rows without
simulating again.  The scripts run
as modules from the repository root (``python -m bench.bench_isolation``,
``python -m bench.studies.bench_excitation``); nothing here edits ``sys.path``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
from collections.abc import Callable, Iterable
from multiprocessing.pool import Pool
from pathlib import Path
from typing import Any

from ema_phm.tools.benchmark import machine

ROOT = Path(__file__).resolve().parents[2]

__all__ = [
    "ROOT",
    "DOCS",
    "OUT_HELP",
    "RESULTS",
    "cli",
    "command_line",
    "git_commit",
    "halves",
    "machine",
    "out_dirs",
    "pool",
    "read_rows",
    "stamp",
    "write_report",
    "write_rows",
]

#: Where the benchmarks' reports (Markdown, PNG) live by default.
DOCS = ROOT / "docs"
#: Where the benchmarks' raw rows (JSON) live by default: out of the docs tree.
RESULTS = ROOT / "bench" / "results"


def cli(
    doc: str | None,
    *,
    raw_description: bool = True,
    quick: str | None = None,
    seed: tuple[int, str | None] | None = None,
    jobs: tuple[int, str | None] | None = None,
    out: tuple[str, str | None] | None = None,
) -> argparse.ArgumentParser:
    """A parser with the common flags a script asks for (each given as (default, help)).

    `quick`: the help of ``--quick``; `seed`, `jobs`, `out`: (default, help) of ``--seed``,
    ``--jobs`` and ``--out``.  The script adds its own flags to what this returns.
    """
    kw: dict[str, Any] = {"description": doc}
    if raw_description:
        kw["formatter_class"] = argparse.RawDescriptionHelpFormatter
    ap = argparse.ArgumentParser(**kw)
    if quick is not None:
        ap.add_argument("--quick", action="store_true", help=quick)
    for flag, spec, kind in (("--seed", seed, int), ("--jobs", jobs, int), ("--out", out, str)):
        if spec is not None:
            default, text = spec
            ap.add_argument(flag, type=kind, default=default, help=text)
    return ap


def command_line(module: str, *fixed: str, flags: Iterable[tuple[str, Any, Any]] = ()) -> str:
    """How to re-run a benchmark: `fixed` flags, then each (flag, value, default) that differs.

    `module` is the benchmark's name under bench/ (``bench_robust``: it runs as
    ``python -m bench.bench_robust``).  A flag whose default is None is left out while its
    value is empty (None, 0, '').
    """
    parts = [f".venv/bin/python -m bench.{module}", *fixed]
    for flag, value, default in flags:
        if value == default or (default is None and not value):
            continue
        parts.append(f"{flag} {value}")
    return " ".join(parts)


#: The help of a benchmark's ``--out`` (default None: `out_dirs`).
OUT_HELP = "folder of the raw rows and the report (default: rows bench/results/, report docs/)"


def out_dirs(out: str | None) -> tuple[Path, Path]:
    """(folder of the raw rows, folder of the report) for ``--out``, both made if missing.

    Without ``--out``: RESULTS (bench/results/) and DOCS (docs/); with it, that folder for both.
    """
    rows, report = (RESULTS, DOCS) if out is None else (Path(out), Path(out))
    for folder in (rows, report):
        folder.mkdir(parents=True, exist_ok=True)
    return rows, report


def git_commit() -> dict[str, Any]:
    """The checkout's short commit, and whether ema_phm/ differs from it (`dirty`)."""
    import subprocess  # noqa: PLC0415 - only the stamp runs git

    def git(*args: str) -> str:
        out = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True)
        return out.stdout.strip()

    return {
        "commit": git("rev-parse", "--short", "HEAD"),
        "dirty": bool(git("status", "--porcelain", "ema_phm")),
    }


def stamp(command: str) -> dict[str, Any]:
    """The machine and the command line a set of raw rows was measured with."""
    return {"machine": machine(), "command": command}


def write_rows(path: Path, data: Any, *, text: str | None = None) -> None:
    """Write the raw rows (`text`, or `data` as indented JSON) through a temporary file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1) if text is None else text)
    tmp.replace(path)


#: Below this line a report's hand-written analysis is kept when the report is rewritten.
KEEP_MARKER = "<!-- kept when regenerated: hand-written analysis below -->"


def write_report(path: Path, text: str, marker: str = KEEP_MARKER) -> None:
    """Write a report, keeping what stood below `marker` in the one it replaces."""
    kept = None
    if path.exists():
        old = path.read_text()
        if marker in old:
            kept = old[old.index(marker) + len(marker) :]
    path.write_text(text + "\n" + marker + (kept or "\n"))


def read_rows(path: Path) -> Any:
    """The raw rows a benchmark stored (`write_rows`)."""
    return json.loads(path.read_text())


def pool(jobs: int, initializer: Callable[[], None] | None = None, method: str = "fork") -> Pool:
    """A process pool of `jobs` workers, each running `initializer` (e.g. a JIT warm-up)."""
    return mp.get_context(method).Pool(jobs, initializer=initializer)


def halves(items: list[dict], key: str = "index") -> dict[str, list[dict]]:
    """All items, those with an even `key` (tuned on) and those with an odd one (held out)."""
    return {
        "all": items,
        "even": [s for s in items if s[key] % 2 == 0],
        "odd": [s for s in items if s[key] % 2 == 1],
    }
