"""What travels on the wire and in bags: topic names, message types, layouts, encode and decode.

Every ``std_msgs/msg/Float64MultiArray`` here is row-major with ``data_offset`` 0 when
encoded:

``/ema/telemetry`` and ``/ema/window``
    n samples: ``dim`` = ("samples", n, Cn), ("channels", C, C) with C = len(CHANNELS);
    data n x C in `CHANNELS` order (t, command, load, theta_u, theta_m, omega_m, i3eq,
    temperature; SI units, temperature in degC; NaN load = not measured,
    NaN temperature = unknown).
    A stream with an identity (`StreamId`: hardware id and run id) labels its first dim
    ``samples {"hardware_id": ..., "run_id": ...}`` (the JSON after one space), so that a
    receiver can tell two sources on one topic apart; plain "samples" is an anonymous stream.
    A window on ``/ema/window`` whose stream numbers its windows (cut by excitation) is
    labelled ``samples {"cycle": c}`` (monitor_node gives no identity there; a label with
    both is read too).
    Decoders also read the legacy layout ("channels", 7, 7) of recordings made before
    the temperature channel (`LEGACY_CHANNELS`) and return it with a NaN temperature.
``/ema/ground_truth``
    The N_K fault levels: ``dim`` = ("k", N_K, N_K).
``/ema/health``
    One result: ``dim`` = (`HEALTH_LABEL`, n, n); data in `HEALTH_FIELDS` order (generated
    from the fault table, `domain.health_layout`): the fit (k1..kN, percent_err, fitness,
    evaluations, elapsed_s, window_t0, window_t1, level), then the prognosis after it
    (`HEALTH_RUL_FIELDS`: RUL percentiles 5/50/95 in cycles of each fault with a RUL,
    NaN where a fault is not degrading, inf where a percentile never reaches the threshold;
    ``rul_dominant`` the 1-based k entry of the dominant prognosis, 0 = none).  Decoders
    also read the fit-only layout of recordings made before the prognosis
    (`HEALTH_FIELDS_FIT`) and return its RUL fields as NaN.

``/ema/run_info`` is a ``std_msgs/msg/String`` holding one JSON object;
``/diagnostics`` a ``diagnostic_msgs/msg/DiagnosticArray``.

The typed topics ``/ema/telemetry_batch``, ``/ema/telemetry_sample``, ``/ema/window_batch``
and ``/ema/actuator_health`` carry ``ema_phm_msgs`` messages (`ema_phm.telemetry.typed`).

Encoders return `ArrayParts` (labels, sizes, strides, flat float64 data);
`to_message` turns them into a message of the classes it is given (rclpy's or
rosbags').  Decoders read any object with the std_msgs field names
(``layout.dim[i].label/size/stride``, ``layout.data_offset``, ``data``), so one
decoder serves both.  Decoders check the sizes and the number of values, not the
labels or strides; a mismatch raises `WindowError` naming the topic, the layout
found and the one expected.  No rclpy, no rosbags.
"""

from __future__ import annotations

import array
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..domain.faults import N_K
from ..domain.health_layout import (  # noqa: F401  (wire.HEALTH_* is the layout on this wire)
    HEALTH_FIELDS,
    HEALTH_FIELDS_FIT,
    HEALTH_LABEL,
    HEALTH_RUL_FIELDS,
)
from ..domain.window import CHANNELS, LEGACY_CHANNELS, telemetry_rows
from ..errors import WindowError

TELEMETRY_TOPIC = "/ema/telemetry"
GROUND_TRUTH_TOPIC = "/ema/ground_truth"
RUN_INFO_TOPIC = "/ema/run_info"
#: Exactly the window a monitor fitted (telemetry layout).
WINDOW_TOPIC = "/ema/window"
HEALTH_TOPIC = "/ema/health"
DIAGNOSTICS_TOPIC = "/diagnostics"
#: Typed topics (ema_phm_msgs, `ema_phm.telemetry.typed`), published beside the ones above.
TELEMETRY_BATCH_TOPIC = "/ema/telemetry_batch"
TELEMETRY_SAMPLE_TOPIC = "/ema/telemetry_sample"
WINDOW_BATCH_TOPIC = "/ema/window_batch"
ACTUATOR_HEALTH_TOPIC = "/ema/actuator_health"

FLOAT64_MULTIARRAY = "std_msgs/msg/Float64MultiArray"
STRING = "std_msgs/msg/String"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
#: Message type of every topic.
TOPIC_TYPES: dict[str, str] = {
    TELEMETRY_TOPIC: FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY,
    RUN_INFO_TOPIC: STRING,
    WINDOW_TOPIC: FLOAT64_MULTIARRAY,
    HEALTH_TOPIC: FLOAT64_MULTIARRAY,
    DIAGNOSTICS_TOPIC: DIAGNOSTIC_ARRAY,
    TELEMETRY_BATCH_TOPIC: "ema_phm_msgs/msg/TelemetryBatch",
    TELEMETRY_SAMPLE_TOPIC: "ema_phm_msgs/msg/TelemetrySample",
    WINDOW_BATCH_TOPIC: "ema_phm_msgs/msg/TelemetryBatch",
    ACTUATOR_HEALTH_TOPIC: "ema_phm_msgs/msg/ActuatorHealth",
}

#: Labels of the two telemetry dims.
TELEMETRY_LABELS: tuple[str, str] = ("samples", "channels")
#: Label of the one ground-truth dim, and its size.
GROUND_TRUTH_LABEL = "k"
_NCH = len(CHANNELS)
_NCH_LEGACY = len(LEGACY_CHANNELS)


@dataclass(frozen=True)
class StreamId:
    """Who produced a telemetry stream: the actuator's hardware id and this run's id."""

    hardware_id: str
    run_id: str

    def __post_init__(self) -> None:
        for name in ("hardware_id", "run_id"):
            value = getattr(self, name)
            if not isinstance(value, str) or not value or len(value) > MAX_STREAM_ID_CHARS:
                raise WindowError(
                    f"stream {name} must be a non-empty string of at most "
                    f"{MAX_STREAM_ID_CHARS} characters, got {value!r}"
                )

    def __str__(self) -> str:
        return f"{self.hardware_id} (run {self.run_id})"


def describe_stream(stream: StreamId | None) -> str:
    """A stream in words, for messages: "stream <hw> (run <id>)" or "an anonymous stream"."""
    return "an anonymous stream" if stream is None else f"stream {stream}"


#: Longest hardware id or run id a telemetry label may carry.
MAX_STREAM_ID_CHARS = 128


def samples_label(stream: StreamId | None, cycle: int | None = None) -> str:
    """The label of the samples dim: "samples", with the stream's identity and the cycle.

    `cycle`: the operating cycle of a window on ``/ema/window`` (a stream that numbers its
    windows, as windows cut by excitation are), so that a replay numbers them as the monitor
    did.
    """
    ident: dict[str, Any] = {}
    if stream is not None:
        ident = {"hardware_id": stream.hardware_id, "run_id": stream.run_id}
    if cycle is not None:
        ident["cycle"] = int(cycle)
    return f"{TELEMETRY_LABELS[0]} {json.dumps(ident)}" if ident else TELEMETRY_LABELS[0]


def _label_object(label: str, topic: str) -> dict[str, Any] | None:
    """The JSON object after a samples label's first space (None: none); WindowError."""
    _head, _, text = str(label).partition(" ")
    if not text:
        return None
    try:
        obj = json.loads(text)
    except ValueError as exc:
        raise WindowError(
            f"{topic} message has a malformed stream identity in its label {label[:200]!r}: {exc}"
        ) from None
    if not isinstance(obj, dict):
        raise WindowError(
            f"{topic} message has a malformed stream identity in its label {label[:200]!r}: "
            "not a JSON object"
        )
    return obj


def stream_of_label(label: str, *, topic: str = TELEMETRY_TOPIC) -> StreamId | None:
    """The identity a samples label carries (None: anonymous); WindowError if malformed."""
    obj = _label_object(label, topic)
    if obj is None or (set(obj) == {"cycle"}):  # a window's cycle only: anonymous
        return None
    try:
        return StreamId(str(obj["hardware_id"]), str(obj["run_id"]))
    except (KeyError, WindowError) as exc:
        raise WindowError(
            f"{topic} message has a malformed stream identity in its label {label[:200]!r}: {exc}"
        ) from None


def cycle_of_label(label: str, *, topic: str = WINDOW_TOPIC) -> int | None:
    """The operating cycle a window's samples label carries (None: none); WindowError."""
    obj = _label_object(label, topic)
    if obj is None or "cycle" not in obj:
        return None
    cycle = obj["cycle"]
    if isinstance(cycle, bool) or not isinstance(cycle, int) or cycle < 0:
        raise WindowError(f"{topic} message labels cycle {cycle!r}, not a whole number >= 0")
    return cycle


@dataclass(frozen=True)
class ArrayParts:
    """The fields of a Float64MultiArray: one (label, size, stride) per dim and the flat data."""

    labels: tuple[str, ...]
    sizes: tuple[int, ...]
    strides: tuple[int, ...]
    data: np.ndarray
    data_offset: int = 0


@dataclass(frozen=True)
class MessageClasses:
    """The std_msgs classes of one message library, and how it wants ``data`` given."""

    array: Callable[..., Any]
    layout: Callable[..., Any]
    dimension: Callable[..., Any]
    data: Callable[[np.ndarray], Any]


def as_double_array(flat: np.ndarray) -> array.array:
    """`flat` as an ``array.array('d')`` (what rclpy messages hold), copied in one step."""
    buf = array.array("d")
    buf.frombytes(np.ascontiguousarray(flat, dtype=np.float64).tobytes())
    return buf


def encode_array(data: np.ndarray | Sequence[float], labels: Sequence[str]) -> ArrayParts:
    """A 1-D or 2-D array, row-major, one label per axis (ValueError otherwise)."""
    a = np.ascontiguousarray(data, dtype=np.float64)
    if a.ndim not in (1, 2) or len(labels) != a.ndim:
        raise ValueError(
            f"need a 1-D or 2-D array and one label per axis, got shape {a.shape} "
            f"and labels {list(labels)}"
        )
    sizes = tuple(int(n) for n in a.shape)
    strides = tuple(int(np.prod(sizes[i:])) for i in range(len(sizes)))
    return ArrayParts(tuple(str(lab) for lab in labels), sizes, strides, a.reshape(-1))


def encode_telemetry(
    rows: np.ndarray, stream: StreamId | None = None, cycle: int | None = None
) -> ArrayParts:
    """N samples (n x len(CHANNELS), `CHANNELS` order) in the telemetry / window layout.

    `stream`: the producer's identity, `cycle` a window's operating cycle, carried in the
    samples label (`samples_label`; neither: "samples").
    """
    a = np.asarray(rows, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != _NCH:
        raise WindowError(
            f"telemetry must be n x {_NCH} ({', '.join(CHANNELS)}), got shape {a.shape}"
        )
    return encode_array(a, (samples_label(stream, cycle), TELEMETRY_LABELS[1]))


def encode_ground_truth(k: np.ndarray | Sequence[float]) -> ArrayParts:
    """The N_K fault levels in the ground-truth layout."""
    a = np.asarray(k, dtype=np.float64)
    if a.shape != (N_K,):
        raise WindowError(f"ground-truth k must have {N_K} entries, got shape {a.shape}")
    return encode_array(a, [GROUND_TRUTH_LABEL])


def encode_health(vector: np.ndarray | Sequence[float]) -> ArrayParts:
    """A health vector (`HEALTH_FIELDS` order) in the health layout."""
    a = np.asarray(vector, dtype=np.float64)
    if a.shape != (len(HEALTH_FIELDS),):
        raise WindowError(
            f"health vector must have {len(HEALTH_FIELDS)} entries, got shape {a.shape}"
        )
    return encode_array(a, [HEALTH_LABEL])


def encode_run_info(meta: dict[str, Any]) -> str:
    """`meta` as the ``/ema/run_info`` JSON text (numpy values as lists / numbers)."""
    return json.dumps(meta, default=_json_default)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")


def to_message(parts: ArrayParts, classes: MessageClasses) -> Any:
    """A Float64MultiArray of `classes` holding `parts`."""
    dims = [
        classes.dimension(label=lab, size=size, stride=stride)
        for lab, size, stride in zip(parts.labels, parts.sizes, parts.strides, strict=True)
    ]
    return classes.array(
        layout=classes.layout(dim=dims, data_offset=parts.data_offset),
        data=classes.data(parts.data),
    )


def parts_of(msg: Any) -> ArrayParts:
    """The fields of a Float64MultiArray-like object, unchecked (data copied)."""
    dims = list(msg.layout.dim)
    return ArrayParts(
        labels=tuple(str(d.label) for d in dims),
        sizes=tuple(int(d.size) for d in dims),
        strides=tuple(int(d.stride) for d in dims),
        data=np.array(msg.data, dtype=np.float64).reshape(-1),
        data_offset=int(msg.layout.data_offset),
    )


def describe(parts: ArrayParts) -> str:
    """The layout of `parts` in one line, for error messages."""
    return (
        f"sizes {list(parts.sizes)} (labels {list(parts.labels)}, "
        f"strides {list(parts.strides)}), data_offset {parts.data_offset}, "
        f"{parts.data.size} values"
    )


def decode_telemetry(msg: Any, *, topic: str = TELEMETRY_TOPIC) -> np.ndarray:
    """The n x len(CHANNELS) samples of a telemetry-layout message (a new array).

    A legacy n x 7 message (no temperature channel) comes back with a NaN temperature.
    """
    p = parts_of(msg)
    n = p.sizes[0] if p.sizes else 0
    width = p.sizes[1] if len(p.sizes) == 2 else None
    if width not in (_NCH, _NCH_LEGACY) or p.data.size != p.data_offset + n * width:
        raise WindowError(
            f"{topic} message has layout {describe(p)}; expected sizes [n, {_NCH}] "
            f"(labels {list(TELEMETRY_LABELS)}) with data_offset + n*{_NCH} values "
            f"(or the legacy [n, {_NCH_LEGACY}] without temperature)"
        )
    return telemetry_rows(p.data[p.data_offset :].reshape(n, width))


def decode_stream(msg: Any, *, topic: str = TELEMETRY_TOPIC) -> StreamId | None:
    """The stream identity a telemetry-layout message carries (None: anonymous or no dims)."""
    dims = list(msg.layout.dim)
    return stream_of_label(str(dims[0].label), topic=topic) if dims else None


def decode_vector(msg: Any, *, topic: str, size: int) -> np.ndarray:
    """The `size` values after ``data_offset`` of a message (a new array)."""
    p = parts_of(msg)
    if p.data.size != p.data_offset + size:
        raise WindowError(
            f"{topic} message has layout {describe(p)}; expected {size} values after data_offset"
        )
    return p.data[p.data_offset :]


def decode_ground_truth(msg: Any, *, topic: str = GROUND_TRUTH_TOPIC) -> np.ndarray:
    """The N_K values of a ground-truth message (values not range-checked)."""
    return decode_vector(msg, topic=topic, size=N_K)


def decode_health(msg: Any, *, topic: str = HEALTH_TOPIC) -> dict[str, float]:
    """A health message as {field: value} in `HEALTH_FIELDS` order.

    A message of the fit-only layout (`HEALTH_FIELDS_FIT`, recorded before the prognosis)
    gives NaN RUL fields.
    """
    p = parts_of(msg)
    if p.data.size == p.data_offset + len(HEALTH_FIELDS_FIT):
        values = decode_vector(msg, topic=topic, size=len(HEALTH_FIELDS_FIT))
        values = np.concatenate([values, np.full(len(HEALTH_RUL_FIELDS), np.nan)])
    else:
        values = decode_vector(msg, topic=topic, size=len(HEALTH_FIELDS))
    return {name: float(v) for name, v in zip(HEALTH_FIELDS, values, strict=True)}
