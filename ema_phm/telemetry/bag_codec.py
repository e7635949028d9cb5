"""The bag codec: topics, types, QoS and (de)serialization of what ema_phm writes to bags."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

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
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from ..errors import BagError
from .qos import TOPIC_QOS
from .wire import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
    WINDOW_TOPIC,
    MessageClasses,
    encode_array,
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


def one_line(exc: BaseException) -> str:
    """An exception as one line (its words, or its type)."""
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
        raise BagError(f"cannot serialize {msgtype}: {one_line(exc)}") from None


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
