"""ema_phm_msgs with rclpy: the built package, CDR across rclpy and rosbags, the nodes' topics."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from node_helpers import Listener, wait_until  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from typed_helpers import full_report, rows  # noqa: E402

from ema_phm.domain.faults import NAMES, k_with  # noqa: E402
from ema_phm.domain.window import CHANNELS  # noqa: E402
from ema_phm.ros import typed_messages as tm  # noqa: E402
from ema_phm.ros.common import OUTPUT_QOS, TELEMETRY_QOS  # noqa: E402
from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402
from ema_phm.telemetry import bags, typed, wire  # noqa: E402

FRICTION = k_with(friction=0.5).tolist()


def test_health_round_trip_through_rclpy_cdr() -> None:
    report = full_report()
    msg = tm.actuator_health(report, 1_700_000_000_000_000_001)
    back = deserialize_message(serialize_message(msg), tm.ActuatorHealth)
    assert back == msg
    got = tm.health_report(back)
    np.testing.assert_array_equal(got.assessment.k, report.assessment.k)
    np.testing.assert_array_equal(got.extras.k_high, report.extras.k_high)
    assert (got.level, got.message, got.extras.nuisances) == (
        report.level,
        report.message,
        report.extras.nuisances,
    )
    assert tm.ActuatorHealth.STALE == typed.STALE == 3


@pytest.mark.parametrize("which", ["health", "batch", "sample"])
def test_rclpy_and_rosbags_read_each_others_bytes(which: str) -> None:
    """The built C typesupport and rosbags' schema from the .msg files agree on the wire."""
    classes = typed.rosbags_classes(bags.TYPESTORE)
    a = rows(30)
    if which == "health":
        name, ours = typed.ACTUATOR_HEALTH, tm.actuator_health(full_report(), 9)
        theirs = typed.actuator_health(classes, full_report(), 9)
        cls = tm.ActuatorHealth
    elif which == "batch":
        name, ours = typed.TELEMETRY_BATCH, tm.telemetry_batch(a, 9)
        theirs, cls = typed.telemetry_batch(classes, a, 9), tm.TelemetryBatch
    else:
        name, ours = typed.TELEMETRY_SAMPLE, tm.telemetry_samples(a, 9)[1]
        theirs, cls = typed.telemetry_samples(classes, a, 9)[1], tm.TelemetrySample
    canonical = bags.serialize(name, theirs)  # rosbags zeroes the CDR padding, rclpy may not
    from_rclpy = bags.TYPESTORE.deserialize_cdr(bytes(serialize_message(ours)), name)
    assert bags.serialize(name, from_rclpy) == canonical
    from_rosbags = deserialize_message(canonical, cls)  # and back through rclpy
    again = bags.TYPESTORE.deserialize_cdr(bytes(serialize_message(from_rosbags)), name)
    assert bags.serialize(name, again) == canonical


class TypedProbe(Listener):
    """Listens to the typed topics and the legacy telemetry."""

    def __init__(self, g: InProcessGraph) -> None:
        super().__init__(g, "typed_probe")
        self.got: dict[str, list] = {}
        sub = self.node.create_subscription
        for cls, topic, qos in (
            (Float64MultiArray, wire.TELEMETRY_TOPIC, TELEMETRY_QOS),
            (tm.TelemetryBatch, wire.TELEMETRY_BATCH_TOPIC, TELEMETRY_QOS),
            (tm.TelemetrySample, wire.TELEMETRY_SAMPLE_TOPIC, TELEMETRY_QOS),
            (tm.TelemetryBatch, wire.WINDOW_BATCH_TOPIC, OUTPUT_QOS),
            (tm.ActuatorHealth, wire.ACTUATOR_HEALTH_TOPIC, OUTPUT_QOS),
        ):
            self.got[topic] = []
            sub(cls, topic, self._add(self.got[topic]), qos)

    def of(self, topic: str) -> list:
        with self.lock:
            return list(self.got[topic])


def test_ema_node_publishes_typed_batches_and_a_decimated_sample_stream(graph):
    probe = TypedProbe(graph)
    ema = graph.add(
        EmaNode, realtime_factor=0.0, max_windows=1, duration=0.2, wait_for_subscribers=1
    )
    assert ema.finished.wait(30.0)
    n = ema.samples_per_window + 1
    assert wait_until(
        lambda: (
            sum(len(m.t) for m in probe.of(wire.TELEMETRY_BATCH_TOPIC)) == n
            and sum(len(m.data) for m in probe.of(wire.TELEMETRY_TOPIC)) == len(CHANNELS) * n
        ),
        10.0,
    )
    legacy = np.vstack([wire.decode_telemetry(m) for m in probe.of(wire.TELEMETRY_TOPIC)])
    batches = probe.of(wire.TELEMETRY_BATCH_TOPIC)
    np.testing.assert_array_equal(np.vstack([typed.batch_rows(m) for m in batches]), legacy)
    assert batches[0].sample_rate_hz == pytest.approx(ema.sample_rate, rel=1e-6)
    assert wait_until(
        lambda: len(probe.of(wire.TELEMETRY_SAMPLE_TOPIC)) == len(legacy[::20]), 10.0
    ), len(probe.of(wire.TELEMETRY_SAMPLE_TOPIC))
    samples = np.array([typed.sample_row(m) for m in probe.of(wire.TELEMETRY_SAMPLE_TOPIC)])
    np.testing.assert_array_equal(samples, legacy[:: typed.SAMPLE_DECIMATION])


def test_monitor_publishes_actuator_health_and_records_the_typed_topics(graph, tmp_path):
    probe = TypedProbe(graph)
    bag = tmp_path / "rec"
    monitor = graph.add(MonitorNode, record_bag=str(bag), max_evaluations=300)
    ema = graph.add(
        EmaNode, k=FRICTION, realtime_factor=0.0, max_windows=1, wait_for_subscribers=2
    )
    results = monitor.wait_for_results(1, timeout=120.0, failures=1)
    assert results, f"no health result; failures {list(monitor.failures)}"
    r = results[0]
    assert wait_until(
        lambda: (
            any(m.assessed for m in probe.of(wire.ACTUATOR_HEALTH_TOPIC))
            and probe.of(wire.WINDOW_BATCH_TOPIC)
        ),
        10.0,
    )
    health_msgs = probe.of(wire.ACTUATOR_HEALTH_TOPIC)
    assert not health_msgs[0].assessed  # the start-up status: waiting, no fit
    fit = next(m for m in health_msgs if m.assessed)
    assert [getattr(fit, n).name for n in NAMES] == list(NAMES)
    np.testing.assert_allclose([getattr(fit, n).value for n in NAMES], r["k"])
    assert fit.level == {"OK": 0, "WARN": 1, "ERROR": 2}[r["level"]]
    assert fit.dominant_fault == r["dominant_fault"] and fit.hardware_id == "ema_sim"
    assert fit.evaluations == r["evaluations"] and fit.window_t0 == r["window_t0"]
    # what the fit reports beyond k reaches the message (intervals, flags, adequacy, nuisances)
    np.testing.assert_allclose(
        [[getattr(fit, n).low, getattr(fit, n).high] for n in NAMES], r["k_interval"]
    )
    assert [getattr(fit, n).identifiable for n in NAMES] == [f["ok"] for f in r["identifiable"]]
    assert fit.adequacy.evaluated and fit.adequacy.statistic == r["adequacy"]["statistic"]
    assert {x.name: x.value for x in fit.nuisances} == r["nuisance"]
    window = typed.batch_rows(probe.of(wire.WINDOW_BATCH_TOPIC)[0])
    assert window.shape == (ema.samples_per_window + 1, len(CHANNELS))
    monitor.close()
    counts: dict[str, int] = {}
    for topic, msgtype, _t, msg in bags.read_messages(bag):
        counts[topic] = counts.get(topic, 0) + 1
        if topic == wire.ACTUATOR_HEALTH_TOPIC:
            assert msgtype == typed.ACTUATOR_HEALTH and msg.friction.name == "friction"
    assert counts.get(wire.WINDOW_BATCH_TOPIC) == 1
    assert counts.get(wire.ACTUATOR_HEALTH_TOPIC, 0) >= 2
    assert bags.read_window(bag).n == ema.samples_per_window + 1  # the legacy reader still works
