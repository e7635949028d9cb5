"""The typed messages of ``ema_phm_msgs``: their schemas, and library objects <-> messages.

Message types (``ema_phm_msgs/msg/*.msg``, built by ``scripts/build_msgs.sh`` or colcon):

``TelemetryBatch``
    header + ``sample_rate_hz`` + one float64 array per channel of `CHANNELS`.
``TelemetrySample``
    header + one float64 per channel: one sample, the plottable stream.
``ActuatorHealth``
    header, hardware id, level (constants OK/WARN/ERROR/STALE as diagnostic_msgs),
    message, one named `FaultEstimate` per fault (value, 90 % interval, severity,
    level, identifiability, remaining life), adequacy, nuisances, fit figures.

The functions here build and read messages through the attribute names only, like
`ema_phm.telemetry.wire`: `TypedClasses` says which classes to build with (rclpy's, in
`ema_phm.ros.typed_messages`, or rosbags', `rosbags_classes`), so one converter serves
the nodes and the bags.  No rclpy.

What `ema_phm.diagnosis.health.Assessment` does not hold yet -- the 90 % intervals,
identifiability, adequacy, nuisances, remaining life -- comes in `HealthExtras`; left
out, the message carries NaN (numbers), ``false``/``""`` (identifiable, reason),
``evaluated = false`` (adequacy) and no nuisances.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import get_types_from_msg

from ..diagnosis.health import ERROR, OK, STALE, WARN, Assessment
from ..diagnosis.nuisance import REPORTED_UNITS
from ..domain.faults import N_K, NAMES, NOMINAL
from ..domain.window import CHANNELS, TIME_COLUMN
from ..errors import BagError, WindowError
from .wire import StreamId

PACKAGE = "ema_phm_msgs"
TELEMETRY_BATCH = "ema_phm_msgs/msg/TelemetryBatch"
TELEMETRY_SAMPLE = "ema_phm_msgs/msg/TelemetrySample"
ACTUATOR_HEALTH = "ema_phm_msgs/msg/ActuatorHealth"
FAULT_ESTIMATE = "ema_phm_msgs/msg/FaultEstimate"
REMAINING_LIFE = "ema_phm_msgs/msg/RemainingLife"
ADEQUACY = "ema_phm_msgs/msg/Adequacy"
NUISANCE = "ema_phm_msgs/msg/Nuisance"
HEADER = "std_msgs/msg/Header"
TIME = "builtin_interfaces/msg/Time"
#: Every message type of the package, in dependency order (nested types first).
MESSAGE_TYPES: tuple[str, ...] = (
    REMAINING_LIFE,
    FAULT_ESTIMATE,
    ADEQUACY,
    NUISANCE,
    ACTUATOR_HEALTH,
    TELEMETRY_BATCH,
    TELEMETRY_SAMPLE,
)
#: One TelemetrySample is published per this many telemetry samples (100 Hz at 2 kHz).
SAMPLE_DECIMATION = 20
#: ActuatorHealth.level constants (OK, WARN, ERROR, STALE) are the diagnostic_msgs levels
#: of `diagnosis.health`, imported above.
#: The RemainingLife fields, in message order.
RUL_FIELDS: tuple[str, ...] = (
    "cycles_p5",
    "cycles_p50",
    "cycles_p95",
    "hours_p5",
    "hours_p50",
    "hours_p95",
    "horizon_hours",
    "p_threshold_within_horizon",
)
_NAN = math.nan


def msg_dir() -> Path:
    """The folder holding the ``.msg`` files: the checkout's, else the installed share folder.

    BagError when neither exists (ema_phm_msgs neither in a checkout nor installed).
    """
    here = Path(__file__).resolve().parents[2] / PACKAGE / "msg"
    if (here / "ActuatorHealth.msg").is_file():
        return here
    try:
        from ament_index_python.packages import (  # noqa: PLC0415  (optional: ROS machines)
            PackageNotFoundError,
            get_package_share_directory,
        )
    except ImportError:
        raise BagError(
            f"the {PACKAGE} message definitions are not in {here} and ament_index_python "
            "is not installed to find them"
        ) from None
    try:
        share = Path(get_package_share_directory(PACKAGE)) / "msg"
    except (PackageNotFoundError, LookupError, ValueError):
        raise BagError(
            f"the {PACKAGE} message definitions are neither in {here} nor installed "
            "(build it: scripts/build_msgs.sh, or colcon build)"
        ) from None
    if not (share / "ActuatorHealth.msg").is_file():
        raise BagError(f"{share} has no ActuatorHealth.msg")
    return share


def msg_texts() -> dict[str, str]:
    """{full type name: .msg text} of every message of the package."""
    folder = msg_dir()
    out = {}
    for name in MESSAGE_TYPES:
        path = folder / (name.rsplit("/", 1)[1] + ".msg")
        try:
            out[name] = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise BagError(f"cannot read {path}: {exc.strerror}") from None
    return out


def register_types(typestore: Any) -> None:
    """Add the package's message types to a rosbags ``Typestore`` (no-op if there)."""
    if all(name in typestore.types for name in MESSAGE_TYPES):
        return
    types: dict[str, Any] = {}
    for name, text in msg_texts().items():
        types.update(get_types_from_msg(text, name))
    typestore.register(types)


@dataclass(frozen=True)
class TypedClasses:
    """Message classes of one library (by full type name) and how float64[] fields are given."""

    types: Mapping[str, Callable[..., Any]]
    floats: Callable[[np.ndarray], Any]

    def make(self, msgtype: str, /, **fields: Any) -> Any:
        """A message of type `msgtype` with `fields`."""
        return self.types[msgtype](**fields)


def rosbags_classes(typestore: Any) -> TypedClasses:
    """The classes of a rosbags typestore (the package's types registered into it)."""
    register_types(typestore)
    names = (*MESSAGE_TYPES, HEADER, TIME)
    return TypedClasses({n: typestore.types[n] for n in names}, np.ascontiguousarray)


def stamp_of(t_ns: int) -> tuple[int, int]:
    """(sec, nanosec) of a time in integer nanoseconds (sec may be negative)."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    if not -(2**31) <= sec < 2**31:
        raise WindowError(f"time {t_ns} ns does not fit a builtin_interfaces/Time")
    return sec, nsec


def header(classes: TypedClasses, t_ns: int, frame_id: str = "") -> Any:
    """A std_msgs/Header stamped `t_ns` (nanoseconds)."""
    sec, nsec = stamp_of(t_ns)
    return classes.make(HEADER, stamp=classes.make(TIME, sec=sec, nanosec=nsec), frame_id=frame_id)


def time_ns(hdr: Any) -> int:
    """The stamp of a header in nanoseconds."""
    return int(hdr.stamp.sec) * 1_000_000_000 + int(hdr.stamp.nanosec)


# ------------------------------------------------------------------- telemetry
def _rows(rows: np.ndarray) -> np.ndarray:
    a = np.asarray(rows, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != len(CHANNELS) or a.shape[0] < 1:
        raise WindowError(
            f"telemetry must be n x {len(CHANNELS)} ({', '.join(CHANNELS)}) with n >= 1, "
            f"got shape {a.shape}"
        )
    return a


def sample_rate(t: np.ndarray) -> float:
    """Samples per second of an evenly sampled time base (NaN with fewer than 2 samples)."""
    if t.size < 2:
        return _NAN
    span = float(t[-1] - t[0])
    return (t.size - 1) / span if span > 0 else _NAN


def sample_stamp_ns(origin_ns: int, t: float) -> int:
    """The ROS time [ns] of a sample at stream time `t` [s]: the stream's origin plus t."""
    return int(origin_ns) + round(float(t) * 1e9)


def _ids(stream: StreamId | None) -> dict[str, str]:
    if stream is None:
        return {"hardware_id": "", "run_id": ""}
    return {"hardware_id": stream.hardware_id, "run_id": stream.run_id}


def stream_of(msg: Any) -> StreamId | None:
    """The stream identity of a TelemetryBatch / TelemetrySample (None: not carried)."""
    hw, run = str(getattr(msg, "hardware_id", "")), str(getattr(msg, "run_id", ""))
    return StreamId(hw, run) if hw and run else None


def telemetry_batch(
    classes: TypedClasses, rows: np.ndarray, origin_ns: int, stream: StreamId | None = None
) -> Any:
    """A TelemetryBatch of n samples (n x len(CHANNELS), `CHANNELS` order) of `stream`.

    Stamped with its first sample's time on the ROS clock: `origin_ns` (the stream's stamp
    origin, the ROS time of t = 0) plus t[0].
    """
    a = _rows(rows)
    columns = {c: classes.floats(np.ascontiguousarray(a[:, i])) for i, c in enumerate(CHANNELS)}
    return classes.make(
        TELEMETRY_BATCH,
        header=header(classes, sample_stamp_ns(origin_ns, a[0, TIME_COLUMN])),
        **_ids(stream),
        sample_rate_hz=sample_rate(a[:, TIME_COLUMN]),
        **columns,
    )


def batch_rows(msg: Any) -> np.ndarray:
    """The n x len(CHANNELS) samples of a TelemetryBatch.

    WindowError if its arrays differ in length.
    """
    cols = [np.asarray(getattr(msg, c), dtype=np.float64).reshape(-1) for c in CHANNELS]
    sizes = {c: col.size for c, col in zip(CHANNELS, cols, strict=True)}
    if len(set(sizes.values())) != 1:
        raise WindowError(f"TelemetryBatch arrays differ in length: {sizes}")
    return np.column_stack(cols) if cols[0].size else np.empty((0, len(CHANNELS)))


def telemetry_samples(
    classes: TypedClasses,
    rows: np.ndarray,
    origin_ns: int,
    stream: StreamId | None = None,
    *,
    every: int = SAMPLE_DECIMATION,
) -> list[Any]:
    """TelemetrySample messages of the rows whose sample index ``round(t * rate)`` % every == 0.

    Picking by the sample's own time keeps the stream evenly spaced across batches of
    any size.  Each is stamped with its own sample's time: `origin_ns` plus t.
    """
    a = _rows(rows)
    if every < 1:
        raise WindowError(f"sample decimation must be >= 1, got {every}")
    rate = sample_rate(a[:, TIME_COLUMN])
    if math.isfinite(rate):
        index = np.rint(a[:, TIME_COLUMN] * rate).astype(np.int64)
        keep = np.flatnonzero(index % every == 0)
    else:
        keep = np.arange(a.shape[0])
    ids = _ids(stream)
    return [
        classes.make(
            TELEMETRY_SAMPLE,
            header=header(classes, sample_stamp_ns(origin_ns, a[i, TIME_COLUMN])),
            **ids,
            **{c: float(a[i, j]) for j, c in enumerate(CHANNELS)},
        )
        for i in keep
    ]


def sample_row(msg: Any) -> np.ndarray:
    """The len(CHANNELS) channel values of a TelemetrySample, in `CHANNELS` order."""
    return np.array([float(getattr(msg, c)) for c in CHANNELS], dtype=np.float64)


# ---------------------------------------------------------------------- health
@dataclass(frozen=True)
class RemainingLife:
    """Remaining useful life of one fault mode (`RUL_FIELDS`; NaN = not estimated)."""

    cycles_p5: float = _NAN
    cycles_p50: float = _NAN
    cycles_p95: float = _NAN
    hours_p5: float = _NAN
    hours_p50: float = _NAN
    hours_p95: float = _NAN
    horizon_hours: float = _NAN
    p_threshold_within_horizon: float = _NAN


@dataclass(frozen=True)
class AdequacyResult:
    """The model adequacy test of a fit (``evaluated`` False = not run)."""

    statistic: float = _NAN
    threshold: float = _NAN
    ok: bool = False
    evaluated: bool = False


@dataclass(frozen=True)
class NuisanceValue:
    """One nuisance estimate: name, unit, value."""

    name: str
    unit: str
    value: float


def _nan_k() -> np.ndarray:
    return np.full(N_K, _NAN)


@dataclass(frozen=True)
class HealthExtras:
    """What an ActuatorHealth carries beyond `Assessment` (defaults: not estimated).

    ``k_low``/``k_high``: the 90 % interval per k entry; ``identifiable`` and
    ``reasons`` per k entry; ``rul`` per k entry.
    """

    k_low: np.ndarray = field(default_factory=_nan_k)
    k_high: np.ndarray = field(default_factory=_nan_k)
    identifiable: tuple[bool, ...] = (False,) * N_K
    reasons: tuple[str, ...] = ("",) * N_K
    adequacy: AdequacyResult = AdequacyResult()
    nuisances: tuple[NuisanceValue, ...] = ()
    rul: tuple[RemainingLife, ...] = (RemainingLife(),) * N_K
    no_degradation_detected: bool = False

    def __post_init__(self) -> None:
        for name in ("k_low", "k_high"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.shape != (N_K,):
                raise WindowError(
                    f"HealthExtras.{name} must have {N_K} entries, got shape {a.shape}"
                )
            object.__setattr__(self, name, a)
        for name in ("identifiable", "reasons", "rul"):
            if len(getattr(self, name)) != N_K:
                raise WindowError(
                    f"HealthExtras.{name} must have {N_K} entries, got {len(getattr(self, name))}"
                )


@dataclass(frozen=True)
class HealthReport:
    """Everything one ActuatorHealth message holds, as library objects.

    ``assessment`` is the fit (None: no fit yet); ``assessed`` says whether it was
    made on the window this message reports (False: a status such as waiting, busy,
    stale, failed, not excited, and the k entries are the last fit's).
    """

    level: int
    message: str
    hardware_id: str
    assessed: bool
    assessment: Assessment | None
    extras: HealthExtras = HealthExtras()


def actuator_health(classes: TypedClasses, report: HealthReport, t_ns: int) -> Any:
    """An ActuatorHealth message of `report`, stamped `t_ns`."""
    if report.level not in (OK, WARN, ERROR, STALE):
        raise WindowError(f"health level must be 0..3 (OK..STALE), got {report.level}")
    a, x = report.assessment, report.extras
    k = _nan_k() if a is None else np.asarray(a.k, dtype=np.float64)
    sev = _nan_k() if a is None else np.asarray(a.severity, dtype=np.float64)
    levels = np.zeros(N_K, dtype=int) if a is None else np.asarray(a.levels, dtype=int)
    faults = {
        name: classes.make(
            FAULT_ESTIMATE,
            name=name,
            value=float(k[i]),
            low=float(x.k_low[i]),
            high=float(x.k_high[i]),
            nominal=float(NOMINAL[i]),
            severity=float(sev[i]),
            level=int(levels[i]),
            identifiable=bool(x.identifiable[i]),
            reason=str(x.reasons[i]),
            rul=classes.make(
                REMAINING_LIFE, **{f: float(getattr(x.rul[i], f)) for f in RUL_FIELDS}
            ),
        )
        for i, name in enumerate(NAMES)
    }
    adequacy = classes.make(
        ADEQUACY,
        evaluated=bool(x.adequacy.evaluated),
        statistic=float(x.adequacy.statistic),
        threshold=float(x.adequacy.threshold),
        ok=bool(x.adequacy.ok),
    )
    nuisances = [
        classes.make(NUISANCE, name=n.name, unit=n.unit, value=float(n.value)) for n in x.nuisances
    ]
    evaluations = 0 if a is None else int(a.evaluations)
    if not 0 <= evaluations < 2**32:
        raise WindowError(f"evaluations {evaluations} does not fit a uint32")
    return classes.make(
        ACTUATOR_HEALTH,
        header=header(classes, t_ns),
        hardware_id=report.hardware_id,
        level=int(report.level),
        message=report.message,
        assessed=bool(report.assessed),
        dominant_fault="" if a is None else NAMES[int(a.dominant)],
        window_t0=_NAN if a is None else float(a.window_t0),
        window_t1=_NAN if a is None else float(a.window_t1),
        **faults,
        adequacy=adequacy,
        nuisances=nuisances,
        percent_err=_NAN if a is None else float(a.percent_err),
        fitness=_NAN if a is None else float(a.fitness),
        evaluations=evaluations,
        elapsed_s=_NAN if a is None else float(a.elapsed_s),
        no_degradation_detected=bool(x.no_degradation_detected),
    )


def health_report(msg: Any) -> HealthReport:
    """The HealthReport an ActuatorHealth message holds.

    The assessment is rebuilt (without ``k_true``) when the message has a finite k;
    WindowError if the message names faults out of order or has a bad level.
    """
    faults = [getattr(msg, name) for name in NAMES]
    for name, f in zip(NAMES, faults, strict=True):
        if f.name != name:
            raise WindowError(f"ActuatorHealth.{name}.name is {f.name!r}, expected {name!r}")
    level = int(msg.level)
    if level not in (OK, WARN, ERROR, STALE):
        raise WindowError(f"ActuatorHealth.level must be 0..3, got {level}")
    return HealthReport(
        level=level,
        message=str(msg.message),
        hardware_id=str(msg.hardware_id),
        assessed=bool(msg.assessed),
        assessment=_assessment_of(msg, faults),
        extras=_extras_of_message(msg, faults),
    )


def _assessment_of(msg: Any, faults: list[Any]) -> Assessment | None:
    """The fit an ActuatorHealth holds (None when its k is not finite: no fit yet)."""
    k = np.array([f.value for f in faults], dtype=np.float64)
    if not np.all(np.isfinite(k)):
        return None
    dominant = str(msg.dominant_fault)
    if dominant not in NAMES:
        raise WindowError(f"ActuatorHealth.dominant_fault {dominant!r} is not a fault name")
    levels = np.array([int(f.level) for f in faults], dtype=int)
    return Assessment(
        k=k,
        severity=np.array([f.severity for f in faults], dtype=np.float64),
        levels=levels,
        level=int(levels.max()),
        dominant=NAMES.index(dominant),
        message=str(msg.message),
        percent_err=float(msg.percent_err),
        fitness=float(msg.fitness),
        evaluations=int(msg.evaluations),
        elapsed_s=float(msg.elapsed_s),
        window_t0=float(msg.window_t0),
        window_t1=float(msg.window_t1),
    )


def _extras_of_message(msg: Any, faults: list[Any]) -> HealthExtras:
    """The intervals, flags, adequacy, nuisances and RULs of an ActuatorHealth."""
    ad = msg.adequacy
    return HealthExtras(
        k_low=np.array([f.low for f in faults], dtype=np.float64),
        k_high=np.array([f.high for f in faults], dtype=np.float64),
        identifiable=tuple(bool(f.identifiable) for f in faults),
        reasons=tuple(str(f.reason) for f in faults),
        adequacy=AdequacyResult(
            float(ad.statistic), float(ad.threshold), bool(ad.ok), bool(ad.evaluated)
        ),
        nuisances=tuple(
            NuisanceValue(str(n.name), str(n.unit), float(n.value)) for n in msg.nuisances
        ),
        rul=tuple(
            RemainingLife(**{name: float(getattr(f.rul, name)) for name in RUL_FIELDS})
            for f in faults
        ),
        no_degradation_detected=bool(msg.no_degradation_detected),
    )


def extras_of(assessment: Any | None) -> HealthExtras:
    """The HealthExtras an assessment already holds; what it lacks stays "not estimated".

    Reads, when present, ``k_interval`` ((N_K, 2) 90 % intervals), ``identifiable`` (N_K pairs
    (bool, reason)), ``adequacy`` ({statistic, threshold, ok}) and ``nuisance`` (name ->
    value, units from `ema_phm.diagnosis.nuisance.REPORTED_UNITS`); by name, so it works
    with an `Assessment` with or without those fields.  Remaining life is not read here.
    """
    if assessment is None:
        return HealthExtras()
    fields: dict[str, Any] = {}
    interval = getattr(assessment, "k_interval", None)
    if interval is not None:
        iv = np.asarray(interval, dtype=np.float64)
        if iv.shape != (N_K, 2):
            raise WindowError(f"k_interval must be {N_K} x 2, got shape {iv.shape}")
        fields["k_low"], fields["k_high"] = iv[:, 0].copy(), iv[:, 1].copy()
    flags = getattr(assessment, "identifiable", None)
    if flags is not None:
        fields["identifiable"] = tuple(bool(ok) for ok, _ in flags)
        fields["reasons"] = tuple(str(why) for _, why in flags)
    adequacy = getattr(assessment, "adequacy", None)
    if adequacy is not None:
        fields["adequacy"] = AdequacyResult(
            statistic=float(adequacy["statistic"]),
            threshold=float(adequacy["threshold"]),
            ok=bool(adequacy["ok"]),
            evaluated=True,
        )
    values = getattr(assessment, "nuisance", None)
    if values:
        units = {name: unit.split(" (", 1)[0] for name, unit in REPORTED_UNITS.items()}
        fields["nuisances"] = nuisances_of(values, units)
    return HealthExtras(**fields)


def nuisances_of(
    values: Mapping[str, float], units: Mapping[str, str]
) -> tuple[NuisanceValue, ...]:
    """Nuisance name -> value pairs as NuisanceValue entries (unit "" when unknown)."""
    return tuple(NuisanceValue(n, units.get(n, ""), float(v)) for n, v in values.items())
