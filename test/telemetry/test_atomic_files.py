"""Unit and calibration files are written whole or not at all; an empty one is named clearly."""

from __future__ import annotations

import errno
import io
from pathlib import Path

import pytest

from ema_phm.atomic_file import write_text_atomic
from ema_phm.diagnosis.calibration import CalibrationResult, write_calibration
from ema_phm.diagnosis.commissioning import CommissioningResult, write_unit
from ema_phm.errors import ConfigError
from ema_phm.model.belief import MonitorBelief

OLD = "belief: {mechanics.j_motor: 1.0e-5}\n"


class _FullDisk:
    """A file object whose first write stores half the bytes, then fails with ENOSPC."""

    def __init__(self, inner: io.IOBase) -> None:
        self.inner = inner

    def write(self, data: bytes | str) -> int:
        self.inner.write(data[: len(data) // 2])
        self.inner.flush()
        raise OSError(errno.ENOSPC, "No space left on device")

    def __getattr__(self, name: str):
        return getattr(self.inner, name)

    def __enter__(self) -> _FullDisk:
        return self

    def __exit__(self, *exc: object) -> None:
        self.inner.close()


@pytest.fixture
def full_disk(monkeypatch):
    """Call it to fill the disk: every file opened for writing from then on fails midway.

    Path.write_text and os.fdopen both open through io.open.
    """
    real = io.open

    def opener(file, mode="r", *args, **kwargs):
        f = real(file, mode, *args, **kwargs)
        return _FullDisk(f) if any(c in mode for c in "wxa") else f

    return lambda: monkeypatch.setattr(io, "open", opener)


def _calibration() -> CalibrationResult:
    return CalibrationResult(
        ke=0.0859, gt=0.0801, mse_before=0.13, mse_after=0.064, ke_before=0.08, gt_before=0.08,
        evaluations=10,
    )  # fmt: skip


def _unit() -> CommissioningResult:
    return CommissioningResult(
        factors={"inertia": 1.0}, intervals={"inertia": (0.9, 1.1)},
        identifiable={"inertia": True}, values={"mechanics.j_motor": 2.0e-5}, nuisances=[{}],
        fitness_before=[1.0], fitness_after=[0.5], temperature_c=20.0, wall_s=1.0,
        evaluations=10,
    )  # fmt: skip


def _folder_files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_write_text_atomic_on_a_full_disk_keeps_the_old_file(tmp_path, full_disk):
    target = tmp_path / "unit.yaml"
    target.write_text(OLD)
    full_disk()
    with pytest.raises(OSError) as info:
        write_text_atomic(target, "belief: {mechanics.j_motor: 3.0e-5}\n" * 100)
    assert info.value.errno == errno.ENOSPC
    assert target.read_text() == OLD
    assert _folder_files(tmp_path) == ["unit.yaml"]  # no temporary file left behind


def test_write_text_atomic_replaces_whole(tmp_path):
    target = tmp_path / "x.yaml"
    target.write_text("old\n")
    target.chmod(0o640)
    write_text_atomic(target, "new\n")
    assert target.read_text() == "new\n" and target.stat().st_mode & 0o777 == 0o640
    assert _folder_files(tmp_path) == ["x.yaml"]


@pytest.mark.parametrize(
    "write, name", [(lambda p: write_unit(_unit(), p), "unit"), (None, "calibration")]
)
def test_unit_and_calibration_files_survive_a_full_disk(tmp_path, full_disk, write, name):
    write = write or (lambda p: write_calibration(_calibration(), p))
    target = tmp_path / f"{name}.yaml"
    write(target)
    before = target.read_bytes()
    full_disk()
    with pytest.raises(ConfigError, match=f"cannot write {name} file .*No space left"):
        write(target)
    assert target.read_bytes() == before  # the old file, whole
    assert _folder_files(tmp_path) == [f"{name}.yaml"]


def test_new_unit_file_on_a_full_disk_leaves_no_file(tmp_path, full_disk):
    target = tmp_path / "unit.yaml"
    full_disk()
    with pytest.raises(ConfigError, match="No space left"):
        write_unit(_unit(), target)
    assert not target.exists() and _folder_files(tmp_path) == []


@pytest.mark.parametrize("text", ["", "# only a comment\n"])
def test_an_empty_unit_file_is_named_not_nonetype(tmp_path, text):
    empty = tmp_path / "unit.yaml"
    empty.write_text(text)
    with pytest.raises(ConfigError) as info:
        MonitorBelief.default().with_unit(empty)
    msg = str(info.value)
    assert str(empty) in msg and "is empty" in msg and "NoneType" not in msg
