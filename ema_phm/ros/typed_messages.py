"""Library objects <-> the typed messages of ``ema_phm_msgs``, with rclpy's classes.

The conversions themselves live in `ema_phm.telemetry.typed` (rclpy-free, shared with
the bags); this module binds them to the rclpy message classes that
``scripts/build_msgs.sh`` (pip) or colcon (ROS) generated, and to a node's clock.
Importing it without ema_phm_msgs built raises ImportError naming the fix.
"""

from __future__ import annotations

from typing import Any

import numpy as np

try:
    from ema_phm_msgs.msg import (  # type: ignore[attr-defined]  # generated, untyped
        ActuatorHealth,
        Adequacy,
        FaultEstimate,
        Nuisance,
        RemainingLife,
        TelemetryBatch,
        TelemetrySample,
    )
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        f"ema_phm_msgs is not built ({exc}); run scripts/setup_env.sh (pip) or "
        "colcon build (ROS) -- see README, 'Typed messages'"
    ) from None
from builtin_interfaces.msg import Time
from std_msgs.msg import Header

from ..telemetry import typed
from ..telemetry.typed import HealthReport, TypedClasses
from ..telemetry.wire import StreamId, as_double_array

#: rclpy's classes of the typed messages, for the `ema_phm.telemetry.typed` converters.
RCLPY_TYPED = TypedClasses(
    {
        typed.ACTUATOR_HEALTH: ActuatorHealth,
        typed.ADEQUACY: Adequacy,
        typed.FAULT_ESTIMATE: FaultEstimate,
        typed.NUISANCE: Nuisance,
        typed.REMAINING_LIFE: RemainingLife,
        typed.TELEMETRY_BATCH: TelemetryBatch,
        typed.TELEMETRY_SAMPLE: TelemetrySample,
        typed.HEADER: Header,
        typed.TIME: Time,
    },
    as_double_array,
)

__all__ = [
    "ActuatorHealth",
    "RCLPY_TYPED",
    "TelemetryBatch",
    "TelemetrySample",
    "actuator_health",
    "health_report",
    "telemetry_batch",
    "telemetry_samples",
]


def telemetry_batch(
    rows: np.ndarray, origin_ns: int, stream: StreamId | None = None
) -> TelemetryBatch:
    """An rclpy TelemetryBatch of `stream`'s rows (n x len(CHANNELS)), stamped origin_ns + t[0]."""
    return typed.telemetry_batch(RCLPY_TYPED, rows, origin_ns, stream)


def telemetry_samples(
    rows: np.ndarray,
    origin_ns: int,
    stream: StreamId | None = None,
    *,
    every: int = typed.SAMPLE_DECIMATION,
) -> list[TelemetrySample]:
    """The rclpy TelemetrySample messages of the rows on the decimation grid (origin_ns + t)."""
    return typed.telemetry_samples(RCLPY_TYPED, rows, origin_ns, stream, every=every)


def actuator_health(report: HealthReport, t_ns: int) -> ActuatorHealth:
    """An rclpy ActuatorHealth of `report`, stamped `t_ns`."""
    return typed.actuator_health(RCLPY_TYPED, report, t_ns)


def health_report(msg: Any) -> HealthReport:
    """The HealthReport of an ActuatorHealth (rclpy's or rosbags')."""
    return typed.health_report(msg)
