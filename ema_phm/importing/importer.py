"""`import_recordings`: foreign recordings in, one-window ema_phm recordings out.

Per source: read the series the map names (`sources`), make the channels (`derive`), find
the stretches without a gap and put every channel on the actuator's grid (`resample`), cut
the windows (`segments`), and give each its identity.  Each window becomes a bag as
`telemetry.bags.write_window` writes it, at
``OUT/<hardware_id>/<run_id>/<baseline|window>_<cycle>`` (ids made safe for a path:
`path_name`), with run_info ``hardware_id``, ``run_id``, ``cycle``, ``purpose``,
``sample_rate``, ``imported_from`` (the source's name), ``source_start_s`` (the window's
start in the source) and ``channels`` (how each channel was obtained).

All windows are written to a staging folder inside OUT first, and moved into place only
when every source was read and no target holds other content: a failure leaves OUT as it
was.  A target already holding the same bytes is left alone (importing twice changes
nothing).
"""

# Heavy libraries are imported where used: `ema-phm --help` stays fast.
# ruff: noqa: PLC0415

from __future__ import annotations

import dataclasses
import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..domain.window import CURRENT_LOGGED_KEY, MIN_SAMPLES, RECORDED, Window
from ..errors import ConfigError
from ..physics.parameters import ActuatorParameters
from . import derive, resample, segments
from .channel_map import IQ_CONVENTIONS, ChannelMap
from .sources import STAGING_PREFIX, Series, read_series

if TYPE_CHECKING:
    from .stream import StreamCounts

#: Characters an id keeps in a path; any other makes the name `<safe>-<digest>`.
_SAFE = re.compile(r"[^A-Za-z0-9._-]")
#: How each derived channel is described in run_info ``channels``.
DERIVED_TEXT = {
    "through_gear": "theta_u / gear_ratio (no motor encoder)",
    "rate_of_theta_m": "central difference of theta_m",
    "park_q": "Park q current of the phase currents, acquisition-filtered",
}


@dataclass
class SourceReport:
    """What one source gave."""

    path: str
    windows: int = 0
    stretches: int = 0
    seconds: float = 0.0  # the recording's span
    seconds_in_gaps: float = 0.0  # not covered by every series without a gap
    longest_s: float = 0.0  # the longest stretch every series covers without a gap
    windows_dropped: int = 0  # listed (times rule) but spanning a gap or outside the recording
    too_short: int = 0  # windows of fewer than MIN_SAMPLES samples
    too_long: int = 0  # --stream: segments or marked runs beyond the longest a stream cuts


@dataclass
class ImportReport:
    """What `import_recordings` did."""

    sources: list[SourceReport] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "sources": [vars(s) for s in self.sources],
            "written": self.written,
            "unchanged": self.unchanged,
        }

    def lines(self) -> list[str]:
        """The text report."""
        out = []
        for s in self.sources:
            drop = f", {s.windows_dropped} listed windows not wholly recorded" * bool(
                s.windows_dropped
            ) + f", {s.too_long} windows too long to stream, dropped" * bool(s.too_long)
            out.append(
                f"{s.path}: {s.windows} windows from {s.stretches} gap-free stretches "
                f"(longest {s.longest_s:.3f} s) of a {s.seconds:.3f} s log; "
                f"{s.seconds_in_gaps:.3f} s not covered by every series{drop}"
            )
        out.append(f"{len(self.written)} recordings written, {len(self.unchanged)} already there")
        return out


@dataclass(frozen=True)
class WindowIdentity:
    """Whose a window is."""

    hardware_id: str
    run_id: str
    purpose: str
    cycle: int | None  # None: numbered in order


def path_name(name: str) -> str:
    """`name` as one safe path component: itself if made of [A-Za-z0-9._-] and not dots only."""
    if name and not _SAFE.search(name) and name.strip(".") and not name.startswith("."):
        return name
    digest = hashlib.sha256(name.encode("utf-8")).hexdigest()[:8]
    return f"{_SAFE.sub('_', name).lstrip('.')[:40]}-{digest}"


def identity_of(source: Path, cmap: ChannelMap, overrides: dict[str, str]) -> WindowIdentity:
    """The identity of a source's windows: flags over the file name over the map."""
    ident = cmap.identity
    found: dict[str, str] = {}
    if ident.from_name is not None:
        m = ident.from_name.search(source.name)
        if m is None and not (overrides.get("hardware_id") or ident.hardware_id):
            raise ConfigError(
                f"{source}: its name does not match identity.from_name "
                f"'{ident.from_name.pattern}', and nothing else names its unit"
            )
        found = {} if m is None else {k: v for k, v in m.groupdict().items() if v is not None}
    pick = {
        key: overrides.get(key) or found.get(key) or getattr(ident, key)
        for key in ("hardware_id", "run_id", "purpose")
    }
    if not pick["hardware_id"]:
        raise ConfigError(
            f"{source}: no hardware_id: name the unit in the map (identity.hardware_id), "
            "with --hardware-id, or by a from_name group"
        )
    if pick["purpose"] not in ("baseline", "diagnose"):
        raise ConfigError(f"{source}: purpose {pick['purpose']!r} is not baseline or diagnose")
    cycle = found.get("cycle")
    if cycle is not None and not cycle.isdigit():
        raise ConfigError(f"{source}: its name gives cycle {cycle!r}, not a whole number")
    return WindowIdentity(
        hardware_id=str(pick["hardware_id"]),
        run_id=str(pick["run_id"] or "run"),
        purpose=str(pick["purpose"]),
        cycle=None if cycle is None else int(cycle),
    )


def channel_series(
    series: dict[Any, Series], cmap: ChannelMap, actuator: ActuatorParameters
) -> dict[str, Series | None]:
    """Each monitor channel as a series (None: unknown, or omega_m taken from theta_m later)."""
    ch = cmap.channels
    out: dict[str, Series | None] = {}
    for name, src in ch.items():
        out[name] = None if src.ref is None else series[src.ref]
    theta_u = out["theta_u"]
    assert theta_u is not None
    if ch["theta_m"].derive == "through_gear":
        out["theta_m"] = derive.through_gear(theta_u, actuator)
    i3 = ch["i3eq"]
    if i3.derive == "park_q":
        theta_m = out["theta_m"]
        assert theta_m is not None
        angle = (
            derive.electrical_angle(theta_m, actuator, i3.angle_offset_rad)
            if i3.angle is None
            else derive.unwrapped(
                Series(series[i3.angle].t, series[i3.angle].v + i3.angle_offset_rad)
            )
        )
        phases = (series[i3.phases[0]], series[i3.phases[1]], series[i3.phases[2]])
        out["i3eq"] = derive.acquisition_filtered(derive.park_q(phases, angle), actuator)
    elif i3.iq_convention is not None:
        s = out["i3eq"]
        assert s is not None
        out["i3eq"] = Series(s.t, s.v * IQ_CONVENTIONS[i3.iq_convention])
    return out


def provenance(cmap: ChannelMap) -> dict[str, str]:
    """run_info ``channels``: how each channel was obtained."""
    out = {}
    for name, src in cmap.channels.items():
        if src.unknown:
            out[name] = "unknown"
        elif src.derive is not None:
            out[name] = "derived: " + DERIVED_TEXT[src.derive]
        else:
            assert src.ref is not None
            conv = f" (drive iq, {src.iq_convention} convention)" * bool(src.iq_convention)
            out[name] = f"{RECORDED}: {src.ref.label}{conv}"
    return out


def source_windows(
    path: Path, cmap: ChannelMap, actuator: ActuatorParameters
) -> tuple[list[tuple[Window, float]], SourceReport]:
    """The windows of one source, each with its start in the source [s], and the report."""
    rate = actuator.acquisition.sample_rate
    series = _from_first_sample(read_series(path, cmap))
    try:
        chans = channel_series(series, cmap, actuator)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    present = [s for s in chans.values() if s is not None]
    marker = None if cmap.windows.marker is None else series[cmap.windows.marker]
    # every series read must be there: a gap in phase B is a gap in I_3eq (a marker is held:
    # one sent only when it changes has no gaps)
    read = [s for r, s in series.items() if r != cmap.windows.marker]
    spans = resample.stretches([*read, *present], cmap.max_gap_s)
    first = min(float(s.t[0]) for s in present)
    last = max(float(s.t[-1]) for s in present)
    report = SourceReport(str(path), stretches=len(spans), seconds=last - first)
    report.seconds_in_gaps = report.seconds - sum(b - a for a, b in spans)
    report.longest_s = max((b - a for a, b in spans), default=0.0)
    i3 = chans["i3eq"]
    logged = None if i3 is None or cmap.channels["i3eq"].derive else resample.logged_grid(i3, rate)
    out: list[tuple[Window, float]] = []
    found = 0
    for span in spans:
        t = resample.grid(span, rate)
        if t.size < 2:
            continue
        cols = on_grid_columns(chans, t, rate)
        held = None if marker is None else resample.held(marker, t)
        for a, b in segments.windows_in(cmap.windows, t, rate, cols["command"], held):
            found += 1
            if b - a + 1 < MIN_SAMPLES:
                report.too_short += 1
                continue
            rows = {k: v[a : b + 1] for k, v in cols.items()}
            w = Window(
                t=t[a : b + 1] - t[a],
                command=rows["command"],
                load=rows["load"],
                theta_u=rows["theta_u"],
                theta_m=rows["theta_m"],
                omega_m=rows["omega_m"],
                i3eq=rows["i3eq"],
                temperature=rows["temperature"],
                meta=_logged_meta(logged, round(t[a] * rate), round(t[b] * rate)),
            )
            out.append((w.validated(), float(t[a])))
    if cmap.windows.by == "times":
        report.windows_dropped = len(cmap.windows.times) - found
    report.windows = len(out)
    return out, report


def _logged_meta(logged: tuple[int, np.ndarray] | None, first: int, last: int) -> dict[str, Any]:
    """A window's `CURRENT_LOGGED_KEY` (grid indices first..last), if its current has one."""
    if logged is None:
        return {}
    phase = resample.logged_first(logged, first, last)
    if phase is None:
        return {}
    return {CURRENT_LOGGED_KEY: {"every": logged[0], "first": phase}}


def _from_first_sample(series: dict[Any, Series]) -> dict[Any, Series]:
    """The series with time 0 at the earliest sample of any (the grid starts on a sample)."""
    t0 = min(float(s.t[0]) for s in series.values())
    return {r: Series(s.t - t0, s.v) for r, s in series.items()}


def on_grid_columns(
    chans: dict[str, Series | None], t: np.ndarray, rate: float
) -> dict[str, np.ndarray]:
    """Every channel at the grid times `t` (unknown: NaN; omega_m from theta_m if derived)."""
    cols: dict[str, np.ndarray] = {}
    for name, s in chans.items():
        cols[name] = np.full(t.size, np.nan) if s is None else resample.on_grid(s, t, rate)
    if chans["omega_m"] is None:
        cols["omega_m"] = derive.rate_of(cols["theta_m"], 1.0 / rate)
    return cols


def import_recordings(
    sources: Sequence[str | Path],
    cmap: ChannelMap,
    actuator: ActuatorParameters,
    out: str | Path,
    *,
    overrides: dict[str, str] | None = None,
    stream: bool = False,
) -> ImportReport:
    """Import `sources` into `out` (see the module docstring).

    `stream`: read each bag once in time order, in memory bounded by the window
    (`importing.stream`).  ConfigError or BagError naming the first problem, with `out`
    left as it was.
    """
    out = Path(out)
    report = ImportReport()
    counters: dict[tuple[str, str, str], int] = {}
    if stream:  # refuse a source a stream cannot take before reading any
        from .stream import check_streamable

        for src in sources:
            check_streamable(Path(src), cmap)
    staging = _Staging(out, report)
    try:
        for src in sources:
            path = Path(src)
            ident = identity_of(path, cmap, overrides or {})
            windows, sr = _windows_of(path, cmap, actuator, stream)
            report.sources.append(sr)
            key = (ident.hardware_id, ident.run_id, ident.purpose)
            count = 0
            for count, (w, start) in enumerate(windows, 1):  # noqa: B007 - counted
                if ident.cycle is not None and count > 1:
                    held = len(windows) if isinstance(windows, list) else "more than one"
                    raise ConfigError(
                        f"{path}: its name gives cycle {ident.cycle} but it holds {held} "
                        "windows; cut one window per file, or number them in order (no cycle "
                        "group)"
                    )
                cycle = (
                    ident.cycle
                    if ident.cycle is not None
                    else counters.get(key, cmap.identity.first_cycle)
                )
                counters[key] = cycle + 1
                target, window = _planned(out, path, ident, cycle, w, start, cmap, actuator)
                staging.add(target, window, f"{path} at {start:g} s")
            if isinstance(windows, _Streamed):
                _count_stream(sr, windows, actuator.acquisition.sample_rate)
                sr.windows = count
        if not staging.targets:
            raise ConfigError(_no_window(report, cmap))
        staging.commit()
    finally:
        staging.close()
    return report


def _windows_of(
    path: Path, cmap: ChannelMap, actuator: ActuatorParameters, stream: bool
) -> tuple[list[tuple[Window, float]] | _Streamed, SourceReport]:
    """A source's windows (a list, or as a stream: an iterator) and its report."""
    if not stream:
        return source_windows(path, cmap, actuator)
    from .stream import StreamCounts, stream_windows

    counts = StreamCounts()
    return _Streamed(stream_windows(path, cmap, actuator, counts), counts), SourceReport(str(path))


@dataclass
class _Streamed:
    """A stream's windows, iterated once, and what it counted."""

    windows: Iterator[tuple[Window, float]]
    counts: StreamCounts

    def __iter__(self) -> Iterator[tuple[Window, float]]:
        return self.windows


def _count_stream(report: SourceReport, streamed: _Streamed, rate: float) -> None:
    """A streamed source's report (once its windows were read): its messages and grid rows."""
    c = streamed.counts
    report.too_short = c.too_short
    report.too_long = c.discarded
    report.windows_dropped = c.dropped
    if c.first_msg_s is not None and c.last_msg_s is not None:
        report.seconds = c.last_msg_s - c.first_msg_s
    if c.first_s is None:
        return
    report.stretches = c.stretches
    report.longest_s = max(c.longest_rows - 1, 0) / rate
    report.seconds_in_gaps = max(report.seconds - (c.rows - c.stretches) / rate, 0.0)


def _planned(  # noqa: PLR0917 - one window's whole description
    out: Path,
    source: Path,
    ident: WindowIdentity,
    cycle: int,
    w: Window,
    start: float,
    cmap: ChannelMap,
    actuator: ActuatorParameters,
) -> tuple[Path, Window]:
    """(target folder, window with its run_info)."""
    meta = {
        **w.meta,  # what the window says of its own samples (`CURRENT_LOGGED_KEY`)
        "hardware_id": ident.hardware_id,
        "run_id": ident.run_id,
        "cycle": cycle,
        "purpose": ident.purpose,
        "sample_rate": actuator.acquisition.sample_rate,
        "imported_from": source.name,
        "source_start_s": round(start, 9),
        "channels": provenance(cmap),
    }
    kind = "baseline" if ident.purpose == "baseline" else "window"
    target = out / path_name(ident.hardware_id) / path_name(ident.run_id) / f"{kind}_{cycle:05d}"
    return target, dataclasses.replace(w, meta=meta)


def _move_all(moves: list[tuple[Path, Path]], report: ImportReport) -> None:
    """Move the staged bags into place: all of them, or none (ConfigError naming the problem)."""
    made: list[Path] = []  # the folders this import created, outermost first
    try:
        for _staged, target in moves:
            missing = [p for p in (target.parent, *target.parent.parents) if not p.exists()]
            target.parent.mkdir(parents=True, exist_ok=True)
            made.extend(reversed(missing))
    except OSError as exc:
        for folder in made:
            shutil.rmtree(folder, ignore_errors=True)
        raise ConfigError(f"cannot create {exc.filename}: {exc.strerror}") from None
    done: list[tuple[Path, Path]] = []
    try:
        for staged, target in moves:
            os.rename(staged, target)
            done.append((staged, target))
    except OSError as exc:
        for staged, target in reversed(done):  # put back what was moved: nothing half-written
            os.rename(target, staged)
        for folder in made:  # and the folders made for them
            shutil.rmtree(folder, ignore_errors=True)
        raise ConfigError(f"cannot write {exc.filename}: {exc.strerror}") from None
    report.written.extend(str(target) for _staged, target in moves)


def _no_window(report: ImportReport, cmap: ChannelMap) -> str:
    """Why the sources gave no window, in one line."""
    longest = max((s.longest_s for s in report.sources), default=0.0)
    rule = cmap.windows
    wanted = {
        "length": f"windows of {rule.seconds:g} s",
        "times": "the listed times",
        "marker": f"marker runs of at least {rule.min_duration_s:g} s",
        "excitation": f"command motion of at least {rule.min_duration_s:g} s",
    }[rule.by]
    return (
        f"no window in {len(report.sources)} source(s): the longest stretch every series covers "
        f"without a gap is {longest:.3f} s, and the map asks for {wanted} (windows: by "
        f"{rule.by}); nothing written"
    )


class _Staging:
    """Windows written in a staging folder inside OUT as they come, moved into place at the end.

    Each window is on disk once added, so memory does not grow with the windows.  A target
    already holding the same bytes is left alone; one holding other content is an error.
    `close` removes the staging folder, and OUT if this import created it and wrote nothing.
    """

    def __init__(self, out: Path, report: ImportReport) -> None:
        self.out = out
        self.report = report
        self.targets: dict[Path, str] = {}  # target -> the source and time that give it
        self.moves: list[tuple[Path, Path]] = []
        self.created = not out.exists()
        self.folder: Path | None = None

    def add(self, target: Path, w: Window, source: str) -> None:
        """Write `w` for `target` (`source`: where it came from, for the error messages)."""
        from ..telemetry.bags import digest_of, write_window

        if target in self.targets:
            raise ConfigError(
                f"two windows would be {target}: {self.targets[target]} and {source} give the "
                "same unit, run and cycle"
            )
        self.targets[target] = source
        if self.folder is None:
            try:
                self.out.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ConfigError(f"--out {self.out}: cannot create it: {exc.strerror}") from None
            self.folder = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=self.out))
        staged = write_window(self.folder / str(len(self.targets)), w)
        if not target.exists():
            self.moves.append((staged, target))
        elif digest_of(target) != digest_of(staged):
            raise ConfigError(
                f"{target} already exists with other content: remove it, or import into "
                "another --out"
            )
        else:
            self.report.unchanged.append(str(target))
            shutil.rmtree(staged, ignore_errors=True)

    def commit(self) -> None:
        """Move every staged window into place (all or none)."""
        _move_all(self.moves, self.report)

    def close(self) -> None:
        """Remove what is left of the staging (and OUT, if created for nothing)."""
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)
        if self.created and not self.report.written:
            shutil.rmtree(self.out, ignore_errors=True)
