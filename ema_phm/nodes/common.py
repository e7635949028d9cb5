"""Topics, QoS profiles and message conversions shared by the ema_phm nodes."""
from __future__ import annotations

import array
from typing import Any, Sequence

import numpy as np
import rclpy
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from ..bag_io import GROUND_TRUTH_TOPIC, RUN_INFO_TOPIC, TELEMETRY_TOPIC
from ..errors import WindowError
from ..telemetry import CHANNELS
from ..window_assembler import WINDOW_TOPIC

__all__ = ["TELEMETRY_TOPIC", "GROUND_TRUTH_TOPIC", "RUN_INFO_TOPIC", "WINDOW_TOPIC", "HEALTH_TOPIC",
           "DIAGNOSTICS_TOPIC", "TELEMETRY_QOS", "LATCHED_QOS", "OUTPUT_QOS", "multiarray", "rows_of"]

HEALTH_TOPIC = "/ema/health"
DIAGNOSTICS_TOPIC = "/diagnostics"

#: Telemetry: reliable and deep, so a burst at realtime_factor 0 is not dropped.
TELEMETRY_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE)
#: run_info and ground truth: latched (transient local), so late joiners get the last one.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Health, diagnostics, fitted windows.
OUTPUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)


def multiarray(data: np.ndarray | Sequence[float], labels: Sequence[str]) -> Float64MultiArray:
    """A Float64MultiArray holding a 1-D or 2-D array row-major (same layout as bag_io)."""
    a = np.ascontiguousarray(data, dtype=np.float64)
    if a.ndim != len(labels) or a.ndim not in (1, 2):
        raise ValueError(f"need a 1-D or 2-D array and one label per axis, got {a.shape} and {list(labels)}")
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=lab, size=int(n), stride=int(np.prod(a.shape[i:])))
                      for i, (lab, n) in enumerate(zip(labels, a.shape))]
    msg.layout.data_offset = 0
    buf = array.array("d")
    buf.frombytes(a.tobytes())
    msg.data = buf
    return msg


def rows_of(msg: Float64MultiArray) -> np.ndarray:
    """The n x 7 samples of a telemetry-layout message (raises WindowError on another layout)."""
    sizes = [int(d.size) for d in msg.layout.dim]
    data = np.frombuffer(msg.data, dtype=np.float64) if len(msg.data) else np.empty(0)
    off = int(msg.layout.data_offset)
    nch = len(CHANNELS)
    if len(sizes) != 2 or sizes[1] != nch or data.size != off + sizes[0] * nch:
        raise WindowError(f"telemetry message has layout sizes {sizes} and {data.size} values (data_offset {off}); "
                          f"expected [n, {nch}] with n*{nch} values")
    return data[off:].reshape(sizes[0], nch).copy()


def spin_main(node_cls: Any, name: str, args: list[str] | None = None) -> int:
    """The executables' main: init, build the node (a bad parameter -> one line, exit 2),
    spin until Ctrl-C / SIGTERM, then destroy the node (which closes any recording)."""
    import sys

    from rclpy.executors import ExternalShutdownException

    from ..errors import EmaPhmError
    rclpy.init(args=args)
    try:
        node = node_cls()
    except EmaPhmError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
