"""Window assembly from streamed telemetry, run_info parsing and fitted-window reading.

(ema_phm.telemetry.window_assembler).  rclpy-free; no node is spun here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ema_phm.domain.faults import N_K
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import BagError, ConfigError, WindowError
from ema_phm.telemetry.bags import GROUND_TRUTH_TOPIC, BagRecorder, float64_multiarray
from ema_phm.telemetry.window_assembler import Completed, Discarded, WindowAssembler

F64 = "std_msgs/msg/Float64MultiArray"

# -------------------------------------------------------------------- window assembly

FS, N = 100.0, 20  # 0.2 s windows of 20 samples (+1 shared boundary sample)


def stream(j_from: int, j_to: int) -> np.ndarray:
    """Rows for sample indices j_from .. j_to - 1 (channel 1 = the index, to check content)."""
    j = np.arange(j_from, j_to)
    rows = np.zeros((j.size, len(CHANNELS)))
    rows[:, 0] = j / FS
    rows[:, 1] = j
    return rows


def feed_all(asm: WindowAssembler, batches: list[np.ndarray]) -> list:
    out = []
    for b in batches:
        out += asm.feed(b)
    return out


def batches(j_from: int, j_to: int, size: int) -> list[np.ndarray]:
    return [stream(a, min(a + size, j_to)) for a in range(j_from, j_to, size)]


@pytest.mark.parametrize("size", [1, 3, 7, 20, 21, 50])
def test_windows_aligned_and_share_boundary_sample(size):
    asm = WindowAssembler(FS, N)
    ev = feed_all(asm, batches(0, 3 * N + 5, size))
    assert all(isinstance(e, Completed) for e in ev)
    assert [e.j0 for e in ev] == [0, N, 2 * N]
    for e in ev:
        assert e.data.shape == (N + 1, len(CHANNELS))
        np.testing.assert_array_equal(e.data[:, 1], np.arange(e.j0, e.j0 + N + 1))
        assert e.t0 == pytest.approx(e.j0 / FS) and e.t1 == pytest.approx((e.j0 + N) / FS)


def test_mid_stream_start_skips_to_next_boundary():
    asm = WindowAssembler(FS, N)
    ev = feed_all(asm, batches(13, 13 + 2 * N + 1, 6))
    assert [e.j0 for e in ev] == [N]  # 13..19 skipped, window 20..40
    assert asm.samples_skipped == N - 13
    assert not any(isinstance(e, Discarded) for e in ev)


def test_dropped_message_discards_window_with_reason_then_resumes():
    asm = WindowAssembler(FS, N)
    b = batches(0, 4 * N + 1, 5)
    del b[6]  # samples 30..34 lost: window 20..40 broken
    ev = feed_all(asm, b)
    done = [e for e in ev if isinstance(e, Completed)]
    gone = [e for e in ev if isinstance(e, Discarded)]
    assert [e.j0 for e in done] == [0, 2 * N, 3 * N]  # resumes at the next boundary (40)
    assert len(gone) == 1 and gone[0].j0 == N and gone[0].samples == 10
    assert "time gap" in gone[0].reason and "5 sample(s)" in gone[0].reason


def test_out_of_order_and_repeated_messages_discard():
    asm = WindowAssembler(FS, N)
    b = batches(0, 2 * N + 1, 5)
    b[2], b[3] = b[3], b[2]
    ev = feed_all(asm, b)
    reasons = [e.reason for e in ev if isinstance(e, Discarded)]
    assert len(reasons) == 1 and "gap" in reasons[0]
    assert [e.j0 for e in ev if isinstance(e, Completed)] == [N]
    asm2 = WindowAssembler(FS, N)
    b = batches(0, N + 1, 5)
    ev = feed_all(asm2, b[:3] + [b[2]] + b[3:])  # a repeated message
    assert [e for e in ev if isinstance(e, Discarded)][0].reason.startswith("out-of-order")


def test_gap_inside_a_message_and_off_grid_times():
    asm = WindowAssembler(FS, N)
    rows = stream(0, N + 1)
    rows = np.delete(rows, 7, axis=0)
    ev = asm.feed(rows)
    assert len(ev) == 1 and isinstance(ev[0], Discarded) and "1 sample(s)" in ev[0].reason
    asm = WindowAssembler(FS, N)
    rows = stream(0, N + 1)
    rows[4, 0] += 0.3 / FS
    ev = asm.feed(rows)
    assert isinstance(ev[0], Discarded) and "not on the" in ev[0].reason
    rows = stream(0, N + 1)
    rows[5, 0] = np.nan
    ev = WindowAssembler(FS, N).feed(rows)
    assert len(ev) == 1 and isinstance(ev[0], Discarded) and "nan" in ev[0].reason


def test_assembler_reset_and_validation():
    asm = WindowAssembler(FS, N)
    asm.feed(stream(0, 5))
    ev = asm.reset("new run")
    assert len(ev) == 1 and ev[0].reason == "new run" and ev[0].samples == 5
    assert asm.reset() == []
    with pytest.raises(WindowError):
        asm.feed(np.zeros((3, 6)))
    assert asm.feed(np.zeros((0, 7))) == []
    with pytest.raises(WindowError):
        WindowAssembler(0.0, N)
    with pytest.raises(WindowError):
        WindowAssembler(FS, 1)


# --------------------------------------------------------------- issue 7: run_info checks


@pytest.mark.parametrize(
    "text,words",
    [
        (
            '{"sample_rate": 2000.0, "samples_per_window": Infinity}',
            "samples_per_window must be an integer in [100",
        ),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        (
            '{"sample_rate": NaN, "samples_per_window": 200}',
            "sample_rate must be a number in [1, 1e+06] Hz, got nan",
        ),
        ('{"sample_rate": 2000.0, "samples_per_window": 1e9}', "got 1000000000.0"),
        ('{"sample_rate": 2000.0, "samples_per_window": -5}', "got -5"),
        ('{"sample_rate": 2000.0, "samples_per_window": 200.5}', "got 200.5"),
        ('{"sample_rate": "fast", "samples_per_window": 200}', "got 'fast'"),
        ('{"sample_rate": 2000.0}', "no 'samples_per_window'"),
        ("[1, 2]", "must be a JSON object, got list"),
        ("{oops", "not JSON"),
    ],
)
def test_parse_run_info_rejects_malformed(text, words):
    from ema_phm.telemetry.window_assembler import parse_run_info

    with pytest.raises(ConfigError) as err:
        parse_run_info(text)
    assert words in str(err.value)


def test_parse_run_info_accepts_the_ema_node_layout():
    from ema_phm.telemetry.window_assembler import parse_run_info

    r = parse_run_info('{"sample_rate": 2000.0, "samples_per_window": 4000, "seed": 3}')
    assert (r.sample_rate, r.samples_per_window, r.info["seed"]) == (2000.0, 4000, 3)


# ---------------------------------------------------------------- fitted windows from a bag


@pytest.mark.parametrize("bad", [float("nan"), 1.5])
def test_fitted_windows_refuse_bad_ground_truth(tmp_path: Path, bad: float) -> None:
    """read_fitted_windows (replays of node recordings) applies the same ground-truth check."""
    from ema_phm.telemetry.window_assembler import WINDOW_TOPIC, read_fitted_windows

    k = np.full(N_K, 0.5)
    k[0] = bad
    with BagRecorder(tmp_path / "bag", topics={WINDOW_TOPIC: F64, GROUND_TRUTH_TOPIC: F64}) as rec:
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(k, ["k"]), 1)
        rec.write(WINDOW_TOPIC, float64_multiarray(np.zeros((4, 7)), ["samples", "channels"]), 2)
    with pytest.raises(BagError, match=rf"{GROUND_TRUTH_TOPIC}.*k1 = {bad!r}"):
        read_fitted_windows(tmp_path / "bag")
