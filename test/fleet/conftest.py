"""Fixtures of the fleet tests: a private PostgreSQL server (postgres_server.py), a fleet."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from postgres_server import fresh_database, postgres_server

from ema_phm.fleet.generate import generate_fleet
from ema_phm.fleet.ingest import ingest
from ema_phm.fleet.settings import DiagnosisSettings
from ema_phm.fleet.store import Store


@pytest.fixture(scope="session")
def postgres_url() -> Iterator[str]:
    """SQLAlchemy URL of this session's own server on 127.0.0.1 (database `postgres`).

    Started at first use (about a second), stopped and deleted at the end of the session;
    skips without PostgreSQL's programs, or fails under CI=true.
    """
    with postgres_server() as url:
        yield url


@pytest.fixture
def postgres_db_url(postgres_url: str) -> Iterator[str]:
    """SQLAlchemy URL of a new, empty database of this test's own, dropped afterwards."""
    with fresh_database(postgres_url) as url:
        yield url


# --- a small generated fleet, and its results diagnosed in this process -----------------


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """3 units x 4 flights, no baselines (not commissioned: a fit of ~1 s a window)."""
    out = tmp_path_factory.mktemp("fleet") / "fleet"
    generate_fleet(out, units=3, windows=4, seed=5, baselines=0)
    return out


@pytest.fixture(scope="session")
def quick_settings() -> DiagnosisSettings:
    """Settings with a small search budget: what the tests compare, not what is accurate."""
    return DiagnosisSettings(max_evaluations=150)


@pytest.fixture(scope="session")
def reference_store(
    small_fleet: Path, quick_settings: DiagnosisSettings, tmp_path_factory: pytest.TempPathFactory
) -> Path:
    """The small fleet diagnosed in this process (no Dask), uninterrupted: its SQLite file."""
    path = tmp_path_factory.mktemp("reference") / "ref.sqlite"
    with Store(path) as store:
        report = ingest([small_fleet], store, quick_settings, workers=0)
        assert not report.failed and report.windows_diagnosed == 12, report.lines()
    return path


@pytest.fixture(scope="session")
def reference_rows(reference_store: Path) -> dict[str, list[dict[str, Any]]]:
    """Every unit's rows of `reference_store`."""
    with Store(reference_store) as store:
        return store.unit_rows()
