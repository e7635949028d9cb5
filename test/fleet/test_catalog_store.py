"""fleet.catalog (which recordings, whose, which windows) and fleet.store (the results)."""

from __future__ import annotations

import math
import shutil
import sqlite3
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import sqlalchemy as sa

from ema_phm.domain.faults import NOMINAL
from ema_phm.errors import ConfigError, StoreError
from ema_phm.fleet import catalog, store
from ema_phm.fleet.settings import DiagnosisSettings
from ema_phm.fleet.unit_job import Commissioned, WindowResult
from ema_phm.simulator import real_ema
from ema_phm.telemetry.bags import write_window
from ema_phm.tools import fleet as fleet_cli

BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def window() -> object:
    return real_ema.simulate(NOMINAL, command=None).window


def _bag(path: Path, window: object, **meta: object) -> Path:
    return write_window(path, replace(window, meta=dict(meta)))  # type: ignore[type-var]


def test_windows_are_ordered_by_cycle_whatever_the_files_are_called(
    tmp_path: Path, window: object
) -> None:
    for name, cycle in (("zz", 0), ("aa", 2), ("mm", 1)):
        _bag(tmp_path / "u" / name, window, hardware_id="U1", run_id="r", cycle=cycle)
    cat = catalog.scan([tmp_path])
    assert [r.cycle for r in cat.units["U1"].windows] == [0, 1, 2]
    assert len(cat.recordings) == 3 and not cat.refused


def test_a_bag_found_twice_is_read_once_and_a_foreign_one_is_refused(
    tmp_path: Path, window: object
) -> None:
    a = _bag(tmp_path / "fleet" / "a", window, hardware_id="U1", cycle=0)
    shutil.copytree(a, tmp_path / "fleet" / "copy_of_a")
    _bag(tmp_path / "fleet" / "nobody", window, cycle=1)  # no hardware_id
    _bag(tmp_path / "fleet" / "bad_cycle", window, hardware_id="U1", cycle=1.5)
    manifest = tmp_path / "list.txt"
    manifest.write_text("# the same folder, listed\nfleet/a\n")
    cat = catalog.scan([tmp_path / "fleet", manifest])
    assert len(cat.units["U1"].windows) == 1 and cat.duplicates == 1
    assert len(cat.refused) == 2
    assert any("hardware_id None does not name the unit" in r for r in cat.refused)
    assert any("cycle 1.5 is not a whole number" in r for r in cat.refused)
    known = catalog.scan([tmp_path / "fleet"], known=set(cat.recordings))
    assert known.known == 2 and not known.units  # a and its copy


def test_a_missing_source_or_manifest_entry_is_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        catalog.find_recordings([tmp_path / "nowhere"])
    manifest = tmp_path / "m.txt"
    manifest.write_text("gone\n")
    with pytest.raises(ConfigError, match=r"m.txt line 1: .*gone does not exist"):
        catalog.find_recordings([manifest])


def _result(**changes: object) -> WindowResult:
    base = WindowResult(
        unit_id="U1",
        run_id="r",
        cycle=3,
        recording="d" * 64,
        status="counted",
        t0=6.0,
        t1=8.0,
        k=[0.1 + 0.2, 1e-300, 0.5],
        k_interval=[[0.0, 0.30000000000000004]],
        adequacy={"statistic": 0.5, "threshold": 1.4, "ok": True},
        prognosis={"headline": "x", "prognosis": None},
        streak={"friction": 2},
        cycle_hours=2.0,
    )
    return replace(base, **changes)  # type: ignore[arg-type]


@pytest.fixture(params=["sqlite", "postgresql"])
def store_url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    if request.param == "sqlite":
        return str(tmp_path / "s.sqlite")
    return str(request.getfixturevalue("postgres_db_url"))


def test_a_window_is_stored_once_and_reads_back_exactly(store_url: str) -> None:
    with store.Store(store_url) as s:
        assert s.save_window(_result()) is True
        assert s.save_window(_result(status="skipped")) is False  # the key refuses it
        assert s.save_window(_result(cycle=4, wall_s=math.nan)) is True
        rows = s.unit_rows()["U1"]
    assert [r["cycle"] for r in rows] == [3, 4] and [r["seq"] for r in rows] == [0, 1]
    got = rows[0]
    assert got["k"] == [0.1 + 0.2, 1e-300, 0.5] and got["k_interval"][0][1] == 0.30000000000000004
    assert got["status"] == "counted" and got["streak"] == {"friction": 2}
    assert math.isnan(rows[1]["wall_s"])


def test_a_commissioning_is_kept_and_not_replaced(store_url: str) -> None:
    with store.Store(store_url) as s:
        assert s.save_commissioning(Commissioned("U1", {"mechanics.j_motor": 1.5e-5}, "", ("a",)))
        assert not s.save_commissioning(Commissioned("U1", None, "later", ()))
        com = s.commissioning()["U1"]
    assert com.belief_values == {"mechanics.j_motor": 1.5e-5} and com.baselines == ("a",)


def test_another_schema_version_is_refused(store_url: str) -> None:
    with store.Store(store_url) as s:
        with s.engine.begin() as c:
            c.execute(sa.update(store.META).values(value="99"))
    with pytest.raises(StoreError, match="schema version 99; this ema_phm reads version 2"):
        store.Store(store_url)


def test_a_version_1_store_gains_the_unseen_column_and_keeps_its_windows(store_url: str) -> None:
    """A store written before `unseen` existed: opened, upgraded in place, nothing lost."""
    with store.Store(store_url) as s:
        s.save_window(WindowResult("U1", "r", 0, "d", "counted", k=[0.0] * 8))
        with s.engine.begin() as c:
            c.execute(sa.text("ALTER TABLE windows DROP COLUMN unseen"))
            c.execute(sa.update(store.META).values(value="1"))
    with store.Store(store_url) as s:
        assert s.schema_version == store.SCHEMA_VERSION == 2
        s.save_window(
            WindowResult("U1", "r", 1, "d", "counted", k=[0.0] * 8, unseen={"backlash": "no"})
        )
        rows = s.unit_rows("U1")["U1"]
    assert [r["unseen"] for r in rows] == [None, {"backlash": "no"}]


def test_settings_are_recorded_once_and_checked(store_url: str) -> None:
    with store.Store(store_url) as s:
        s.check_settings(DiagnosisSettings(seed=1))
        s.check_settings(DiagnosisSettings(seed=1))
        assert s.settings() == DiagnosisSettings(seed=1).as_dict()
        with pytest.raises(StoreError, match=r"seed 1 \(now 2\)"):
            s.check_settings(DiagnosisSettings(seed=2))


def test_settings_recorded_before_one_fit_settings_type_still_match(tmp_path: Path) -> None:
    """A store recorded max_evaluations null and no fitness or nuisance: today's defaults."""
    import json

    old = {
        k: v for k, v in DiagnosisSettings().as_dict().items() if k not in ("fitness", "nuisance")
    }
    with store.Store(tmp_path / "s.sqlite") as s:
        with s.engine.begin() as c:
            c.execute(
                sa.insert(store.META).values(
                    key="settings", value=json.dumps({**old, "max_evaluations": None})
                )
            )
        s.check_settings(DiagnosisSettings())  # the same settings: accepted
        with pytest.raises(StoreError, match=r"max_evaluations 0 \(now 5\)"):
            s.check_settings(DiagnosisSettings(max_evaluations=5))


def test_store_urls_and_their_errors(tmp_path: Path) -> None:
    assert store.store_url(tmp_path / "x.sqlite").get_backend_name() == "sqlite"
    with pytest.raises(StoreError, match="is a folder"):
        store.Store(tmp_path)
    with pytest.raises(StoreError, match="no driver"):
        store.Store("nosuchdb://u@127.0.0.1/x")
    with pytest.raises(StoreError, match="no store at"):
        store.Store(tmp_path / "missing.sqlite", create=False)
    assert not (tmp_path / "missing.sqlite").exists()
    assert fleet_cli.DEFAULT_STORE == store.DEFAULT_STORE


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["fleet", "ingest", "/nonexistent/fleet"], "fleet source /nonexistent/fleet does not"),
        (["fleet", "ingest", ".", "--workers", "-1"], "--workers must be"),
        (["fleet", "status", "--store", "/nonexistent/s.sqlite"], "no store at"),
        (["fleet", "simulate", "--out", "x", "--units", "0"], "--units must be"),
        (["fleet", "ingest", ".", "--preset", "nope"], "unknown preset 'nope'"),
        (["fleet", "ingest", ".", "--scheduler", "nonsense"], "cannot reach the Dask scheduler"),
        (["fleet", "ingest", ".", "--actuator", "nowhere.yaml"], "nowhere.yaml"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args: list[str], message: str, tmp_path: Path) -> None:
    run = subprocess.run(
        [str(BIN / "ema-phm"), *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
        check=False,
    )
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], run.stderr


def test_an_ingest_that_can_use_no_recording_fails_with_the_reason(
    tmp_path: Path, window: object
) -> None:
    """It exited 0 having diagnosed nothing; now 2, the first refusal's reason on stderr."""
    _bag(tmp_path / "src" / "a", window, cycle=0)  # no hardware_id: whose is it?
    _bag(tmp_path / "src" / "b", window, cycle=1)
    run = subprocess.run(
        [str(BIN / "ema-phm"), "fleet", "ingest", "src", "--store", "s.sqlite", "--workers", "0"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
        check=False,
    )
    assert run.returncode == 2, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("ema-phm: error: no recording could be used: ")
    assert "hardware_id" in last and "(and 1 more refused)" in last


def test_loose_mcap_files_and_symlinked_folders_are_found(tmp_path: Path, window: object) -> None:
    from ema_phm.telemetry.bags import locate_mcap

    src = tmp_path / "src"
    for cycle in (0, 1):
        bag = _bag(src / f"b{cycle}", window, hardware_id="U1", cycle=cycle)
        shutil.copy(locate_mcap(bag), tmp_path / f"loose_{cycle}.mcap")
    (tmp_path / "units").mkdir()
    _bag(tmp_path / "other" / "b", window, hardware_id="U2", cycle=0)
    (tmp_path / "units" / "linked").symlink_to(tmp_path / "other", target_is_directory=True)
    (tmp_path / "units" / "loop").symlink_to(tmp_path / "units", target_is_directory=True)
    found = catalog.find_recordings([tmp_path])
    names = sorted(p.name for p in found)
    assert "loose_0.mcap" in names and "loose_1.mcap" in names
    cat = catalog.scan([tmp_path / "loose_0.mcap", tmp_path / "loose_1.mcap", tmp_path / "units"])
    assert [r.cycle for r in cat.units["U1"].windows] == [0, 1]
    assert [r.cycle for r in cat.units["U2"].windows] == [0] and not cat.refused


def test_runs_are_taken_in_the_natural_order_of_their_ids(tmp_path: Path, window: object) -> None:
    for run in ("life-10", "life-2", "life-1"):
        _bag(tmp_path / run, window, hardware_id="U1", run_id=run, cycle=0)
    cat = catalog.scan([tmp_path])
    assert [r.run_id for r in cat.units["U1"].windows] == ["life-1", "life-2", "life-10"]


def test_a_file_that_is_not_a_store_is_refused(tmp_path: Path) -> None:
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    with pytest.raises(StoreError, match="cannot open it"):
        store.Store(junk)
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as c:
        c.execute("create table t (x)")
    with pytest.raises(StoreError, match="is not an ema_phm fleet store"):
        store.Store(other, create=False)


def _row(cycle: int, status: str, level: str, dominant: str, ok: bool, prognosis: dict) -> dict:
    return {
        "cycle": cycle, "status": status, "reason": "" if ok else "not explained",
        "level": level, "dominant": dominant, "message": f"{level}: {dominant}",
        "adequacy": {"statistic": 1.0, "threshold": 1.4, "ok": ok}, "k": [0.0] * 8,
        "k_interval": None, "k_true": None, "prognosis": prognosis, "run_id": "r",
    }  # fmt: skip


def test_a_unit_is_judged_by_its_last_fit_as_the_live_status_is() -> None:
    from ema_phm.fleet.summary import unit_view

    rul = {"p5": 3.0, "p50": 6.0, "p95": None}
    prog = {
        "level": "WARN", "dominant_fault": "friction", "headline": "friction degrading",
        "prognosis": {"faults": [{"fault": "friction", "status": "degrading",
                                  "rul_cycles": rul, "rul_hours": rul}]},
    }  # fmt: skip
    claimed = _row(4, "counted", "ERROR", "backlash", True, {"level": "OK"})
    u = unit_view("U", [claimed], None)
    assert (u.level, u.fault, u.rul_cycles) == ("ERROR", "backlash", None)
    unexplained = _row(5, "not_counted", "WARN", "backlash", False, {"level": "OK"})
    u = unit_view("U", [claimed, unexplained], None)
    assert (u.level, u.fault) == ("WARN", None) and u.headline.startswith("not explained")
    alarm = _row(6, "counted", "OK", "friction", True, prog)
    u = unit_view("U", [claimed, unexplained, alarm], None)
    assert (u.level, u.fault) == ("WARN", "friction")
    assert u.rul_cycles is not None and u.rul_cycles.p50 == 6.0 and math.isinf(u.rul_cycles.p95)
    assert unit_view("U", [], None).level == "UNKNOWN"


def test_a_commissioning_s_warnings_reach_the_ingest_report(store_url: str) -> None:
    """Not kept in the store: said in the report of the ingest that commissioned the unit."""
    from ema_phm.fleet.ingest import IngestReport, _Run

    warned = Commissioned("U1", {"mechanics.j_motor": 1.5e-5}, "", ("a",), 1.0, ("a doubt",))
    with store.Store(store_url) as s:
        run = _Run(s, IngestReport(), total=0, progress=None)
        run.commissioned(warned)
        assert s.commissioning()["U1"].warnings == ()  # the store keeps the values only
    assert run.report.commission_warnings == ["U1: a doubt"]
    assert "commissioned despite: U1: a doubt" in run.report.lines()
