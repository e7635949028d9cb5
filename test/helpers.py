"""Plain helpers shared by tests in several folders (imported by name, not collected).

Test modules import them as ``from helpers import ...``: pytest puts ``test/`` on
``sys.path`` when it loads ``test/conftest.py``.  They live in a plain module, not in
the conftest, because some are used in ``pytest.mark.parametrize`` arguments at
import time, and a conftest cannot be imported by name (every folder's is "conftest").
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ema_phm.domain.faults import DEFAULT_ERROR, DEFAULT_WARN, NOMINAL
from ema_phm.domain.window import Window
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema as hf

#: monitor_node's isolation parameters at their defaults (IsolationSettings.from_values).
ISOLATION_DEFAULTS = {
    "preset": "",
    "seed": 0,
    "fitness": "default",
    "max_evaluations": 0,
    "warn_threshold": list(DEFAULT_WARN),
    "error_threshold": list(DEFAULT_ERROR),
}
#: Keys a health DiagnosticStatus carries besides k1..k8.
STATUS_VALUE_KEYS = [
    "percent_err",
    "fitness",
    "evaluations",
    "elapsed_s",
    "windows_done",
    "windows_skipped_busy",
    "windows_discarded",
]
#: User angle per motor angle of the default parameters.
GEAR = 0.002
#: Index in k of each fault name `k_with` accepts (``k1`` ... ``k8`` are accepted too).
FAULT_INDEX: dict[str, int] = {
    "friction": 0,
    "backlash": 1,
    "sc_a": 2,
    "sc_b": 3,
    "sc_c": 4,
    "ecc": 5,
    "phase": 6,
    "gain": 7,
}


def k_with(**faults: float) -> np.ndarray:
    """NOMINAL with the named entries changed: ``k_with(friction=0.5)`` or ``k_with(k1=0.5)``."""
    k = NOMINAL.copy()
    for name, value in faults.items():
        index = FAULT_INDEX[name] if name in FAULT_INDEX else int(name[1:]) - 1
        k[index] = value
    return k


def rms(x: np.ndarray) -> float:
    """Root mean square of `x`."""
    return float(np.sqrt(np.mean(x**2)))


def window_at(rate_divisor: int, duration: float = 0.3) -> Window:
    """A nominal HF window of `duration` s kept at every `rate_divisor`-th sample."""
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=duration)).window
    return Window.from_matrix(w.matrix()[::rate_divisor], k_true=w.k_true)


def growing_isolate(rate: float, *, misfit: int | None = None):
    """A fake `isolate`: its w-th call fits k1 = rate * w, +-0.03 intervals, explained.

    Call `misfit` (if given) fits k1 = 0.9 that the model does not explain.
    """
    from ema_phm.diagnosis.adequacy import Adequacy
    from ema_phm.diagnosis.isolation import IsolationResult

    calls: list[np.ndarray] = []

    def fit(window, **kw):
        k = NOMINAL.copy()
        ok = len(calls) != misfit
        k[0] = rate * len(calls) if ok else 0.9
        calls.append(k)
        return IsolationResult(
            k=k,
            fitness=0.1,
            evaluations=1,
            wall_s=0.01,
            preset="de",
            seed=0,
            k_interval=np.column_stack([np.clip(k - 0.03, 0, 1), np.clip(k + 0.03, 0, 1)]),
            adequacy=Adequacy(statistic=1.0 if ok else 9.0, threshold=1.43, ok=ok),
        )

    return fit


def fail_once(monkeypatch, owner: object, name: str, message: str) -> None:
    """Make `owner.name` raise RuntimeError(message) on its first call, then work as before."""
    real = getattr(owner, name)
    calls: list[int] = []

    def flaky(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError(message)
        return real(*args, **kwargs)

    monkeypatch.setattr(owner, name, flaky)


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    """`ema-phm ARGV` in-process: (exit code, stdout, stderr); argparse's exits are caught."""
    from ema_phm.tools.cli import main

    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse's usage errors
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def setup_py_data_files(folder: Path, env: dict[str, str] | None = None) -> dict[str, list[str]]:
    """The data_files of the setup.py in `folder` (run up to its configuration), by destination."""
    code = (
        "import json, setuptools\n"
        "from distutils.core import run_setup\n"
        "d = run_setup('setup.py', stop_after='config')\n"
        "print(json.dumps(d.data_files))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return dict(json.loads(out.strip().splitlines()[-1]))


def simulate_cycles_bag(folder: Path, degradation: str, *options: str) -> tuple[Path, Path]:
    """`ema-phm simulate --degradation` of the YAML text `degradation` into folder/bag.

    `options` are the rest of the command line (``--windows N`` ...); (bag, degradation file).
    """
    from ema_phm.tools.cli import main

    deg = folder / "deg.yaml"
    deg.write_text(degradation)
    bag = folder / "bag"
    assert main(["simulate", "--degradation", str(deg), *options, "--out", str(bag)]) == 0
    return bag, deg


def run_shell(block: str, cwd: Path, env: dict[str, str], timeout: float = 600) -> Any:
    """A documented block of shell commands run as a user runs it (bash, stop at a failure)."""
    return subprocess.run(
        ["bash", "-euo", "pipefail", "-c", block],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
