"""`ema-phm import`: a rig's bags and tables, through a channel map, into ema_phm recordings.

The map's format and a worked example: docs/your_recordings.md; the work: ema_phm.importing.
"""

# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
from typing import Any

from .args import actuator_of, add_actuator_arg
from .output import add_json_arg, emit


def add_import(subparsers: Any) -> None:
    """The `import` subcommand."""
    p = subparsers.add_parser(
        "import",
        help="turn a rig's ROS 2 bags (MCAP, sqlite3) or CSV / Parquet files into "
        "recordings every command reads, through a channel map",
    )
    p.add_argument("sources", nargs="+", metavar="SRC", help="bag folders, .csv or .parquet files")
    p.add_argument(
        "--map",
        required=True,
        metavar="MAP.yaml",
        help="channel map: where each monitor channel comes from (docs/your_recordings.md)",
    )
    add_actuator_arg(p, what="whose sample rate, gear ratio, pole pairs and current filter apply")
    p.add_argument(
        "--out", required=True, help="folder of the recordings (created; existing ones kept)"
    )
    p.add_argument("--hardware-id", default=None, help="the unit (over the map and file names)")
    p.add_argument("--run-id", default=None, help="the unit's life (over the map and file names)")
    p.add_argument(
        "--purpose",
        choices=("baseline", "diagnose"),
        default=None,
        help="baseline: healthy commissioning windows (over the map and file names)",
    )
    add_stream_arg(p)
    add_json_arg(p, what="what was imported")
    p.set_defaults(func=_cmd_import)


def add_stream_arg(p: argparse.ArgumentParser) -> None:
    """``--stream``: bags read once, in memory bounded by the window (`importing.stream`)."""
    p.add_argument(
        "--stream",
        action="store_true",
        help="read each bag once in time order, in memory bounded by the window, and cut "
        "the windows as monitor_node does live (bags only; docs/your_recordings.md)",
    )


def _cmd_import(args: argparse.Namespace) -> int:
    from ..importing.channel_map import load_channel_map
    from ..importing.importer import import_recordings
    from ..importing.sources import find_sources

    cmap = load_channel_map(args.map)
    overrides = {
        k: v
        for k, v in (
            ("hardware_id", args.hardware_id),
            ("run_id", args.run_id),
            ("purpose", args.purpose),
        )
        if v is not None
    }
    report = import_recordings(
        find_sources(args.sources),
        cmap,
        actuator_of(args),
        args.out,
        overrides=overrides,
        stream=args.stream,
    )
    emit(args, report.as_dict(), report.lines())
    return 0
