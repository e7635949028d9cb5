"""A current logged slower than the acquisition grid: fitted at the log's own samples."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from bench.harness import rig_forms, scenarios
from ema_phm.diagnosis import health
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import CURRENT_LOGGED_KEY, Window, current_logged
from ema_phm.errors import WindowError
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.importer import import_recordings
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit
from ema_phm.telemetry.bags import read_window

ACTUATOR = ActuatorParameters.default()


@pytest.fixture(scope="module")
def flight() -> Window:
    """A drawn unit's healthy window in its flight environment, with realistic sensors."""
    unit, env = Unit.draw(0), scenarios.environment(0)
    kw = scenarios.sim_kw(unit, ACTUATOR, CommandSpec(), env)
    return real_ema.simulate(NOMINAL, seed=5000, **kw).window.without_truth()


def _imported(tmp_path: Path, w: Window, *, every: int, windows: dict | None = None) -> Window:
    """`w` as a drive's CSV with its current on every `every`-th row only, imported."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    thinned = np.full(w.n, np.nan)
    thinned[::every] = w.i3eq[::every]
    src = rig_forms.table(tmp_path / "log.csv", dataclasses.replace(w, i3eq=thinned))
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = windows or {"by": "length", "seconds": 1.5}
    report = import_recordings([src], parse_channel_map(m, where="m"), ACTUATOR, tmp_path / "o")
    return read_window(sorted(report.written)[0])


def test_a_1khz_current_is_marked_on_its_own_samples(flight, tmp_path):
    got = _imported(tmp_path, flight, every=2)
    assert got.meta[CURRENT_LOGGED_KEY] == {"every": 2, "first": 0}
    # a window from an odd grid sample: the log's samples are its odd ones
    odd = _imported(
        tmp_path / "odd", flight, every=2, windows={"by": "times", "times": [[0.0005, 1.2]]}
    )
    assert odd.meta[CURRENT_LOGGED_KEY] == {"every": 2, "first": 1}
    assert current_logged(odd.meta, odd.n) == (2, 1)


def test_a_current_on_every_sample_has_no_mark(flight, tmp_path):
    assert CURRENT_LOGGED_KEY not in _imported(tmp_path, flight, every=1).meta


@pytest.mark.parametrize(
    "bad", [{"every": 1, "first": 0}, {"every": 2, "first": 2}, {"every": 2}, 3]
)
def test_a_bad_mark_is_named(bad):
    with pytest.raises(WindowError, match=CURRENT_LOGGED_KEY):
        current_logged({CURRENT_LOGGED_KEY: bad}, 100)


def test_a_healthy_window_with_a_1khz_current_is_explained(flight, tmp_path):
    """At the log's own samples a healthy window is explained, and no fault is claimed.

    Compared sample by sample at 2 kHz, the interpolated half of a 1 kHz current (what the
    log aliased and the interpolation invented) left the window not explained.
    """
    got = _imported(tmp_path, flight, every=2, windows={"by": "length", "seconds": 2.0})
    options = FitSettings(seed=0).isolate_options(None)
    res = isolate(got, **options)
    assert res.adequacy.ok, res.adequacy
    assert health.assess_isolation(res).level == health.OK
    # the hunting measure takes out the noise the interpolated current carries (measured:
    # 0.08 A, native 0.0; its noise measured on every sample: 0.87 A, near HUNTING_A 1 A)
    assert Fitness(got).hunting_rms < 0.2
    unmarked = dataclasses.replace(
        got, meta={k: v for k, v in got.meta.items() if k != CURRENT_LOGGED_KEY}
    )
    assert not isolate(unmarked, **options).adequacy.ok


def _table_with_current(path: Path, current_rows: np.ndarray) -> Path:
    """3.2 s at 2 kHz with a 0.2 s gap at 1 s; a 300 Hz current on `current_rows` only."""
    import pyarrow as pa
    from pyarrow import csv

    rows = np.concatenate([np.arange(0, 2000), np.arange(2400, 6400)])
    t = rows / 2000.0
    slow = 0.01 * np.sin(3.0 * t)
    current = np.full(t.size, np.nan)
    keep = np.isin(rows, current_rows)
    current[keep] = np.sin(2 * np.pi * 300.0 * t[keep])
    cols = {
        "time_s": t,
        "command_deg": np.degrees(slow),
        "surface_rad": slow,
        "motor_rad": 500.0 * slow,
        "motor_rpm": np.full(t.size, 10.0),
        "current_A": current,
        "temperature_C": np.full(t.size, 30.0),
    }
    with path.open("wb") as f:
        csv.write_csv(pa.table(cols), f)
    return path


def _windows_of(tmp_path: Path, src: Path) -> list[Window]:
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = {"by": "length", "seconds": 0.5}
    report = import_recordings([src], parse_channel_map(m, where="m"), ACTUATOR, tmp_path / "o")
    return [read_window(p) for p in sorted(report.written)]


def test_each_window_marks_the_logs_own_samples_even_when_the_phase_moves(tmp_path):
    """Each window's mark points at the log's own samples, wherever their phase.

    Even rows before the gap, odd rows after: at the marked samples the imported current is
    the logged 300 Hz sine exactly (one phase for the whole log marked the interpolated
    samples of one stretch instead).
    """
    every = np.arange(0, 6400)
    rows = every[((every < 2000) & (every % 2 == 0)) | ((every >= 2400) & (every % 2 == 1))]
    windows = _windows_of(tmp_path, _table_with_current(tmp_path / "log.csv", rows))
    assert len(windows) == 4
    for w in windows:
        every_, first = current_logged(w.meta, w.n) or (0, 0)
        assert every_ == 2
        t = w.meta["source_start_s"] + w.t[first::2]
        assert np.allclose(w.i3eq[first::2], np.sin(2 * np.pi * 300.0 * t), atol=1e-6)


def test_a_drifting_log_is_not_marked(tmp_path):
    """A step of 3 after every 14 of 2 (a drifting clock): no single phase, no mark."""
    steps = np.tile([2] * 14 + [3], 300)
    rows = np.concatenate([[0], np.cumsum(steps)])
    windows = _windows_of(tmp_path, _table_with_current(tmp_path / "log.csv", rows))
    assert windows and all(CURRENT_LOGGED_KEY not in w.meta for w in windows)
