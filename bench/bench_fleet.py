#!/usr/bin/env python3
"""Fleet benchmark (issue 22): Dask scaling and overhead, worker memory, accuracy, sizing.

Usage (from the repo root; each phase alone, the raw JSON accumulates):
    .venv/bin/python -m bench.bench_fleet --generate /tmp/ema_fleet_40x10  # the fleet, timed
    nohup .venv/bin/python -m bench.bench_fleet --scaling --dir /tmp/ema_fleet_40x10 \
        > /tmp/fleet_scaling.log 2>&1 &
    nohup .venv/bin/python -m bench.bench_fleet --fleet --dir /tmp/ema_fleet_40x10 \
        > /tmp/fleet_fleet.log 2>&1 &
    .venv/bin/python -m bench.bench_fleet --report        # docs/benchmarks_fleet.md
    .venv/bin/python -m bench.bench_fleet --quick --generate /tmp/q --scaling --fleet --report

``--generate DIR`` writes the simulated fleet (`fleet.generate.generate_fleet`: 40 units x
10 flights, 2 hangar baselines each, --seed) into DIR unless it exists, timed.
``--scaling`` ingests the first --units-subset units (default 8) three times into fresh
SQLite stores: a plain loop in this process (``workers=0``), an embedded Dask cluster of 1
worker and of 2; it records wall times, windows/s, the 2-vs-1 ratio, Dask's overhead per
window (with and without the cluster's start-up), each window's isolation time, the
workers' RSS, and whether the three stores hold identical results.  ``--fleet`` ingests
the whole fleet with the default embedded cluster (one worker per core), reads the view,
writes the HTML report and scores the named faults and RULs against the fleet's truth.
``--report`` renders docs/benchmarks_fleet.md from the JSON alone (the hand-written
analysis below its marker is kept), with a sizing table on paper for larger fleets.

The raw JSON (bench/results/bench_fleet.json) is written after each phase.  Stores, the HTML
report and the subset manifest live in a temporary folder (--work keeps them).  ``--quick`` (3
units x 3 flights, 200 LF evaluations per fit) checks that the script works: its rows and
report go to a temporary folder unless --out is given (never docs/ nor bench/results/),
labelled "quick, not a measurement".
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from bench.fleet.common import MD, QUICK_OUT, RAW, Run, load, save, sizes
from bench.harness import DOCS, RESULTS, cli, out_dirs


def _parser() -> argparse.ArgumentParser:
    ap = cli(
        __doc__,
        quick="a tiny fleet and budget: checks the script works (not a measurement)",
        seed=(0, "the generated fleet's seed"),
        out=(
            None,
            f"folder of {RAW} and {MD} (default bench/results/ and docs/; --quick: {QUICK_OUT})",
        ),
    )
    ap.add_argument("--generate", metavar="DIR", default=None, help="generate the fleet here")
    ap.add_argument("--dir", default=None, help="the fleet (default: --generate's, the JSON's)")
    ap.add_argument("--scaling", action="store_true", help="plain loop vs 1 vs 2 workers")
    ap.add_argument("--fleet", action="store_true", help="the whole fleet, scored")
    ap.add_argument("--report", action="store_true", help=f"write {MD} from the JSON")
    ap.add_argument("--units-subset", type=int, default=None, help="units of --scaling")
    ap.add_argument("--work", default=None, help="keep stores and HTML here (default: temp)")
    return ap


def _out(args: argparse.Namespace) -> tuple[Path, Path]:
    """(folder of the raw JSON, folder of the report), made if missing."""
    if args.out is None and args.quick:
        return out_dirs(str(QUICK_OUT))
    if args.out is None:
        return out_dirs(None)
    out = Path(args.out).resolve()
    for kept in (DOCS.resolve(), RESULTS.resolve()):
        if args.quick and (out == kept or kept in out.parents):
            raise SystemExit("--quick never writes to docs/ or bench/results/: name another --out")
    return out_dirs(str(out))


def _phases(run: Run, args: argparse.Namespace, data: dict) -> None:
    """Run the phases asked for, saving the JSON after each."""
    from bench.fleet.accuracy import run_fleet  # noqa: PLC0415
    from bench.fleet.gen import run_generate  # noqa: PLC0415
    from bench.fleet.report import write  # noqa: PLC0415
    from bench.fleet.scaling import run_scaling  # noqa: PLC0415

    raw = run.out / RAW
    if args.generate:
        data["generate"] = run_generate(run, Path(args.generate).resolve(), data.get("generate"))
        save(raw, data)
    if args.scaling:
        data["scaling"] = run_scaling(run, args.units_subset or sizes(run.quick)["subset"])
        save(raw, data)
    if args.fleet:
        data["fleet"] = run_fleet(run)
        save(raw, data)
    if args.report:
        if not any(data.get(k) for k in ("generate", "scaling", "fleet")):
            raise SystemExit(f"{raw}: nothing measured yet (run a phase first)")
        data["report_command"] = run.command("--report")
        save(raw, data)
        write(run.report / MD, data)
        print(f"wrote {run.report / MD}")


def main() -> int:
    """Run the phases asked for (none: --report)."""
    args = _parser().parse_args()
    if not (args.generate or args.scaling or args.fleet):
        args.report = True
    out, report = _out(args)
    data = load(out / RAW, args.quick)
    fleet_dir = args.dir or args.generate or (data.get("generate") or {}).get("dir")
    if (args.scaling or args.fleet) and fleet_dir is None:
        raise SystemExit("name the fleet: --dir DIR (or --generate DIR)")
    with tempfile.TemporaryDirectory(prefix="bench_fleet_") as tmp:
        work = Path(args.work or tmp).resolve()
        work.mkdir(parents=True, exist_ok=True)
        run = Run(
            quick=args.quick,
            seed=args.seed,
            fleet_dir=None if fleet_dir is None else Path(fleet_dir).resolve(),
            out=out,
            report=report,
            work=work,
            out_given=args.out is not None,
        )
        _phases(run, args, data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
