"""The channel map: where each monitor channel of a foreign recording comes from.

One YAML file (format and examples: docs/your_recordings.md).  `load_channel_map` checks it
whole on load; every problem is a `ConfigError` of one line naming the key and the value.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..domain.window import CHANNEL_TABLE, MAY_BE_UNMEASURED
from ..errors import ConfigError
from ..telemetry.listed_assembler import LATEST_S
from ..telemetry.span_assembler import SpanRule
from .units import conversion

#: The map format this code reads.
VERSION = 1
#: Monitor channels a map must place (the time comes with each source).
MAPPED_CHANNELS: tuple[str, ...] = tuple(c.name for c in CHANNEL_TABLE if c.name != "t")
#: Unit of each monitor channel.
CHANNEL_UNIT: dict[str, str] = {c.name: c.unit for c in CHANNEL_TABLE}
#: Entry that says a channel is not recorded (only where `MAY_BE_UNMEASURED`).
UNKNOWN = "unknown"
#: Derivations, by the channel they make (formulas: `derive` and docs/your_recordings.md).
DERIVATIONS: dict[str, tuple[str, ...]] = {
    "theta_m": ("through_gear",),
    "omega_m": ("rate_of_theta_m",),
    "i3eq": ("park_q",),
}
#: Scaling conventions of a drive's q current, as the factor to the phase amplitude (I_3eq).
IQ_CONVENTIONS: dict[str, float] = {
    "amplitude": 1.0,  # amplitude-invariant Park (2/3): iq is the phase amplitude
    "power": (2.0 / 3.0) ** 0.5,  # power-invariant Park (sqrt(2/3)): iq = sqrt(3/2) x amplitude
    "rms": 2.0**0.5,  # iq scaled to the phase RMS: amplitude = sqrt(2) x iq
}
#: How windows are cut.
WINDOW_RULES = ("times", "marker", "excitation", "length")
#: Where a bag message's time comes from.
STAMPS = ("header", "log")
#: What a recording is for (`fleet.catalog`).
PURPOSES = ("baseline", "diagnose")

_REF_KEYS = {
    "topic",
    "field",
    "joint",
    "interface",
    "index",
    "column",
    "unit",
    "scale",
    "offset",
    "delay_s",
}
_FIELD_PATH = re.compile(
    r"^[A-Za-z_][A-Za-z0-9_]*(\[\d+\])?(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+\])?)*$"
)


@dataclass(frozen=True)
class SourceRef:
    """One value series in a recording: a bag topic's field, or a table column.

    Values are converted as ``(raw * scale + offset) * factor + shift`` where factor and shift
    take `unit` to the monitor channel's unit; times as ``t - delay_s`` (a clock that runs
    late, or a topic stamped when received).
    """

    topic: str | None = None
    field: str = "data"
    joint: str | None = None  # JointState / DynamicJointState entry, by name
    interface: str | None = None  # DynamicJointState interface, by name
    index: int | None = None  # element of an array field (Float64MultiArray)
    column: str | None = None
    unit: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    delay_s: float = 0.0
    factor: float = 1.0
    shift: float = 0.0

    @property
    def label(self) -> str:
        """How a message names this series."""
        if self.column is not None:
            return f"column {self.column!r}"
        who = "".join(
            f" {k} {v!r}"
            for k, v in (
                ("joint", self.joint),
                ("interface", self.interface),
                ("index", self.index),
            )
            if v is not None
        )
        return f"{self.topic} field {self.field!r}{who}"


@dataclass(frozen=True)
class ChannelSource:
    """Where one monitor channel comes from: a series, a derivation, or nothing (unknown)."""

    channel: str
    ref: SourceRef | None = None
    derive: str | None = None
    phases: tuple[SourceRef, ...] = ()  # park_q: the three phase currents (A, B, C)
    angle: SourceRef | None = None  # park_q: the electrical angle (None: from theta_m)
    angle_offset_rad: float = 0.0  # park_q: electrical angle of phase A's axis
    iq_convention: str | None = None  # i3eq read as a drive's iq, in this convention

    @property
    def unknown(self) -> bool:
        """The channel is not recorded."""
        return self.ref is None and self.derive is None


@dataclass(frozen=True)
class WindowRule:
    """How the continuous stretches of a recording are cut into windows."""

    by: str = "length"
    seconds: float = 2.0  # length: each window's duration
    times: tuple[tuple[float, float], ...] = ()  # times: (start, end) from the recording's start
    marker: SourceRef | None = None  # marker: windows where it is non-zero
    # the excitation rule's defaults are the live one's (`SpanRule`): one place for both
    min_duration_s: float = SpanRule.min_duration_s  # marker / excitation: shorter dropped
    max_pause_s: float = SpanRule.max_pause_s  # excitation: a still command this short
    settle_s: float = SpanRule.settle_s  # excitation: kept before the command moves


@dataclass(frozen=True)
class Identity:
    """Whose a recording is: fixed values, or taken from the file name."""

    hardware_id: str | None = None
    run_id: str | None = None
    purpose: str = "diagnose"
    from_name: re.Pattern[str] | None = None
    first_cycle: int = 0


@dataclass(frozen=True)
class ChannelMap:
    """A checked channel map."""

    channels: dict[str, ChannelSource]
    windows: WindowRule = field(default_factory=WindowRule)
    identity: Identity = field(default_factory=Identity)
    time: SourceRef | None = None  # tables: the time column
    stamps: str = "header"
    max_gap_s: float | None = None
    msg_definitions: dict[str, str] = field(default_factory=dict)  # type name -> .msg text
    source: str = ""

    def channel_refs(self) -> list[SourceRef]:
        """Every series the channels read, each once, in a stable order."""
        out: list[SourceRef] = []
        for src in self.channels.values():
            for r in (src.ref, *src.phases, src.angle):
                if r is not None and r not in out:
                    out.append(r)
        return out

    def refs(self) -> list[SourceRef]:
        """Every series the map reads (the channels', then a marker), each once."""
        out = self.channel_refs()
        if self.windows.marker is not None and self.windows.marker not in out:
            out.append(self.windows.marker)
        return out


def load_channel_map(path: str | Path) -> ChannelMap:
    """Read and check a channel map file; ConfigError of one line naming the problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"channel map {path}: cannot read it: {exc.strerror}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise ConfigError(f"channel map {path}: not YAML{at} ({problem})") from None
    return parse_channel_map(data, where=str(path), base=path.parent)


def parse_channel_map(data: Any, *, where: str, base: Path | None = None) -> ChannelMap:
    """The ChannelMap a parsed YAML mapping describes (`base`: folder of relative .msg paths)."""
    m = _mapping(data, where)
    _no_unknown_keys(
        m,
        {"version", "channels", "windows", "identity", "time", "stamps", "max_gap_s", "msg_types"},
        where,
    )
    if m.get("version") != VERSION:
        raise ConfigError(f"{where}: version {m.get('version')!r} is not {VERSION}")
    chans = _mapping(m.get("channels"), f"{where}: channels")
    _no_unknown_keys(chans, set(MAPPED_CHANNELS), f"{where}: channels")
    channels = {name: _channel(name, chans.get(name), where) for name in MAPPED_CHANNELS}
    stamps = m.get("stamps", "header")
    if stamps not in STAMPS:
        raise ConfigError(f"{where}: stamps {stamps!r} is not one of {', '.join(STAMPS)}")
    gap = m.get("max_gap_s")
    return ChannelMap(
        channels=channels,
        windows=_window_rule(m.get("windows", {}), f"{where}: windows"),
        identity=_identity(m.get("identity", {}), f"{where}: identity"),
        time=None if m.get("time") is None else _ref(m["time"], "s", f"{where}: time"),
        stamps=stamps,
        max_gap_s=None if gap is None else _positive(gap, f"{where}: max_gap_s"),
        msg_definitions=_msg_types(m.get("msg_types", {}), where, base),
        source=where,
    )


def _channel(name: str, entry: Any, where: str) -> ChannelSource:
    """One channel's entry."""
    at = f"{where}: channels.{name}"
    if entry is None:
        raise ConfigError(
            f"{at} is missing: say where it comes from"
            + (f" or write {UNKNOWN!r}" if name in MAY_BE_UNMEASURED else "")
        )
    if entry == UNKNOWN:
        if name not in MAY_BE_UNMEASURED:
            raise ConfigError(
                f"{at} is {UNKNOWN!r}, but the monitor needs it"
                + (f" (derive it: derive: {DERIVATIONS[name][0]})" if name in DERIVATIONS else "")
            )
        return ChannelSource(name)
    e = _mapping(entry, at)
    if "derive" in e:
        return _derived(name, e, at)
    conv = e.get("iq_convention")
    if conv is not None and (name != "i3eq" or conv not in IQ_CONVENTIONS):
        raise ConfigError(
            f"{at}: iq_convention {conv!r} "
            + (
                f"is not one of {', '.join(IQ_CONVENTIONS)}"
                if name == "i3eq"
                else "applies to i3eq only"
            )
        )
    rest = {k: v for k, v in e.items() if k != "iq_convention"}
    return ChannelSource(name, ref=_ref(rest, CHANNEL_UNIT[name], at), iq_convention=conv)


def _derived(name: str, e: Mapping[str, Any], at: str) -> ChannelSource:
    """A derived channel's entry."""
    how = e["derive"]
    if how not in DERIVATIONS.get(name, ()):
        allowed = ", ".join(DERIVATIONS.get(name, ())) or "nothing (map it to a recorded series)"
        raise ConfigError(f"{at}: derive {how!r}: {name} can be derived by {allowed}")
    if how != "park_q":
        _no_unknown_keys(e, {"derive"}, at)
        return ChannelSource(name, derive=how)
    _no_unknown_keys(e, {"derive", "phases", "angle", "angle_offset_rad"}, at)
    phases = e.get("phases")
    if not isinstance(phases, list) or len(phases) != 3:
        raise ConfigError(f"{at}: phases {phases!r} must list the three phase currents A, B, C")
    refs = tuple(_ref(p, "A", f"{at}.phases[{i}]") for i, p in enumerate(phases))
    angle = e.get("angle", "theta_m")
    angle_ref = None if angle == "theta_m" else _ref(angle, "rad", f"{at}.angle")
    return ChannelSource(
        name,
        derive=how,
        phases=refs,
        angle=angle_ref,
        angle_offset_rad=_number(e.get("angle_offset_rad", 0.0), f"{at}.angle_offset_rad"),
    )


def _ref(entry: Any, expected_unit: str, at: str) -> SourceRef:
    """A series reference (`SourceRef`), its unit checked against `expected_unit`."""
    e = _mapping(entry, at)
    _no_unknown_keys(e, _REF_KEYS, at)
    topic, column = e.get("topic"), e.get("column")
    if (topic is None) == (column is None):
        raise ConfigError(f"{at}: give either topic (a bag) or column (a table), not {dict(e)!r}")
    if column is not None:
        if not isinstance(column, str) or not column:
            raise ConfigError(f"{at}: column {column!r} is not a column name")
        bad = sorted(k for k in ("field", "joint", "interface", "index") if k in e)
        if bad:
            raise ConfigError(f"{at}: {', '.join(bad)} apply to a topic, not to column {column!r}")
    else:
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise ConfigError(f"{at}: topic {topic!r} is not a topic name (it starts with '/')")
        fld = e.get("field", "data")
        if not isinstance(fld, str) or not _FIELD_PATH.match(fld):
            raise ConfigError(f"{at}: field {fld!r} is not a field path like 'a.b[2].c'")
        if "interface" in e and "joint" not in e:
            raise ConfigError(f"{at}: interface {e['interface']!r} needs the joint it belongs to")
    index = e.get("index")
    if index is not None and (isinstance(index, bool) or not isinstance(index, int) or index < 0):
        raise ConfigError(f"{at}: index {index!r} is not a whole number >= 0")
    unit = e.get("unit", expected_unit)
    factor, shift = conversion(str(unit), expected_unit, where=f"{at}")
    for key in ("joint", "interface"):
        if key in e and (not isinstance(e[key], str) or not e[key]):
            raise ConfigError(f"{at}: {key} {e[key]!r} is not a name")
    return SourceRef(
        topic=topic,
        field=e.get("field", "data"),
        joint=e.get("joint"),
        interface=e.get("interface"),
        index=index,
        column=column,
        unit=str(unit),
        scale=_number(e.get("scale", 1.0), f"{at}.scale"),
        offset=_number(e.get("offset", 0.0), f"{at}.offset"),
        delay_s=_number(e.get("delay_s", 0.0), f"{at}.delay_s"),
        factor=factor,
        shift=shift,
    )


def _window_rule(entry: Any, at: str) -> WindowRule:
    """The `windows` section."""
    e = _mapping(entry, at)
    by = e.get("by", "length")
    if by not in WINDOW_RULES:
        raise ConfigError(f"{at}: by {by!r} is not one of {', '.join(WINDOW_RULES)}")
    allowed = {
        "length": {"seconds"},
        "times": {"times"},
        "marker": {"marker", "min_duration_s"},
        "excitation": {"min_duration_s", "max_pause_s", "settle_s"},
    }[by]
    _no_unknown_keys(e, allowed | {"by"}, at)
    kw: dict[str, Any] = {"by": by}
    for key in ("seconds", "min_duration_s", "max_pause_s", "settle_s"):
        if key in e:
            kw[key] = _positive(e[key], f"{at}.{key}", zero=key == "settle_s")
    if by == "times":
        kw["times"] = _times(e.get("times"), f"{at}.times")
    if by == "marker":
        if "marker" not in e:
            raise ConfigError(f"{at}: by marker needs marker: the topic or column that marks them")
        kw["marker"] = _ref(e["marker"], "1", f"{at}.marker")
    return WindowRule(**kw)


def _times(entry: Any, at: str) -> tuple[tuple[float, float], ...]:
    """A list of [start, end] pairs in seconds."""
    if not isinstance(entry, list) or not entry:
        raise ConfigError(f"{at}: {entry!r} must list [start, end] pairs in seconds")
    out = []
    for i, pair in enumerate(entry):
        if not isinstance(pair, list) or len(pair) != 2:
            raise ConfigError(f"{at}[{i}]: {pair!r} is not a [start, end] pair")
        a, b = (_number(v, f"{at}[{i}]") for v in pair)
        if not (0.0 <= a < b <= LATEST_S):
            raise ConfigError(
                f"{at}[{i}]: [{a:g}, {b:g}] must have 0 <= start < end <= {LATEST_S:g} s"
            )
        out.append((a, b))
    return tuple(out)


def _identity(entry: Any, at: str) -> Identity:
    """The `identity` section."""
    e = _mapping(entry, at)
    _no_unknown_keys(e, {"hardware_id", "run_id", "purpose", "from_name", "first_cycle"}, at)
    for key in ("hardware_id", "run_id"):
        v = e.get(key)
        if v is not None and (not isinstance(v, str) or not v.strip() or v != v.strip()):
            raise ConfigError(f"{at}: {key} {v!r} is not a non-empty name without outer spaces")
    purpose = e.get("purpose", "diagnose")
    if purpose not in PURPOSES:
        raise ConfigError(f"{at}: purpose {purpose!r} is not one of {', '.join(PURPOSES)}")
    pattern = None
    if "from_name" in e:
        try:
            pattern = re.compile(str(e["from_name"]))
        except re.error as exc:
            raise ConfigError(
                f"{at}: from_name {e['from_name']!r} is not a regex ({exc})"
            ) from None
        unknown = set(pattern.groupindex) - {"hardware_id", "run_id", "cycle", "purpose"}
        if unknown:
            raise ConfigError(
                f"{at}: from_name names groups {sorted(unknown)}; it may name hardware_id, "
                "run_id, cycle and purpose"
            )
    first = e.get("first_cycle", 0)
    if isinstance(first, bool) or not isinstance(first, int) or first < 0:
        raise ConfigError(f"{at}: first_cycle {first!r} is not a whole number >= 0")
    return Identity(
        hardware_id=e.get("hardware_id"),
        run_id=e.get("run_id"),
        purpose=purpose,
        from_name=pattern,
        first_cycle=first,
    )


def _msg_types(entry: Any, where: str, base: Path | None) -> dict[str, str]:
    """`msg_types`: message type name -> the .msg file defining it (read now)."""
    e = _mapping(entry, f"{where}: msg_types")
    out = {}
    for name, file in e.items():
        if not isinstance(name, str) or name.count("/") != 2:
            raise ConfigError(f"{where}: msg_types key {name!r} is not a type like pkg/msg/Name")
        p = Path(str(file))
        p = p if p.is_absolute() or base is None else base / p
        try:
            out[name] = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(
                f"{where}: msg_types {name}: cannot read {p}: {exc.strerror}"
            ) from None
    return out


def _mapping(entry: Any, at: str) -> Mapping[str, Any]:
    """`entry` if it is a mapping with text keys (an absent section is empty)."""
    if entry is None:
        return {}
    if not isinstance(entry, Mapping) or not all(isinstance(k, str) for k in entry):
        raise ConfigError(f"{at}: {entry!r} is not a mapping of names to values")
    return entry


def _no_unknown_keys(e: Mapping[str, Any], known: set[str], at: str) -> None:
    """ConfigError naming the first key of `e` not in `known`."""
    bad = sorted(set(e) - known)
    if bad:
        raise ConfigError(f"{at}: unknown key {bad[0]!r} (known: {', '.join(sorted(known))})")


def _number(v: Any, at: str) -> float:
    """A finite number."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"{at}: {v!r} is not a finite number")
    try:
        x = float(v)
    except OverflowError:  # an integer beyond any float
        raise ConfigError(f"{at}: {v} is not a finite number") from None
    if not math.isfinite(x):
        raise ConfigError(f"{at}: {v!r} is not a finite number")
    return x


def _positive(v: Any, at: str, *, zero: bool = False) -> float:
    """A finite number > 0 (>= 0 with `zero`)."""
    x = _number(v, at)
    if x < 0 or (x == 0 and not zero):
        raise ConfigError(f"{at}: {v!r} must be {'>=' if zero else '>'} 0")
    return x
