"""Fixtures of the fleet tests: a private PostgreSQL server (postgres_server.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from postgres_server import fresh_database, postgres_server


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
