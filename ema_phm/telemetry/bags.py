"""Telemetry windows as rosbag2 bags (MCAP storage), without rclpy.

A bag is a rosbag2 directory: ``metadata.yaml`` + one ``.mcap``, CDR.  Topic
names, message types and layouts are those of `ema_phm.telemetry.wire`.
`write_window` writes ``/ema/run_info`` (the window's ``meta`` as JSON, only if
non-empty), ``/ema/ground_truth`` (only if ``k_true`` is known), then
``/ema/telemetry`` in batches of ``samples_per_message`` samples.  `read_window`
concatenates all telemetry batches in log-time order and takes the last ground truth.

Log times are ``EPOCH_OFFSET_NS + round(t * 1e9)`` where ``t`` is the sample
time of the first sample of the batch (run_info and ground truth use the first
sample's time), clamped to never decrease so that log-time order is write order.

Every failure the caller can cause is raised as `BagError` (bad bag or path) or
`WindowError` (unwritable window) with a one-line message naming the file.  A
path that is not a regular file or directory (a FIFO, a device, a socket) is
refused before anything opens it.

Recordings: `BagRecorder` writes a complete MCAP chunk at least every
``flush_period`` seconds, so a writer killed with SIGKILL loses at most that much.
The first OSError writing it (a full disk) stops it once with `RecordingStopped`.
A recording left unfinished (a ``.mcap`` without footer, no ``metadata.yaml``) is
read up to its last complete chunk (`ema_phm.telemetry.bag_recovery`), with a
`BagRecoveredWarning` saying what was kept; `read_window` also puts that text in
``meta["bag_recovered"]``.

Integrity: every chunk, the data section and the summary carry a CRC
(`ema_phm.telemetry.mcap_storage`).  Opening a finished bag checks them first
(`verify_mcap`, one pass over the file); a bag that fails is read record by record
without its damaged chunks, with a `BagCorruptWarning` naming the file and each damaged
chunk's byte offset.  Bags written before the CRCs (0 stored) are read unchecked.
"""

from __future__ import annotations

import json
import shutil
import stat
import threading
from collections.abc import Generator, Iterator, Mapping, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, cast

import numpy as np
from rosbags.interfaces import (
    Connection,
    MessageDefinitionFormat,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, StoragePlugin
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from ..atomic_file import fsync_dir
from ..domain.faults import LABELS
from ..domain.window import TIME_COLUMN, Window
from ..errors import BagError, ConfigError, RecordingStopped, WindowError
from ..limits import check
from .bag_recovery import (  # noqa: F401  (re-exported)
    BagCorruptWarning,
    BagRecoveredWarning,
    RecoveryReport,
    SalvagedMcap,
    default_recovery_path,
    mcap_state,
    verify_mcap,
)
from .mcap_storage import CrcMcapWriter, Rosbag2Writer
from .qos import TOPIC_QOS
from .typed import PACKAGE as TYPED_PACKAGE
from .typed import register_types as register_typed_types
from .wire import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,  # noqa: F401  (re-exported)
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
    WINDOW_TOPIC,
    MessageClasses,
    decode_ground_truth,
    decode_telemetry,
    encode_array,
    encode_ground_truth,
    encode_run_info,
    encode_telemetry,
    to_message,
)

#: Topics `read_window` reads (and checks the type of).
BAG_TOPIC_TYPES: dict[str, str] = {
    t: TOPIC_TYPES[t] for t in (RUN_INFO_TOPIC, GROUND_TRUTH_TOPIC, TELEMETRY_TOPIC, WINDOW_TOPIC)
}
#: Added to sample times so log times look like wall-clock (2023-11-14) and stay >= 0.
EPOCH_OFFSET_NS = 1_700_000_000 * 10**9
#: rosbag2 metadata version written (rosbags supports 8 and 9).
BAG_VERSION: Literal[8, 9] = 9
#: Type store (ROS 2 Kilted message definitions) used to (de)serialize.
TYPESTORE: Typestore = get_typestore(Stores.ROS2_KILTED)
#: The rosbags std_msgs classes, for `to_message`.
ROSBAGS_CLASSES = MessageClasses(
    array=TYPESTORE.types[FLOAT64_MULTIARRAY],
    layout=TYPESTORE.types["std_msgs/msg/MultiArrayLayout"],
    dimension=TYPESTORE.types["std_msgs/msg/MultiArrayDimension"],
    data=np.ascontiguousarray,
)


#: rosbag2's "infinite" duration (RMW_DURATION_INFINITE), what `ros2 bag record` writes.
_INFINITE = QosTime(sec=9223372036, nsec=854775807)


def offered_qos(topic: str) -> list[Qos]:
    """What our publishers offer on `topic` (`ema_phm.telemetry.qos`); [] for other topics.

    Written to metadata.yaml as ``offered_qos_profiles`` so that ``ros2 bag play`` replays
    ``/ema/run_info`` and ``/ema/ground_truth`` latched (transient local).
    """
    spec = TOPIC_QOS.get(topic)
    if spec is None:
        return []
    durability = QosDurability.TRANSIENT_LOCAL if spec.latched else QosDurability.VOLATILE
    return [
        Qos(
            history=QosHistory.KEEP_LAST,
            depth=spec.depth,
            reliability=QosReliability.RELIABLE,
            durability=durability,
            deadline=_INFINITE,
            lifespan=_INFINITE,
            liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=_INFINITE,
            avoid_ros_namespace_conventions=False,
        )
    ]


def _one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def float64_multiarray(data: np.ndarray | Sequence[float], labels: Sequence[str]) -> Any:
    """A rosbags ``std_msgs/msg/Float64MultiArray`` holding a 1-D or 2-D array row-major."""
    return to_message(encode_array(data, labels), ROSBAGS_CLASSES)


def string_msg(text: str) -> Any:
    """A ``std_msgs/msg/String``."""
    return TYPESTORE.types[STRING](data=text)


def serialize(msgtype: str, obj: Any) -> bytes:
    """CDR bytes (little endian, with encapsulation header) of a rosbags message object."""
    try:
        return bytes(TYPESTORE.serialize_cdr(obj, msgtype))
    except Exception as exc:
        raise BagError(f"cannot serialize {msgtype}: {_one_line(exc)}") from None


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
            raise BagError(f"cannot create bag {self.path}: {_one_line(exc)}") from None
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
            f"recording {self.path} stopped: {_one_line(exc)}; it holds what was written "
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
                raise BagError(f"cannot write {topic} to {self.path}: {_one_line(exc)}") from None

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
            self._close_error = f"cannot finish bag {self.path}: {_one_line(exc)}"
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


_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISDIR, "a directory"),
)
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
                ".mcap file)"
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
            f"{path} is not a rosbag2 bag: no metadata.yaml and {found} in the directory"
        )
    return mcaps[0]


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
def _open_bag(path: Path) -> Iterator[Reader | SalvagedMcap]:
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
                f"{_one_line(exc)}"
            ) from None
    try:
        yield source
    except BagError:
        raise
    except Exception as exc:
        raise BagError(
            f"cannot read bag {path} (corrupt or truncated?): {_one_line(exc)}"
        ) from None
    finally:
        if isinstance(source, Reader):
            with suppress(Exception):
                source.close()


def typestore_for(conns: Sequence[Connection]) -> Typestore:
    """TYPESTORE, or a copy that also knows the connections' other .msg types."""
    missing = [c for c in conns if c.msgtype not in TYPESTORE.types]
    if not missing:
        return TYPESTORE
    store = get_typestore(Stores.ROS2_KILTED)
    for c in missing:
        if c.msgdef.format == MessageDefinitionFormat.MSG and c.msgtype not in store.types:
            store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
    return store


def read_messages(
    path: str | Path, topics: Sequence[str] | None = None
) -> Generator[tuple[str, str, int, Any], None, None]:
    """Yield (topic, msgtype, log time ns, decoded message) in log-time order.

    An unfinished recording is read up to its last complete chunk, with a `BagRecoveredWarning`.
    """
    path = Path(path)
    with _open_bag(path) as reader:
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
            f"{sorted({c.topic for c in connections})})"
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
    with _open_bag(path) as reader:
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
                "--windows`), not one window; read them with "
                "ema_phm.telemetry.cycle_bags.read_cycle_windows"
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
                f"bag {path}: cannot decode a {conn.topic} message at {t_ns} ns: {_one_line(exc)}"
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
