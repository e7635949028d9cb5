"""Writing bags: `BagRecorder`, `new_bag` and `write_window` (one window as a bag).

`BagRecorder` writes from a thread of its own and a complete MCAP chunk at least every flush
period, so a writer killed with SIGKILL loses at most that much; the first OSError stops it
once with `RecordingStopped`.
"""

from __future__ import annotations

import shutil
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from types import TracebackType
from typing import Any, cast

import numpy as np
from rosbags.rosbag2 import StoragePlugin
from rosbags.typesys.store import Typestore

from ..atomic_file import fsync_dir
from ..domain.window import TIME_COLUMN, Window
from ..errors import BagError, ConfigError, RecordingStopped, WindowError
from ..limits import check
from .bag_codec import (
    BAG_VERSION,
    EPOCH_OFFSET_NS,
    ROSBAGS_CLASSES,
    TYPESTORE,
    offered_qos,
    one_line,
    serialize,
    string_msg,
)
from .mcap_storage import CrcMcapWriter, Rosbag2Writer
from .typed import PACKAGE as TYPED_PACKAGE
from .typed import register_types as register_typed_types
from .wire import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,
    TELEMETRY_TOPIC,
    encode_ground_truth,
    encode_run_info,
    encode_telemetry,
    to_message,
)


class BagRecorder:
    """Thread-safe rosbag2 (MCAP) writer for raw CDR or rosbags message objects.

    The .mcap is written by `ema_phm.telemetry.mcap_storage` (the `mcap` library, with
    chunk, data-section and summary CRCs), metadata.yaml by rosbags.  A chunk is written
    once it holds 1 MiB, and a daemon thread also seals the pending chunk and hands it to
    the OS every `flush_period` seconds, so a killed writer loses at most that much.
    `close` cannot be cut short by a signal: see there.

    The first OSError writing the file (a full disk, an I/O error) stops the recording:
    the file is closed as it is (readable up to its last complete chunk, like a killed
    recording), `failed` becomes True, `failure` says why, and that one call raises
    `RecordingStopped`; later `write_raw` calls store nothing and raise nothing.  A failure
    in the flush thread is raised by the next `write_raw`, or by `close` if none comes.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        topics: Mapping[str, str],
        flush_period: float = 1.0,
        typestore: Typestore | None = None,
    ) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._close_lock = threading.Lock()
        self._writer: Rosbag2Writer | None = None
        self._finisher: threading.Thread | None = None
        self._finished = threading.Event()
        self._close_error: str | None = None
        self.failure: str | None = None
        self._failure_told = False
        try:
            self._flush_period = float(check("bag_flush_period", flush_period))
        except ConfigError as exc:
            raise BagError(f"cannot record {self.path}: {exc}") from None
        store = TYPESTORE if typestore is None else typestore
        if self.path.exists() or self.path.is_symlink():
            raise BagError(f"refusing to overwrite {self.path}: it already exists")
        if any(t.startswith(TYPED_PACKAGE + "/") for t in topics.values()):
            try:  # the ema_phm_msgs schemas, from their .msg files, embedded in the bag
                register_typed_types(store)
            except BagError as exc:
                raise BagError(f"cannot record {self.path}: {exc}") from None
        if unknown := sorted({t for t in topics.values() if t not in store.types}):
            raise BagError(f"cannot record {self.path}: unknown message type(s) {unknown}")
        self._types = dict(topics)
        writer = Rosbag2Writer(self.path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        try:
            writer.open()
            self._conns = {
                topic: writer.add_connection(
                    topic, msgtype, typestore=store, offered_qos_profiles=offered_qos(topic)
                )
                for topic, msgtype in topics.items()
            }
        except Exception as exc:
            with suppress(Exception):
                writer.abort()
            raise BagError(f"cannot create bag {self.path}: {one_line(exc)}") from None
        self._writer = writer
        self._stop_flushing = threading.Event()
        self._flusher = threading.Thread(
            target=self._flush_loop, name=f"BagRecorder-flush {self.path.name}", daemon=True
        )
        self._flusher.start()

    @property
    def failed(self) -> bool:
        """True once a write to the file failed and the recording stopped (see `failure`)."""
        return self.failure is not None

    def _stop(self, writer: Rosbag2Writer, exc: OSError) -> None:
        """Stop recording after `exc`: close the file as it is.  Hold `_lock`."""
        self.failure = (
            f"recording {self.path} stopped: {one_line(exc)}; it holds what was written "
            f"before (read up to its last complete chunk, `ema-phm recover {self.path}`)"
        )
        self._writer = None
        with suppress(Exception):
            writer.abort()

    def _tell_failure(self) -> None:
        """Raise RecordingStopped the first time only.  Hold `_lock`."""
        if self.failure is not None and not self._failure_told:
            self._failure_told = True
            raise RecordingStopped(self.failure)

    def write_raw(self, topic: str, data: bytes | memoryview, t_ns: int) -> None:
        """Store already-serialized CDR bytes as they are (padding included).

        After the recording stopped (`failed`): RecordingStopped once, then nothing.
        """
        with self._lock:
            if self.failure is not None:
                self._tell_failure()
                return
            if self._writer is None:
                raise BagError(f"bag {self.path} is closed; cannot write {topic}")
            if topic not in self._conns:
                raise BagError(
                    f"bag {self.path} has no topic {topic!r} (recording {sorted(self._conns)})"
                )
            if not 0 <= int(t_ns) < 2**63:
                raise BagError(f"bag {self.path}: log time {t_ns} ns for {topic} is out of range")
            try:
                self._writer.write(self._conns[topic], int(t_ns), bytes(data))
            except OSError as exc:
                self._stop(self._writer, exc)
                self._tell_failure()
            except Exception as exc:
                raise BagError(f"cannot write {topic} to {self.path}: {one_line(exc)}") from None

    def write(self, topic: str, msg_obj: Any, t_ns: int) -> None:
        """Serialize a rosbags message object with the topic's type and store it."""
        if topic not in self._types:
            raise BagError(
                f"bag {self.path} has no topic {topic!r} (recording {sorted(self._types)})"
            )
        self.write_raw(topic, serialize(self._types[topic], msg_obj), t_ns)

    def flush(self) -> None:
        """Write the pending chunk now (complete, readable after a SIGKILL)."""
        with self._lock:
            self._seal()
            self._tell_failure()

    def _seal(self) -> None:
        """Write the pending chunk; an OSError stops the recording.  Hold `_lock`."""
        writer = self._writer
        if writer is None or writer.storage is None:
            return
        try:
            cast(CrcMcapWriter, writer.storage).seal()
        except OSError as exc:
            self._stop(writer, exc)

    def _flush_loop(self) -> None:
        while not self._stop_flushing.wait(self._flush_period):
            with self._lock:
                if self._writer is None:
                    return
                self._seal()  # a failure is raised by the next write_raw / close

    def close(self) -> None:
        """Finish the .mcap and write metadata.yaml; later calls only wait for that.

        The finishing runs in a non-daemon thread (so interpreter exit waits for it)
        and the caller waits for it: a KeyboardInterrupt or SystemExit raised meanwhile
        by a signal handler (a second Ctrl-C) is held back and raised again once the
        bag is complete.  A stopped recording is left unfinished (no metadata.yaml);
        its RecordingStopped is raised here if no `write_raw` raised it yet.
        """
        with self._close_lock:
            if self._finisher is None:
                self._finisher = threading.Thread(
                    target=self._finish, name=f"BagRecorder-close {self.path.name}"
                )
                self._finisher.start()
        deferred = _wait_holding_signals(self._finished)
        error, self._close_error = self._close_error, None
        if deferred is not None:
            raise deferred
        with self._lock:
            self._tell_failure()
        if error is not None:
            raise BagError(error)

    def _finish(self) -> None:
        try:
            self._stop_flushing.set()
            self._flusher.join()
            with self._lock:
                writer, self._writer = self._writer, None
            if writer is not None:
                try:
                    writer.close()
                except OSError as exc:  # left unfinished, like a killed recording
                    with self._lock:
                        self._stop(writer, exc)
                    return
                fsync_dir(self.path)  # metadata.yaml's rename
        except Exception as exc:
            self._close_error = f"cannot finish bag {self.path}: {one_line(exc)}"
        finally:
            self._finished.set()

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _wait_holding_signals(done: threading.Event) -> BaseException | None:
    """Wait for `done`; a KeyboardInterrupt/SystemExit raised meanwhile is returned, not raised.

    Only the first one is kept.

    Not Thread.join: on Python 3.11 a join interrupted by a signal marks the thread as
    finished, and interpreter exit then no longer waits for it.
    """
    deferred: BaseException | None = None
    while True:
        try:
            while not done.wait(0.1):
                pass
            return deferred
        except (KeyboardInterrupt, SystemExit) as exc:
            deferred = deferred or exc


@contextmanager
def new_bag(
    path: Path, topics: Mapping[str, str], *, typestore: Typestore | None = None
) -> Iterator[BagRecorder]:
    """A `BagRecorder` for a new bag at `path`, closed when the block ends.

    When the block or the closing fails or is interrupted, the bag is removed again
    (the recorder created the directory: nothing was there before).
    """
    rec = BagRecorder(path, topics=topics, typestore=typestore)
    try:
        yield rec
        rec.close()
    except BaseException:
        with suppress(Exception):
            rec.close()
        shutil.rmtree(path, ignore_errors=True)
        raise


def write_window(path: str | Path, window: Window, *, samples_per_message: int = 100) -> Path:
    """Write `window` as a new rosbag2 MCAP bag directory at `path`; return the path."""
    path = Path(path)
    if samples_per_message < 1:
        raise BagError(f"samples_per_message must be >= 1, got {samples_per_message}")
    try:
        data = window.matrix()
    except ValueError as exc:
        raise WindowError(f"cannot write {path}: channels differ in length ({exc})") from None
    if data.shape[0] == 0:
        raise WindowError(f"cannot write {path}: window has no samples")
    try:
        truth = None if window.k_true is None else encode_ground_truth(window.k_true)
    except WindowError as exc:
        raise WindowError(f"cannot write {path}: {exc}") from None
    try:
        info = encode_run_info(window.meta) if window.meta else None
    except (TypeError, ValueError) as exc:
        raise WindowError(f"cannot write {path}: meta is not JSON-serializable ({exc})") from None
    if path.exists() or path.is_symlink():
        raise BagError(f"refusing to overwrite {path}: it already exists")
    topics = {TELEMETRY_TOPIC: FLOAT64_MULTIARRAY}
    if info is not None:
        topics[RUN_INFO_TOPIC] = STRING
    if truth is not None:
        topics[GROUND_TRUTH_TOPIC] = FLOAT64_MULTIARRAY
    stamp = 0

    def next_stamp(t: float) -> int:
        nonlocal stamp
        if np.isfinite(t):
            stamp = max(stamp, min(2**63 - 1, EPOCH_OFFSET_NS + round(float(t) * 1e9)))
        return stamp

    with new_bag(path, topics) as rec:
        t0 = next_stamp(data[0, TIME_COLUMN])
        if info is not None:
            rec.write(RUN_INFO_TOPIC, string_msg(info), t0)
        if truth is not None:
            rec.write(GROUND_TRUTH_TOPIC, to_message(truth, ROSBAGS_CLASSES), t0)
        for i in range(0, data.shape[0], samples_per_message):
            block = data[i : i + samples_per_message]
            rec.write(
                TELEMETRY_TOPIC,
                to_message(encode_telemetry(block), ROSBAGS_CLASSES),
                next_stamp(block[0, TIME_COLUMN]),
            )
    return path
