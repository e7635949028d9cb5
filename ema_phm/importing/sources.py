"""Time series from foreign recordings: ROS 2 bags (MCAP, sqlite3) and tables (CSV, Parquet).

`read_series(path, cmap)` returns one `Series` per `SourceRef` the map reads, its values in the
monitor channel's unit and its times in seconds from the recording's first message (bags)
or first row (tables).  A bag message's time is its ``header.stamp`` when the map says
``stamps: header`` and the message has a non-zero one, else its log time.  Every problem is
one line naming the file, the topic or column and the value: `BagError` for a bag,
`ConfigError` for a table.
"""

# Heavy libraries are imported where used: `ema-phm --help` stays fast.
# ruff: noqa: PLC0415

from __future__ import annotations

import os
import re
from array import array
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BagError, ConfigError
from .channel_map import ChannelMap, SourceRef

BAG_SUFFIXES = (".mcap", ".db3")
CSV_SUFFIXES = (".csv",)
PARQUET_SUFFIXES = (".parquet", ".pq")
#: An import's staging folder (left by a killed import): never a source.
STAGING_PREFIX = ".import-"
_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?")


@dataclass(frozen=True)
class BagSample:
    """One message read from a bag: its topic, type, content and times."""

    topic: str
    msgtype: str
    msg: Any
    ns: int  # its time [ns from the bag's start]: header stamp or log time (`bag_messages`)
    log_ns: int  # its log time [ns]


@dataclass(frozen=True)
class Series:
    """Values at times [s], times strictly increasing."""

    t: np.ndarray
    v: np.ndarray


def kind_of(path: Path) -> str:
    """'bag' or 'table'; ConfigError naming what `path` is not."""
    if path.is_dir() and (path / "metadata.yaml").exists():
        return "bag"
    suffix = path.suffix.lower()
    if path.is_file() and suffix in CSV_SUFFIXES + PARQUET_SUFFIXES:
        return "table"
    if path.is_file() and suffix in BAG_SUFFIXES:
        raise ConfigError(
            f"{path}: a bare {suffix} file; give the bag's folder (the one with metadata.yaml)"
        )
    if not path.exists():
        raise ConfigError(f"{path} does not exist")
    raise ConfigError(
        f"{path} is neither a ROS 2 bag (a folder with metadata.yaml) nor a CSV or Parquet file"
    )


def find_sources(paths: Iterable[str | Path]) -> list[Path]:
    """The recordings under `paths`: bags and tables as given, folders searched to any depth.

    In a folder, a sub-folder holding ``metadata.yaml`` is one bag (not searched inside);
    ``.csv``, ``.parquet`` and ``.pq`` files are tables.  Sorted, each once.
    """
    out: list[Path] = []
    for given in paths:
        p = Path(given)
        if p.is_dir() and not (p / "metadata.yaml").exists():
            for root, dirs, files in os.walk(p):
                here = Path(root)
                dirs[:] = [d for d in dirs if not d.startswith(STAGING_PREFIX)]
                if (here / "metadata.yaml").exists():
                    out.append(here)
                    dirs.clear()
                    continue
                dirs.sort()
                suffixes = CSV_SUFFIXES + PARQUET_SUFFIXES
                out.extend(here / f for f in sorted(files) if Path(f).suffix.lower() in suffixes)
        else:
            kind_of(p)
            out.append(p)
    if not out:
        raise ConfigError(f"no bag, CSV or Parquet file under {', '.join(map(str, paths))}")
    return list(dict.fromkeys(out))


def read_series(path: Path, cmap: ChannelMap) -> dict[SourceRef, Series]:
    """Every series `cmap` reads from the recording at `path` (see the module docstring)."""
    refs = cmap.refs()
    if kind_of(path) == "bag":
        raw = _bag_series(path, refs, cmap)
    else:
        raw = _table_series(path, refs, cmap)
    return {r: _checked(path, r, t, v) for r, (t, v) in raw.items()}


def converted(ref: SourceRef, t: np.ndarray, v: np.ndarray) -> Series:
    """Raw times and values as the monitor reads them: the delay taken off, the unit's."""
    return Series(t=t - ref.delay_s, v=(v * ref.scale + ref.offset) * ref.factor + ref.shift)


def _checked(path: Path, ref: SourceRef, t: np.ndarray, v: np.ndarray) -> Series:
    """The series in the monitor's unit; error on no samples or time that does not increase."""
    if t.size == 0:
        raise ConfigError(f"{path}: {ref.label} has no samples")
    steps = np.diff(t)
    if steps.size and not np.all(steps > 0):
        i = int(np.flatnonzero(~(steps > 0))[0])
        raise ConfigError(
            f"{path}: {ref.label}: time does not increase at sample {i + 1} "
            f"({t[i]:.9g} s then {t[i + 1]:.9g} s)"
        )
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad))
        raise ConfigError(f"{path}: {ref.label}: sample {i} (t = {t[i]:.9g} s) is {float(v[i])!r}")
    return converted(ref, t, v)


# -- bags -------------------------------------------------------------------------------


def _typestore(cmap: ChannelMap) -> Any:
    """Kilted's message types plus the map's own (`msg_types`)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    for name, text in cmap.msg_definitions.items():
        try:
            store.register(get_types_from_msg(text, name))
        except Exception as exc:  # noqa: BLE001 - rosbags raises several kinds
            raise ConfigError(f"{cmap.source}: msg_types {name}: {exc}") from None
    return store


def bag_messages(path: Path, refs: list[SourceRef], cmap: ChannelMap) -> Iterator[BagSample]:
    """The messages of the bag at `path` that `refs` read, in log-time order, deserialized.

    Each with its time [ns from the bag's start]: the header stamp when the map says
    ``stamps: header`` and the message has one, else its log time.  BagError naming the
    bag and the topic for a missing topic or an unreadable message.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError

    topics: dict[str, None] = {}  # in the map's order: the first missing one is named
    for r in refs:
        if r.topic is None:
            raise ConfigError(f"{path} is a bag; the map's {r.label} names a table column")
        topics[r.topic] = None
    try:
        with AnyReader([path], default_typestore=_typestore(cmap)) as reader:
            have = {c.topic: c for c in reader.connections}
            for topic in topics:
                if topic not in have:
                    raise BagError(
                        f"bag {path} has no topic {topic} (it has {', '.join(sorted(have))})"
                    )
            conns = [c for c in reader.connections if c.topic in topics]
            origin = reader.start_time
            for conn, log_ns, raw in reader.messages(connections=conns):
                msg, ns = _message(reader, conn, raw, log_ns, path, cmap)
                yield BagSample(conn.topic, conn.msgtype, msg, ns - origin, log_ns)
    except AnyReaderError as exc:
        raise BagError(f"bag {path} cannot be read: {exc}") from None


def _message(  # noqa: PLR0913, PLR0917 - one message and where it is from
    reader: Any, conn: Any, raw: bytes, log_ns: int, path: Path, cmap: ChannelMap
) -> tuple[Any, int]:
    """(the message, its time [ns]: header stamp if the map says and it has one, else log)."""
    try:
        msg = reader.deserialize(raw, conn.msgtype)
    except Exception as exc:  # noqa: BLE001 - a foreign bag's bytes
        raise BagError(f"bag {path}: a {conn.topic} message is unreadable: {exc}") from None
    stamp = header_stamp_ns(msg) if cmap.stamps == "header" else None
    return msg, stamp or log_ns


def first_times(path: Path, refs: list[SourceRef], cmap: ChannelMap) -> dict[str, int]:
    """Per topic `refs` read, the time of its first message [ns, the messages' own clock].

    Its header stamp when the map says ``stamps: header`` (`bag_messages`' rule), else its
    log time; a topic's first message by log time (one read per topic).
    """
    from rosbags.highlevel import AnyReader, AnyReaderError

    topics = {r.topic for r in refs if r.topic is not None}
    out: dict[str, int] = {}
    try:
        with AnyReader([path], default_typestore=_typestore(cmap)) as reader:
            for conn in reader.connections:
                if conn.topic not in topics or conn.topic in out:
                    continue
                for _c, log_ns, raw in reader.messages(connections=[conn]):
                    out[conn.topic] = _message(reader, conn, raw, log_ns, path, cmap)[1]
                    break
    except AnyReaderError as exc:
        raise BagError(f"bag {path} cannot be read: {exc}") from None
    return out


def _bag_series(
    path: Path, refs: list[SourceRef], cmap: ChannelMap
) -> dict[SourceRef, tuple[np.ndarray, np.ndarray]]:
    """(times, raw values) of each ref read from the bag at `path`."""
    by_topic: dict[str, list[SourceRef]] = {}
    for r in refs:
        by_topic.setdefault(r.topic or "", []).append(r)
    # typed arrays, not lists: 16 bytes a sample, where a list of Python numbers takes ~70
    times = {r: array("q") for r in refs}
    values = {r: array("d") for r in refs}
    for m in bag_messages(path, refs, cmap):
        for r in by_topic[m.topic]:
            values[r].append(value_of(m.msg, r, f"bag {path}: {r.label} ({m.msgtype})"))
            times[r].append(m.ns)
    # whole nanoseconds from the earliest sample, then seconds: stamps on another clock
    # than the log's sit ~1e18 ns from the log's start, where a float second has 2e-7 s steps
    first = min((int(times[r][0]) for r in refs if len(times[r])), default=0)
    out = {}
    for r in refs:  # times converted (their buffer freed), values viewed in place
        t = (np.frombuffer(times.pop(r), dtype=np.int64) - first) * 1e-9
        out[r] = (t, np.frombuffer(values.pop(r), dtype=np.float64))
    return out


def header_stamp_ns(msg: Any) -> int | None:
    """The message's header stamp in ns, None without a header or with a zero stamp."""
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return None
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return ns or None


def value_of(msg: Any, ref: SourceRef, where: str) -> float:
    """The number `ref` names in `msg`; BagError beginning with `where`, naming the field."""
    if ref.interface is not None:
        got = _interface_value(msg, ref, where)
    else:
        got = _field(msg, ref.field, where)
        if ref.joint is not None:
            names = list(_field(msg, "name", where))
            if ref.joint not in names:
                raise BagError(f"{where}: joint {ref.joint!r} is not in name {names}")
            got = _element(got, names.index(ref.joint), where)
    if ref.index is not None:
        got = _element(got, ref.index, where)
    if not isinstance(got, (bool, np.bool_, int, float, np.number)):
        raise BagError(f"{where}: the value is {type(got).__name__}, not a number")
    return float(got)  # a std_msgs/Bool marker reads as 0 / 1


def _interface_value(msg: Any, ref: SourceRef, where: str) -> Any:
    """A DynamicJointState value: `ref.joint`'s interface `ref.interface`."""
    names = list(_field(msg, "joint_names", where))
    if ref.joint not in names:
        raise BagError(f"{where}: joint {ref.joint!r} is not in joint_names {names}")
    group = _element(_field(msg, "interface_values", where), names.index(ref.joint), where)
    interfaces = list(_field(group, "interface_names", where))
    if ref.interface not in interfaces:
        raise BagError(f"{where}: interface {ref.interface!r} is not in {interfaces}")
    return _element(_field(group, "values", where), interfaces.index(ref.interface), where)


def _field(obj: Any, dotted: str, where: str) -> Any:
    """The value at a field path like ``a.b[2].c``."""
    for part in dotted.split("."):
        m = _STEP.fullmatch(part)
        if m is None or not hasattr(obj, m.group(1)):
            fields = ", ".join(getattr(obj, "__dataclass_fields__", {}) or ())
            raise BagError(f"{where}: no field {part!r} (fields: {fields})")
        obj = getattr(obj, m.group(1))
        if m.group(2) is not None:
            obj = _element(obj, int(m.group(2)), where)
    return obj


def _element(seq: Any, i: int, where: str) -> Any:
    """seq[i], BagError when `seq` is not a sequence or too short."""
    try:
        return seq[i]
    except (IndexError, TypeError):
        size = len(seq) if hasattr(seq, "__len__") else "no"
        raise BagError(f"{where}: no element {i} (it has {size} elements)") from None


# -- tables -----------------------------------------------------------------------------


def _table_series(
    path: Path, refs: list[SourceRef], cmap: ChannelMap
) -> dict[SourceRef, tuple[np.ndarray, np.ndarray]]:
    """(times, raw values) of each ref's column; a column's empty cells are not samples."""
    if cmap.time is None:
        raise ConfigError(
            f"{path} is a table; the channel map {cmap.source} needs time: {{column: NAME}}"
        )
    for r in refs:
        if r.column is None:
            raise ConfigError(f"{path} is a table; the map's {r.label} names a bag topic")
    columns = _columns(path, [cmap.time.column or "", *(r.column or "" for r in refs)])
    t_raw = columns[cmap.time.column or ""]
    if np.isnan(t_raw).any():
        i = int(np.argmax(np.isnan(t_raw)))
        raise ConfigError(f"{path}: time column {cmap.time.column!r} is empty at row {i}")
    t = (t_raw * cmap.time.scale + cmap.time.offset) * cmap.time.factor
    steps = np.diff(t)
    if steps.size and not np.all(steps > 0):  # the time column's fault, named as such
        i = int(np.flatnonzero(~(steps > 0))[0])
        raise ConfigError(
            f"{path}: time column {cmap.time.column!r} does not increase at row {i + 1} "
            f"({t[i]:.9g} s then {t[i + 1]:.9g} s)"
        )
    t = t - t[0] if t.size else t
    out = {}
    for r in refs:
        v = columns[r.column or ""]
        keep = ~np.isnan(v)
        out[r] = (t[keep], v[keep])
    return out


def _columns(path: Path, names: Iterable[str]) -> Mapping[str, np.ndarray]:
    """The named numeric columns of a CSV or Parquet file, missing cells as NaN."""
    import pyarrow as pa
    import pyarrow.compute as pc

    wanted = list(dict.fromkeys(names))
    try:  # from a file object: pyarrow reads a path as a URI ('%2F' becoming '/')
        with path.open("rb") as f:
            if path.suffix.lower() in CSV_SUFFIXES:
                from pyarrow import csv

                table = csv.read_csv(f)
            else:
                from pyarrow import parquet

                table = parquet.read_table(f)
    except (pa.ArrowInvalid, OSError) as exc:
        first = str(exc).splitlines()[0]
        raise ConfigError(f"{path} cannot be read as a table: {first}") from None
    out = {}
    for name in wanted:
        if name not in table.column_names:
            raise ConfigError(
                f"{path} has no column {name!r} (it has {', '.join(table.column_names)})"
            )
        col = table.column(name)
        if not (
            pa.types.is_integer(col.type)
            or pa.types.is_floating(col.type)
            or pa.types.is_boolean(col.type)  # a marker column reads as 0 / 1
        ):
            raise ConfigError(f"{path}: column {name!r} holds {col.type}, not numbers")
        out[name] = np.asarray(pc.cast(col, pa.float64()).to_numpy(zero_copy_only=False))
    return out
