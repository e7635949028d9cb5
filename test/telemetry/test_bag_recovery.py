"""Killed and interrupted recordings.

Reading up to the last complete chunk, recover_bag, chunks sealed while recording, a close that a
second signal cannot cut short.
"""

from __future__ import annotations

import errno
import io
import signal
import struct
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.rosbag2 import Reader

from ema_phm.domain.faults import N_K
from ema_phm.domain.window import CHANNELS, Window
from ema_phm.errors import BagError, RecordingStopped
from ema_phm.telemetry.bag_recovery import default_recovery_path
from ema_phm.telemetry.bags import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,
    TELEMETRY_TOPIC,
    BagRecorder,
    BagRecoveredWarning,
    float64_multiarray,
    read_messages,
    read_window,
    recover_bag,
    string_msg,
    write_window,
)

ROOT = Path(__file__).parents[2]
TOPICS = {
    RUN_INFO_TOPIC: STRING,
    GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY,
    TELEMETRY_TOPIC: FLOAT64_MULTIARRAY,
}


def block(i: int, n: int = 10) -> np.ndarray:
    data = np.full((n, len(CHANNELS)), float(i))
    data[:, 0] = (i * n + np.arange(n)) * 5e-4
    return data


def record(path: Path, n_blocks: int, *, flush_every: int = 0) -> None:
    """A finished recording: run_info, ground truth, n_blocks telemetry blocks.

    A chunk is sealed every flush_every blocks.
    """
    with BagRecorder(path, topics=TOPICS) as rec:
        rec.write(RUN_INFO_TOPIC, string_msg('{"sample_rate": 2000.0}'), 1)
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.full(N_K, 0.5), ["k"]), 1)
        for i in range(n_blocks):
            rec.write(
                TELEMETRY_TOPIC, float64_multiarray(block(i), ["samples", "channels"]), 2 + i
            )
            if flush_every and i % flush_every == flush_every - 1:
                rec.flush()


def only_mcap(bag: Path) -> Path:
    (mcap,) = bag.glob("*.mcap")
    return mcap


def killed_copy(src_mcap: Path, dest: Path, cut: int) -> Path:
    """A bag folder as a killed writer leaves it: `cut` bytes of the .mcap, no metadata.yaml."""
    dest.mkdir()
    (dest / src_mcap.name).write_bytes(src_mcap.read_bytes()[:cut])
    return dest


def independent_count(mcap: Path) -> int:
    """Messages in the complete chunks, counted with the `mcap` package's stream reader."""
    n = 0
    with mcap.open("rb") as f:
        try:
            for rec in StreamReader(f, emit_chunks=True).records:
                if (
                    isinstance(rec, Chunk)
                    and rec.compression == ""
                    and len(rec.data) == rec.uncompressed_size
                ):
                    n += sum(isinstance(r, Message) for r in breakup_chunk(rec))
        except (McapError, ValueError, EOFError, struct.error) as exc:  # the cut-short tail
            assert "Footer" not in repr(exc)
    return n


def quiet(fn, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagRecoveredWarning)
        return fn(*args)


# ---- reading unfinished recordings ------------------------------------------------------------


def test_truncated_at_many_offsets_reads_every_complete_chunk(tmp_path: Path) -> None:
    record(tmp_path / "full", 40, flush_every=6)
    mcap = only_mcap(tmp_path / "full")
    with mcap.open("rb") as f:
        chunks = sorted(
            make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset
        )
    assert len(chunks) == 7  # 6 flushed every 6 blocks + the last 4 blocks on close
    ends = [c.chunk_start_offset + c.chunk_length for c in chunks]
    size = mcap.stat().st_size
    cuts = sorted(
        {
            43,
            60,
            ends[0] - 1,
            ends[0],
            ends[0] + 5,
            ends[2] + 3,
            (ends[3] + ends[4]) // 2,
            ends[-1] + 1,
            size - 50,
            size - 1,
        }
    )
    for j, cut in enumerate(cuts):
        bag = killed_copy(mcap, tmp_path / f"cut{j}", cut)
        complete = [c for c, end in zip(chunks, ends, strict=True) if end <= cut]
        if not complete:
            with pytest.raises(BagError, match="nothing is readable") as err:
                quiet(lambda b: list(read_messages(b)), bag)
            assert str(only_mcap(bag)) in str(err.value)
            continue
        # block i is logged at 2 + i after run_info and truth at 1: the messages up to the
        # last complete chunk's end time are 2 + (end - 1)
        expected = 2 + complete[-1].message_end_time - 1
        got = quiet(lambda b: list(read_messages(b)), bag)
        assert len(got) == expected == independent_count(only_mcap(bag)), cut
        assert [m[2] for m in got] == sorted(m[2] for m in got)
        w = quiet(read_window, bag)
        assert w.n == 10 * (expected - 2)
        np.testing.assert_array_equal(
            w.matrix(), np.concatenate([block(i) for i in range(expected - 2)])
        )
        np.testing.assert_array_equal(w.k_true, np.full(N_K, 0.5))


def test_plain_reading_says_what_it_recovered(tmp_path: Path) -> None:
    record(tmp_path / "full", 12, flush_every=4)
    mcap = only_mcap(tmp_path / "full")
    bag = killed_copy(mcap, tmp_path / "killed", mcap.stat().st_size - 200)
    with pytest.warns(BagRecoveredWarning) as caught:
        w = read_window(bag)
    text = str(caught[0].message)
    assert "\n" not in text and str(only_mcap(bag)) in text
    assert (
        f"{TELEMETRY_TOPIC} 12" in text and "recovered 14 messages" in text and "dropped" in text
    )
    assert w.meta == {"sample_rate": 2000.0, "bag_recovered": text}
    assert w.n == 120
    direct = quiet(read_window, only_mcap(bag))  # the .mcap file itself, not its folder
    assert direct.n == 120


def test_a_finished_bag_reads_without_warning(tmp_path: Path) -> None:
    record(tmp_path / "full", 5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w = read_window(tmp_path / "full")
    assert "bag_recovered" not in w.meta


def test_nothing_readable_names_the_file(tmp_path: Path) -> None:
    bag = tmp_path / "rec"
    bag.mkdir()
    (bag / "rec.mcap").write_bytes(
        b"\x89MCAP0\r\n" + b"\x01" + (34).to_bytes(8, "little") + b"\x00" * 20
    )
    for target in (bag, bag / "rec.mcap"):
        with pytest.raises(BagError) as err:
            quiet(read_window, target)
        assert str(bag / "rec.mcap") in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(BagError, match="rec.mcap"):
        recover_bag(bag)
    assert not default_recovery_path(bag).exists()


def test_recover_bag_rebuilds_a_finished_bag(tmp_path: Path) -> None:
    record(tmp_path / "full", 30, flush_every=7)
    mcap = only_mcap(tmp_path / "full")
    bag = killed_copy(mcap, tmp_path / "rec", mcap.stat().st_size - 300)
    report = recover_bag(bag)
    assert report.out == tmp_path / "rec_recovered" == default_recovery_path(bag)
    assert report.messages == {RUN_INFO_TOPIC: 1, GROUND_TRUTH_TOPIC: 1, TELEMETRY_TOPIC: 30}
    assert report.bytes_dropped == 0 and report.complete  # the cut fell in the summary
    line = report.summary()
    assert "\n" not in line and "recovered 32 messages" in line and str(report.out) in line
    assert (report.out / "metadata.yaml").is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a finished bag: no recovery needed any more
        w = read_window(report.out)
    np.testing.assert_array_equal(w.matrix(), np.concatenate([block(i) for i in range(30)]))
    with Reader(report.out) as reader:  # rosbags alone, through metadata.yaml
        assert {c.topic: c.msgcount for c in reader.connections} == report.messages
    raw_in = [m[2] for m in quiet(lambda b: list(read_messages(b)), bag)]
    assert raw_in == [m[2] for m in read_messages(report.out)]

    cut = killed_copy(mcap, tmp_path / "cut", 9000)
    out = tmp_path / "elsewhere" / "fixed"
    out.parent.mkdir()
    report = recover_bag(only_mcap(cut), out=out)
    assert report.out == out and report.bytes_dropped > 0 and not report.complete
    assert (
        report.total_messages == len(list(read_messages(out))) == independent_count(only_mcap(cut))
    )
    with pytest.raises(BagError, match="exists"):
        recover_bag(cut, out=out)


# ---- a writer killed while recording ----------------------------------------------------------

RECORDER = textwrap.dedent("""
    import sys, time
    import numpy as np
    from ema_phm.telemetry.bags import (
        FLOAT64_MULTIARRAY, TELEMETRY_TOPIC, BagRecorder, float64_multiarray, serialize,
    )
    rec = BagRecorder(sys.argv[1], topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY})
    for i in range(10**6):
        data = np.full((100, 8), float(i))
        msg = float64_multiarray(data, ["samples", "channels"])
        rec.write_raw(TELEMETRY_TOPIC, serialize(FLOAT64_MULTIARRAY, msg),
                      10**9 + i)
        print(i + 1, flush=True)
        time.sleep(0.05)
""")


def test_sigkill_mid_recording_loses_at_most_the_last_second(tmp_path: Path) -> None:
    """20 messages/s (5.6 kB each); SIGKILL after ~3 s.

    Before: an empty .mcap, nothing readable.
    """
    bag = tmp_path / "rec"
    proc = subprocess.Popen(
        [sys.executable, "-c", RECORDER, str(bag)], stdout=subprocess.PIPE, text=True, cwd=ROOT
    )
    written = 0
    try:
        deadline = time.monotonic() + 60
        while written < 70 and time.monotonic() < deadline:
            written = int(proc.stdout.readline() or written)
    finally:
        proc.send_signal(signal.SIGKILL)
        rest = proc.communicate(timeout=30)[0].split()
    written = int(rest[-1]) if rest else written
    assert written >= 70
    assert not (bag / "metadata.yaml").exists()
    recovered = quiet(lambda b: sum(1 for _ in read_messages(b)), bag)
    assert recovered == independent_count(only_mcap(bag))
    assert written - 25 <= recovered <= written, (
        written,
        recovered,
    )  # 1 s of flush period = 20 messages
    w = quiet(read_window, bag)
    assert w.n == 100 * recovered
    np.testing.assert_array_equal(w.matrix()[::100, 1], np.arange(recovered, dtype=float))


# ---- a second signal while closing ------------------------------------------------------------

CLOSER = textwrap.dedent("""
    import signal, sys, time
    import numpy as np
    from ema_phm.telemetry import mcap_storage
    from ema_phm.telemetry.bags import (
        FLOAT64_MULTIARRAY, TELEMETRY_TOPIC, BagRecorder, float64_multiarray,
    )

    finish = mcap_storage.CrcMcapWriter.close
    def slow_close(self, version, metadata):  # stands for a large recording's long close
        print("closing", flush=True)
        time.sleep(1.5)
        finish(self, version, metadata)
    mcap_storage.CrcMcapWriter.close = slow_close
    if sys.argv[2] == "SIGTERM":
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    else:  # Python's own handler, even where SIGINT arrives ignored (a background CI job)
        signal.signal(signal.SIGINT, signal.default_int_handler)

    rec = BagRecorder(sys.argv[1], topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY})
    for i in range(300):
        block = np.full((50, 8), float(i))
        rec.write(TELEMETRY_TOPIC, float64_multiarray(block, ["samples", "channels"]), i)
    rec.close()
    print("closed", flush=True)
""")


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_two_signals_during_close_keep_the_whole_bag(tmp_path: Path, signame: str) -> None:
    """Before: KeyboardInterrupt/SystemExit inside close -> header-only .mcap, no metadata.yaml."""
    sig = getattr(signal, signame)
    bag = tmp_path / "rec"
    proc = subprocess.Popen(
        [sys.executable, "-c", CLOSER, str(bag), signame],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        assert proc.stdout.readline().strip() == "closing"
        time.sleep(0.2)
        proc.send_signal(sig)
        time.sleep(0.05)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    # the signal still stops the program, once the bag is complete
    assert "closed" not in out
    assert proc.returncode == (-signal.SIGINT if signame == "SIGINT" else 143), err
    assert (bag / "metadata.yaml").is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w = read_window(bag)
    assert w.n == 300 * 50
    np.testing.assert_array_equal(w.matrix()[::50, 1], np.arange(300, dtype=float))


def test_close_is_idempotent_and_write_after_close_fails(tmp_path: Path) -> None:
    rec = BagRecorder(tmp_path / "b", topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY})
    rec.write(TELEMETRY_TOPIC, float64_multiarray(block(0), ["samples", "channels"]), 5)
    rec.close()
    rec.close()
    with pytest.raises(BagError, match="closed"):
        rec.write(TELEMETRY_TOPIC, float64_multiarray(block(1), ["samples", "channels"]), 6)
    assert read_window(tmp_path / "b").n == 10


def test_flush_period_is_bounded(tmp_path: Path) -> None:
    with pytest.raises(BagError, match=r"bag_flush_period.*\[0.01, 3600\]"):
        BagRecorder(tmp_path / "b", topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY}, flush_period=0)
    assert not (tmp_path / "b").exists()


# ---- the command line ---------------------------------------------------------------------------


def test_cli_recover_prints_one_line_and_writes_the_bag(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from ema_phm.tools.cli import main

    record(tmp_path / "full", 30, flush_every=7)
    mcap = only_mcap(tmp_path / "full")
    bag = killed_copy(mcap, tmp_path / "rec", 9000)
    assert main(["recover", str(bag), "--out", str(tmp_path / "fixed")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("recovered ") and str(tmp_path / "fixed") in out[0]
    assert (tmp_path / "fixed" / "metadata.yaml").is_file()
    assert main(["recover", str(bag), "--out", str(tmp_path / "fixed")]) == 2  # never overwrites
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0]
    assert main(["recover", str(tmp_path / "nothing")]) == 2
    assert str(tmp_path / "nothing") in capsys.readouterr().err


def test_cli_reading_a_killed_recording_says_what_it_recovered(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from ema_phm.tools.cli import main

    record(tmp_path / "full", 30, flush_every=7)
    bag = killed_copy(only_mcap(tmp_path / "full"), tmp_path / "rec", 9000)
    # the window is too short to fit: what matters is the warning line printed before that refusal
    assert main(["isolate", str(bag)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("ema-phm: warning: recovered ") and len(err) == 2


# ---- a full disk while recording --------------------------------------------------------------


class _SmallDisk:
    """A file that takes `room` bytes, then fails every write with ENOSPC (writing what fits)."""

    def __init__(self, inner, room: int) -> None:
        self.inner, self.room = inner, room

    def write(self, data) -> int:
        n = len(data)
        if n > self.room:
            self.inner.write(bytes(data[: self.room]))
            self.room = 0
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= n
        return self.inner.write(data)

    def __getattr__(self, name: str):
        return getattr(self.inner, name)


@pytest.fixture
def small_disk(monkeypatch):
    """Call it with a byte count: .mcap files created from then on hold at most that much."""
    real = io.open

    def fill(room: int) -> None:
        def opener(file, mode="r", *args, **kwargs):
            f = real(file, mode, *args, **kwargs)
            return _SmallDisk(f, room) if str(file).endswith(".mcap") and "x" in mode else f

        monkeypatch.setattr(io, "open", opener)

    return fill


def test_a_full_disk_stops_the_recording_once(tmp_path: Path, small_disk) -> None:
    """Before: every later message raised again (the node logged 247 errors in 40 s)."""
    small_disk(6000)
    bag = tmp_path / "rec"
    rec = BagRecorder(bag, topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY}, flush_period=3600)
    raised: list[Exception] = []
    for i in range(200):
        try:
            rec.write(
                TELEMETRY_TOPIC, float64_multiarray(block(i), ["samples", "channels"]), 2 + i
            )
            if i % 2 == 1:
                rec.flush()
        except Exception as exc:  # noqa: BLE001 - every one is counted
            raised.append(exc)
    assert len(raised) == 1 and isinstance(raised[0], RecordingStopped), raised
    msg = str(raised[0])
    assert "\n" not in msg and str(bag) in msg and "No space left on device" in msg
    assert rec.failed and rec.failure == msg
    rec.close()  # already said: nothing more
    rec.close()
    assert not (bag / "metadata.yaml").exists()
    # what reached the disk before the failure reads as an unfinished recording
    with pytest.warns(BagRecoveredWarning):
        w = read_window(bag)
    assert 0 < w.n < 200 * 10
    np.testing.assert_array_equal(w.matrix(), np.concatenate([block(i) for i in range(w.n // 10)]))


def test_a_full_disk_in_the_flush_thread_is_raised_by_close(tmp_path: Path, small_disk) -> None:
    small_disk(2000)
    rec = BagRecorder(
        tmp_path / "rec", topics={TELEMETRY_TOPIC: FLOAT64_MULTIARRAY}, flush_period=0.05
    )
    for i in range(5):
        rec.write(TELEMETRY_TOPIC, float64_multiarray(block(i), ["samples", "channels"]), 2 + i)
    deadline = time.monotonic() + 30.0
    while not rec.failed and time.monotonic() < deadline:  # the flush thread hits it
        time.sleep(0.05)
    assert rec.failed
    with pytest.raises(RecordingStopped, match="No space left"):
        rec.close()
    rec.close()  # once only


def test_write_window_on_a_full_disk_leaves_no_bag(tmp_path: Path, small_disk) -> None:
    small_disk(3000)
    rows = np.zeros((401, len(CHANNELS)))
    rows[:, 0] = np.arange(401) / 2000.0
    with pytest.raises(RecordingStopped, match="No space left"):
        write_window(tmp_path / "w", Window.from_matrix(rows, meta={"sample_rate": 2000.0}))
    assert not (tmp_path / "w").exists()
