"""`ema-phm fleet`: every unit's recordings diagnosed on Dask, stored, ranked, reported.

Sub-commands: ``ingest`` (diagnose what the store does not hold yet: `fleet.ingest`),
``status`` (units ranked by risk), ``report`` (one HTML page: `fleet.report`) and
``simulate`` (a generated fleet with its truth: `fleet.generate`).  Each prints a short
text, or one JSON object with ``--json`` (`output.emit`).
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading Dask, SQLAlchemy, scipy, numba or matplotlib for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from ..limits import Limit
from .args import (
    OneLineParser,
    actuator_of,
    add_actuator_arg,
    add_fit_args,
    growth_priors_arg,
    limited,
    thresholds_arg,
)
from .import_recordings import add_stream_arg
from .output import add_json_arg, emit, wants_json

#: The store when --store is not given (fleet.store.DEFAULT_STORE, named here so that
#: building the parser does not import SQLAlchemy; a test keeps the two equal).
DEFAULT_STORE = "ema_phm_fleet.sqlite"
#: `fleet simulate`'s defaults: fleet.generate.DEGRADING_SHARE and physics.envelope.BASELINES
#: (named here for the same reason; a test keeps them equal).
DEFAULT_DEGRADING_SHARE = 0.75
DEFAULT_BASELINES = 2
_workers_arg = limited("workers", label="--workers", limit=Limit(0, 256, integer=True))
_units_arg = limited("units", label="--units", limit=Limit(1, 100000, integer=True))
_fleet_windows_arg = limited("windows", label="--windows", limit=Limit(2, 1000, integer=True))
_share_arg = limited("share", label="--degrading-share", limit=Limit(0.0, 1.0))


def add_fleet(subparsers: Any) -> None:
    """The `fleet` subcommand and its own subcommands."""
    f = subparsers.add_parser(
        "fleet", help="a fleet's recordings: diagnose on Dask, store, rank, report"
    )
    sub = f.add_subparsers(dest="fleet_cmd", required=True, parser_class=OneLineParser)
    _add_ingest(sub)
    _add_status(sub)
    _add_report(sub)
    _add_simulate(sub)


def _add_store_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--store",
        default=DEFAULT_STORE,
        metavar="FILE|URL",
        help="results store: a SQLite file or a database URL (postgresql+psycopg://user@host/db)",
    )


def _add_ingest(sub: Any) -> None:
    i = sub.add_parser(
        "ingest",
        help="diagnose every window of the recordings not yet in the store, units in parallel",
    )
    i.add_argument(
        "sources",
        nargs="+",
        help="folders of bags (any depth), bags, or manifests (.txt); with --map, a rig's "
        "bags, CSV or Parquet files (or folders of them)",
    )
    _add_store_arg(i)
    i.add_argument(
        "--map",
        default=None,
        metavar="MAP.yaml",
        help="the sources are a rig's own recordings: import them through this channel map "
        "first (as `ema-phm import`; docs/your_recordings.md)",
    )
    i.add_argument(
        "--imported",
        default=None,
        metavar="DIR",
        help="with --map: where the imported recordings are kept (default: beside a SQLite "
        "store, STORE.imported)",
    )
    add_stream_arg(i)
    i.add_argument(
        "--workers",
        type=_workers_arg,
        default=None,
        help="processes of the embedded Dask cluster (default: one per core; 0: no Dask)",
    )
    i.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on this Dask scheduler (tcp://host:port) instead of an embedded cluster",
    )
    add_fit_args(i)
    i.add_argument(
        "--horizon",
        type=limited("rul_horizon_cycles", label="--horizon"),
        default=10,
        metavar="CYCLES",
        help="RUL alarm horizon in cycles, as monitor_node's rul_horizon_cycles",
    )
    i.add_argument("--thresholds", type=thresholds_arg, default=None, metavar="T1,...")
    i.add_argument(
        "--growth-priors",
        type=growth_priors_arg,
        default=None,
        metavar="FILE.yaml|none",
        help="growth priors as for `ema-phm prognose` (default: the packaged ones)",
    )
    add_actuator_arg(i, what="the monitor believes every unit is this actuator")
    add_json_arg(i, what="the ingest's report")
    i.set_defaults(func=_cmd_ingest)


def _add_status(sub: Any) -> None:
    s = sub.add_parser("status", help="units ranked by risk: level, fault, RUL, last window")
    _add_store_arg(s)
    add_json_arg(s, what="the ranked units")
    s.set_defaults(func=_cmd_status)


def _add_report(sub: Any) -> None:
    r = sub.add_parser("report", help="one self-contained HTML page of the fleet")
    _add_store_arg(r)
    r.add_argument("--out", required=True, metavar="FILE.html", help="page to write")
    add_json_arg(r, what="what was written")
    r.set_defaults(func=_cmd_report)


def _add_simulate(sub: Any) -> None:
    s = sub.add_parser(
        "simulate", help="a generated fleet: N drawn units, baselines and a window per cycle"
    )
    s.add_argument("--out", required=True, help="folder to write (must not exist)")
    s.add_argument("--units", type=_units_arg, default=40, help="units to draw")
    s.add_argument("--windows", type=_fleet_windows_arg, default=10, help="flights per unit")
    s.add_argument(
        "--seed", type=limited("seed"), default=0, help="draws of the units and their faults"
    )
    s.add_argument(
        "--baselines",
        type=limited("baselines", label="--baselines", limit=Limit(0, 20, integer=True)),
        default=DEFAULT_BASELINES,
        help="healthy hangar windows per unit to commission it from (0: none)",
    )
    s.add_argument(
        "--degrading-share",
        type=_share_arg,
        default=DEFAULT_DEGRADING_SHARE,
        help="probability that a unit has a growing fault",
    )
    add_json_arg(s, what="what was written")
    s.set_defaults(func=_cmd_simulate)


def _settings(args: argparse.Namespace) -> Any:
    from ..fleet.settings import DiagnosisSettings

    return DiagnosisSettings(
        preset=args.preset or "",
        seed=int(args.seed),
        max_evaluations=args.max_evaluations or 0,
        # absolute: a worker on another machine, or a later ingest elsewhere, finds it
        actuator=None if args.actuator is None else str(Path(args.actuator).resolve()),
        thresholds=None if args.thresholds is None else tuple(args.thresholds),
        horizon_cycles=int(args.horizon),
        growth_priors=args.growth_priors,
    )


class _WindowBar:
    """Windows done of the ingest, on one stderr line (only when stderr is a terminal)."""

    def __init__(self) -> None:
        self.on = sys.stderr.isatty()

    def __call__(self, done: int, total: int) -> None:
        if self.on:
            frac = done / max(total, 1)
            sys.stderr.write(f"\r[{'#' * int(30 * frac):<30}] {done}/{total} windows")
            sys.stderr.flush()

    def close(self) -> None:
        if self.on:
            sys.stderr.write("\n")


def _cmd_ingest(args: argparse.Namespace) -> int:
    from ..fleet.ingest import ingest
    from ..fleet.store import Store

    settings = _settings(args)
    if args.stream and args.map is None:
        raise ConfigError("--stream reads a rig's bags through --map: give the channel map")
    sources = _imported(args) if args.map is not None else args.sources
    bar = _WindowBar()
    with Store(args.store) as store:
        try:
            report = ingest(
                sources,
                store,
                settings,
                workers=args.workers,
                scheduler=args.scheduler,
                progress=bar,
            )
        finally:
            bar.close()
    emit(args, report.as_dict(), report.lines())
    if not (report.recordings_read or report.recordings_known):
        reason = report.refused[0] if report.refused else "no recording found"
        more = f" (and {len(report.refused) - 1} more refused)" if len(report.refused) > 1 else ""
        print(f"ema-phm: error: no recording could be used: {reason}{more}", file=sys.stderr)
        return 2
    return 1 if report.failed else 0


def _imported(args: argparse.Namespace) -> list[str]:
    """Import the raw sources through --map (`ema-phm import`); the folder to ingest."""
    from ..importing.channel_map import load_channel_map
    from ..importing.importer import import_recordings
    from ..importing.sources import find_sources

    folder = args.imported
    if folder is None:
        if "://" in args.store:
            raise ConfigError("--map with a database URL store needs --imported DIR")
        folder = f"{args.store}.imported"
    cmap = load_channel_map(args.map)
    report = import_recordings(
        find_sources(args.sources), cmap, actuator_of(args), folder, stream=args.stream
    )
    if not wants_json(args):
        print("\n".join(report.lines()))
    return [folder]


def _cmd_status(args: argparse.Namespace) -> int:
    from ..fleet.store import Store
    from ..fleet.summary import read_view

    with Store(args.store, create=False) as store:
        view = read_view(store)
    emit(args, view.as_dict(), _status_lines(view))
    return 0


def _status_lines(view: Any) -> list[str]:
    """The text of `fleet status`: a line per unit, most at risk first."""
    from ..fleet.view import not_seen

    lines = [
        f"{view.store}: {len(view.units)} units, most at risk first",
        f"{'unit':<14} {'level':<7} {'fault':<18} {'RUL p5/p50/p95 [cycles]':<26} last  windows",
    ]
    for u in view.units:
        rul = (
            "-"
            if u.rul_cycles is None
            else "/".join(f"{v:g}" for v in (u.rul_cycles.p5, u.rul_cycles.p50, u.rul_cycles.p95))
        )
        last = "-" if u.last_cycle is None else str(u.last_cycle)
        lines.append(
            f"{u.unit_id:<14} {u.level:<7} {u.fault or '-':<18} {rul:<26} {last:<5} "
            f"{u.counted}/{u.windows}"
            + ("" if u.commissioned else "  (not commissioned)")
            + (f"  (not seen: {', '.join(hidden)})" if (hidden := not_seen(u)) else "")
        )
    return lines


def _cmd_report(args: argparse.Namespace) -> int:
    from ..fleet.report import write_report
    from ..fleet.store import Store
    from ..fleet.summary import read_view

    with Store(args.store, create=False) as store:
        view = read_view(store)
    written = write_report(view, args.out)
    emit(
        args,
        {"report": str(written), "store": view.store, "units": len(view.units)},
        f"wrote {written}: {len(view.units)} units",
    )
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ..fleet.generate import TRUTH_FILE, generate_fleet

    drawn = generate_fleet(
        args.out,
        units=args.units,
        windows=args.windows,
        seed=args.seed,
        degrading_share=args.degrading_share,
        baselines=args.baselines,
    )
    degrading = sum(d.fault is not None for d in drawn)
    emit(
        args,
        {
            "fleet": str(args.out),
            "units": len(drawn),
            "degrading": degrading,
            "windows": args.windows,
            "baselines": args.baselines,
            "seed": args.seed,
            "truth": str(Path(args.out) / TRUTH_FILE),
        },
        f"wrote {args.out}: {len(drawn)} units ({degrading} with a growing fault), "
        f"{args.windows} flights each, truth in {TRUTH_FILE}",
    )
    return 0
