"""CRCs: written into every bag, checked on read; a damaged chunk is named and the rest is read."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli
from mcap.reader import make_reader
from mcap.records import Chunk, DataEnd, Footer
from mcap.stream_reader import StreamReader
from test_bag_recovery import block, only_mcap, record

from ema_phm.domain.window import CHANNELS, Window
from ema_phm.errors import BagError
from ema_phm.telemetry.bags import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    BagCorruptWarning,
    read_messages,
    read_window,
    recover_bag,
    verify_mcap,
)


def chunk_spans(mcap: Path) -> list[tuple[int, int]]:
    """(start, length) of each chunk record, in file order, from the summary."""
    with mcap.open("rb") as f:
        idx = make_reader(f).get_summary().chunk_indexes
    return sorted((c.chunk_start_offset, c.chunk_length) for c in idx)


def flip(mcap: Path, at: int, n: int = 20) -> None:
    """Invert `n` bytes from byte `at` (as a bad disk sector or a bad copy would)."""
    raw = bytearray(mcap.read_bytes())
    raw[at : at + n] = bytes(b ^ 0xFF for b in raw[at : at + n])
    mcap.write_bytes(bytes(raw))


def telemetry_blocks(bag: Path) -> list[int]:
    """Which `block(i)` each telemetry message of the bag holds (checked to be exactly it)."""
    out = []
    for topic, _type, _t, msg in read_messages(bag):
        if topic == TELEMETRY_TOPIC:
            data = np.asarray(msg.data).reshape(-1, len(CHANNELS))
            i = int(data[0, 1])
            np.testing.assert_array_equal(data, block(i))
            out.append(i)
    return out


def test_recorded_bags_carry_every_crc(tmp_path: Path) -> None:
    """Before, rosbags' writer stored 0 for all three: nothing could be checked."""
    record(tmp_path / "b", 20, flush_every=6)
    mcap = only_mcap(tmp_path / "b")
    with mcap.open("rb") as f:
        records = list(StreamReader(f, emit_chunks=True, validate_crcs=True).records)
    chunks = [r for r in records if isinstance(r, Chunk)]
    assert len(chunks) == 4 and all(c.uncompressed_crc != 0 for c in chunks)
    assert [r.data_section_crc != 0 for r in records if isinstance(r, DataEnd)] == [True]
    assert [r.summary_crc != 0 for r in records if isinstance(r, Footer)] == [True]
    assert verify_mcap(mcap) == []


def test_flipped_bytes_in_a_chunk_are_named_and_the_other_chunks_read(tmp_path: Path) -> None:
    """Before: CRC 0, so the flipped bytes came back as data, without a word."""
    record(tmp_path / "b", 40, flush_every=6)  # 7 chunks: blocks 0-5, 6-11, ..., 36-39
    mcap = only_mcap(tmp_path / "b")
    start, length = chunk_spans(mcap)[2]  # blocks 12..17
    flip(mcap, start + length // 2)
    problems = verify_mcap(mcap)
    assert problems and problems[0].startswith(f"chunk at byte {start}: CRCValidationError")
    with pytest.warns(BagCorruptWarning) as caught:
        got = telemetry_blocks(tmp_path / "b")
    text = str(caught[0].message)
    assert "\n" not in text and str(mcap) in text and f"chunk at byte {start}" in text
    assert got == [i for i in range(40) if not 12 <= i < 18]


def test_a_damaged_first_chunk_leaves_the_rest_readable(tmp_path: Path) -> None:
    """The first chunk holds the schemas and channels: the summary's copies stand in."""
    record(tmp_path / "b", 20, flush_every=6)
    mcap = only_mcap(tmp_path / "b")
    start, length = chunk_spans(mcap)[0]
    flip(mcap, start + length - 30)
    with pytest.warns(BagCorruptWarning, match=f"chunk at byte {start}"):
        got = telemetry_blocks(tmp_path / "b")
    assert got == list(range(6, 20))


@pytest.mark.parametrize("where", ["message index", "summary"])
def test_damage_outside_the_chunks_is_named_and_every_message_reads(
    tmp_path: Path, where: str
) -> None:
    record(tmp_path / "b", 12, flush_every=6)
    mcap = only_mcap(tmp_path / "b")
    spans = chunk_spans(mcap)
    if where == "message index":  # right after the first chunk record
        flip(mcap, spans[0][0] + spans[0][1] + 12, n=2)
        words = "data section CRC mismatch"
    else:
        with mcap.open("rb") as f:
            records = list(StreamReader(f).records)
        footer = next(r for r in records if isinstance(r, Footer))
        flip(mcap, footer.summary_start + 20, n=2)
        words = f"summary section at byte {footer.summary_start} CRC mismatch"
    assert any(words in p for p in verify_mcap(mcap)), verify_mcap(mcap)
    with pytest.warns(BagCorruptWarning, match=words):
        assert telemetry_blocks(tmp_path / "b") == list(range(12))


def test_recover_bag_drops_the_damaged_chunk_and_writes_a_sound_bag(tmp_path: Path) -> None:
    record(tmp_path / "b", 20, flush_every=6)
    mcap = only_mcap(tmp_path / "b")
    start, length = chunk_spans(mcap)[1]
    flip(mcap, start + length // 2)
    report = recover_bag(tmp_path / "b", out=tmp_path / "fixed")
    assert [d.split(":")[0] for d in report.damaged] == [f"chunk at byte {start}"]
    assert report.messages == {RUN_INFO_TOPIC: 1, GROUND_TRUTH_TOPIC: 1, TELEMETRY_TOPIC: 14}
    assert verify_mcap(only_mcap(tmp_path / "fixed")) == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert telemetry_blocks(tmp_path / "fixed") == [*range(6), *range(12, 20)]


def test_a_window_bag_with_its_chunk_damaged_is_refused_naming_the_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """The issue's case: 20 flipped bytes used to isolate as if nothing had happened."""
    from ema_phm.telemetry.bags import write_window

    rows = np.zeros((4001, len(CHANNELS)))
    rows[:, 0] = np.arange(4001) / 2000.0
    rows[:, 6] = np.sin(rows[:, 0])
    bag = write_window(tmp_path / "w", Window.from_matrix(rows, meta={"sample_rate": 2000.0}))
    mcap = only_mcap(bag)
    (start, length), *_ = chunk_spans(mcap)
    flip(mcap, start + length // 2)
    with pytest.warns(BagCorruptWarning), pytest.raises(BagError) as err:
        read_window(bag)
    assert f"chunk at byte {start}" in str(err.value) and str(mcap) in str(err.value)
    code, _out, errtext = run_cli(capsys, "isolate", str(bag))
    lines = errtext.strip().splitlines()
    assert code == 2 and len(lines) == 2, lines
    assert lines[0].startswith("ema-phm: warning: ") and f"chunk at byte {start}" in lines[0]
    assert lines[1].startswith("ema-phm: error: ")
