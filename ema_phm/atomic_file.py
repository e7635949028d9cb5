"""Files written whole or not at all.

`write_text_atomic` writes to a temporary file in the target's folder, fsyncs it, then
`os.replace`s it over the target and fsyncs the folder: a full disk, a crash or a
signal midway leaves the old file (or no file) and never a truncated one.
`write_yaml_file` writes a commented YAML file (calibration, unit) that way.
"""

from __future__ import annotations

import os
import secrets
from contextlib import suppress
from pathlib import Path
from typing import Any, Mapping

import yaml

from .errors import ConfigError


def fsync_dir(folder: Path) -> None:
    """Make a rename or a new file in `folder` durable (no-op where folders cannot be opened)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # e.g. Windows: no O_RDONLY on folders
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems refuse fsync on a folder; the data itself is synced
        pass
    finally:
        os.close(fd)


def write_text_atomic(path: str | Path, text: str, *, encoding: str = "utf-8") -> Path:
    """Replace `path` with `text`, all of it or nothing; OSError (the old file intact) on failure.

    The folder must exist.  A file mode the target had is kept (umask default otherwise).
    """
    path = Path(path)
    data = text.encode(encoding)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    # 0o666 minus the umask, as open() gives a new file
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        with suppress(FileNotFoundError):
            os.chmod(tmp, path.stat().st_mode & 0o7777)
        os.replace(tmp, path)
    except BaseException:
        with suppress(OSError):
            tmp.unlink()
        raise
    fsync_dir(path.parent)
    return path


def refuse_folder(path: Path, what: str) -> None:
    """ConfigError when the `what` output `path` is a folder (suggesting ``what.yaml`` in it)."""
    if path.is_dir():
        raise ConfigError(
            f"{what} output {path} is a folder; name a file (e.g. {path / f'{what}.yaml'})"
        )


def write_yaml_file(path: Path, header: str, body: Mapping[str, Any], *, what: str) -> Path:
    """Write `header` (comment lines) and `body` as YAML to `path` atomically; return `path`.

    Its folder is created.  ConfigError naming the `what` file when it cannot be written.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, header + yaml.safe_dump(dict(body), sort_keys=False))
    except OSError as exc:
        raise ConfigError(f"cannot write {what} file {path}: {exc.strerror or exc}") from None
    return path
