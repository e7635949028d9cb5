"""Reading and rebuilding rosbag2 MCAP recordings that are unfinished or damaged.

A writer killed (SIGKILL, power loss) before it closed leaves a ``.mcap`` without
its summary and footer, and no ``metadata.yaml``.  Every record it wrote before
dying is still on disk; the last one may be cut short.  `scan_mcap` walks the
file record by record and keeps exactly the complete ones: a chunk counts only
when its whole record is present, its CRC (when the writer stored one) matches and
every record inside it parses.  A damaged chunk is left out and named (its byte
offset and why) and the scan goes on; the scan stops at a record that is cut short
or has no valid opcode.  `verify_mcap` checks a finished file's CRCs (chunks, data
section, summary) without decoding messages.  `bags` reads unfinished or damaged files
through `SalvagedMcap`, and its `recover_bag` writes what a scan keeps as a finished bag
(with `BagRecorder`: this module imports nothing of `bags`).

Only this module and `bags` know the MCAP byte layout; neither imports rclpy.
"""

from __future__ import annotations

import struct
import warnings
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.records import Chunk
from mcap.stream_reader import get_chunk_data_stream
from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag2,
    MessageDefinition,
    MessageDefinitionFormat,
)

from ..errors import BagError

MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END = (
    0x02,
    0x03,
    0x04,
    0x05,
    0x06,
    0x0F,
)
#: Highest opcode MCAP defines; a record beyond it means the framing is lost.
_OP_LAST = 0x0F
#: Footer record: opcode, length (20), summary start, summary offset start, summary CRC.
_FOOTER = struct.Struct("<BQQQI")
#: Larger records are taken as garbage (a torn length field), not allocated.
_MAX_RECORD = 4 * 2**30


class BagRecoveredWarning(UserWarning):
    """A bag was read from an unfinished recording; the text is `RecoveryReport.summary()`."""


class BagCorruptWarning(BagRecoveredWarning):
    """A bag's bytes fail their CRC: it was read without the damaged chunks (named in the text)."""


class _Malformed(Exception):
    """A record is cut short or inconsistent; the scan stops before it."""


@dataclass(frozen=True)
class _Channel:
    id: int
    topic: str
    msgtype: str
    encoding: str
    msgdef: MessageDefinition


@dataclass
class RecoveryReport:
    """What a scan (and, for `recover_bag`, a rebuild) kept of one ``.mcap``."""

    source: Path
    file_bytes: int
    #: Bytes of complete records, from the start of the file.
    bytes_kept: int
    #: True when the file reached its data-end record (the writer finished the data section).
    complete: bool
    chunks: int
    messages: dict[str, int] = field(default_factory=dict)
    #: Topics left out: no schema, or not CDR-encoded.
    skipped_topics: list[str] = field(default_factory=list)
    #: The rebuilt bag, when `recover_bag` wrote one.
    out: Path | None = None
    #: Why the scan stopped before the end of the file ("" when it did not).
    stop_reason: str = ""
    #: Damage found and stepped over: "chunk at byte N: why", CRC mismatches outside chunks.
    damaged: list[str] = field(default_factory=list)

    @property
    def bytes_dropped(self) -> int:
        """Bytes of the file not kept (0 when the file was complete)."""
        return 0 if self.complete else self.file_bytes - self.bytes_kept

    @property
    def total_messages(self) -> int:
        """Messages recovered over all topics."""
        return sum(self.messages.values())

    def summary(self) -> str:
        """One line: messages recovered per topic, bytes dropped, where the result went."""
        per_topic = ", ".join(f"{t} {n}" for t, n in sorted(self.messages.items())) or "none"
        text = f"{self.source} is damaged: {'; '.join(self.damaged)}; " if self.damaged else ""
        text += (
            f"recovered {self.total_messages} messages ({per_topic}) in {self.chunks} "
            "complete chunks "
            f"from {self.source}; dropped {self.bytes_dropped} of {self.file_bytes} bytes"
        )
        if self.stop_reason:
            text += f" ({self.stop_reason})"
        if self.skipped_topics:
            text += f"; skipped topics {self.skipped_topics}"
        if self.out is not None:
            text += f"; rebuilt bag: {self.out}"
        return text


def mcap_state(mcap: Path) -> str:
    """State of `mcap`: "finished", "unfinished" or "foreign".

    Finished: starts and ends with the MCAP magic; unfinished: only starts with it.
    """
    with mcap.open("rb") as f:
        size = f.seek(0, 2)
        f.seek(0)
        if f.read(len(MAGIC)) != MAGIC:
            return "foreign"
        if size < 2 * len(MAGIC):
            return "unfinished"
        f.seek(size - len(MAGIC))
        return "finished" if f.read(len(MAGIC)) == MAGIC else "unfinished"


class _Cursor:
    """Bounds-checked little-endian reads from one record's bytes."""

    def __init__(self, buf: bytes | memoryview) -> None:
        self.buf = memoryview(buf)
        self.pos = 0

    def take(self, n: int) -> memoryview:
        if n < 0 or self.pos + n > len(self.buf):
            raise _Malformed(f"a field of {n} bytes runs past its record")
        out = self.buf[self.pos : self.pos + n]
        self.pos += n
        return out

    def uint(self, fmt: str) -> int:
        size = struct.calcsize(fmt)
        return int(struct.unpack(fmt, self.take(size))[0])

    def text(self) -> str:
        try:
            return str(self.take(self.uint("<I")), "utf-8")
        except UnicodeDecodeError:
            raise _Malformed("a string is not UTF-8") from None

    def blob(self, length_fmt: str) -> bytes:
        return bytes(self.take(self.uint(length_fmt)))

    def rest(self) -> bytes:
        return bytes(self.take(len(self.buf) - self.pos))


def _parse_schema(c: _Cursor) -> tuple[int, str, str, bytes]:
    return c.uint("<H"), c.text(), c.text(), c.blob("<I")


def _parse_channel(c: _Cursor) -> tuple[int, int, str, str]:
    cid, schema_id, topic, encoding = c.uint("<H"), c.uint("<H"), c.text(), c.text()
    c.blob("<I")  # metadata map (QoS profiles): not needed to read or rebuild
    return cid, schema_id, topic, encoding


def _parse_message(c: _Cursor) -> tuple[int, int, bytes]:
    cid = c.uint("<H")
    c.take(4)  # sequence
    log_time = c.uint("<Q")
    c.take(8)  # publish time
    return cid, log_time, c.rest()


def _chunk_payload(body: bytes) -> bytes:
    """The uncompressed records of a chunk record; _Malformed when its CRC or sizes fail."""
    c = _Cursor(body)
    start, end, size, crc = c.uint("<Q"), c.uint("<Q"), c.uint("<Q"), c.uint("<I")
    compression = c.text()
    data = c.blob("<Q")
    try:
        stream, n = get_chunk_data_stream(
            Chunk(
                compression=compression,
                data=data,
                message_end_time=end,
                message_start_time=start,
                uncompressed_crc=crc,
                uncompressed_size=size,
            ),
            validate_crc=True,
        )
        raw = stream.read(n) if n else b""
    except (McapError, ValueError, RuntimeError) as exc:  # CRCValidationError is a ValueError
        raise _Malformed(f"{type(exc).__name__}: {exc}") from None
    if len(raw) != size:
        raise _Malformed(f"it holds {len(raw)} bytes, its header says {size}")
    return bytes(raw)


def _inner_records(raw: bytes) -> list[tuple[int, bytes]]:
    """(opcode, body) of every record inside a chunk; _Malformed when any is incomplete."""
    inner, out = _Cursor(raw), []
    while inner.pos < len(raw):
        op, length = inner.uint("<B"), inner.uint("<Q")
        out.append((op, bytes(inner.take(length))))
    return out


@dataclass
class _Scan:
    report: RecoveryReport
    channels: dict[int, _Channel]
    counts: dict[int, int]


def _walk(f: BinaryIO, size: int, report: RecoveryReport) -> Iterator[tuple[int, int, bytes]]:
    """(opcode, byte offset, body) of the complete data-section records, in file order.

    A chunk's body is its uncompressed records; a chunk whose CRC or sizes fail is left
    out and listed in report.damaged.  At the data-end record the data-section CRC (if
    stored) is checked.  Updates report.bytes_kept, report.complete and report.stop_reason.
    """
    head = f.read(len(MAGIC))
    if head != MAGIC:
        raise BagError(f"{report.source} is not an MCAP file (it starts with {head[:8]!r})")
    pos = report.bytes_kept = len(MAGIC)
    crc = zlib.crc32(MAGIC)
    while True:
        header = f.read(9)
        if len(header) < 9:
            report.stop_reason = (
                f"record header cut short at byte {pos}"
                if header
                else "no data-end record: the writer did not finish"
            )
            return
        op, length = struct.unpack("<BQ", header)
        if not 0 < op <= _OP_LAST:
            report.stop_reason = f"no valid record at byte {pos} (opcode 0x{op:02x})"
            return
        if length > _MAX_RECORD or pos + 9 + length > size:
            report.stop_reason = (
                f"record at byte {pos} (opcode 0x{op:02x}, {length} bytes) is cut short"
            )
            return
        body = f.read(length)
        if op in (_OP_DATA_END, _OP_FOOTER):
            report.complete = True
            report.bytes_kept = pos
            stored = struct.unpack_from("<I", body)[0] if op == _OP_DATA_END and length >= 4 else 0
            if stored and stored != crc and not report.damaged:
                report.damaged.append(
                    f"data section CRC mismatch (stored 0x{stored:08x}, computed 0x{crc:08x}): "
                    "a record outside the chunks is damaged"
                )
            return
        crc = zlib.crc32(body, zlib.crc32(header, crc))
        if op == _OP_CHUNK:
            try:
                yield op, pos, _chunk_payload(body)
            except _Malformed as exc:
                report.damaged.append(f"chunk at byte {pos}: {exc}")
        else:
            yield op, pos, body
        pos += 9 + length
        report.bytes_kept = pos


def _records(f: BinaryIO, size: int, report: RecoveryReport) -> Iterator[tuple[int, bytes]]:
    """Complete records in file order, chunks opened (see `_walk`); damaged chunks left out."""
    for op, pos, body in _walk(f, size, report):
        if op != _OP_CHUNK:
            yield op, body
            continue
        try:
            inner = _inner_records(body)
        except _Malformed as exc:
            report.damaged.append(f"chunk at byte {pos}: {exc}")
            continue
        report.chunks += 1
        yield from inner


def _summary_records(f: BinaryIO, size: int) -> tuple[str, list[tuple[int, bytes]]]:
    """(problem or "", records) of a finished file's summary section.

    The records are returned only when the summary's CRC was stored and matches.
    """
    if size < 2 * len(MAGIC) + _FOOTER.size:
        return "", []
    footer_at = size - len(MAGIC) - _FOOTER.size
    f.seek(footer_at)
    footer = f.read(_FOOTER.size)
    if f.read(len(MAGIC)) != MAGIC:  # an unfinished file: its summary was cut, nothing to check
        return "", []
    op, _length, start, _offsets, stored = _FOOTER.unpack(footer)
    if op != _OP_FOOTER or not len(MAGIC) <= start <= footer_at:
        return f"no valid footer at byte {footer_at}", []
    if start == 0 or stored == 0:
        return "", []
    f.seek(start)
    summary = f.read(footer_at - start)
    computed = zlib.crc32(footer[:-4], zlib.crc32(summary))
    if computed != stored:
        return (
            f"summary section at byte {start} CRC mismatch (stored 0x{stored:08x}, "
            f"computed 0x{computed:08x})"
        ), []
    c, out = _Cursor(summary), []
    try:
        while c.pos < len(summary):
            rop, length = c.uint("<B"), c.uint("<Q")
            out.append((rop, bytes(c.take(length))))
    except _Malformed:
        return f"summary section at byte {start} does not parse", []
    return "", out


def verify_mcap(mcap: Path) -> list[str]:
    """What fails its CRC in `mcap` (chunks, data section, summary); [] when nothing does.

    Reads the whole file once without decoding messages.  A CRC the writer did not
    store (0, as rosbags' own writer leaves them) is not checked.
    """
    size = mcap.stat().st_size
    report = RecoveryReport(source=mcap, file_bytes=size, bytes_kept=0, complete=False, chunks=0)
    try:
        with mcap.open("rb") as f:
            for _ in _walk(f, size, report):
                pass
            problem = _summary_records(f, size)[0] if report.complete else ""
    except OSError as exc:
        raise BagError(f"cannot read {mcap}: {type(exc).__name__}: {exc}") from None
    if report.stop_reason:
        return [*report.damaged, report.stop_reason]
    return [*report.damaged, *([problem] if problem else [])]


def _connection(ch: _Channel, count: int) -> Connection:
    return Connection(
        id=ch.id,
        topic=ch.topic,
        msgtype=ch.msgtype,
        msgdef=ch.msgdef,
        digest="",
        msgcount=count,
        ext=ConnectionExtRosbag2(serialization_format=ch.encoding, offered_qos_profiles=[]),
        owner=None,
    )


def _scan(
    mcap: Path, *, want: set[int] | None = None, sink: list[tuple[int, int, bytes]] | None = None
) -> _Scan:
    """One pass over `mcap`: channels and counts.

    Appends (channel id, log time, data) of the `want` channels to `sink`.  A finished
    file's summary (when its CRC holds) supplies the schemas and channels a damaged first
    chunk took with it.
    """
    size = mcap.stat().st_size
    report = RecoveryReport(source=mcap, file_bytes=size, bytes_kept=0, complete=False, chunks=0)
    schemas: dict[int, tuple[str, str, bytes]] = {}
    channels: dict[int, _Channel] = {}
    counts: dict[int, int] = {}

    def take(op: int, body: bytes) -> None:
        c = _Cursor(body)
        if op == _OP_SCHEMA:
            sid, name, enc, data = _parse_schema(c)
            schemas.setdefault(sid, (name, enc, data))
        elif op == _OP_CHANNEL:
            cid, sid, topic, encoding = _parse_channel(c)
            if cid in channels:
                return
            if sid not in schemas or encoding != "cdr":
                if topic not in report.skipped_topics:
                    report.skipped_topics.append(topic)
                return
            name, enc, data = schemas[sid]
            fmt = MessageDefinitionFormat.IDL if enc == "ros2idl" else MessageDefinitionFormat.MSG
            channels[cid] = _Channel(
                cid, topic, name, encoding, MessageDefinition(fmt, data.decode())
            )
        elif op == _OP_MESSAGE:
            cid, t_ns, data = _parse_message(c)
            counts[cid] = counts.get(cid, 0) + 1
            if sink is not None and (want is None or cid in want):
                sink.append((cid, t_ns, data))

    try:
        with mcap.open("rb") as f:
            for op, body in _records(f, size, report):
                take(op, body)
            if report.complete:
                problem, summary = _summary_records(f, size)
                if problem:
                    report.damaged.append(problem)
                for op, body in summary:
                    if op in (_OP_SCHEMA, _OP_CHANNEL):
                        take(op, body)
    except _Malformed as exc:
        raise BagError(f"{mcap}: a record inside a complete chunk is malformed ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BagError(f"cannot read {mcap}: {type(exc).__name__}: {exc}") from None
    counts = {cid: n for cid, n in counts.items() if cid in channels}
    for cid, ch in channels.items():
        report.messages[ch.topic] = report.messages.get(ch.topic, 0) + counts.get(cid, 0)
    return _Scan(report, channels, counts)


class SalvagedMcap:
    """The complete records of one ``.mcap``, read like a rosbags ``Reader``."""

    def __init__(self, mcap: Path) -> None:
        self.path = mcap
        scan = _scan(mcap)
        self.report = scan.report
        if not scan.channels:
            raise BagError(
                f"nothing is readable in {mcap}: no complete chunk in its "
                f"{self.report.file_bytes} bytes "
                f"({self.report.stop_reason or 'no channels'})"
            )
        self.connections = [
            _connection(ch, scan.counts.get(cid, 0)) for cid, ch in scan.channels.items()
        ]

    def messages(
        self, connections: Sequence[Connection] | None = None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """(connection, log time ns, CDR bytes) of the complete records, in log-time order.

        Ties keep file order.

        Holds the selected messages in memory to sort them (a second pass over the file).
        """
        conns = {c.id: c for c in (self.connections if connections is None else connections)}
        sink: list[tuple[int, int, bytes]] = []
        _scan(self.path, want=set(conns), sink=sink)
        sink.sort(key=lambda m: m[1])  # stable: file order among equal log times
        for cid, t_ns, data in sink:
            yield conns[cid], t_ns, data

    def warn(self, *, stacklevel: int = 2) -> None:
        """Warn with the report's summary (BagCorruptWarning when damage was found)."""
        category = BagCorruptWarning if self.report.damaged else BagRecoveredWarning
        warnings.warn(self.report.summary(), category, stacklevel=stacklevel + 1)


def default_recovery_path(bag: Path) -> Path:
    """``<bag>_recovered`` beside the bag (``x.mcap`` -> ``x_recovered``)."""
    name = bag.stem if bag.suffix == ".mcap" and not bag.is_dir() else bag.name
    return bag.with_name(f"{name}_recovered")
