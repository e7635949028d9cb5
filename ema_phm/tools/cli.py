"""`ema-phm` command line.  Imports rclpy only for `demo` without --offline and for `play`.

Exit codes: 0 ok, 2 bad input (one line on stderr naming the problem), 1 other failures.
Each subcommand but the small `recover` and `bench` (here) lives in its own module
(simulate, diagnose, prognose, demo, play, fleet); this module assembles them.
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import sys
import warnings
from typing import Any, Callable, Sequence

from ..errors import EmaPhmError
from .args import OneLineParser
from .demo import add_demo
from .diagnose import add_calibrate, add_isolate
from .fleet import add_fleet
from .import_recordings import add_import
from .output import add_json_arg, emit
from .play import add_play
from .prognose import add_prognose
from .simulate import add_simulate


def _cmd_recover(args: argparse.Namespace) -> int:
    from ..telemetry.bags import recover_bag

    report = recover_bag(args.bag, out=args.out)
    data = {
        "source": str(report.source),
        "out": None if report.out is None else str(report.out),
        "messages": dict(report.messages),
        "total_messages": report.total_messages,
        "chunks": report.chunks,
        "file_bytes": report.file_bytes,
        "bytes_dropped": report.bytes_dropped,
        "complete": report.complete,
        "stop_reason": report.stop_reason,
        "skipped_topics": list(report.skipped_topics),
        "damaged": list(report.damaged),
    }
    emit(args, data, report.summary())
    return 0


def _add_recover(subparsers: Any) -> None:
    """The `recover` subcommand."""
    r = subparsers.add_parser(
        "recover",
        help="rebuild a recording whose writer was killed (no metadata.yaml or no MCAP "
        "footer) from its complete chunks, as a finished bag",
    )
    r.add_argument(
        "bag", help="bag folder or .mcap file of the unfinished recording (left untouched)"
    )
    r.add_argument(
        "--out", default=None, help="new bag folder to write (default: BAG_recovered beside it)"
    )
    add_json_arg(r, what="what was recovered")
    r.set_defaults(func=_cmd_recover)


def _cmd_bench(args: argparse.Namespace) -> int:
    from .benchmark import measure_models

    res = measure_models(cold_start=not args.no_cold_start)
    emit(args, res, [f"{key:>22}: {val}" for key, val in res.items()])
    return 0


def _add_bench(subparsers: Any) -> None:
    """The `bench` subcommand."""
    b = subparsers.add_parser("bench", help="measure speed/accuracy")
    b.add_argument("what", choices=("models",), help="what to measure: the HF and LF models")
    add_json_arg(b, what="the measurements")
    b.add_argument(
        "--no-cold-start", action="store_true", help="skip the cold-start subprocess measurement"
    )
    b.set_defaults(func=_cmd_bench)


#: Every subcommand, and the function that adds it to the parser.
SUBCOMMANDS: dict[str, Callable[[Any], None]] = {
    "simulate": add_simulate,
    "isolate": add_isolate,
    "recover": _add_recover,
    "calibrate": add_calibrate,
    "bench": _add_bench,
    "demo": add_demo,
    "prognose": add_prognose,
    "play": add_play,
    "fleet": add_fleet,
    "import": add_import,
}


def build_parser() -> argparse.ArgumentParser:
    """The `ema-phm` argument parser with every subcommand of `SUBCOMMANDS`."""
    p = OneLineParser(
        prog="ema-phm",
        description="Model-based fault isolation for EMAs (HF 'real EMA' + LF monitor).",
    )
    subparsers = p.add_subparsers(dest="cmd", required=True, parser_class=OneLineParser)
    for add in SUBCOMMANDS.values():
        add(subparsers)
    return p


def _one_line_warning(
    message: Warning | str, category: type[Warning], *_: object, **__: object
) -> None:
    """Warnings the package emits on purpose (a recovered bag) as one stderr line each."""
    print(f"ema-phm: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """The `ema-phm` command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning
            return int(args.func(args))
    except EmaPhmError as exc:
        print(f"ema-phm: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ema-phm: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
