"""How every `ema-phm` command prints its result: a short text, or one JSON object (--json).

`add_json_arg` gives a subcommand its ``--json`` option and `emit` prints the result: the
text by default, the JSON object (one line) with ``--json``.  Progress and warnings go to
stderr either way, so the JSON on stdout stays one parseable object.
"""

from __future__ import annotations

import argparse
import json
from typing import Any, Iterable, Mapping


def add_json_arg(p: argparse.ArgumentParser, *, what: str = "the result") -> None:
    """--json: print `what` as one JSON object instead of text."""
    p.add_argument(
        "--json", action="store_true", help=f"print {what} as one JSON object instead of text"
    )


def wants_json(args: argparse.Namespace) -> bool:
    """True when the command was asked for JSON (--json)."""
    return bool(getattr(args, "json", False))


def emit(args: argparse.Namespace, data: Mapping[str, Any], text: str | Iterable[str]) -> None:
    """Print `data` as one JSON line with --json, else `text` (a string, or its lines)."""
    if wants_json(args):
        print(json.dumps(data), flush=True)
    else:
        print(text if isinstance(text, str) else "\n".join(text), flush=True)
