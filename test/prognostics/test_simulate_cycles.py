"""`ema-phm simulate --windows N --degradation FILE`: multi-window bags and reading them back."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import run_cli, simulate_cycles_bag

from ema_phm.errors import BagError
from ema_phm.simulator.degradation import Degradation
from ema_phm.telemetry import bags
from ema_phm.telemetry.cycle_bags import read_cycle_windows

DEGRADATION = """\
cycle_hours: 3.5
faults:
  friction: {law: linear, onset: 1, initial: 0.1, rate: 0.2}
  gain_drift: {law: step, onset: 2, initial: 0.8}
"""


@pytest.fixture(scope="module")
def cycle_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cycles")
    options = ["--windows", "3", "--duration", "0.1", "--noise-current", "0.1", "--seed", "4"]
    return simulate_cycles_bag(folder, DEGRADATION, *options)


def test_round_trip_gives_one_window_per_cycle_with_its_true_k(cycle_bag):
    bag, deg = cycle_bag
    windows = read_cycle_windows(bag)
    expected = Degradation.load(deg).trajectory(range(3))
    assert [w.meta["cycle"] for w in windows] == [0, 1, 2]
    for c, w in enumerate(windows):
        w.validated()
        assert w.n == 201  # 0.1 s at 2 kHz: samples cN .. (c+1)N
        assert w.t[0] == pytest.approx(0.1 * c) and w.t[-1] == pytest.approx(0.1 * (c + 1))
        np.testing.assert_array_equal(w.k_true, expected[c])
        assert w.meta["cycle_hours"] == 3.5 and w.meta["windows"] == 3
    # consecutive windows share their boundary sample
    np.testing.assert_array_equal(windows[0].matrix()[-1], windows[1].matrix()[0])
    assert windows[1].k_true[0] == pytest.approx(0.1) and windows[2].k_true[7] == 0.8


def test_multi_window_bag_is_not_read_as_one_window(cycle_bag, capsys):
    with pytest.raises(BagError, match="holds 3 windows"):
        bags.read_window(cycle_bag[0])
    code, out, err = run_cli(capsys, "isolate", str(cycle_bag[0]))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "fit them all with `ema-phm prognose`" in err  # a command, not a Python function


def test_cycle_hours_option_overrides_the_file(cycle_bag, tmp_path, capsys):
    _, deg = cycle_bag
    bag = tmp_path / "b"
    code, out, err = run_cli(
        capsys,
        "simulate",
        "--windows",
        "1",
        "--degradation",
        str(deg),
        "--cycle-hours",
        "0.5",
        "--duration",
        "0.05",
        "--out",
        str(bag),
    )
    assert code == 0, err
    assert "0.5 h each" in out
    assert read_cycle_windows(bag)[0].meta["cycle_hours"] == 0.5


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--windows", "3"], "needs both --windows N and --degradation FILE"),
        (["--windows", "0", "--degradation", "D"], r"--windows must be an integer in \[1, "),
        (["--windows", "2", "--degradation", "D", "--k", "0,0,0,0,0,0,0.5,0.5"], "leave --k"),
        (["--windows", "2", "--degradation", "D", "--cycle-hours", "-1"], "--cycle-hours"),
        (["--windows", "2", "--degradation", "missing.yaml"], "degradation file not found"),
        (["--windows", "40", "--degradation", "D"], r"k1 = 1\.1 at cycle 6"),
        ([], "simulate needs --k"),
    ],
)
def test_bad_multi_window_input_is_one_line_exit_2(cycle_bag, tmp_path, capsys, argv, match):
    _, deg = cycle_bag
    argv = [
        str(deg) if a == "D" else str(tmp_path / a) if a.endswith(".yaml") else a for a in argv
    ]
    code, out, err = run_cli(
        capsys, "simulate", *argv, "--duration", "0.05", "--out", str(tmp_path / "x")
    )
    assert code == 2
    assert re.match(r"ema-phm( simulate)?: error: ", err) and err.count("\n") == 1, err
    assert re.search(match, err), err
    assert not (tmp_path / "x").exists()


def test_reader_refuses_a_bag_without_window_geometry(tmp_path):
    from ema_phm.domain.window import Window

    data = np.zeros((300, 8))
    data[:, 0] = np.arange(300) / 2000.0
    bags.write_window(tmp_path / "one", Window.from_matrix(data))
    with pytest.raises(BagError, match="samples_per_window"):
        read_cycle_windows(tmp_path / "one")


def test_a_monitor_recording_is_read_as_its_fitted_windows_with_their_cycles(tmp_path):
    from ema_phm.telemetry.bags import ROSBAGS_CLASSES, BagRecorder, string_msg
    from ema_phm.telemetry.cycle_bags import log_time_ns
    from ema_phm.telemetry.wire import (
        FLOAT64_MULTIARRAY,
        GROUND_TRUTH_TOPIC,
        RUN_INFO_TOPIC,
        STRING,
        WINDOW_TOPIC,
        encode_ground_truth,
        encode_run_info,
        encode_telemetry,
        to_message,
    )

    topics = {RUN_INFO_TOPIC: STRING, GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY}
    topics[WINDOW_TOPIC] = FLOAT64_MULTIARRAY
    info = {"sample_rate": 2000.0, "samples_per_window": 100, "window_duration": 0.05}
    k1 = np.array([0.1, 0, 0, 0, 0, 0, 0.5, 0.5])
    with BagRecorder(tmp_path / "rec", topics=topics) as rec:
        rec.write(RUN_INFO_TOPIC, string_msg(encode_run_info(info)), log_time_ns(0.0))
        for t0, k in ((0.1, k1), (0.2, 2 * k1)):
            rows = np.zeros((101, 8))
            rows[:, 0] = t0 + np.arange(101) / 2000.0
            truth = to_message(encode_ground_truth(np.minimum(k, 1.0)), ROSBAGS_CLASSES)
            rec.write(GROUND_TRUTH_TOPIC, truth, log_time_ns(t0))
            window = to_message(encode_telemetry(rows), ROSBAGS_CLASSES)
            rec.write(WINDOW_TOPIC, window, log_time_ns(t0 + 0.05))
    windows = read_cycle_windows(tmp_path / "rec")
    assert [w.meta["cycle"] for w in windows] == [2, 4]
    assert windows[0].k_true[0] == pytest.approx(0.1) and windows[1].k_true[0] == 0.2
    assert windows[1].n == 101
