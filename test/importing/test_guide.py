"""docs/your_recordings.md runs: its maps written, its commands run on logs in a rig's forms.

The logs are a simulated fleet's unit (two baselines, six flights) rewritten as a rig records
them (`bench.harness.rig_forms.rig_copy`): JointState bags in ``rig/``, CSV in ``csv_logs/``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers import run_shell

from bench.harness import rig_forms
from ema_phm.fleet.generate import generate_fleet
from ema_phm.importing.channel_map import load_channel_map

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "your_recordings.md"
FLIGHTS = 6


def _files(text: str) -> dict[str, str]:
    """The guide's files: a ``<!-- guide-file: NAME -->`` line, then a fenced block."""
    return dict(re.findall(r"<!-- guide-file: (\S+) -->\n```[a-z]*\n(.*?)```", text, re.S))


def _commands(text: str) -> list[str]:
    """The guide's command blocks, marked ``<!-- guide -->``, in order."""
    return re.findall(r"<!-- guide -->\n```[a-z]*\n(.*?)```", text, re.S)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A folder holding the rig's logs in both forms and the guide's maps."""
    here = tmp_path_factory.mktemp("guide")
    generate_fleet(here / "native", units=1, windows=FLIGHTS, seed=0)
    rig_forms.rig_copy(here / "native", here / "rig", form="bag")
    rig_forms.rig_copy(here / "native", here / "csv_logs", form="csv")
    for name, body in _files(GUIDE.read_text(encoding="utf-8")).items():
        (here / name).write_text(body, encoding="utf-8")
    return here


def test_the_guide_has_its_maps_and_commands():
    text = GUIDE.read_text(encoding="utf-8")
    assert set(_files(text)) == {"rig_map.yaml", "csv_map.yaml"}
    joined = "\n".join(_commands(text))
    for command in ("import", "calibrate --baseline", "isolate", "prognose", "fleet ingest"):
        assert f"ema-phm {command}" in joined
    for command in ("import rig --map rig_map.yaml --out streamed --stream",):
        assert f"ema-phm {command}" in joined


def test_the_guide_maps_load(folder):
    for name in ("rig_map.yaml", "csv_map.yaml"):
        load_channel_map(folder / name)


def test_the_guide_commands_run_in_order(folder, ema_phm_on_path):
    expected = [
        ("8 recordings written", "commissioned one unit", "k1 friction", "summary after 6"),
        ("8 recordings written",),  # --stream: the same recordings
        ("8 recordings written", "most at risk first"),
        ("8 recordings written", "k1 friction"),
    ]
    for block, says in zip(_commands(GUIDE.read_text(encoding="utf-8")), expected, strict=True):
        run = run_shell(block, folder, ema_phm_on_path)
        assert run.returncode == 0, f"{block}\n{run.stdout}{run.stderr}"
        for text in says:
            assert text in run.stdout, f"{block}: no {text!r} in\n{run.stdout}"
