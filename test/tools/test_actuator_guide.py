"""docs/your_actuator.md runs: its actuator file loads, its commands run on a unit of that design.

The unit is the packaged small_pi_ema.yaml design (the file the guide's user describes without
its high_fidelity section and healthy levels), drawn with unit seed 7 and recorded with the
benchmarks' kind of noise: two healthy hangar runs and a flight with a friction fault (k1 0.8).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers import run_shell

from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator_file import load_actuator

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "your_actuator.md"
DESIGN = ROOT / "config" / "actuators" / "small_pi_ema.yaml"
NOISE = "--noise-current 0.1 --noise-position 5e-5 --noise-speed 1.9"
#: The flight's friction: 0.8, whose 90 % interval stays off healthy (0.37-0.51 at its lower
#: end, with 1 or 2 BLAS threads); at 0.5 this unit's interval reached 0 with 1 thread.
HEALTHY, FRICTION = "0,0,0,0,0,0,0.5,0.5", "0.8,0,0,0,0,0,0.5,0.5"


def _files(text: str) -> dict[str, str]:
    """The guide's files: a ``<!-- guide-file: NAME -->`` line, then a fenced block."""
    return dict(re.findall(r"<!-- guide-file: (\S+) -->\n```[a-z]*\n(.*?)```", text, re.S))


def _commands(text: str) -> list[str]:
    """The guide's command blocks, marked ``<!-- guide -->``, in order."""
    return re.findall(r"<!-- guide -->\n```[a-z]*\n(.*?)```", text, re.S)


@pytest.fixture(scope="module")
def folder(tmp_path_factory, ema_phm_on_path) -> Path:
    """The guide's file, and the rig's recordings of one unit of that design."""
    here = tmp_path_factory.mktemp("actuator_guide")
    for name, body in _files(GUIDE.read_text(encoding="utf-8")).items():
        (here / name).write_text(body, encoding="utf-8")
    sim = f"ema-phm simulate --actuator {DESIGN} --unit-seed 7 {NOISE} --load-unmeasured"
    rig = "\n".join(
        [
            f"{sim} --seed 1 --k {HEALTHY} --temperature 22 --load -3 --out rig/baseline-1",
            f"{sim} --seed 2 --k {HEALTHY} --temperature 22 --load -3 --out rig/baseline-2",
            f"{sim} --seed 3 --k {FRICTION} --temperature 35 --load 5 --out rig/flight-001",
        ]
    )
    run = run_shell(rig, here, ema_phm_on_path)
    assert run.returncode == 0, run.stderr
    return here


def test_the_guide_s_file_is_the_design_less_what_a_user_need_not_write(folder):
    described = load_actuator(folder / "my_drive.yaml")
    design = load_actuator(DESIGN)
    assert not described.simulable and described.monitor_values == {
        "monitor.stiffness": design.monitor_values["monitor.stiffness"]
    }
    for sec in ("motor", "inverter", "controller", "current_loop", "mechanics", "acquisition"):
        assert dict(described[sec]) == dict(design[sec]), sec
    assert MonitorBelief.for_actuator(described).own_levels == set()


def test_the_guide_commands_run(folder, ema_phm_on_path):
    (block,) = _commands(GUIDE.read_text(encoding="utf-8"))
    run = run_shell(block, folder, ema_phm_on_path)
    assert run.returncode == 0, f"{block}\n{run.stdout}{run.stderr}"
    says = (
        "commissioned one unit from 2 baseline(s)",
        "measured on these baselines (the actuator description gives no level to judge it by",
        "wrote my_unit.yaml",
        "friction (k1 = ",
    )
    for text in says:
        assert text in run.stdout, f"no {text!r} in\n{run.stdout}"
    assert re.search(r"(WARN|ERROR): friction", run.stdout), run.stdout
