"""Which recordings a fleet has, whose they are, and which windows they hold.

A source is a folder (searched to any depth, symlinks followed: a folder holding
``metadata.yaml`` is one bag, a loose ``.mcap`` file is one too), a bag, or a manifest
(a ``.txt`` file: one path per line, relative to the manifest; ``#`` starts a comment).
A recording says whose it is in its run_info: ``hardware_id`` (the unit, required),
``run_id`` (a life of the unit, optional) and ``purpose`` (``baseline``: a healthy
commissioning window; otherwise a window to diagnose).  A recording of one window names
its ``cycle``; a multi-window recording (`ema-phm simulate --windows`, a monitor's
recording) numbers its windows itself (`cycle_bags.read_cycle_windows`).

A recording is known by the SHA-256 of its ``.mcap`` bytes, so the same file found twice,
under two names, or in a later ingest is read once.  A window is known by (unit, run,
cycle): the first recording holding it (in path order) is the one diagnosed.  A unit's
runs are taken in the natural order of their ids (``life-2`` before ``life-10``): name
them so that it is their order in time.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..domain.window import Window
from ..errors import BagError, ConfigError, EmaPhmError
from ..importing.sources import STAGING_PREFIX
from ..telemetry.bags import digest_of, read_messages, read_window, run_info_object
from ..telemetry.cycle_bags import read_cycle_windows
from ..telemetry.wire import RUN_INFO_TOPIC

#: run_info keys: the unit, its life, what the recording is for, a one-window recording's cycle.
UNIT_KEY, RUN_KEY, PURPOSE_KEY, CYCLE_KEY = "hardware_id", "run_id", "purpose", "cycle"
#: `PURPOSE_KEY` of a healthy commissioning recording.
BASELINE = "baseline"
#: Manifest suffixes.
MANIFEST_SUFFIXES = (".txt",)


@dataclass(frozen=True)
class WindowRef:
    """Where one window of a unit is: its recording and its place in it."""

    unit_id: str
    run_id: str
    cycle: int
    path: str
    index: int  # the window's index in its recording
    recording: str  # the recording's digest
    baseline: bool = False

    @property
    def key(self) -> tuple[str, str, int]:
        """The window's identity: (unit, run, cycle)."""
        return (self.unit_id, self.run_id, self.cycle)


@dataclass(frozen=True)
class Recording:
    """One recording read: its digest, whose it is, its windows."""

    path: str
    digest: str
    unit_id: str
    run_id: str
    baseline: bool
    cycles: list[int]  # each window's cycle, in the recording's order
    windows: list[Window] | None  # None: not read (`read_recording(load=False)`)


def _run_info(path: Path) -> dict[str, Any] | None:
    """The recording's first run_info object (None without one)."""
    messages = read_messages(path, [RUN_INFO_TOPIC])
    try:
        for _topic, _type, _t, msg in messages:
            return run_info_object(path, msg.data)
    finally:
        messages.close()
    return None


def read_recording(path: str | Path, digest: str | None = None, *, load: bool = True) -> Recording:
    """Read a recording: whose it is and its windows, each with its cycle in `meta`.

    `load` False: a one-window recording's window is not read (its run_info says all the
    catalog needs).  BagError naming the recording when it has no run_info
    ``hardware_id``, when a one-window recording names no whole-number ``cycle``, or when
    it cannot be read.
    """
    path = Path(path)
    info = _run_info(path) or {}
    unit = info.get(UNIT_KEY)
    if not isinstance(unit, str) or not unit.strip() or unit != unit.strip():
        raise BagError(
            f"{path}: run_info {UNIT_KEY} {unit!r} does not name the unit it was recorded on "
            "(a non-empty id without surrounding spaces): cannot tell whose it is"
        )
    if CYCLE_KEY in info:
        cycle = info[CYCLE_KEY]
        if isinstance(cycle, bool) or not isinstance(cycle, int) or cycle < 0:
            raise BagError(f"{path}: run_info {CYCLE_KEY} {cycle!r} is not a whole number >= 0")
        windows = [read_window(path)] if load else None
        cycles = [cycle]
    else:
        windows = read_cycle_windows(path)
        cycles = [int(w.meta["cycle"]) for w in windows]
    return Recording(
        str(path),
        digest or digest_of(path),
        unit,
        str(info.get(RUN_KEY, "")),
        info.get(PURPOSE_KEY) == BASELINE,
        cycles,
        windows,
    )


def _is_bag_dir(path: Path) -> bool:
    """A rosbag2 bag folder: it holds metadata.yaml."""
    return (path / "metadata.yaml").is_file()


def _walk(folder: Path) -> Iterator[Path]:
    """The bags under `folder`, sorted: bag folders (not searched inside) and loose .mcap files.

    Symlinked folders are followed, each real folder once.
    """
    seen: set[Path] = set()
    for root, dirs, files in os.walk(folder, followlinks=True):
        here = Path(root)
        real = here.resolve()
        if real in seen or _is_bag_dir(here):
            dirs.clear()
            if real not in seen:
                seen.add(real)
                yield here
            continue
        seen.add(real)
        dirs[:] = sorted(d for d in dirs if not d.startswith(STAGING_PREFIX))  # a killed import's
        yield from (here / f for f in sorted(files) if f.endswith(".mcap"))


def _manifest(path: Path) -> list[Path]:
    out = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        entry = Path(text) if Path(text).is_absolute() else path.parent / text
        if not entry.exists():
            raise ConfigError(f"manifest {path} line {n}: {entry} does not exist")
        out.append(entry)
    return out


def find_recordings(sources: Sequence[str | Path]) -> list[Path]:
    """Every recording under `sources` (folders, bags, manifests), each once, absolute."""
    found: list[Path] = []
    for source in sources:
        p = Path(source)
        if not p.exists():
            raise ConfigError(f"fleet source {p} does not exist")
        if p.is_file() and p.suffix in MANIFEST_SUFFIXES:
            found.extend(x for entry in _manifest(p) for x in _expand(entry))
        else:
            found.extend(_expand(p))
    return list(dict.fromkeys(x.resolve() for x in found))


def _expand(p: Path) -> Iterable[Path]:
    if p.is_dir():
        return _walk(p)
    if p.suffix == ".mcap":
        return [p]
    raise ConfigError(f"{p} is not a bag, a folder of bags or a manifest (.txt)")


@dataclass
class UnitWork:
    """A unit's windows found in the sources, in the order they are to be diagnosed."""

    unit_id: str
    baselines: list[WindowRef] = field(default_factory=list)
    windows: list[WindowRef] = field(default_factory=list)


@dataclass(frozen=True)
class RecordingEntry:
    """A recording read: whose, what for, and the window keys it holds."""

    path: str
    unit_id: str
    baseline: bool
    keys: list[tuple[str, str, int]]


@dataclass
class Catalog:
    """What the sources hold: each unit's windows, each recording's keys, what was refused."""

    units: dict[str, UnitWork] = field(default_factory=dict)
    recordings: dict[str, RecordingEntry] = field(default_factory=dict)  # by digest
    refused: list[str] = field(default_factory=list)  # one line per recording not used
    known: int = 0  # recordings skipped: already complete in the store
    duplicates: int = 0  # windows or recordings found again

    def add(self, rec: Recording) -> None:
        """Add a recording's windows (a window already held is a duplicate)."""
        work = self.units.setdefault(rec.unit_id, UnitWork(rec.unit_id))
        refs = work.baselines if rec.baseline else work.windows
        held = {r.key for r in refs}
        keys = []
        for i, cycle in enumerate(rec.cycles):
            ref = WindowRef(
                rec.unit_id,
                rec.run_id,
                cycle,
                rec.path,
                i,
                rec.digest,
                rec.baseline,
            )
            keys.append(ref.key)
            if ref.key in held:
                self.duplicates += 1
                continue
            held.add(ref.key)
            refs.append(ref)
        self.recordings[rec.digest] = RecordingEntry(rec.path, rec.unit_id, rec.baseline, keys)


def scan(sources: Sequence[str | Path], known: set[str] | None = None) -> Catalog:
    """Read every recording under `sources` not in `known` (digests); order each unit's windows.

    A recording that cannot be read or says not whose it is, is refused with its reason
    (`Catalog.refused`): the others go on.
    """
    known = known or set()
    cat = Catalog()
    for path in find_recordings(sources):
        try:
            digest = digest_of(path)
            if digest in known or digest in cat.recordings:
                cat.known += digest in known
                cat.duplicates += digest not in known
                continue
            cat.add(read_recording(path, digest, load=False))
        except (EmaPhmError, OSError) as exc:
            cat.refused.append(f"{path}: {' '.join(str(exc).split())}")
    for work in cat.units.values():
        work.windows.sort(key=_order)
        work.baselines.sort(key=_order)
    return cat


def _order(ref: WindowRef) -> tuple[list[tuple[int, int | str]], int]:
    """Runs in the natural order of their ids (life-2 before life-10), then cycles."""
    parts = re.split(r"(\d+)", ref.run_id)
    key = [(0, int(s)) if s.isdigit() else (1, s) for s in parts if s]
    return key, ref.cycle


def read_life(path: str | Path) -> list[Window]:
    """The windows of one unit's life, in cycle order, each with its ``cycle`` in meta.

    `path` is a multi-window bag (`cycle_bags.read_cycle_windows`), a one-window recording
    that names its cycle, or a folder (or manifest) of one-window recordings of one unit and
    one run, as `ema-phm import` writes them; baselines in it are left out.  BagError naming
    the units and runs when the folder holds more than one life, or a cycle twice.
    """
    p = Path(path)
    if p.is_dir() and not _is_bag_dir(p) or p.suffix in MANIFEST_SUFFIXES:
        lives: dict[tuple[str, str], list[Window]] = {}
        for found in find_recordings([p]):
            rec = read_recording(found)
            if not rec.baseline:
                lives.setdefault((rec.unit_id, rec.run_id), []).extend(rec.windows or [])
        if len(lives) != 1:
            names = ", ".join(f"{u} run {r!r}" for u, r in sorted(lives)) or "no recordings"
            raise BagError(
                f"{p} holds {len(lives)} lives ({names}): give one unit's run, or diagnose "
                "them all with `ema-phm fleet ingest`"
            )
        windows = sorted(next(iter(lives.values())), key=lambda w: int(w.meta[CYCLE_KEY]))
        cycles = [int(w.meta[CYCLE_KEY]) for w in windows]
        twice = sorted({c for c in cycles if cycles.count(c) > 1})
        if twice:
            raise BagError(f"{p}: cycle {twice[0]} is recorded more than once")
        return windows
    info = _run_info(p) or {}
    if CYCLE_KEY in info:
        return read_recording(p).windows or []
    return read_cycle_windows(p)
