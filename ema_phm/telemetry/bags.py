"""Telemetry windows as rosbag2 bags (MCAP storage), without rclpy: the public face.

What callers use, from three modules of one idea each: `bag_codec` (topics, types, QoS,
serialization), `bag_recorder` (writing) and `bag_reader` (reading and salvage).

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

from .bag_codec import (
    BAG_TOPIC_TYPES,
    BAG_VERSION,
    EPOCH_OFFSET_NS,
    ROSBAGS_CLASSES,
    TYPESTORE,
    float64_multiarray,
    offered_qos,
    serialize,
    string_msg,
    typestore_for,
)
from .bag_reader import (
    digest_of,
    ground_truth,
    locate_mcap,
    read_messages,
    read_window,
    recover_bag,
    run_info_object,
    telemetry_rows,
)
from .bag_recorder import BagRecorder, new_bag, write_window
from .bag_recovery import (
    BagCorruptWarning,
    BagRecoveredWarning,
    RecoveryReport,
    SalvagedMcap,
    default_recovery_path,
    mcap_state,
    verify_mcap,
)
from .wire import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,
    TELEMETRY_TOPIC,
    WINDOW_TOPIC,
)

__all__ = [
    "BAG_TOPIC_TYPES",
    "BAG_VERSION",
    "EPOCH_OFFSET_NS",
    "FLOAT64_MULTIARRAY",
    "GROUND_TRUTH_TOPIC",
    "ROSBAGS_CLASSES",
    "RUN_INFO_TOPIC",
    "STRING",
    "TELEMETRY_TOPIC",
    "TYPESTORE",
    "WINDOW_TOPIC",
    "BagCorruptWarning",
    "BagRecorder",
    "BagRecoveredWarning",
    "RecoveryReport",
    "SalvagedMcap",
    "default_recovery_path",
    "digest_of",
    "float64_multiarray",
    "ground_truth",
    "locate_mcap",
    "mcap_state",
    "new_bag",
    "offered_qos",
    "read_messages",
    "read_window",
    "recover_bag",
    "run_info_object",
    "serialize",
    "string_msg",
    "telemetry_rows",
    "typestore_for",
    "verify_mcap",
    "write_window",
]
