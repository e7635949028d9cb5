"""`ema-phm play`: a recorded bag into a live monitor, and the command's error paths."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from rclpy.qos import DurabilityPolicy  # noqa: E402 - after importorskip

from ema_phm.domain.faults import N_K  # noqa: E402 - after importorskip
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402 - after importorskip
from ema_phm.ros.player import BagPlayer, play_bag  # noqa: E402 - after importorskip
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402 - after importorskip
from ema_phm.telemetry import bags  # noqa: E402 - after importorskip
from ema_phm.telemetry.player import Recording  # noqa: E402 - after importorskip
from ema_phm.telemetry.wire import (  # noqa: E402 - after importorskip
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
)
from ema_phm.tools.cli import main  # noqa: E402 - after importorskip

ROOT = Path(__file__).resolve().parents[2]
NOMINAL = ROOT / "bags" / "nominal"


def test_a_bundled_bag_played_into_a_namespaced_monitor_is_fitted(ros_domain_id):
    """The monitor in namespace left fits the replayed window as if it came live."""
    recorded_k = bags.read_window(NOMINAL).k_true.tolist()
    with InProcessGraph(ros_domain_id) as graph:
        monitor = graph.add(MonitorNode, namespace="left", max_evaluations=60)
        result = play_bag(str(NOMINAL), rate=20.0, namespace="left", context=graph.context)
        results = monitor.wait_for_results(1, timeout=60.0, failures=1, not_excited=1)
    assert result.published == len(Recording.open(NOMINAL).records)
    assert result.unacknowledged == ()
    assert result.subscribers["/left/ema/telemetry"] == 1
    assert results, (list(monitor.failures), monitor.counters)
    r = results[0]
    assert r["k_true"] == recorded_k and len(r["k"]) == N_K
    assert r["window_t0"] == 0.0 and math.isfinite(r["percent_err"])
    assert monitor.counters["windows_discarded"] == 0


def test_latched_topics_are_published_transient_local(ros_domain_id):
    with InProcessGraph(ros_domain_id) as graph:
        player = BagPlayer(Recording.open(NOMINAL), context=graph.context)
        graph.nodes.append(player)
        durability = {
            topic: pub.qos_profile.durability for topic, pub in player.publishers_by_topic.items()
        }
        depth = player.publishers_by_topic[TELEMETRY_TOPIC].qos_profile.depth
    assert durability[RUN_INFO_TOPIC] == DurabilityPolicy.TRANSIENT_LOCAL
    assert durability[GROUND_TRUTH_TOPIC] == DurabilityPolicy.TRANSIENT_LOCAL
    assert durability[TELEMETRY_TOPIC] == DurabilityPolicy.VOLATILE and depth == 1000


@pytest.mark.parametrize(
    "argv,words",
    [
        (["play", "/nonexistent/bag"], "ema-phm: error: bag /nonexistent/bag does not exist"),
        (["play", str(NOMINAL), "--rate", "0"], "in [0.001, 1000], got '0'"),
        (["play", str(NOMINAL), "--rate", "-2"], "in [0.001, 1000], got '-2'"),
        (["play", str(NOMINAL), "--rate", "nan"], "in [0.001, 1000], got 'nan'"),
        (["play", str(NOMINAL), "--rate", "inf"], "in [0.001, 1000], got 'inf'"),
        (["play", str(NOMINAL), "--topics", "/nope"], "has no topic /nope"),
        (["play", str(NOMINAL), "--wait-for-subscribers", "-1"], "integer >= 0, got '-1'"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, argv, words):
    with pytest.raises(SystemExit) as exit_info:
        raise SystemExit(main(argv))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err
    assert err.startswith(("ema-phm: error: ", "ema-phm play: error: ")), err


def test_the_command_plays_without_waiting_when_told(capsys):
    assert main(["play", str(NOMINAL), "--rate", "50", "--wait-for-subscribers", "0"]) == 0
    err = capsys.readouterr().err
    n = len(Recording.open(NOMINAL).records)
    assert f"ema-phm play: published {n} message(s)" in err


def test_the_command_prints_one_json_object_with_json(capsys):
    argv = ["play", str(NOMINAL), "--rate", "50", "--wait-for-subscribers", "0", "--json"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    data = json.loads(out)
    assert out.count("\n") == 1 and data["published"] == len(Recording.open(NOMINAL).records)
    assert data["stopped"] is False and data["bag"] == str(NOMINAL)
    assert "published" not in err  # the text goes to stderr without --json only
