"""monitor_node on a rig's own topics (`channel_map_file`), started as `ros2 run` starts it.

This process plays the rig: one `sensor_msgs/JointState` per sample on /joint_states (the
surface, the motor and the surface's command as joints), header-stamped, published after the
node is up (it subscribes once the topic appears); the motor's current is the JointState's
effort, or a `std_msgs/Float64` on /motor/current, which has no header: the node times it by
when it received it, and a recorder in this process (as `ros2 bag record` would) writes the
bag whose offline import the live k is compared with.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from node_processes import start_node, stop_node

pytest.importorskip("rclpy")
pytest.importorskip("sensor_msgs")

RIG_MAP = {
    "version": 1,
    "identity": {"hardware_id": "rig-9"},
    "channels": {
        "command": {"topic": "/joint_states", "joint": "surface_command", "field": "position"},
        "load": "unknown",
        "theta_u": {"topic": "/joint_states", "joint": "surface", "field": "position"},
        "theta_m": {"topic": "/joint_states", "joint": "motor", "field": "position"},
        "omega_m": {"topic": "/joint_states", "joint": "motor", "field": "velocity"},
        "i3eq": {"topic": "/joint_states", "joint": "motor", "field": "effort", "unit": "A"},
        "temperature": "unknown",
    },
}
#: The same rig with its current on a topic of its own, without a header: timed by when it
#: is received, it comes late and in bunches when the publisher stalls (here up to ~10 ms),
#: which the default gap (5 steps, 2.5 ms) would read as gaps.
RIG_MAP_FLOAT64 = {
    **RIG_MAP,
    "max_gap_s": 0.05,
    "channels": {
        **RIG_MAP["channels"],
        "i3eq": {"topic": "/motor/current", "field": "data", "unit": "A"},
    },
}


#: The node's windows (window_duration 0.4) as the import cuts them; and by excitation.
LENGTH_04 = {"by": "length", "seconds": 0.4}
EXCITATION = {"by": "excitation", "max_pause_s": 0.25, "settle_s": 0.1, "min_duration_s": 0.5}


def _rig_window():
    """The rig's 1 s chirp (the HF, noise-free)."""
    from ema_phm.domain.faults import NOMINAL
    from ema_phm.physics.commands import CommandSpec
    from ema_phm.simulator import real_ema

    return real_ema.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window


def _rig_tests(rest_s: float = 0.7):
    """The rig's 1 s chirp twice, each followed by `rest_s` held at its last sample.

    Stitched, not simulated: the second chirp starts from the first one's initial state, so
    the monitor model does not explain it; only the cutting and the fit are compared.
    """
    from types import SimpleNamespace

    w = _rig_window()
    hold = round(rest_s / (w.t[1] - w.t[0]))
    names = ("command", "theta_u", "theta_m", "omega_m", "i3eq")
    once = {c: np.concatenate([getattr(w, c), np.full(hold, getattr(w, c)[-1])]) for c in names}
    both = {c: np.concatenate([v, v]) for c, v in once.items()}
    n = both["command"].size
    return SimpleNamespace(n=n, t=np.arange(n) * (w.t[1] - w.t[0]), **both)


def _joints(w: Any, i: int, *, separate_current: bool) -> tuple[list[str], list, list, list]:
    """Sample i of `w` as the rig's JointState: names, positions, velocities, efforts.

    A `w` with a `marker` has a joint `test_active` whose position is the marker.
    """
    names = ["surface", "motor", "surface_command"]
    position = [float(w.theta_u[i]), float(w.theta_m[i]), float(w.command[i])]
    velocity = [0.0, float(w.omega_m[i]), 0.0]
    effort = [0.0, 0.0 if separate_current else float(w.i3eq[i]), 0.0]
    marker = getattr(w, "marker", None)
    if marker is not None:
        names.append("test_active")
        position.append(float(marker[i]))
        velocity.append(0.0)
        effort.append(0.0)
    return names, position, velocity, effort


def _recorded_bag(path: Path, start_ns: int, currents: list[tuple[int, float]], w: Any) -> Path:
    """The rig's stream as `ros2 bag record` would keep it (MCAP).

    Each JointState at its header stamp; each Float64 current at the time this process's
    recorder received it (`currents`; none: the current is the JointState's effort).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    joint_state = store.types["sensor_msgs/msg/JointState"]
    header_t, stamp_t = (
        store.types["std_msgs/msg/Header"],
        store.types["builtin_interfaces/msg/Time"],
    )
    float64 = store.types["std_msgs/msg/Float64"]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        js = writer.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        cur = writer.add_connection("/motor/current", "std_msgs/msg/Float64", typestore=store)
        rows: list[tuple[int, Any, Any]] = []
        for i in range(w.n):
            ns = start_ns + round(w.t[i] * 1e9)
            stamp = stamp_t(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            names, position, velocity, effort = _joints(w, i, separate_current=bool(currents))
            msg = joint_state(
                header=header_t(stamp=stamp, frame_id=""),
                name=names,
                position=np.array(position),
                velocity=np.array(velocity),
                effort=np.array(effort),
            )
            rows.append((ns, js, msg))
        rows += [(ns, cur, float64(data=v)) for ns, v in currents]
        for ns, conn, msg in sorted(rows, key=lambda r: r[0]):
            writer.write(conn, ns, store.serialize_cdr(msg, conn.msgtype))
    return path


def _offline_k(
    folder: Path, rig_map: dict, start_ns: int, currents: list, w: Any, windows: dict
) -> list[list[float]]:
    """The k of each window (the map's `windows`) of the recorded stream imported offline.

    Fitted in turn as the node fits them (`monitor.policy`: the first searched, the next
    tracked from it if the first is explained).
    """
    import dataclasses

    from ema_phm.diagnosis.isolation import isolate
    from ema_phm.diagnosis.isolation_settings import FitSettings
    from ema_phm.importing.channel_map import parse_channel_map
    from ema_phm.importing.importer import import_recordings
    from ema_phm.monitor.estimator import IsolationEstimator
    from ema_phm.monitor.policy import FitPolicy
    from ema_phm.physics.parameters import ActuatorParameters
    from ema_phm.telemetry.bags import read_window

    bag = _recorded_bag(folder / "recorded", start_ns, currents, w)
    cmap = parse_channel_map({**rig_map, "windows": windows}, where="m")
    report = import_recordings([bag], cmap, ActuatorParameters.default(), folder / "offline")
    # the provenance the live run_info gives its windows (the map's own)
    windows = [dataclasses.replace(read_window(p), meta={}) for p in sorted(report.written)]
    estimator = IsolationEstimator(
        FitSettings(seed=0, max_evaluations=100).isolate_options(None), isolate
    )
    policy = FitPolicy()
    return [[float(v) for v in policy.fit(w, estimator).result.k] for w in windows]


def _publish_window(node, publishers: dict, executor, w: Any) -> int:
    """The simulated stream `w`, each sample at its own time (about real time); its start [ns].

    A headerless current is timed by when it is received, so the samples are not sent in
    bursts: each waits for its time.
    """
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    separate_current = "/motor/current" in publishers
    start = node.get_clock().now().nanoseconds
    t0 = time.monotonic()
    for i in range(w.n):
        while time.monotonic() - t0 < w.t[i]:
            pass
        msg = JointState()
        ns = start + round(w.t[i] * 1e9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
        msg.name, msg.position, msg.velocity, msg.effort = _joints(
            w, i, separate_current=separate_current
        )
        publishers["/joint_states"].publish(msg)
        if separate_current:
            publishers["/motor/current"].publish(Float64(data=float(w.i3eq[i])))
        if i % 20 == 19:
            executor.spin_once(timeout_sec=0.0)
    return start


class _Recorder:
    """The rig's headerless current as a recorder hears it: (receive time [ns], value)."""

    def __init__(self, domain: int) -> None:
        import threading

        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Float64

        from ema_phm.ros.mapped_inputs import RIG_QOS

        self.heard: list[tuple[int, float]] = []
        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("recorder", context=self.ctx)
        self.node.create_subscription(Float64, "/motor/current", self._on_current, RIG_QOS)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def _on_current(self, msg, info) -> None:
        self.heard.append((int(info["received_timestamp"]), float(msg.data)))

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.thread.join(timeout=10)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def _run_rig(
    domain: int,
    folder: Path,
    node_hardware_id: str,
    rig_map: dict,
    w: Any = None,
    window_labels: list[str] | None = None,
) -> tuple[list, list[str], int, list[tuple[int, float]]]:
    """The monitor_node process fed the rig's stream `w`, until it published two results.

    `w` defaults to one 1 s chirp (two 0.4 s windows).  Returns its /ema/health, its
    messages, the stream's start [ns] and the current the recorder heard; the samples
    label of each /ema/window it published goes to `window_labels`.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64, Float64MultiArray

    from ema_phm.ros.common import OUTPUT_QOS

    w = _rig_window() if w is None else w
    (folder / "rig_map.yaml").write_text(yaml.safe_dump(rig_map), encoding="utf-8")
    params = [
        f"channel_map_file:={folder / 'rig_map.yaml'}",
        "window_duration:=0.4",
        f"hardware_id:={node_hardware_id}",
        # warmed up: a first fit that loads the kernels stalls the node long enough for a
        # 4 kHz stream of messages to overflow its queue (a gap: the next window is lost)
        "warm_up:=true",
        "max_evaluations:=100",
        "prognostics:=false",
    ]
    monitor = start_node("monitor_node", domain, *params)
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    rig = rclpy.create_node("rig", context=ctx)
    health: list[Float64MultiArray] = []
    said: list[str] = []
    rig.create_subscription(Float64MultiArray, "/ema/health", health.append, OUTPUT_QOS)
    if window_labels is not None:
        rig.create_subscription(
            Float64MultiArray,
            "/ema/window",
            lambda m: window_labels.append(m.layout.dim[0].label),
            OUTPUT_QOS,
        )
    rig.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda m: said.extend(s.message for s in m.status),
        OUTPUT_QOS,
    )
    publishers = {"/joint_states": rig.create_publisher(JointState, "/joint_states", 1000)}
    if rig_map["channels"]["i3eq"]["topic"] == "/motor/current":
        publishers["/motor/current"] = rig.create_publisher(Float64, "/motor/current", 1000)
    recorder = _Recorder(domain) if "/motor/current" in publishers else None
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rig)
    try:
        deadline = time.monotonic() + 90.0
        while time.monotonic() < deadline and any(
            rig.count_subscribers(topic) < 1 + (topic == "/motor/current") for topic in publishers
        ):
            executor.spin_once(timeout_sec=0.2)
        for topic in publishers:
            assert rig.count_subscribers(topic) == 1 + (topic == "/motor/current"), (
                f"monitor_node never subscribed to {topic}"
            )
        end = time.monotonic() + 1.0  # the match completes on both sides before sample 0
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
        start = _publish_window(rig, publishers, executor, w)
        deadline = time.monotonic() + (180.0 if node_hardware_id == "rig-9" else 8.0)
        while len(health) < 2 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.2)
            if health and node_hardware_id != "rig-9":
                break
        return health, said, start, recorder.heard if recorder else []
    finally:
        executor.shutdown()
        if recorder:
            recorder.close()
        rig.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, err = stop_node(monitor)
        assert code == 0, err


def test_the_monitor_fits_a_rigs_joint_states_as_the_import_does(ros_domain_id, tmp_path: Path):
    health, said, start, _ = _run_rig(ros_domain_id, tmp_path, "rig-9", RIG_MAP)
    quiet = {m for m in said if "STALE" not in m}
    assert len(health) == 2, f"not every window was fitted: {len(health)} of 2; {quiet}"
    live = [[float(v) for v in h.data[:8]] for h in health]
    # both from the same whole-nanosecond stamps; the phase of a near-zero eccentricity
    # turns the last rounding into 1e-8
    offline = _offline_k(tmp_path, RIG_MAP, start, [], _rig_window(), LENGTH_04)
    assert np.allclose(live, offline, rtol=0, atol=1e-6)


def test_the_monitor_cuts_a_rigs_excitation_segments_as_the_import_does(
    ros_domain_id, tmp_path: Path
):
    """A map with windows by excitation: live, each test the rig ran is one window, as offline.

    Two 1 s chirps, each followed by 0.7 s of rest: the two windows the import cuts from the
    recording, with the same span (the window times on /ema/health) and the same k, and
    their cycles 0 and 1 on /ema/window (what a replay of the node's recording numbers by).
    The node fits the first while the second streams in: with an input queue of 1000
    samples it lost some on a loaded machine (a gap ends a segment, live as offline):
    `RIG_QOS`.
    """
    from ema_phm.telemetry.wire import cycle_of_label

    rig_map = {**RIG_MAP, "windows": EXCITATION}
    w = _rig_tests(rest_s=0.7)
    labels: list[str] = []
    health, said, start, _ = _run_rig(ros_domain_id, tmp_path, "rig-9", rig_map, w, labels)
    quiet = {m for m in said if "STALE" not in m}
    assert len(health) == 2, f"not every segment was fitted: {len(health)} of 2; {quiet}"
    live = [[float(v) for v in h.data[:8]] for h in health]
    offline = _offline_k(tmp_path, RIG_MAP, start, [], w, EXCITATION)
    assert len(offline) == 2
    assert np.allclose(live, offline, rtol=0, atol=1e-6)
    spans = [_window_span(h) for h in health]
    assert spans[0][0] == 0.0 and all(1.0 < b - a < 1.3 for a, b in spans), spans
    assert spans[1][0] > spans[0][1] + 0.2, spans  # the rest between is in neither window
    # each fitted window names its cycle, so that the node's recording replays in order
    assert [cycle_of_label(label) for label in labels] == [0, 1], labels


@pytest.mark.parametrize("by", ["marker", "times"])
def test_the_monitor_cuts_a_rigs_marked_or_listed_tests_as_the_import_does(
    by, ros_domain_id, tmp_path: Path
):
    """Windows by marker (each run of the rig's `test_active`) or by times (listed), live.

    The rig marks the first 1.2 s of each of its two tests (1.7 s each), or the map lists
    them: the windows the import cuts from the recording, with the same span and k, numbered
    0 and 1 on /ema/window.
    """
    from ema_phm.telemetry.wire import cycle_of_label

    w = _rig_tests(rest_s=0.7)
    period = w.n // 2  # each test's samples
    w.marker = (np.arange(w.n) % period < 2400).astype(float)  # its first 1.2 s at 2 kHz
    second = float(w.t[period])
    expected = [(0.0, 1.1995), (second, second + 1.1995)]
    windows = (
        {
            "by": "marker",
            "marker": {"topic": "/joint_states", "joint": "test_active", "field": "position"},
        }
        if by == "marker"
        else {"by": "times", "times": [list(s) for s in expected]}
    )
    rig_map = {**RIG_MAP, "windows": windows}
    labels: list[str] = []
    health, said, start, _ = _run_rig(ros_domain_id, tmp_path, "rig-9", rig_map, w, labels)
    quiet = {m for m in said if "STALE" not in m}
    assert len(health) == 2, f"not every marked test was fitted: {len(health)} of 2; {quiet}"
    live = [[float(v) for v in h.data[:8]] for h in health]
    offline = _offline_k(tmp_path, RIG_MAP, start, [], w, windows)
    assert len(offline) == 2
    assert np.allclose(live, offline, rtol=0, atol=1e-6)
    spans = [_window_span(h) for h in health]
    assert np.allclose(spans, expected, atol=1e-3), spans  # the report's times: to 1 ms
    assert [cycle_of_label(label) for label in labels] == [0, 1], labels


def _window_span(health: Any) -> tuple[float, float]:
    from ema_phm.domain.health_layout import HEALTH_FIELDS

    return (
        float(health.data[HEALTH_FIELDS.index("window_t0")]),
        float(health.data[HEALTH_FIELDS.index("window_t1")]),
    )


def test_a_headerless_current_topic_is_timed_as_a_recorder_times_it(ros_domain_id, tmp_path: Path):
    """JointState + a Float64 current: every window fitted, each k the recorded bag's.

    The recorded bag is the one a recorder beside the node kept, imported offline.  The
    node and the recorder each time a current sample by when their middleware received it:
    the same bunches, microseconds apart, which a 100-evaluation fit of a healthy window
    turns into k apart by at most 0.012 and 0.030 in two runs on a 2-core machine and by
    0.0995 in a fresh-clone CI run (k6, eccentricity; the phase k7 aside: it has no meaning
    without an eccentricity): the bound below is twice that.
    """
    health, said, start, heard = _run_rig(ros_domain_id, tmp_path, "rig-9", RIG_MAP_FLOAT64)
    quiet = {m for m in said if "STALE" not in m}
    assert len(health) == 2, f"not every window was fitted: {len(health)} of 2; {quiet}"
    assert len(heard) == _rig_window().n, "the recorder missed current samples"
    live = np.array([[float(v) for v in h.data[:8]] for h in health])
    offline = np.array(
        _offline_k(tmp_path, RIG_MAP_FLOAT64, start, heard, _rig_window(), LENGTH_04)
    )
    apart = np.abs(live - offline)
    apart[:, 6] = 0.0
    assert apart.max() < 0.2, (live, offline)


def test_a_rig_of_another_hardware_id_is_not_judged(ros_domain_id, tmp_path: Path):
    health, said, _, _ = _run_rig(ros_domain_id, tmp_path, "ema-other", RIG_MAP)
    assert not health
    assert any("not the unit this monitor watches" in m and "rig-9" in m for m in said), said
