"""ema_phm_msgs without rclpy: the .msg files, the converters with rosbags' classes, the bags."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore
from typed_helpers import full_report, rows

from ema_phm.domain.faults import LABELS, N_K, NAMES, NOMINAL
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import BagError, WindowError
from ema_phm.telemetry import typed, wire
from ema_phm.telemetry.bags import TYPESTORE, BagRecorder, read_messages, serialize
from ema_phm.telemetry.wire import StreamId

ROOT = Path(__file__).resolve().parents[2]
MSG_PKG = ROOT / "ema_phm_msgs"
CLASSES = typed.rosbags_classes(TYPESTORE)


# ------------------------------------------------------------------ the package
def test_cmakelists_lists_every_msg_file_and_typed_knows_them_all() -> None:
    files = sorted(p.name for p in (MSG_PKG / "msg").glob("*.msg"))
    listed = sorted(re.findall(r'"msg/(\w+\.msg)"', (MSG_PKG / "CMakeLists.txt").read_text()))
    assert files == listed
    assert sorted(n.rsplit("/", 1)[1] + ".msg" for n in typed.MESSAGE_TYPES) == files
    actions = sorted(p.name for p in (MSG_PKG / "action").glob("*.action"))
    cmake = (MSG_PKG / "CMakeLists.txt").read_text()
    assert actions == sorted(re.findall(r'"action/(\w+\.action)"', cmake)) == ["RunTest.action"]


def test_actuator_health_fault_fields_are_the_fault_table() -> None:
    # one FaultEstimate field per fault, in k's order, each commented with its k label
    text = (MSG_PKG / "msg" / "ActuatorHealth.msg").read_text(encoding="utf-8")
    fields = re.findall(r"^FaultEstimate\s+(\w+)\s*#\s*(k\d+):", text, flags=re.MULTILINE)
    assert [name for name, _ in fields] == list(NAMES)
    assert [label for _, label in fields] == list(LABELS)
    # and the converter fills them from the table, each with its own name
    msg = typed.actuator_health(CLASSES, full_report(), 0)
    assert [getattr(msg, name).name for name in NAMES] == list(NAMES)


def test_package_xml_is_a_rosidl_interface_package() -> None:
    import xml.etree.ElementTree as ET

    root = ET.parse(MSG_PKG / "package.xml").getroot()
    assert root.findtext("name") == typed.PACKAGE
    assert root.findtext("member_of_group") == "rosidl_interface_packages"
    assert root.find("export/build_type").text == "ament_cmake"
    assert {e.text for e in root.findall("buildtool_depend")} == {
        "ament_cmake",
        "rosidl_default_generators",
    }
    assert {e.text for e in root.findall("exec_depend")} == {"rosidl_default_runtime"}


def test_message_fields_are_the_library_names() -> None:
    fields = TYPESTORE.fielddefs
    batch = [name for name, _ in fields[typed.TELEMETRY_BATCH][1]]
    assert batch == ["header", "hardware_id", "run_id", "sample_rate_hz", *CHANNELS]
    sample = [n for n, _ in fields[typed.TELEMETRY_SAMPLE][1]]
    assert sample == ["header", "hardware_id", "run_id", *CHANNELS]
    health_fields = [n for n, _ in fields[typed.ACTUATOR_HEALTH][1]]
    assert health_fields[health_fields.index("friction") :][:N_K] == list(NAMES)
    consts = {c[0]: c[2] for c in fields[typed.ACTUATOR_HEALTH][0]}
    assert consts == {"OK": 0, "WARN": 1, "ERROR": 2, "STALE": 3}
    rul = [n for n, _ in fields[typed.REMAINING_LIFE][1]]
    assert tuple(rul) == typed.RUL_FIELDS


def test_every_field_has_a_comment() -> None:
    """Units and meanings travel with the schema: a comment on each field's line or above it."""
    for path in (MSG_PKG / "msg").glob("*.msg"):
        above = ""
        for line in path.read_text().splitlines():
            code = line.split("#", 1)[0].strip()
            if code and "=" not in code:
                assert "#" in line or above.startswith("#"), f"{path.name}: {line!r}"
            above = line.strip()


# ---------------------------------------------------------------- telemetry
def test_telemetry_batch_round_trip_through_cdr() -> None:
    a = rows(100, t0=1.5)
    sid = StreamId("ema-1", "r1")
    msg = typed.telemetry_batch(CLASSES, a, 1_700_000_000_250_000_000, sid)
    back = TYPESTORE.deserialize_cdr(serialize(typed.TELEMETRY_BATCH, msg), typed.TELEMETRY_BATCH)
    np.testing.assert_array_equal(typed.batch_rows(back), a)  # NaN load kept
    assert back.sample_rate_hz == pytest.approx(2000.0, rel=1e-9)
    # stamped with its first sample's time: the origin plus t[0] = 1.5 s
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == (1_700_000_001, 750_000_000)
    assert typed.time_ns(back.header) == 1_700_000_001_750_000_000
    assert typed.stream_of(back) == sid


def test_one_sample_batch_has_no_rate() -> None:
    msg = typed.telemetry_batch(CLASSES, rows(1), 0)
    assert math.isnan(msg.sample_rate_hz) and typed.batch_rows(msg).shape == (1, len(CHANNELS))


@pytest.mark.parametrize("shape", [(5, 7), (0, 8), (8,)])
def test_telemetry_batch_refuses_bad_shapes(shape) -> None:
    with pytest.raises(WindowError, match="telemetry must be n x 8"):
        typed.telemetry_batch(CLASSES, np.zeros(shape), 0)


def test_batch_with_arrays_of_different_lengths_is_refused() -> None:
    msg = typed.telemetry_batch(CLASSES, rows(4), 0)
    msg.i3eq = np.zeros(3)
    with pytest.raises(WindowError, match="differ in length"):
        typed.batch_rows(msg)


def test_samples_follow_the_decimation_grid_across_batches() -> None:
    a = rows(400)
    picked = [
        typed.sample_row(m)
        for block in (a[:64], a[64:200], a[200:])  # batch sizes not multiples of 20
        for m in typed.telemetry_samples(CLASSES, block, 0)
    ]
    np.testing.assert_array_equal(np.array(picked), a[::20])


def test_each_sample_is_stamped_with_its_own_time() -> None:
    """Issue 17 item 7: one stamp per batch stacked every decimated sample on one instant."""
    a = rows(400)
    origin = 1_700_000_000_000_000_000
    msgs = typed.telemetry_samples(CLASSES, a, origin, StreamId("ema-1", "r1"))
    stamps = np.array([typed.time_ns(m.header) for m in msgs])
    np.testing.assert_array_equal(stamps, origin + np.rint(a[::20, 0] * 1e9).astype(np.int64))
    assert np.all(np.diff(stamps) == 10_000_000)  # 100 Hz, no zero interval
    assert all(typed.stream_of(m) == StreamId("ema-1", "r1") for m in msgs)


def test_sample_decimation_must_be_positive() -> None:
    with pytest.raises(WindowError, match="decimation"):
        typed.telemetry_samples(CLASSES, rows(4), 0, every=0)


def test_stamps_out_of_range_are_refused() -> None:
    assert typed.stamp_of(-1) == (-1, 999_999_999)
    with pytest.raises(WindowError, match="does not fit"):
        typed.header(CLASSES, 2**31 * 1_000_000_000)


# ------------------------------------------------------------------- health
def test_actuator_health_round_trip_through_cdr() -> None:
    report = full_report()
    msg = typed.actuator_health(CLASSES, report, 42)
    raw = serialize(typed.ACTUATOR_HEALTH, msg)
    back = typed.health_report(TYPESTORE.deserialize_cdr(raw, typed.ACTUATOR_HEALTH))
    a, b = report.assessment, back.assessment
    assert (back.level, back.message, back.hardware_id, back.assessed) == (
        report.level,
        report.message,
        "ema_sim",
        True,
    )
    for name in ("k", "severity", "levels"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name))
    for name in ("level", "dominant", "message", "fitness", "evaluations", "elapsed_s"):
        assert getattr(b, name) == getattr(a, name), name
    assert (b.window_t0, b.window_t1, b.percent_err) == (a.window_t0, a.window_t1, a.percent_err)
    assert b.k_true is None  # not on the wire
    x, y = report.extras, back.extras
    np.testing.assert_array_equal(y.k_low, x.k_low)
    np.testing.assert_array_equal(y.k_high, x.k_high)
    assert (y.identifiable, y.reasons, y.adequacy, y.rul) == (
        x.identifiable,
        x.reasons,
        x.adequacy,
        x.rul,
    )
    assert y.nuisances == (
        typed.NuisanceValue("load_torque", "N*m", -2.5),
        typed.NuisanceValue("current_offset", "", 0.04),
    )
    assert y.no_degradation_detected is True


def test_health_fields_are_named_per_fault() -> None:
    msg = typed.actuator_health(CLASSES, full_report(), 0)
    assert msg.friction.name == "friction" and msg.friction.value == pytest.approx(0.3)
    assert msg.gain_drift.nominal == NOMINAL[7] and msg.eccentricity_phase.severity == 0.0
    assert msg.level == msg.WARN == typed.WARN and msg.dominant_fault == "friction"
    assert msg.backlash.reason == "flat fitness" and not msg.backlash.identifiable
    assert msg.friction.rul.hours_p50 == 4.0


def test_status_without_any_fit_carries_nan_and_defaults() -> None:
    report = typed.HealthReport(typed.STALE, "STALE: no telemetry", "ema_sim", False, None)
    msg = typed.actuator_health(CLASSES, report, 0)
    assert msg.level == msg.STALE and not msg.assessed and msg.dominant_fault == ""
    assert all(math.isnan(getattr(msg, n).value) for n in NAMES)
    assert all(math.isnan(getattr(msg, n).low) for n in NAMES)
    assert not msg.adequacy.evaluated and list(msg.nuisances) == [] and msg.evaluations == 0
    back = typed.health_report(msg)
    assert back.assessment is None and back.level == typed.STALE and not back.assessed


def test_bad_level_and_misnamed_fault_are_refused() -> None:
    with pytest.raises(WindowError, match="level must be 0..3"):
        typed.actuator_health(CLASSES, typed.HealthReport(7, "", "", False, None), 0)
    msg = typed.actuator_health(CLASSES, full_report(), 0)
    msg.backlash.name = "friction"
    with pytest.raises(WindowError, match="backlash.name"):
        typed.health_report(msg)


def test_extras_must_have_one_entry_per_fault() -> None:
    with pytest.raises(WindowError, match=f"k_low must have {N_K}"):
        typed.HealthExtras(k_low=np.zeros(7))
    with pytest.raises(WindowError, match=f"reasons must have {N_K}"):
        typed.HealthExtras(reasons=("",))


# --------------------------------------------------------------------- bags
def test_a_recorded_bag_embeds_the_schemas_and_reads_back(tmp_path: Path) -> None:
    topics = {
        wire.TELEMETRY_BATCH_TOPIC: typed.TELEMETRY_BATCH,
        wire.TELEMETRY_SAMPLE_TOPIC: typed.TELEMETRY_SAMPLE,
        wire.ACTUATOR_HEALTH_TOPIC: typed.ACTUATOR_HEALTH,
    }
    assert all(wire.TOPIC_TYPES[t] == m for t, m in topics.items())
    a = rows(40)
    with BagRecorder(tmp_path / "bag", topics=topics) as rec:
        rec.write(wire.TELEMETRY_BATCH_TOPIC, typed.telemetry_batch(CLASSES, a, 5), 5)
        for m in typed.telemetry_samples(CLASSES, a, 6):
            rec.write(wire.TELEMETRY_SAMPLE_TOPIC, m, 6)
        rec.write(wire.ACTUATOR_HEALTH_TOPIC, typed.actuator_health(CLASSES, full_report(), 7), 7)
    [mcap_file] = (tmp_path / "bag").glob("*.mcap")
    with mcap_file.open("rb") as f:
        schemas = {s.name: s for s in make_reader(f).get_summary().schemas.values()}
    health_schema = schemas[typed.ACTUATOR_HEALTH].data.decode()
    assert schemas[typed.ACTUATOR_HEALTH].encoding == "ros2msg"
    for nested in ("MSG: ema_phm_msgs/FaultEstimate", "MSG: ema_phm_msgs/RemainingLife"):
        assert nested in health_schema  # a reader needs no ema_phm_msgs installed
    got = list(read_messages(tmp_path / "bag"))
    assert [t for t, *_ in got].count(wire.TELEMETRY_SAMPLE_TOPIC) == 2
    batch = next(m for t, _, _, m in got if t == wire.TELEMETRY_BATCH_TOPIC)
    np.testing.assert_array_equal(typed.batch_rows(batch), a)
    health_msg = next(m for t, _, _, m in got if t == wire.ACTUATOR_HEALTH_TOPIC)
    assert typed.health_report(health_msg).extras.reasons[1] == "flat fitness"


def test_a_fresh_typestore_reads_the_bag_from_its_own_schemas(tmp_path: Path) -> None:
    """What a reader without ema_phm_msgs gets: the types from the schema text in the bag."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import get_types_from_msg

    with BagRecorder(
        tmp_path / "bag", topics={wire.ACTUATOR_HEALTH_TOPIC: typed.ACTUATOR_HEALTH}
    ) as rec:
        rec.write(wire.ACTUATOR_HEALTH_TOPIC, typed.actuator_health(CLASSES, full_report(), 1), 1)
    fresh = get_typestore(Stores.ROS2_KILTED)
    assert typed.ACTUATOR_HEALTH not in fresh.types
    with Reader(tmp_path / "bag") as reader:
        [conn] = reader.connections
        fresh.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        [(_, _, raw)] = list(reader.messages())
    msg = fresh.deserialize_cdr(raw, conn.msgtype)
    assert msg.friction.name == "friction" and msg.hardware_id == "ema_sim"
    assert typed.health_report(msg).extras.nuisances[0].unit == "N*m"


def test_missing_msg_files_are_a_clear_error(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setattr(typed, "msg_dir", lambda: tmp_path)
    store = get_typestore(Stores.ROS2_KILTED)
    with pytest.raises(BagError, match="cannot read"):
        typed.register_types(store)
    with pytest.raises(BagError, match="cannot record"):
        BagRecorder(
            tmp_path / "bag",
            topics={wire.ACTUATOR_HEALTH_TOPIC: typed.ACTUATOR_HEALTH},
            typestore=store,
        )


def test_extras_of_reads_what_an_assessment_holds() -> None:
    from types import SimpleNamespace

    assert typed.extras_of(None).nuisances == () and not typed.extras_of(None).adequacy.evaluated
    bare = typed.extras_of(SimpleNamespace())  # an Assessment without the new fields
    assert np.all(np.isnan(bare.k_low)) and not bare.adequacy.evaluated and bare.nuisances == ()
    interval = np.column_stack([np.linspace(0, 0.7, N_K), np.linspace(0.1, 0.8, N_K)])
    flags = tuple((i % 2 == 0, "" if i % 2 == 0 else f"reason {i}") for i in range(N_K))
    a = SimpleNamespace(
        k_interval=interval,
        identifiable=flags,
        adequacy={"statistic": 1.25, "threshold": 3.0, "ok": True},
        nuisance={"load_torque": -12.5, "temperature_c": 55.0, "unknown_thing": 1.0},
    )
    x = typed.extras_of(a)
    np.testing.assert_array_equal(x.k_low, interval[:, 0])
    np.testing.assert_array_equal(x.k_high, interval[:, 1])
    assert x.identifiable == tuple(ok for ok, _ in flags) and x.reasons[1] == "reason 1"
    assert x.adequacy == typed.AdequacyResult(1.25, 3.0, True, True)
    assert x.nuisances == (
        typed.NuisanceValue("load_torque", "N*m", -12.5),
        typed.NuisanceValue("temperature_c", "degC", 55.0),
        typed.NuisanceValue("unknown_thing", "", 1.0),
    )
    with pytest.raises(WindowError, match=f"{N_K} x 2"):
        typed.extras_of(SimpleNamespace(k_interval=np.zeros((N_K, 3))))
