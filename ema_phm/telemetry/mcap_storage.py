"""rosbag2 MCAP storage written by the `mcap` library, with CRCs.

rosbags' own MCAP writer stores 0 for every CRC (chunk, data section, summary), so a
flipped byte reads back silently.  `CrcMcapWriter` is a rosbags storage plugin (the
``StorageWriter`` protocol of `rosbags.rosbag2.writer`) backed by ``mcap.writer.Writer``
with ``enable_crcs`` (chunk and summary CRCs) and ``enable_data_crcs`` (data section
CRC); rosbags still writes ``metadata.yaml``.  `Rosbag2Writer` is rosbags' ``Writer``
using it.  Chunks are uncompressed, as rosbags wrote them, and hold at most 1 MiB.

The layout is the one rosbag2's MCAP plugin writes: profile "ros2", one schema per type
("ros2msg"/"ros2idl"), channel metadata ``offered_qos_profiles`` and
``topic_type_hash``, a "rosbag2" metadata record holding ``serialized_metadata``.
"""

from __future__ import annotations

import os
from contextlib import suppress
from importlib.metadata import version
from pathlib import Path

from mcap.writer import CompressionType
from mcap.writer import Writer as McapLibWriter
from rosbags.interfaces import Connection, ConnectionExtRosbag2, MessageDefinitionFormat
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.enums import CompressionMode

#: Largest chunk before it is written out (rosbags' McapWriter used the same).
CHUNK_BYTES = 2**20


class CrcMcapWriter:
    """One ``.mcap`` of a rosbag2 bag, written with CRCs (rosbags ``StorageWriter``)."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        if compression != CompressionMode.NONE:  # we never ask for any
            raise ValueError(f"CrcMcapWriter writes uncompressed chunks, not {compression}")
        self.path = path / f"{path.name}.mcap"
        self._file = self.path.open("xb")
        self._mcap = McapLibWriter(
            self._file,
            chunk_size=CHUNK_BYTES,
            compression=CompressionType.NONE,
            enable_crcs=True,
            enable_data_crcs=True,
        )
        self._mcap.start(profile="ros2", library=f"ema_phm (mcap {version('mcap')})")
        self._file.flush()  # the header on disk: a recording killed now is recognisable
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, int] = {}

    def add_msgtype(self, connection: Connection) -> None:
        """Register the schema of `connection`'s message type."""
        idl = connection.msgdef.format == MessageDefinitionFormat.IDL
        self._schemas[connection.msgtype] = self._mcap.register_schema(
            name=connection.msgtype,
            encoding="ros2idl" if idl else "ros2msg",
            data=connection.msgdef.data.encode(),
        )

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        """Register a channel; its metadata carries the QoS and the type hash, as rosbag2's."""
        ext = connection.ext
        assert isinstance(ext, ConnectionExtRosbag2)
        self._channels[connection.id] = self._mcap.register_channel(
            topic=connection.topic,
            message_encoding=ext.serialization_format,
            schema_id=self._schemas[connection.msgtype],
            metadata={
                "offered_qos_profiles": offered_qos_profiles,
                "topic_type_hash": connection.digest,
            },
        )

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        """Add a message; a chunk that fills up goes to the OS at once (a SIGKILL keeps it)."""
        before = self._file.tell()
        self._mcap.add_message(
            channel_id=self._channels[connection.id],
            log_time=timestamp,
            publish_time=timestamp,
            data=bytes(data),
        )
        if self._file.tell() != before:
            self._file.flush()

    def seal(self) -> None:
        """Write the pending chunk (if it holds a message) and hand the file's buffer to the OS."""
        self._mcap.flush()

    def close(self, version: int, metadata: str) -> None:
        """Last chunk, rosbag2 metadata record, summary with CRC, footer; then fsync."""
        _ = version
        self._mcap.flush()
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": metadata})
        self._mcap.finish()
        self._file.flush()
        # the .mcap is on disk before rosbags writes metadata.yaml, the mark of a finished bag
        os.fsync(self._file.fileno())
        self._file.close()

    def abort(self) -> None:
        """Close the file as it is (an unfinished recording); a failing flush is ignored."""
        with suppress(OSError):  # e.g. the disk is still full: the buffer is lost, the fd closed
            self._file.close()


class Rosbag2Writer(Writer):
    """rosbags' rosbag2 ``Writer`` whose MCAP storage is `CrcMcapWriter`."""

    STORAGE_PLUGINS = {StoragePlugin.MCAP: CrcMcapWriter}
