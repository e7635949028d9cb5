"""Replay logic without rclpy: which topics, which QoS, and when each message goes out."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
from helpers import run_cli

from ema_phm.errors import BagError, ConfigError
from ema_phm.telemetry import bags
from ema_phm.telemetry.player import MONITOR_INPUTS, Record, Recording, check_rate, play
from ema_phm.telemetry.qos import TOPIC_QOS
from ema_phm.telemetry.wire import RUN_INFO_TOPIC, TELEMETRY_TOPIC, TOPIC_TYPES

ROOT = Path(__file__).resolve().parents[2]
NOMINAL = ROOT / "bags" / "nominal"


class FakeClock:
    """A clock that only moves when the replay waits (stop.wait is replaced)."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Stop(threading.Event):
    """A stop event whose waits advance a FakeClock instead of sleeping."""

    def __init__(self, clock: FakeClock) -> None:
        super().__init__()
        self.clock = clock

    def wait(self, timeout: float | None = None) -> bool:
        self.clock.now += timeout or 0.0
        return self.is_set()


def _records(times_s):
    return [Record(TELEMETRY_TOPIC, int(t * 1e9), b"x") for t in times_s]


def test_messages_go_out_at_their_log_times_scaled_by_rate():
    clock = FakeClock()
    sent_at = []
    n = play(
        _records([0.0, 0.5, 2.0]),
        lambda rec: sent_at.append(round(clock.now - 100.0, 6)),
        rate=2.0,
        stop=Stop(clock),
        clock=clock,
    )
    assert n == 3 and sent_at == [0.0, 0.25, 1.0]


def test_loop_starts_over_until_stopped():
    clock = FakeClock()
    stop = Stop(clock)
    sent = []

    def publish(rec):
        sent.append(rec.t_ns)
        if len(sent) == 7:
            stop.set()

    n = play(_records([0.0, 1.0, 2.0]), publish, rate=10.0, loop=True, stop=stop, clock=clock)
    assert n == 7 and sent == [0, 10**9, 2 * 10**9] * 2 + [0]


@pytest.mark.parametrize("rate", [0, -1.0, float("nan"), float("inf"), "fast", 1e-300, 1e-4, 2e3])
def test_bad_rate_is_named(rate):
    with pytest.raises(ConfigError, match=r"rate must be a number in \[0\.001, 1000\], got"):
        check_rate(rate)
    with pytest.raises(ConfigError, match="rate must be"):
        play(_records([0.0]), lambda rec: None, rate=rate)


@pytest.mark.parametrize("rate", [1e-3, 1.0, 1e3])
def test_rate_limits_are_accepted(rate):
    assert check_rate(rate) == rate


@pytest.mark.parametrize("rate", ["1e-300", "1e300", "0", "nan"])
def test_play_cli_refuses_a_rate_that_would_hang(capsys, rate):
    """`play --rate 1e-300` used to be accepted and then wait ~1e300 s for the second message."""
    code, out, err = run_cli(capsys, "play", str(NOMINAL), "--rate", rate)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and f"rate must be a number in [0.001, 1000], got {rate!r}" in err


def test_bundled_bag_plays_the_monitor_inputs_with_our_qos():
    rec = Recording.open(NOMINAL)
    assert list(rec.topics) == list(MONITOR_INPUTS)
    assert rec.topics[RUN_INFO_TOPIC].qos.latched  # the bag says [] but the topic is ours
    assert rec.topics[TELEMETRY_TOPIC].qos == TOPIC_QOS[TELEMETRY_TOPIC]
    assert len(rec.records) == sum(t.count for t in rec.topics.values())
    times = [r.t_ns for r in rec.records]
    assert times == sorted(times)


def test_a_foreign_topic_is_latched_only_if_the_bag_says_so(tmp_path):
    topics = {"/other/info": TOPIC_TYPES[RUN_INFO_TOPIC], RUN_INFO_TOPIC: "std_msgs/msg/String"}
    with bags.BagRecorder(tmp_path / "b", topics=topics) as recorder:
        recorder.write("/other/info", bags.string_msg("a"), 1)
        recorder.write(RUN_INFO_TOPIC, bags.string_msg("{}"), 2)
    rec = Recording.open(tmp_path / "b", ["/other/info", RUN_INFO_TOPIC])
    assert not rec.topics["/other/info"].qos.latched  # recorded without profiles
    assert rec.topics[RUN_INFO_TOPIC].qos.latched  # recorded transient local


@pytest.mark.parametrize(
    "topics,words",
    [(None, "has none of"), (["/nope"], "has no topic /nope")],
)
def test_bags_without_the_topics_are_refused(tmp_path, topics, words):
    with bags.BagRecorder(tmp_path / "b", topics={"/x": TOPIC_TYPES[RUN_INFO_TOPIC]}) as r:
        r.write("/x", bags.string_msg("a"), 1)
    with pytest.raises(BagError, match=words):
        Recording.open(tmp_path / "b", topics)


def test_missing_bag_is_named(tmp_path):
    with pytest.raises(BagError, match="does not exist"):
        Recording.open(tmp_path / "nope")
