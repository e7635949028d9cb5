"""A fleet's results store: SQLite by default, any SQLAlchemy URL (PostgreSQL) for a server.

Tables (`SCHEMA_VERSION` in ``meta``): ``meta`` (the schema version and the diagnosis
settings every window was judged with), ``recordings`` (each recording read, by digest;
``complete`` once every window of it is stored), ``units`` (each unit's commissioning) and
``windows`` (one row per diagnosed window, keyed by unit, run and cycle; ``seq`` is the
order the unit's monitor saw them in).  Each window is stored in its own transaction as its
result arrives, so a killed ingest keeps every window it finished and the next one goes on
from there; a window already stored is never stored again (the key refuses it).

One ingest writes to a store at a time (two at once could interleave a unit's windows).
Values a result holds as vectors or mappings are JSON text (floats in JSON round-trip
exactly in Python), the same on SQLite and PostgreSQL.
"""

from __future__ import annotations

import datetime
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import URL, Engine, make_url
from sqlalchemy.exc import ArgumentError, DatabaseError, IntegrityError, NoSuchModuleError

from ..errors import StoreError
from .catalog import RecordingEntry
from .settings import DiagnosisSettings
from .unit_job import Commissioned, WindowResult

#: The layout of the tables below.  A version-1 store is upgraded in place when opened (the
#: windows' nullable ``unseen`` column added: nothing rewritten); any other is refused.
SCHEMA_VERSION = 2
#: Default store: a SQLite file in the working folder.
DEFAULT_STORE = "ema_phm_fleet.sqlite"

_md = sa.MetaData()
META = sa.Table(
    "meta",
    _md,
    sa.Column("key", sa.String(64), primary_key=True),
    sa.Column("value", sa.Text, nullable=False),
)
RECORDINGS = sa.Table(
    "recordings",
    _md,
    sa.Column("digest", sa.String(64), primary_key=True),
    sa.Column("path", sa.Text, nullable=False),
    sa.Column("windows", sa.Integer, nullable=False),
    sa.Column("complete", sa.Boolean, nullable=False),
    sa.Column("ingested", sa.String(32), nullable=False),
)
UNITS = sa.Table(
    "units",
    _md,
    sa.Column("unit_id", sa.String(200), primary_key=True),
    sa.Column("belief_values", sa.Text),  # JSON; NULL: not commissioned
    sa.Column("problem", sa.Text, nullable=False),
    sa.Column("baselines", sa.Text, nullable=False),  # JSON list of digests
    sa.Column("wall_s", sa.Float),
)
#: WindowResult fields held as JSON text.
JSON_FIELDS = (
    "k",
    "k_interval",
    "k_true",
    "adequacy",
    "track_row",
    "prognosis",
    "streak",
    "unseen",
)
WINDOWS = sa.Table(
    "windows",
    _md,
    sa.Column("unit_id", sa.String(200), primary_key=True),
    sa.Column("run_id", sa.String(200), primary_key=True),
    sa.Column("cycle", sa.Integer, primary_key=True),
    sa.Column("seq", sa.Integer, nullable=False),  # the order the unit's monitor saw it in
    sa.Column("recording", sa.String(64), nullable=False),
    sa.Column("status", sa.String(16), nullable=False),
    sa.Column("reason", sa.Text, nullable=False),
    sa.Column("t0", sa.Float),
    sa.Column("t1", sa.Float),
    sa.Column("fit_mode", sa.String(16), nullable=False),
    sa.Column("level", sa.String(8), nullable=False),
    sa.Column("dominant", sa.String(64), nullable=False),
    sa.Column("message", sa.Text, nullable=False),
    sa.Column("evaluations", sa.Integer, nullable=False),
    sa.Column("wall_s", sa.Float),
    sa.Column("cycle_hours", sa.Float),
    *(sa.Column(name, sa.Text) for name in JSON_FIELDS),
    sa.Index("windows_unit_seq", "unit_id", "seq"),
)


def store_url(text: str | Path) -> URL:
    """The SQLAlchemy URL of `text`: a URL as it is, anything else a SQLite file path."""
    text = str(text)
    if "://" in text:
        try:
            return make_url(text)
        except ArgumentError as exc:
            raise StoreError(f"store URL {text!r} is not a database URL ({exc})") from None
    path = Path(text).expanduser()
    if path.is_dir():
        raise StoreError(f"store {path} is a folder; name a file (e.g. {path / DEFAULT_STORE})")
    return URL.create("sqlite", database=str(path.resolve()))


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def _dump(v: Any) -> str | None:
    return None if v is None else json.dumps(v)


def _load(v: str | None) -> Any:
    return None if v is None else json.loads(v)


class Store:
    """A results store: open (creating the tables when new), check, write, read."""

    def __init__(self, url: str | Path = DEFAULT_STORE, *, create: bool = True) -> None:
        """Open the store at `url` (a SQLAlchemy URL or a SQLite file path).

        StoreError naming the URL when the database cannot be reached, its driver is not
        installed, or it holds another schema version; `create` False: also when a SQLite
        store does not exist yet (reading one never creates it).
        """
        self.url = store_url(url)
        self.shown = self.url.render_as_string(hide_password=True)
        sqlite_file = self.url.get_backend_name() == "sqlite" and self.url.database
        if not create and sqlite_file and not Path(str(self.url.database)).is_file():
            raise StoreError(f"no store at {self.url.database} (make one with `fleet ingest`)")
        try:
            self.engine: Engine = sa.create_engine(self.url, future=True)
            if create:
                _md.create_all(self.engine)
            elif not sa.inspect(self.engine).has_table("meta"):
                raise StoreError(f"{self.shown} is not an ema_phm fleet store (no meta table)")
            self.schema_version = self._version()
        except NoSuchModuleError as exc:
            raise StoreError(f"store {self.shown}: no driver for it ({exc})") from None
        except (DatabaseError, ModuleNotFoundError) as exc:
            raise StoreError(f"store {self.shown}: cannot open it ({_first_line(exc)})") from None

    def _version(self) -> int:
        with self.engine.begin() as c:
            got = c.execute(sa.select(META.c.value).where(META.c.key == "schema_version"))
            value = got.scalar()
            if value is None:
                c.execute(sa.insert(META).values(key="schema_version", value=str(SCHEMA_VERSION)))
                return SCHEMA_VERSION
        if int(value) == 1:  # version 2 adds the windows' `unseen` (NULL: nothing held)
            with self.engine.begin() as c:
                c.execute(sa.text("ALTER TABLE windows ADD COLUMN unseen TEXT"))
                c.execute(
                    sa.update(META)
                    .where(META.c.key == "schema_version")
                    .values(value=str(SCHEMA_VERSION))
                )
            return SCHEMA_VERSION
        if int(value) != SCHEMA_VERSION:
            raise StoreError(
                f"store {self.shown} has schema version {value}; this ema_phm reads version "
                f"{SCHEMA_VERSION} (use a new store, or the ema_phm that wrote it)"
            )
        return SCHEMA_VERSION

    def close(self) -> None:
        """Release the connections."""
        self.engine.dispose()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ settings
    def check_settings(self, settings: DiagnosisSettings) -> None:
        """Record `settings` in a new store; StoreError when the store was made with others."""
        want = json.dumps(settings.as_dict(), sort_keys=True)
        with self.engine.begin() as c:
            got = c.execute(sa.select(META.c.value).where(META.c.key == "settings")).scalar()
            if got is None:
                c.execute(sa.insert(META).values(key="settings", value=want))
                return
        old, new = _with_fit_defaults(json.loads(got)), json.loads(want)
        if old != new:
            diff = [
                f"{k} {old.get(k)!r} (now {new.get(k)!r})" for k in new if old.get(k) != new.get(k)
            ]
            raise StoreError(
                f"store {self.shown} was diagnosed with other settings: {'; '.join(diff)}; a "
                "history needs one set (use another store, or the store's settings)"
            )

    def settings(self) -> dict[str, Any] | None:
        """The settings the store's windows were diagnosed with (None: none yet)."""
        with self.engine.connect() as c:
            got = c.execute(sa.select(META.c.value).where(META.c.key == "settings")).scalar()
        return None if got is None else json.loads(got)

    # ------------------------------------------------------------ recordings
    def complete_recordings(self) -> set[str]:
        """Digests of the recordings whose every window is stored."""
        with self.engine.connect() as c:
            rows = c.execute(sa.select(RECORDINGS.c.digest).where(RECORDINGS.c.complete))
            return {r[0] for r in rows}

    def note_recordings(self, recordings: Mapping[str, RecordingEntry]) -> int:
        """Mark complete each recording whose work is stored; how many were.

        `recordings`: by digest, as `catalog.Catalog` has them.  A recording of windows is
        complete when each of its windows is stored, a baseline when its unit's
        commissioning is.
        """
        stored = self.window_keys()
        units = set(self.commissioning())
        done = 0
        with self.engine.begin() as c:
            for digest, rec in recordings.items():
                ok = rec.unit_id in units if rec.baseline else all(k in stored for k in rec.keys)
                if not ok:
                    continue
                c.execute(sa.delete(RECORDINGS).where(RECORDINGS.c.digest == digest))
                c.execute(
                    sa.insert(RECORDINGS).values(
                        digest=digest,
                        path=rec.path,
                        windows=len(rec.keys),
                        complete=True,
                        ingested=_now(),
                    )
                )
                done += 1
        return done

    # ------------------------------------------------------------ units
    def save_commissioning(self, com: Commissioned) -> bool:
        """Store a unit's commissioning; False when the unit already has one (kept)."""
        row = {
            "unit_id": com.unit_id,
            "belief_values": _dump(com.belief_values),
            "problem": com.problem,
            "baselines": json.dumps(list(com.baselines)),
            "wall_s": None if math.isnan(com.wall_s) else com.wall_s,
        }
        try:
            with self.engine.begin() as c:
                c.execute(sa.insert(UNITS).values(**row))
        except IntegrityError:
            if com.unit_id in self.commissioning():  # the key refused it: stored before
                return False
            raise
        return True

    def commissioning(self) -> dict[str, Commissioned]:
        """Every unit's stored commissioning."""
        with self.engine.connect() as c:
            rows = c.execute(sa.select(UNITS)).mappings().all()
        return {
            r["unit_id"]: Commissioned(
                r["unit_id"],
                _load(r["belief_values"]),
                r["problem"],
                tuple(json.loads(r["baselines"])),
                math.nan if r["wall_s"] is None else r["wall_s"],
            )
            for r in rows
        }

    # ------------------------------------------------------------ windows
    def window_keys(self) -> set[tuple[str, str, int]]:
        """(unit, run, cycle) of every stored window."""
        with self.engine.connect() as c:
            rows = c.execute(sa.select(WINDOWS.c.unit_id, WINDOWS.c.run_id, WINDOWS.c.cycle))
            return {(r[0], r[1], int(r[2])) for r in rows}

    def save_window(self, result: WindowResult) -> bool:
        """Store one window's result after the unit's others; False when already stored."""
        row = asdict(result)
        for name in JSON_FIELDS:
            row[name] = _dump(row[name])
        row = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in row.items()
        }
        try:
            with self.engine.begin() as c:
                seq = c.execute(
                    sa.select(sa.func.count()).where(WINDOWS.c.unit_id == result.unit_id)
                ).scalar_one()
                c.execute(sa.insert(WINDOWS).values(seq=int(seq), **row))
        except IntegrityError:
            key = (result.unit_id, result.run_id, result.cycle)
            if key in self.window_keys():  # the key refused it: stored before
                return False
            raise
        return True

    def unit_rows(self, unit_id: str | None = None) -> dict[str, list[dict[str, Any]]]:
        """Stored windows per unit (one unit, or all), in the order they were diagnosed."""
        q = sa.select(WINDOWS).order_by(WINDOWS.c.unit_id, WINDOWS.c.seq)
        if unit_id is not None:
            q = q.where(WINDOWS.c.unit_id == unit_id)
        out: dict[str, list[dict[str, Any]]] = {}
        with self.engine.connect() as c:
            for r in c.execute(q).mappings():
                out.setdefault(r["unit_id"], []).append(_window_row(dict(r)))
        return out


def _window_row(r: Mapping[str, Any]) -> dict[str, Any]:
    """A stored window as a mapping of `WindowResult`'s fields (and ``seq``)."""
    row = dict(r)
    for name in JSON_FIELDS:
        row[name] = _load(row[name])
    for f in fields(WindowResult):
        if isinstance(f.default, float) and row.get(f.name) is None:
            row[f.name] = math.nan
    row["streak"] = row["streak"] or {}
    return row


def _first_line(exc: BaseException) -> str:
    return " ".join(str(exc).split("\n", 1)[0].split())


def results_equal(a: Iterable[Mapping[str, Any]], b: Iterable[Mapping[str, Any]]) -> bool:
    """True when two stores' window rows hold the same results (wall times left out)."""

    def strip(rows: Iterable[Mapping[str, Any]]) -> list[str]:
        keep = [{k: v for k, v in r.items() if k not in ("wall_s",)} for r in rows]
        return sorted(json.dumps(x, sort_keys=True, default=str) for x in keep)

    return strip(a) == strip(b)


def _with_fit_defaults(recorded: dict[str, Any]) -> dict[str, Any]:
    """Settings a store recorded, in today's form.

    A budget of null is 0 (the preset's own); a store made before the fitness and the
    nuisance search were recorded used the defaults.
    """
    out = {"fitness": "recorded", "nuisance": True, **recorded}
    if out.get("max_evaluations") is None:
        out["max_evaluations"] = 0
    return out
