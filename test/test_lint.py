"""The whole tree passes ruff and mypy (ruff.toml and mypy.ini at the top).

`ruff check` (rules E, W, F, I, D, B, PL less the codes ruff.toml names and why),
`ruff format --check`, and `mypy` over ema_phm (mypy.ini: files and settings).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, check=False
    )


@pytest.mark.parametrize("args", [["check", "."], ["format", "--check", "."]], ids=" ".join)
def test_ruff_finds_nothing(args: list[str]) -> None:
    run = _run("ruff", *args)
    assert run.returncode == 0, f"ruff {' '.join(args)}:\n{run.stdout}{run.stderr}"


def test_mypy_finds_nothing() -> None:
    run = _run("mypy")
    assert run.returncode == 0, f"mypy:\n{run.stdout}{run.stderr}"
    assert "Success: no issues found" in run.stdout


def test_the_lint_rules_include_bugbear_pylint_and_a_type_checker() -> None:
    ruff = (ROOT / "ruff.toml").read_text(encoding="utf-8")
    select = next(line for line in ruff.splitlines() if line.startswith("select"))
    assert '"B"' in select and '"PL"' in select
    assert "[mypy]" in (ROOT / "mypy.ini").read_text(encoding="utf-8")
    pins = (ROOT / "requirements.txt").read_text(encoding="utf-8").split()
    assert any(p.startswith("mypy==") for p in pins) and any(p.startswith("ruff==") for p in pins)
