"""Replaying a bag, without rclpy: what to publish, with which QoS, and when.

`Recording.open` reads the chosen topics of a rosbag2 MCAP bag (ours, or any with our
topics) as raw CDR records in log-time order, and gives each topic the QoS to publish
it with: ours from `ema_phm.telemetry.qos` (run_info and ground truth latched,
telemetry 1000 deep), any other topic latched if every profile the bag recorded for it
is transient local.  `play` hands the records to a publish function at their recorded
log times, scaled by `rate`, and starts over with `loop`.  The publisher itself is
`ema_phm.ros.player`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import BagError
from ..limits import check
from .bag_reader import open_bag
from .qos import TopicQos, qos_of
from .wire import GROUND_TRUTH_TOPIC, RUN_INFO_TOPIC, TELEMETRY_TOPIC

#: Topics played when none are named: what a monitor_node listens to.
MONITOR_INPUTS: tuple[str, ...] = (RUN_INFO_TOPIC, GROUND_TRUTH_TOPIC, TELEMETRY_TOPIC)
#: Longest sleep between two looks at the stop flag [s].
POLL_S = 0.1


@dataclass(frozen=True)
class Record:
    """One message as it was recorded: topic, log time and CDR bytes."""

    topic: str
    t_ns: int
    data: bytes


@dataclass(frozen=True)
class PlayTopic:
    """A topic to publish: its type, the QoS to offer and how many messages it has."""

    name: str
    msgtype: str
    qos: TopicQos
    count: int


def check_rate(rate: float | str) -> float:
    """`rate` (a number, or its text as argparse gives it) as a float in LIMITS["play_rate"].

    ConfigError naming the value otherwise.
    """
    return float(check("play_rate", rate, label="rate"))


def _latched_in_bag(profiles: Sequence[object]) -> bool:
    """Whether every recorded offered QoS profile is transient local (rosbag2's rule)."""
    names = [getattr(getattr(p, "durability", None), "name", "") for p in profiles]
    return bool(names) and all(n == "TRANSIENT_LOCAL" for n in names)


@dataclass(frozen=True)
class Recording:
    """The records to play from one bag, in log-time order, and their topics."""

    path: Path
    topics: dict[str, PlayTopic]
    records: tuple[Record, ...]

    @classmethod
    def open(cls, path: str | Path, topics: Sequence[str] | None = None) -> Recording:
        """Read `topics` of the bag at `path` (default: the `MONITOR_INPUTS` it has).

        BagError if the bag cannot be read, has none of the topics, a named topic is
        missing, or one topic is recorded with two types.
        """
        path = Path(path)
        with open_bag(path) as reader:
            present = {c.topic for c in reader.connections}
            if topics is None:
                wanted = [t for t in MONITOR_INPUTS if t in present]
                if not wanted:
                    raise BagError(
                        f"bag {path} has none of {', '.join(MONITOR_INPUTS)} "
                        f"(topics: {', '.join(sorted(present)) or 'none'})"
                    )
            else:
                wanted = list(dict.fromkeys(topics))
                if missing := [t for t in wanted if t not in present]:
                    raise BagError(
                        f"bag {path} has no topic {', '.join(missing)} "
                        f"(topics: {', '.join(sorted(present)) or 'none'})"
                    )
            conns = [c for c in reader.connections if c.topic in wanted]
            found: dict[str, PlayTopic] = {}
            for c in conns:
                known = found.get(c.topic)
                if known is not None and known.msgtype != c.msgtype:
                    raise BagError(
                        f"bag {path}: {c.topic} is recorded as both {known.msgtype} "
                        f"and {c.msgtype}"
                    )
                profiles = list(getattr(c.ext, "offered_qos_profiles", []) or [])
                qos = qos_of(c.topic, latched=_latched_in_bag(profiles))
                count = (known.count if known else 0) + int(c.msgcount)
                found[c.topic] = PlayTopic(c.topic, c.msgtype, qos, count)
            records = tuple(
                Record(conn.topic, int(t_ns), bytes(raw))
                for conn, t_ns, raw in reader.messages(connections=conns)
            )
        if not records:
            raise BagError(f"bag {path}: {', '.join(wanted)} hold no messages")
        return cls(path, {t: found[t] for t in wanted if t in found}, records)

    @property
    def duration_s(self) -> float:
        """Log time from the first to the last record [s]."""
        return (self.records[-1].t_ns - self.records[0].t_ns) / 1e9


def play(
    records: Sequence[Record],
    publish: Callable[[Record], None],
    *,
    rate: float = 1.0,
    loop: bool = False,
    stop: threading.Event | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> int:
    """Publish `records` at their log times scaled by `rate`; return how many went out.

    The first record goes out at once, record i at (t_i - t_0) / rate s later; a
    publish that falls behind is not caught up by skipping.  With `loop` the whole
    sequence starts over after the last record (log times as recorded, so sample
    times jump back), until `stop` is set.  `stop` ends the replay between two records.
    """
    rate = check_rate(rate)
    stop = stop or threading.Event()
    if not records:
        return 0
    sent = 0
    t0 = records[0].t_ns
    while not stop.is_set():
        start = clock()
        for rec in records:
            due = start + (rec.t_ns - t0) / 1e9 / rate
            while (delay := due - clock()) > 0:
                if stop.wait(min(delay, POLL_S)):
                    return sent
            if stop.is_set():
                return sent
            publish(rec)
            sent += 1
        if not loop:
            break
    return sent
