"""Reading bags: `read_window`, `read_messages` and `recover_bag`.

A recording left unfinished is read up to its last complete chunk, a corrupt one without its
damaged chunks (`bag_recovery`); `recover_bag` writes what was kept as a bag of its own.
"""

from __future__ import annotations

import hashlib
import json
import stat
from collections.abc import Generator, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import (
    Connection,
)
from rosbags.rosbag2 import Reader

from ..domain.faults import LABELS
from ..domain.window import Window
from ..errors import BagError, WindowError
from .bag_codec import BAG_TOPIC_TYPES, TYPESTORE, one_line, typestore_for
from .bag_recorder import new_bag
from .bag_recovery import (
    RecoveryReport,
    SalvagedMcap,
    default_recovery_path,
    mcap_state,
    verify_mcap,
)
from .wire import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    WINDOW_TOPIC,
    decode_ground_truth,
    decode_telemetry,
)

_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISDIR, "a directory"),
)
#: What a message about a foreign recording suggests.
IMPORT_HINT = "a rig's bag, CSV or Parquet file goes in with `ema-phm import --map MAP.yaml`"
#: Files of a bag directory that a reader may open.
_BAG_FILE_SUFFIXES = (".yaml", ".mcap", ".db3", ".zstd")


def _require_regular_file(path: Path, *, what: str) -> None:
    """BagError unless `path` (symlinks followed) is a regular file.

    Opening a FIFO would block forever.
    """
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise BagError(f"{what} {path} does not exist") from None
    except OSError as exc:
        raise BagError(f"cannot inspect {what} {path}: {exc.strerror}") from None
    if not stat.S_ISREG(mode):
        kind = next(
            (name for test, name in _KINDS if test(mode)), f"not a regular file (mode {mode:o})"
        )
        raise BagError(f"{what} {path} is {kind}, not a regular file; refusing to open it")


def _bag_files(bag: Path) -> list[Path]:
    """The files of bag directory `bag` a reader may open, each checked to be a regular file."""
    try:
        files = sorted(
            p for p in bag.iterdir() if p.name.endswith(_BAG_FILE_SUFFIXES) or ".mcap." in p.name
        )
    except OSError as exc:
        raise BagError(f"cannot list bag {bag}: {exc.strerror}") from None
    for f in files:
        _require_regular_file(f, what="bag file")
    return files


def locate_mcap(path: Path) -> Path:
    """The one ``.mcap`` of a bag directory, or `path` when it is a ``.mcap`` file (regular)."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        raise BagError(f"bag {path} does not exist")
    if not path.is_dir():
        _require_regular_file(path, what="bag")
        if path.suffix != ".mcap":
            raise BagError(
                f"{path} is not a rosbag2 bag: expected a directory with metadata.yaml (or a "
                f".mcap file); {IMPORT_HINT}"
            )
        return path
    mcaps = [f for f in _bag_files(path) if f.suffix == ".mcap"]
    if len(mcaps) != 1:
        found = (
            "no .mcap file"
            if not mcaps
            else f"{len(mcaps)} .mcap files ({', '.join(m.name for m in mcaps)})"
        )
        raise BagError(
            f"{path} is not a rosbag2 bag: no metadata.yaml and {found} in the directory; "
            f"{IMPORT_HINT}"
        )
    return mcaps[0]


def digest_of(path: str | Path) -> str:
    """SHA-256 (hex) of a bag's ``.mcap`` bytes: a recording's identity, whatever its name."""
    h = hashlib.sha256()
    with locate_mcap(Path(path)).open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _mcap_to_salvage(path: Path) -> Path | None:
    """The .mcap to read record by record, None for a sound finished bag (rosbags reads it).

    That is an unfinished recording, or a finished one whose CRCs fail (`verify_mcap`).
    """
    if path.is_dir():
        files = _bag_files(path)
        if path / "metadata.yaml" not in files:
            return locate_mcap(path)
        mcaps = [f for f in files if f.suffix == ".mcap"]
        for f in mcaps:
            if mcap_state(f) == "unfinished":
                raise BagError(
                    f"bag {path}: {f.name} is truncated (no MCAP footer) though metadata.yaml "
                    "says the "
                    f"recording finished; `ema-phm recover {path}` rebuilds its complete chunks"
                )
        for f in mcaps:
            if mcap_state(f) == "finished" and (problems := verify_mcap(f)):
                if len(mcaps) == 1:
                    return f
                raise BagError(f"bag {path}: {f.name} is damaged: {'; '.join(problems)}")
        return None
    mcap = locate_mcap(path)
    state = mcap_state(mcap)
    return mcap if state == "unfinished" or (state == "finished" and verify_mcap(mcap)) else None


@contextmanager
def open_bag(path: Path) -> Iterator[Reader | SalvagedMcap]:
    """The bag at `path` opened for reading: a finished one checked, an unfinished salvaged."""
    if not path.exists() and not path.is_symlink():
        raise BagError(f"bag {path} does not exist")
    salvage = _mcap_to_salvage(path)
    source: Reader | SalvagedMcap
    if salvage is not None:
        source = SalvagedMcap(salvage)
        source.warn(stacklevel=4)  # _open_bag, contextlib, read_* -> their caller
    else:
        try:
            source = Reader(path)
            source.open()
        except Exception as exc:
            raise BagError(
                f"cannot open bag {path} (corrupt, truncated or not a rosbag2 MCAP bag): "
                f"{one_line(exc)}"
            ) from None
    try:
        yield source
    except BagError:
        raise
    except Exception as exc:
        raise BagError(
            f"cannot read bag {path} (corrupt or truncated?): {one_line(exc)}"
        ) from None
    finally:
        if isinstance(source, Reader):
            with suppress(Exception):
                source.close()


def read_messages(
    path: str | Path, topics: Sequence[str] | None = None
) -> Generator[tuple[str, str, int, Any], None, None]:
    """Yield (topic, msgtype, log time ns, decoded message) in log-time order.

    An unfinished recording is read up to its last complete chunk, with a `BagRecoveredWarning`.
    """
    path = Path(path)
    with open_bag(path) as reader:
        conns = [c for c in reader.connections if topics is None or c.topic in topics]
        if not conns:
            return
        store = typestore_for(conns)
        for conn, t_ns, raw in reader.messages(connections=conns):
            yield conn.topic, conn.msgtype, t_ns, store.deserialize_cdr(raw, conn.msgtype)


def telemetry_rows(
    path: Path, index: int, msg: Any, *, topic: str = TELEMETRY_TOPIC
) -> np.ndarray:
    """The n x len(CHANNELS) samples of message `index` of `topic` (legacy n x 7: NaN temperature).

    BagError names bag, topic and layout.
    """
    try:
        return decode_telemetry(msg, topic=topic)
    except WindowError as exc:
        raise BagError(f"bag {path}: message {index}: {exc}") from None


def ground_truth(path: Path, msg: Any, t_ns: int) -> np.ndarray:
    """The N_K fault levels of a ``/ema/ground_truth`` message.

    Otherwise BagError naming bag, topic and value.
    """
    where = f"bag {path}: {GROUND_TRUTH_TOPIC} message at {t_ns} ns"
    try:
        k = decode_ground_truth(msg)
    except WindowError as exc:
        raise BagError(f"bag {path}: message at {t_ns} ns: {exc}") from None
    bad = np.flatnonzero(~(np.isfinite(k) & (k >= 0.0) & (k <= 1.0)))
    if bad.size:
        i = int(bad[0])
        raise BagError(
            f"{where} has {LABELS[i]} = {float(k[i])!r}; every k must be a finite number in "
            f"[0, 1] (k = {np.array2string(k, separator=', ', max_line_width=10**6)})"
        )
    return k


def _window_connections(path: Path, connections: Sequence[Connection]) -> list[Connection]:
    """The connections `read_window` reads; BagError on a wrong type or no telemetry at all."""
    conns = [c for c in connections if c.topic in BAG_TOPIC_TYPES]
    for c in conns:
        if c.msgtype != BAG_TOPIC_TYPES[c.topic]:
            raise BagError(
                f"bag {path}: topic {c.topic} has type {c.msgtype}, "
                f"expected {BAG_TOPIC_TYPES[c.topic]}"
            )
    if not any(c.topic in (TELEMETRY_TOPIC, WINDOW_TOPIC) for c in conns):
        raise BagError(
            f"bag {path} has no {TELEMETRY_TOPIC} topic (topics: "
            f"{sorted({c.topic for c in connections})}); {IMPORT_HINT}"
        )
    return conns


def run_info_object(path: Path, text: str) -> dict[str, Any]:
    """A run_info message's JSON object; BagError when it is not JSON or not an object."""
    try:
        meta = json.loads(text)
    except ValueError as exc:
        raise BagError(f"bag {path}: {RUN_INFO_TOPIC} is not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise BagError(
            f"bag {path}: {RUN_INFO_TOPIC} is JSON {type(meta).__name__}, expected an object"
        )
    return meta


def read_window(path: str | Path) -> Window:
    """Read a bag written by `write_window` (or recorded by the nodes) back into a Window.

    A bag recorded by monitor_node holds `/ema/window` (the exact window it fitted):
    the last such window is returned, with the last ground truth logged before it.
    Otherwise all `/ema/telemetry` batches are concatenated in log-time order.
    Every ground truth in the bag must be N_K finite numbers in [0, 1].  An
    unfinished recording is read up to its last complete chunk; the returned
    ``meta["bag_recovered"]`` then says what was kept (also emitted as a
    `BagRecoveredWarning`).  A multi-window bag of `simulate --windows` (run_info
    ``windows`` > 1) is refused: `cycle_bags.read_cycle_windows` reads it.
    """
    path = Path(path)
    with open_bag(path) as reader:
        conns = _window_connections(path, reader.connections)
        got = _window_messages(path, reader, conns)
        if got.windows:
            t_win, data = max(got.windows, key=lambda w: w[0])
            before = [k for t, k in got.truths if t <= t_win]
            k_true = before[-1] if before else (got.truths[-1][1] if got.truths else None)
            return Window.from_matrix(data, k_true=k_true, meta=got.meta)
        windows_in_bag = got.meta.get("windows")
        if isinstance(windows_in_bag, int) and windows_in_bag > 1:
            raise BagError(
                f"bag {path} holds {windows_in_bag} windows, one per cycle (`simulate "
                "--windows`), not one window; fit them all with `ema-phm prognose`"
            )
        k_true = max(got.truths, key=lambda t: t[0])[1] if got.truths else None
        expected = sum(c.msgcount for c in conns if c.topic == TELEMETRY_TOPIC)
        blocks = got.blocks
        if not blocks:
            why = f" ({reader.report.summary()})" if isinstance(reader, SalvagedMcap) else ""
            raise BagError(f"bag {path}: {TELEMETRY_TOPIC} has no messages{why}")
        if len(blocks) < expected:
            raise BagError(
                f"bag {path} is truncated: {TELEMETRY_TOPIC} has {len(blocks)} messages, "
                f"metadata says {expected}"
            )
    blocks.sort(key=lambda b: b[:2])
    data = np.concatenate([b[2] for b in blocks])
    if data.shape[0] == 0:
        raise BagError(f"bag {path}: {TELEMETRY_TOPIC} messages hold no samples")
    return Window.from_matrix(data, k_true=k_true, meta=got.meta)


@dataclass
class _WindowMessages:
    """The decoded messages `read_window` reads, each with its log time [ns]."""

    #: (log time, arrival index, rows) of each /ema/telemetry batch
    blocks: list[tuple[int, int, np.ndarray]] = field(default_factory=list)
    windows: list[tuple[int, np.ndarray]] = field(default_factory=list)
    truths: list[tuple[int, np.ndarray]] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)


def _window_messages(path: Path, reader: Any, conns: Sequence[Connection]) -> _WindowMessages:
    """Decode every window-related message of `reader` (BagError naming a bad one)."""
    got = _WindowMessages()
    for conn, t_ns, raw in reader.messages(connections=conns):
        try:
            msg: Any = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
        except Exception as exc:
            raise BagError(
                f"bag {path}: cannot decode a {conn.topic} message at {t_ns} ns: {one_line(exc)}"
            ) from None
        if conn.topic == TELEMETRY_TOPIC:
            got.blocks.append((t_ns, len(got.blocks), telemetry_rows(path, len(got.blocks), msg)))
        elif conn.topic == WINDOW_TOPIC:
            rows = telemetry_rows(path, len(got.windows), msg, topic=WINDOW_TOPIC)
            got.windows.append((t_ns, rows))
        elif conn.topic == GROUND_TRUTH_TOPIC:
            got.truths.append((t_ns, ground_truth(path, msg, t_ns)))
        else:
            got.meta = run_info_object(path, msg.data)
    if isinstance(reader, SalvagedMcap):
        got.meta = {**got.meta, "bag_recovered": reader.report.summary()}
    return got


def recover_bag(path: str | Path, *, out: str | Path | None = None) -> RecoveryReport:
    """Rebuild the readable part of a recording as a finished bag (MCAP + metadata.yaml).

    `path` is a bag directory or a ``.mcap`` file; it is only read.  The new bag goes to
    `out` (default `default_recovery_path`), which must not exist.  Raises BagError
    naming the file when nothing is readable.
    """
    src = Path(path)
    salvaged = SalvagedMcap(locate_mcap(src))
    dest = Path(out) if out is not None else default_recovery_path(src)
    topics: dict[str, str] = {}
    for conn in salvaged.connections:
        if topics.setdefault(conn.topic, conn.msgtype) != conn.msgtype:
            raise BagError(
                f"cannot rebuild {src}: topic {conn.topic} carries two types, "
                f"{topics[conn.topic]} and {conn.msgtype}"
            )
    with new_bag(dest, topics, typestore=typestore_for(salvaged.connections)) as rec:
        for conn, t_ns, data in salvaged.messages():
            rec.write_raw(conn.topic, data, t_ns)
    report = salvaged.report
    report.out = dest
    return report
