"""fleet.ingest: every window once, in order per unit, the same wherever and however it ran.

The reference is the small fleet diagnosed in this process, uninterrupted (conftest); an
embedded Dask cluster, a real `dask scheduler` with two `dask worker`s one of which is
killed, a killed and re-run ingest, and a PostgreSQL store must all hold exactly its rows
(wall times left out).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from ema_phm.fleet.generate import generate_fleet
from ema_phm.fleet.ingest import ingest
from ema_phm.fleet.settings import DiagnosisSettings
from ema_phm.fleet.store import Store, results_equal

BIN = Path(sys.executable).parent
Rows = dict[str, list[dict[str, Any]]]


def _flat(rows: Rows) -> list[dict[str, Any]]:
    return [r for unit in sorted(rows) for r in rows[unit]]


def _same(a: Rows, b: Rows) -> bool:
    return sorted(a) == sorted(b) and results_equal(_flat(a), _flat(b))


def test_every_window_is_stored_once_in_cycle_order(reference_rows: Rows) -> None:
    assert sorted(reference_rows) == ["EMA-0001", "EMA-0002", "EMA-0003"]
    for rows in reference_rows.values():
        assert [r["cycle"] for r in rows] == [0, 1, 2, 3]
        assert [r["seq"] for r in rows] == [0, 1, 2, 3]
        assert rows[0]["fit_mode"] == "global"
        assert all(r["status"] in ("counted", "not_counted", "skipped") for r in rows)
        assert all(r["k_true"] is not None for r in rows)


def test_the_same_recordings_again_add_nothing(
    small_fleet: Path, quick_settings: DiagnosisSettings, reference_rows: Rows, tmp_path: Path
) -> None:
    store_path = tmp_path / "s.sqlite"
    with Store(store_path) as store:
        first = ingest([small_fleet], store, quick_settings, workers=0)
        assert first.windows_diagnosed == 12
        again = ingest([small_fleet], store, quick_settings, workers=0)
        assert again.windows_diagnosed == 0 and again.recordings_known == 12
        copy = tmp_path / "copy"
        shutil.copytree(small_fleet, copy)  # the same bags under other names
        moved = ingest([copy, small_fleet], store, quick_settings, workers=0)
        assert moved.windows_diagnosed == 0 and moved.recordings_read == 0
        assert _same(store.unit_rows(), reference_rows)


def test_an_embedded_cluster_gives_the_results_of_a_plain_loop(
    small_fleet: Path, quick_settings: DiagnosisSettings, reference_rows: Rows, tmp_path: Path
) -> None:
    import os

    threads = {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    with Store(tmp_path / "s.sqlite") as store:
        report = ingest([small_fleet], store, quick_settings, workers=2)
        # the workers' thread limits stay theirs (a later subprocess of ours fits otherwise)
        assert {k: os.environ.get(k) for k in threads} == threads
        assert report.workers == 2 and report.scheduler.startswith("tcp://127.0.0.1:")
        assert not report.failed and report.windows_diagnosed == 12
        assert _same(store.unit_rows(), reference_rows)


def test_a_postgresql_store_holds_the_same_results(
    small_fleet: Path,
    quick_settings: DiagnosisSettings,
    reference_rows: Rows,
    postgres_db_url: str,
) -> None:
    with Store(postgres_db_url) as store:
        report = ingest([small_fleet], store, quick_settings, workers=0)
        assert report.windows_diagnosed == 12
        assert _same(store.unit_rows(), reference_rows)
        assert ingest([small_fleet], store, quick_settings, workers=0).windows_diagnosed == 0


def _stored(path: Path) -> int:
    if not path.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5) as c:
            return int(c.execute("select count(*) from windows").fetchone()[0])
    except sqlite3.OperationalError:  # not created yet, or locked for a moment
        return 0


def test_a_killed_ingest_run_again_gives_the_uninterrupted_results(
    small_fleet: Path, reference_rows: Rows, tmp_path: Path
) -> None:
    store = tmp_path / "s.sqlite"
    cmd = [str(BIN / "ema-phm"), "fleet", "ingest", str(small_fleet), "--store", str(store)]
    cmd += ["--max-evaluations", "150", "--workers", "2"]
    proc = subprocess.Popen(cmd, start_new_session=True, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while _stored(store) < 4:
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        assert time.monotonic() < deadline, "no window stored in 240 s"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the ingest and its Dask workers, mid-run
    proc.wait(timeout=30)
    kept = _stored(store)
    assert 4 <= kept < 12, kept
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert again.returncode == 0, again.stderr
    assert f"{12 - kept} diagnosed now, {kept} stored before" in again.stdout, again.stdout
    with Store(store) as s:
        assert _same(s.unit_rows(), reference_rows)


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A real `dask scheduler` and two `dask worker` processes on 127.0.0.1."""
    procs: list[subprocess.Popen[bytes]] = []
    info = tmp_path / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    env = {
        **os.environ,
        "NUMBA_NUM_THREADS": "1",
        "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False",  # docs/fleet.md: own workers too
        "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "1s",
    }
    try:
        procs.append(
            subprocess.Popen(
                [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                 "--no-dashboard", "--scheduler-file", str(info)],
                start_new_session=True, env=env, **quiet,
            )
        )  # fmt: skip
        deadline = time.monotonic() + 60
        while not info.exists() or not info.read_text():
            assert time.monotonic() < deadline and procs[0].poll() is None, "no scheduler"
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        workers = [
            subprocess.Popen(
                [str(BIN / "dask"), "worker", address, "--host", "127.0.0.1", "--nthreads",
                 "1", "--no-dashboard", "--local-directory", str(tmp_path / f"w{i}")],
                start_new_session=True, env=env, **quiet,
            )
            for i in range(2)
        ]  # fmt: skip
        procs += workers
        yield address, workers
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=30)


def test_an_external_scheduler_loses_nothing_when_a_worker_dies(
    small_fleet: Path,
    quick_settings: DiagnosisSettings,
    reference_rows: Rows,
    dask_cluster: tuple[str, list[subprocess.Popen[bytes]]],
    tmp_path: Path,
) -> None:
    from distributed import Client

    address, workers = dask_cluster
    with Client(address, timeout=60) as client:
        client.wait_for_workers(2, timeout=120)
    killed: list[int] = []

    def kill_one(done: int, total: int) -> None:
        if done == 2 and not killed:  # mid-run: both workers hold a unit's window
            os.killpg(workers[0].pid, signal.SIGKILL)
            killed.append(done)

    with Store(tmp_path / "s.sqlite") as store:
        report = ingest([small_fleet], store, quick_settings, scheduler=address, progress=kill_one)
        assert killed and workers[0].wait(timeout=30) is not None
        assert report.workers == 2 and not report.failed, report.lines()
        assert report.windows_diagnosed == 12
        assert _same(store.unit_rows(), reference_rows)


def test_a_commissioned_unit_is_judged_against_its_own_baselines(tmp_path: Path) -> None:
    fleet = tmp_path / "fleet"
    generate_fleet(fleet, units=1, windows=2, seed=2, baselines=2)
    settings = DiagnosisSettings(max_evaluations=150)
    with Store(tmp_path / "s.sqlite") as store:
        report = ingest([fleet], store, settings, workers=0)
        assert report.commissioned == 1 and report.windows_diagnosed == 2, report.lines()
        com = store.commissioning()["EMA-0001"]
        assert com.belief_values and not com.problem and len(com.baselines) == 2
        assert len(store.complete_recordings()) == 4  # 2 baselines, 2 flights
        again = ingest([fleet], store, settings, workers=0)
        assert again.commissioned == 0 and again.recordings_known == 4


def test_a_store_of_other_settings_is_refused(
    small_fleet: Path, quick_settings: DiagnosisSettings, tmp_path: Path
) -> None:
    from ema_phm.errors import StoreError

    with Store(tmp_path / "s.sqlite") as store:
        store.check_settings(quick_settings)
        other = DiagnosisSettings(max_evaluations=151)
        with pytest.raises(StoreError, match=r"max_evaluations 150 \(now 151\)"):
            ingest([small_fleet], store, other, workers=0)


def test_status_and_report_of_an_ingested_store(
    reference_store: Path, small_fleet: Path, tmp_path: Path
) -> None:
    from browser import console_messages, load

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [str(BIN / "ema-phm"), "fleet", *args, "--store", str(reference_store)],
            capture_output=True, text=True, timeout=300, check=False,
        )  # fmt: skip

    status = cli("status", "--json")
    assert status.returncode == 0, status.stderr
    units = json.loads(status.stdout)["units"]
    truth = json.loads((small_fleet / "fleet_truth.json").read_text())["units"]
    assert sorted(u["unit_id"] for u in units) == sorted(truth)
    order = ["ERROR", "WARN", "OK", "UNKNOWN"]
    assert [order.index(u["level"]) for u in units] == sorted(
        order.index(u["level"]) for u in units
    )
    table = cli("status")
    assert table.returncode == 0 and all(u in table.stdout for u in truth), table.stdout
    page = tmp_path / "fleet.html"
    made = cli("report", "--out", str(page))
    assert made.returncode == 0, made.stderr
    run = load(page)
    assert run.returncode == 0 and console_messages(run.stderr) == [], run.stderr
    assert 'data-ready="1"' in run.stdout
    for u in units:
        assert f'data-unit="{u["unit_id"]}"' in run.stdout
        assert f'data-fault="{u["fault"] or ""}"' in run.stdout


def test_a_window_that_cannot_be_read_is_stored_as_skipped_with_its_reason(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ema_phm.errors import BagError
    from ema_phm.fleet import unit_job

    fleet = tmp_path / "fleet"
    generate_fleet(fleet, units=1, windows=3, seed=3, baselines=0)
    read = unit_job._windows_of

    def flaky(path: str, digest: str) -> Any:
        if path.endswith("flight_0001"):
            raise BagError(f"bag {path}: telemetry truncated")
        return read(path, digest)

    monkeypatch.setattr(unit_job, "_windows_of", flaky)
    with Store(tmp_path / "s.sqlite") as store:
        report = ingest([fleet], store, DiagnosisSettings(max_evaluations=100), workers=0)
        assert not report.failed and report.windows_diagnosed == 3
        rows = store.unit_rows()["EMA-0001"]
    assert rows[0]["status"] != "skipped" and rows[0]["track_row"] is not None
    assert rows[1]["status"] == "skipped"
    assert rows[1]["reason"].startswith("recording unreadable: bag ")
    assert rows[1]["track_row"] == rows[0]["track_row"]
    assert rows[2]["fit_mode"] == "tracked"  # the next window tracks from cycle 0's fit


def test_baselines_that_come_after_a_units_windows_are_not_used_and_said(tmp_path: Path) -> None:
    from ema_phm.fleet.ingest import LATE_BASELINES

    fleet = tmp_path / "fleet"
    generate_fleet(fleet, units=1, windows=2, seed=4, baselines=1)
    later = tmp_path / "later"
    later.mkdir()
    shutil.move(str(fleet / "EMA-0001" / "baseline_0"), later / "baseline_0")
    settings = DiagnosisSettings(max_evaluations=100)
    with Store(tmp_path / "s.sqlite") as store:
        first = ingest([fleet], store, settings, workers=0)
        assert first.windows_diagnosed == 2 and first.commissioned == 0
        second = ingest([fleet, later], store, settings, workers=0)
        assert second.windows_diagnosed == 0 and second.commissioned == 0
        assert second.not_commissioned == [f"EMA-0001: {LATE_BASELINES}"]
        assert store.commissioning()["EMA-0001"].problem == LATE_BASELINES
        third = ingest([fleet, later], store, settings, workers=0)
        assert third.recordings_known == 3 and not third.not_commissioned
