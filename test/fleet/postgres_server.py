"""A private PostgreSQL server for the tests, on 127.0.0.1 only (test/fleet/conftest.py).

`postgres_server()` starts a throwaway cluster (initdb, pg_ctl) in a fresh directory under /tmp
on a free port and yields its SQLAlchemy URL; `fresh_database(url)` yields the URL of a new,
empty database on it and drops that database afterwards.  The programs come from Debian's
`postgresql` package (scripts/system_packages.sh installs it): missing, the tests skip, or fail
under CI=true.  initdb and the server refuse to run as root: as root they run as the package's
`postgres` user (runuser).
"""

from __future__ import annotations

import contextlib
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import NoReturn

import pytest

#: Where Debian puts the server's programs (not on PATH): /usr/lib/postgresql/<major>/bin.
PG_LIB = Path("/usr/lib/postgresql")
#: Ports tried before giving up (another process may take a free port before the server does).
START_ATTEMPTS = 3
INSTALL_HINT = "install it with scripts/system_packages.sh (Debian package postgresql)"


def _unavailable(reason: str) -> NoReturn:
    """Skip the test, or fail it under CI=true, where the server must be there."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason}; {INSTALL_HINT}", pytrace=False)
    pytest.skip(f"{reason}; {INSTALL_HINT}")


def find_bin_dir() -> Path | None:
    """The newest /usr/lib/postgresql/<major>/bin with initdb and pg_ctl, or None."""
    found = [
        d.parent
        for d in PG_LIB.glob("*/bin/initdb")
        if d.parent.name == "bin" and (d.parent / "pg_ctl").is_file()
    ]
    versions = [b for b in found if b.parent.name.isdigit()]
    return max(versions, key=lambda b: int(b.parent.name)) if versions else None


def _free_port() -> int:
    """A port nothing listens on now at 127.0.0.1 (the kernel picks; may be taken later)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _as_server_user(cmd: list[str]) -> list[str]:
    """`cmd` run as the `postgres` user when we are root (initdb and postgres refuse root)."""
    return ["runuser", "-u", "postgres", "--", *cmd] if os.geteuid() == 0 else cmd


def _run(cmd: list[str], cwd: Path, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        _as_server_user(cmd), cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False
    )


def _make_base_dir() -> Path:
    """A fresh directory under /tmp, owned by the user the server runs as.

    /tmp (not $TMPDIR): a short path keeps the socket's under the 107-byte limit, and its
    parents are traversable by `postgres`.
    """
    base = Path(tempfile.mkdtemp(prefix="ema_phm_pg_", dir="/tmp"))
    base.chmod(0o755)
    if os.geteuid() == 0:
        shutil.chown(base, user="postgres", group="postgres")
    return base


def _initdb(bin_dir: Path, data: Path) -> None:
    run = _run(
        [str(bin_dir / "initdb"), "-D", str(data), "--auth=trust", "-U", "postgres"]
        # --locale=C: the same cluster whatever locales this machine has (or lacks)
        + ["--no-sync", "-E", "UTF8", "--locale=C"],
        cwd=data.parent,
    )
    if run.returncode != 0:
        raise RuntimeError(f"initdb failed ({run.returncode}):\n{run.stdout}{run.stderr}")


def _start(bin_dir: Path, data: Path, log: Path) -> int:
    """Start the server on a free port of 127.0.0.1, trying again on another; its port."""
    failures = []
    for _ in range(START_ATTEMPTS):
        port = _free_port()
        # -h: listen on 127.0.0.1 only; -k: the Unix socket in the data dir, not /run/postgresql
        options = f"-h 127.0.0.1 -p {port} -k {data} -c fsync=off"
        cmd = [str(bin_dir / "pg_ctl"), "-D", str(data), "-w", "-t", "60", "-o", options]
        run = _run([*cmd, "-l", str(log), "start"], cwd=data.parent)
        if run.returncode == 0:
            return port
        _stop(bin_dir, data)  # a server that did not come up in time must not stay
        tail = log.read_text(errors="replace")[-2000:] if log.exists() else ""
        failures.append(f"port {port}: {run.stdout}{run.stderr}{tail}")
    raise RuntimeError("PostgreSQL did not start:\n" + "\n".join(failures))


def _stop(bin_dir: Path, data: Path) -> None:
    _run([str(bin_dir / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"], cwd=data.parent)


@contextlib.contextmanager
def postgres_server() -> Iterator[str]:
    """Start a private server; yield `postgresql+psycopg://postgres@127.0.0.1:PORT/postgres`.

    Skips (fails under CI=true) when the programs or, as root, the `postgres` user are
    missing.  On exit the server is stopped (immediate) and its directory removed.
    """
    bin_dir = find_bin_dir()
    if bin_dir is None:
        _unavailable(f"PostgreSQL server programs (initdb, pg_ctl) not found under {PG_LIB}")
    if os.geteuid() == 0:
        if shutil.which("runuser") is None:
            _unavailable("running as root, and runuser (util-linux) is missing")
        try:
            pwd.getpwnam("postgres")
        except KeyError:
            _unavailable("running as root, and the system user `postgres` is missing")
    base = _make_base_dir()
    data = base / "data"
    try:
        _initdb(bin_dir, data)
        port = _start(bin_dir, data, base / "log")
        try:
            yield f"postgresql+psycopg://postgres@127.0.0.1:{port}/postgres"
        finally:
            _stop(bin_dir, data)
    finally:
        shutil.rmtree(base, ignore_errors=True)


@contextlib.contextmanager
def fresh_database(server_url: str) -> Iterator[str]:
    """Create an empty database on the server at `server_url`; yield its URL; drop it after."""
    import sqlalchemy as sa

    name = f"t_{uuid.uuid4().hex}"
    admin = sa.create_engine(server_url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.execute(sa.text(f'CREATE DATABASE "{name}"'))
        try:
            yield sa.make_url(server_url).set(database=name).render_as_string(hide_password=False)
        finally:
            with admin.connect() as conn:
                conn.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
