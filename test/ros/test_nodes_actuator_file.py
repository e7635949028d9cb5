"""`actuator_file` on both nodes: ema_node simulates that actuator, monitor_node believes the file.

In-process (rclpy), short windows and no warm-up: each test takes a second or two.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from node_helpers import Probe, trigger, wait_until  # noqa: E402 - after importorskip
from rclpy.parameter import Parameter  # noqa: E402 - after importorskip

from ema_phm.errors import ConfigError  # noqa: E402 - after importorskip
from ema_phm.model.belief import MonitorBelief  # noqa: E402
from ema_phm.physics.actuator_file import load_actuator, write_actuator  # noqa: E402
from ema_phm.physics.parameters import ActuatorParameters  # noqa: E402
from ema_phm.ros.ema_node import EmaNode, stream_from  # noqa: E402 - after importorskip
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402 - after importorskip
from ema_phm.telemetry.wire import decode_telemetry  # noqa: E402 - after importorskip

#: The one value the written actuator changes: a heavier load side (user inertia x2).
CHANGED = "mechanics.j_user"
#: A short window, published at once.
SHORT = dict(duration=0.1, samples_per_message=50, realtime_factor=0.0, max_windows=1)


@pytest.fixture
def actuator_file(tmp_path: Path) -> Path:
    """The packaged actuator with `CHANGED` doubled, written as an actuator file."""
    default = ActuatorParameters.default()
    changed = default.with_values({CHANGED: 2.0 * default.value(CHANGED)})
    return write_actuator(changed, tmp_path / "heavy_user.yaml")


@pytest.mark.parametrize("node_cls", [EmaNode, MonitorNode])
def test_a_missing_actuator_file_refuses_start_up_naming_it(graph, tmp_path, node_cls):
    missing = tmp_path / "nowhere.yaml"
    with pytest.raises(ConfigError, match=f"actuator_file: config file not found: {missing}"):
        graph.add(node_cls, actuator_file=str(missing))


@pytest.mark.parametrize("node_cls", [EmaNode, MonitorNode])
def test_a_bad_value_in_the_actuator_file_refuses_start_up_naming_file_and_key(
    graph, actuator_file, node_cls
):
    text = actuator_file.read_text(encoding="utf-8")
    bad = "\n".join(
        "  j_motor_kg_m2: -1.0" if line.startswith("  j_motor_kg_m2:") else line
        for line in text.splitlines()
    )
    actuator_file.write_text(bad + "\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=rf"actuator_file: {actuator_file}: .*j_motor_kg_m2"):
        graph.add(node_cls, actuator_file=str(actuator_file))


def _telemetry_rows(probe: Probe) -> np.ndarray:
    with probe.lock:
        return np.vstack([decode_telemetry(m) for m in probe.telemetry])


def test_ema_node_publishes_the_telemetry_of_the_actuator_in_its_file(graph, actuator_file):
    probe = Probe(graph)
    ema = graph.add(EmaNode, actuator_file=str(actuator_file), wait_for_subscribers=1, **SHORT)
    assert wait_until(ema.finished.is_set, 30.0)
    n = ema.samples_published
    assert wait_until(lambda: sum(len(decode_telemetry(m)) for m in probe.telemetry) == n, 10.0)
    published = _telemetry_rows(probe)
    values = {**EmaNode.PARAMETERS.defaults(), **SHORT}

    def offline(**changes: object) -> np.ndarray:
        stream = stream_from({**values, **changes})
        return np.vstack([m.rows for m in iter(stream.next_message, None)])

    np.testing.assert_array_equal(published, offline(actuator_file=str(actuator_file)))
    thesis = offline(actuator_file="")
    assert published.shape == thesis.shape and not np.array_equal(published, thesis)


def test_monitor_belief_is_built_from_the_file_and_kept_at_run_time(graph, actuator_file):
    monitor = graph.add(MonitorNode, warm_up=False, actuator_file=str(actuator_file))
    expected = MonitorBelief.for_actuator(load_actuator(actuator_file))
    belief = monitor.service.settings.belief
    assert belief is not None and belief.sections == expected.sections
    assert belief.value(CHANGED) == 2.0 * MonitorBelief.default().value(CHANGED)
    assert str(actuator_file) in monitor.service.settings.reported()["unit"]
    (res,) = monitor.set_parameters([Parameter("seed", value=3)])
    assert res.successful and monitor.service.settings.seed == 3
    assert monitor.service.settings.belief is belief  # not read again
    (res,) = monitor.set_parameters([Parameter("actuator_file", value="")])
    assert not res.successful and "actuator_file" in res.reason, res.reason


def test_a_run_time_change_does_not_read_the_start_up_files_again(graph, actuator_file):
    """A file moved after start-up does not make later changes fail.

    Found by review: every `ros2 param set` read actuator_file (and unit_file) again.
    """
    monitor = graph.add(MonitorNode, warm_up=False, actuator_file=str(actuator_file))
    belief = monitor.service.settings.belief
    actuator_file.unlink()
    (res,) = monitor.set_parameters([Parameter("seed", value=5)])
    assert res.successful, res.reason
    assert monitor.service.settings.seed == 5 and monitor.service.settings.belief is belief


def test_no_actuator_file_leaves_the_packaged_belief(graph):
    monitor = graph.add(MonitorNode, warm_up=False)
    assert monitor.service.settings.belief is None


def test_commissioning_with_an_actuator_file_is_against_its_belief(
    graph, actuator_file, monkeypatch
):
    """Issue 20: no longer refused; the monitor commissions against the file's belief."""
    from ema_phm.diagnosis.commissioning import CommissioningResult
    from ema_phm.monitor import commissioning_guard

    seen: dict = {}

    def fake_commission(windows, *, belief, checks):
        seen["belief"] = belief
        j = belief.value("mechanics.j_motor")
        return CommissioningResult(
            factors={"inertia": 1.1}, intervals={}, identifiable={"inertia": True},
            values={"mechanics.j_motor": 1.1 * j}, nuisances=[], fitness_before=[],
            fitness_after=[], temperature_c=20.0, wall_s=0.1, evaluations=1,
        )  # fmt: skip

    monkeypatch.setattr(commissioning_guard, "review", lambda ws, spans, belief: ([], []))
    monkeypatch.setattr(commissioning_guard, "commission", fake_commission)
    probe = Probe(graph)
    monitor = graph.add(
        MonitorNode, warm_up=False, actuator_file=str(actuator_file), commission_windows=1
    )
    assert monitor.service.commission_windows == 1
    graph.add(EmaNode, actuator_file=str(actuator_file), wait_for_subscribers=1, **SHORT)
    assert wait_until(lambda: monitor.service.commissioned is not None, 30.0)
    expected = MonitorBelief.for_actuator(load_actuator(actuator_file))
    assert seen["belief"].sections == expected.sections  # not the packaged thesis belief
    commissioned = monitor.service.commissioned
    assert commissioned.value(CHANGED) == expected.value(CHANGED)  # the file's, kept
    assert commissioned.value("mechanics.j_motor") == 1.1 * expected.value("mechanics.j_motor")
    assert wait_until(
        lambda: any("commissioned from 1 window" in s.message for s in probe.statuses()), 5.0
    )
    res = trigger(probe.node, "commission")
    assert res.success and "the next 1 window(s)" in res.message, res.message


def test_ema_node_takes_the_packaged_thesis_actuator_file(graph):
    from ema_phm.physics.actuator_file import packaged_actuator_path

    probe = Probe(graph)
    path = str(packaged_actuator_path())
    ema = graph.add(EmaNode, actuator_file=path, wait_for_subscribers=1, **SHORT)
    assert wait_until(ema.finished.is_set, 30.0)
    n = ema.samples_published
    assert wait_until(lambda: sum(len(decode_telemetry(m)) for m in probe.telemetry) == n, 10.0)
    stream = stream_from({**EmaNode.PARAMETERS.defaults(), **SHORT})
    thesis = np.vstack([m.rows for m in iter(stream.next_message, None)])
    np.testing.assert_array_equal(_telemetry_rows(probe), thesis)
