"""`ema-phm play BAG`: publish a recorded bag into the live ROS 2 graph.

The rclpy part is imported only when the command runs (`ema_phm.ros.player`), so
the rest of the CLI works without ROS.
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import ConfigError
from ..telemetry.player import MONITOR_INPUTS, check_rate
from .output import add_json_arg, emit, wants_json


def _rate(text: str) -> float:
    """Argparse `type=` for --rate: a number in LIMITS["play_rate"] ([0.001, 1000])."""
    try:
        return check_rate(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _count(text: str) -> int:
    """Argparse `type=` for --wait-for-subscribers: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    return value


def add_play(subparsers: Any) -> None:
    """The `play` subcommand."""
    p = subparsers.add_parser(
        "play",
        help="publish a recorded bag into the live ROS 2 graph",
        description=(
            "Publish a rosbag2 MCAP bag (ours or any with our topics) with the QoS the "
            "nodes use (run_info and ground truth latched), at the recorded timing scaled "
            "by --rate, so a running monitor_node fits it as if live."
        ),
    )
    p.add_argument("bag", help="rosbag2 directory (or its .mcap file)")
    p.add_argument("--rate", type=_rate, default=1.0, help="speed factor in [0.001, 1000]")
    p.add_argument("--loop", action="store_true", help="start over after the last message")
    p.add_argument(
        "--topics",
        nargs="+",
        default=None,
        metavar="TOPIC",
        help=f"topics to play (default: those of {', '.join(MONITOR_INPUTS)} the bag has)",
    )
    p.add_argument(
        "--namespace",
        default="",
        help="namespace to publish in: /ema/... topics go to <ns>/ema/... (default: none)",
    )
    p.add_argument(
        "--wait-for-subscribers",
        type=_count,
        default=1,
        metavar="N",
        help="hold the first message until the telemetry topic has N subscribers "
        "(0 = start at once)",
    )
    add_json_arg(p, what="what was published (on stdout; the text goes to stderr)")
    p.set_defaults(func=_cmd_play)


def _cmd_play(args: argparse.Namespace) -> int:
    from ..ros.common import StopSignals
    from ..ros.player import play_bag

    def waiting(topic: str, n: int) -> None:
        print(f"ema-phm play: waiting for {n} subscriber(s) on {topic}", file=sys.stderr)

    signals = StopSignals()
    signals.install()
    try:
        result = play_bag(
            args.bag,
            rate=args.rate,
            loop=args.loop,
            topics=args.topics,
            namespace=args.namespace,
            wait_for_subscribers=args.wait_for_subscribers,
            stop=signals.requested,
            on_waiting=waiting,
        )
    finally:
        signals.restore()
    stopped = " (stopped)" if signals.requested.is_set() else ""
    if wants_json(args):
        data = {
            "bag": str(args.bag),
            "published": result.published,
            "stopped": signals.requested.is_set(),
            "unacknowledged": list(result.unacknowledged),
        }
        emit(args, data, "")
        return 0
    print(f"ema-phm play: published {result.published} message(s){stopped}", file=sys.stderr)
    if result.unacknowledged:
        print(
            "ema-phm play: warning: not every subscriber acknowledged "
            f"{', '.join(result.unacknowledged)}",
            file=sys.stderr,
        )
    return 0
