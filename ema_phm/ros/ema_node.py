"""ema_node: the "real" EMA.  Runs the high-fidelity model and publishes it.

Subscribes (with `command_topic` only: a rig commanded from outside)
  <command_topic>    trajectory_msgs/JointTrajectory (command_type trajectory) or
                     std_msgs/Float64MultiArray data[0] (command_type position): the position
                     commands followed instead of the command window (`command_inbox`)
Publishes
  /ema/telemetry     std_msgs/Float64MultiArray  batches of `samples_per_message` samples,
                     dim[0] ("samples {stream identity JSON}", n, n*C), dim[1] ("channels",
                     C, C), C = len(CHANNELS), rows in CHANNELS order (domain/window.py;
                     the last is the temperature [degC]); the identity is `hardware_id` and
                     `run_id`
  /ema/ground_truth  std_msgs/Float64MultiArray  the true k (one value per fault of
                     domain.faults, dim "k"); latched, published again whenever k changes
                     (at a window boundary)
  /ema/run_info      std_msgs/String             JSON window metadata, the stream identity and
                     ``stamp_origin_ns`` (the node's clock at start-up = t 0); latched
  /ema/telemetry_batch   ema_phm_msgs/TelemetryBatch   the same batches, one array per channel,
                     stamped stamp origin + t[0] (each TelemetrySample: origin + its t)
  /ema/telemetry_sample  ema_phm_msgs/TelemetrySample  every typed.SAMPLE_DECIMATION-th
                     sample (100 Hz at 2 kHz), one message each: the stream to plot
(names relative to the node's namespace: under `-r __ns:=/left` they are /left/ema/...)

The stream (`ema_phm.simulator.actuator_stream.ActuatorStream`) runs in a
dedicated thread, paced by `ema_phm.simulator.pacing.Pacer`: a message is
published once wall time reaches the time of its last sample (`realtime_factor`
0: as fast as possible).  Parameters come from `ema_node_parameters.ema_node_parameters()`,
checked at start-up.  The actuator simulated is the `actuator_file`'s (read at start-up;
'' = the packaged thesis actuator), the unit drawn or described by `unit` around it.
`k` may be changed while running; an accepted value takes
effect at the next window boundary and ground truth and run_info are republished then.
With `degradation` (a YAML file, `ema_phm.simulator.degradation`) each window is one
operating cycle whose k the file's laws give (held constant inside the window, changed at
its boundary like a set k, so ground truth and run_info follow each change); run_info then
also carries ``degradation``, ``degradation_file`` and ``cycle_hours``, as `ema-phm
simulate --windows` writes them, and `k` can be neither given nor set.
With `max_windows` n > 0 the node publishes n windows (and the closing boundary sample),
waits until every subscriber acknowledged them and sets `finished`; the executable then
exits with code 0.
"""

from __future__ import annotations

import sys
import threading
import time
import uuid
from typing import Any, Callable, Mapping

import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.subscription import MessageInfo
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory

from ..domain.faults import NOMINAL
from ..errors import ConfigError
from ..physics.actuator_file import load_actuator
from ..physics.commands import CommandSpec, LoadSpec, default_specs
from ..physics.parameters import ActuatorParameters
from ..simulator.actuator_stream import ActuatorStream
from ..simulator.command_inbox import CommandInbox, TrajectoryInbox
from ..simulator.degradation import Degradation
from ..simulator.pacing import Pacer
from ..telemetry.wire import (
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_BATCH_TOPIC,
    TELEMETRY_SAMPLE_TOPIC,
    TELEMETRY_TOPIC,
    StreamId,
    encode_ground_truth,
    encode_run_info,
    encode_telemetry,
)
from .common import LATCHED_QOS, TELEMETRY_QOS, RelativeTopics, spin_main, to_rclpy
from .ema_node_parameters import ema_node_parameters
from .parameters import declare_all
from .typed_messages import TelemetryBatch, TelemetrySample, telemetry_batch, telemetry_samples

NODE_NAME = "ema_node"
#: s to wait, after the last window, for the subscribers to acknowledge it (reliable QoS).
ACK_TIMEOUT_S = 10.0


def simulated_actuator(values: Mapping[str, Any]) -> ActuatorParameters | None:
    """The actuator of the `actuator_file` parameter (None: '', the packaged thesis actuator)."""
    path = str(values["actuator_file"]).strip()
    if not path:
        return None
    try:
        return load_actuator(path)
    except ConfigError as exc:
        raise ConfigError(f"actuator_file: {exc}") from None


def _command(values: Mapping[str, Any]) -> CommandSpec:
    """The position command the parameters describe (offset: config/commands.yaml's)."""
    base_command, _ = default_specs()
    return CommandSpec(
        kind=str(values["command_kind"]),
        amplitude=values["amplitude"],
        f0=values["f0"],
        f1=values["f1"],
        duration=values["duration"],
        offset=base_command.offset,
    )


def _k_and_degradation(values: Mapping[str, Any]) -> tuple[Any, Degradation | None]:
    """The k to start with and the degradation file's laws (None: k fixed)."""
    path = str(values["degradation"]).strip()
    degradation = Degradation.load(path) if path else None
    k = values["k"]
    if degradation is None:
        return k, None
    if not np.array_equal(np.asarray(k, dtype=np.float64), NOMINAL):  # the default itself
        raise ConfigError(
            f"give k or degradation, not both: degradation {path} sets k per cycle, "
            f"got k {list(k)}"
        )
    return degradation.k(0), degradation


def stream_from(
    values: Mapping[str, Any], command_at: Callable[[np.ndarray], np.ndarray] | None = None
) -> ActuatorStream:
    """The actuator stream the (checked) parameter values describe (`command_at`: from outside)."""
    k, degradation = _k_and_degradation(values)
    if command_at is not None and values["realtime_factor"] <= 0:
        raise ConfigError(
            f"command_topic {values['command_topic']} needs realtime_factor > 0: commands "
            f"arrive in wall time, got realtime_factor {values['realtime_factor']:g}"
        )
    return ActuatorStream(
        k,
        actuator=simulated_actuator(values),
        degradation=degradation,
        cycle_hours=values["cycle_hours"] or None,
        command=_command(values),
        load=LoadSpec(
            kind="constant",
            value=values["load"],
            spring=values["load_spring"],
            measured=not values["load_unmeasured"],
        ),
        seed=values["seed"],
        samples_per_message=values["samples_per_message"],
        noise=(values["noise_current"], values["noise_position"], values["noise_speed"]),
        max_windows=values["max_windows"],
        realtime_factor=values["realtime_factor"],
        unit=values["unit"],
        unit_seed=None if values["unit_seed"] < 0 else values["unit_seed"],
        temperature_c=values["temperature"],
        command_at=command_at,
    )


class EmaNode(RelativeTopics, Node):
    """The simulated actuator: its stream in a thread, telemetry + ground truth + run info out."""

    PARAMETERS = ema_node_parameters()

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        try:
            self._setup()
        except BaseException:
            Node.destroy_node(self)  # a bad parameter must not leave a half-built node behind
            raise

    def _setup(self) -> None:
        values = declare_all(self, self.PARAMETERS)
        self._pacer = Pacer(float(values["realtime_factor"]))
        self._command_type = str(values["command_type"])
        self.commands = _inbox(values)
        self.stream = stream_from(values, None if self.commands is None else self._command_at)
        # who this stream is (telemetry and run_info carry it) and when its t = 0 is on the
        # ROS clock (the typed messages' stamps are that origin plus each sample's t)
        self.stream_id = StreamId(
            str(values["hardware_id"]), str(values["run_id"]) or uuid.uuid4().hex[:12]
        )
        self.stamp_origin_ns = self.get_clock().now().nanoseconds
        self.sample_rate = self.stream.sample_rate
        self.samples_per_window = self.stream.samples_per_window
        self.wait_for_subscribers = int(values["wait_for_subscribers"])
        self._pub_telemetry = self.create_publisher(
            Float64MultiArray, TELEMETRY_TOPIC, TELEMETRY_QOS
        )
        self._pub_batch = self.create_publisher(
            TelemetryBatch, TELEMETRY_BATCH_TOPIC, TELEMETRY_QOS
        )
        self._pub_sample = self.create_publisher(
            TelemetrySample, TELEMETRY_SAMPLE_TOPIC, TELEMETRY_QOS
        )
        self._pub_truth = self.create_publisher(Float64MultiArray, GROUND_TRUTH_TOPIC, LATCHED_QOS)
        self._pub_info = self.create_publisher(String, RUN_INFO_TOPIC, LATCHED_QOS)
        self.messages_published = self.samples_published = self.windows_published = 0
        self.finished = threading.Event()  # set once max_windows windows are out and acked
        self._stop = threading.Event()
        self._publish_truth()
        if self.commands is not None:
            self._command_subscription = self._follow(str(values["command_topic"]))
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.context.on_shutdown(self._stop.set)
        self._thread = threading.Thread(target=self._run, name="ema_node-hf", daemon=True)
        self._thread.start()
        self.get_logger().info(_start_line(values, self.stream))

    @property
    def k(self) -> np.ndarray:
        """The fault vector the model currently runs with."""
        return self.stream.k

    @property
    def k_changes_applied(self) -> int:
        """How many k changes have taken effect."""
        return self.stream.k_changes_applied

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        try:
            self.PARAMETERS.validated(self.PARAMETERS.own(params))  # use_sim_time: rclpy's
            if any(p.name == "k" for p in params):
                self.stream.check_k_may_be_set()
        except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        for p in params:
            if p.name == "k":
                k = self.stream.request_k(list(p.value))
                self.get_logger().info(
                    f"new k {k.tolist()} accepted; applied at the next window boundary"
                )

    def run_info(self) -> dict[str, Any]:
        """The /ema/run_info object: the stream's, with its identity and stamp origin."""
        return {
            **self.stream.run_info(),
            "hardware_id": self.stream_id.hardware_id,
            "run_id": self.stream_id.run_id,
            "stamp_origin_ns": self.stamp_origin_ns,
        }

    def _publish_truth(self) -> None:
        self._pub_info.publish(String(data=encode_run_info(self.run_info())))
        self._pub_truth.publish(to_rclpy(encode_ground_truth(self.stream.k)))

    def _k_applied(self) -> None:
        self._publish_truth()
        self.get_logger().info(
            f"k = {self.stream.k.tolist()} from t = {self.stream.k_since_t:g} s"
        )

    def _run(self) -> None:
        try:
            if self._subscribers_matched():
                self._publish_stream()
        except Exception as exc:  # noqa: BLE001 - a dying context is normal at shutdown
            if not self._stop.is_set() and self.context.ok():
                self.get_logger().error(f"simulation stopped: {type(exc).__name__}: {exc}")

    def _subscribers_matched(self) -> bool:
        """Wait for `wait_for_subscribers` telemetry subscriptions; False if stopped first.

        On /ema/telemetry or on /ema/telemetry_batch (a monitor takes either form; one
        subscriber of both forms counts once).
        """
        while self._telemetry_subscriptions() < self.wait_for_subscribers:
            if self._stop.wait(0.01):
                return False
        return True

    def _telemetry_subscriptions(self) -> int:
        publishers = (self._pub_telemetry, self._pub_batch)
        return max(pub.get_subscription_count() for pub in publishers)

    def _follow(self, topic: str) -> Any:
        """Subscribe to the commands of `topic` in `command_type`'s form."""
        trajectory = self._command_type == "trajectory"
        return self.create_subscription(
            JointTrajectory if trajectory else Float64MultiArray,
            topic,
            self._on_trajectory if trajectory else self._on_command,
            10,
        )

    def _on_command(self, msg: Float64MultiArray, info: MessageInfo) -> None:
        """A set-point of `command_topic`: taken from its arrival on (a bad one is logged)."""
        assert isinstance(self.commands, CommandInbox)
        try:
            if not len(msg.data):
                raise ConfigError("a command message must hold at least one value, got none")
            self.commands.put(float(msg.data[0]), _arrival(info))
        except ConfigError as exc:
            self.get_logger().error(f"ignoring a command: {exc}")

    def _on_trajectory(self, msg: JointTrajectory, info: MessageInfo) -> None:
        """A trajectory of `command_topic` (its first joint): followed from its start time.

        A zero header stamp starts it on arrival, as a joint trajectory controller does; its
        joint names are not read.
        """
        assert isinstance(self.commands, TrajectoryInbox)
        arrived = _arrival(info)
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        begins = arrived
        if stamp_ns:  # the node's clock (ROS time) -> monotonic; a past start skips ahead
            begins = time.monotonic() + (stamp_ns - self.get_clock().now().nanoseconds) / 1e9
        try:
            points = msg.points
            if any(len(p.positions) == 0 for p in points):
                raise ConfigError("a trajectory point has no position")
            offsets = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in points]
            positions = [p.positions[0] for p in points]
            self.commands.put(begins, np.array(offsets), np.array(positions))
        except ConfigError as exc:
            self.get_logger().error(f"ignoring a trajectory: {exc}")

    def _command_at(self, t: np.ndarray) -> np.ndarray:
        """The commands held at the simulated times t (before the stream starts: the rest)."""
        assert self.commands is not None
        wall = self._pacer.wall_at(t)
        if wall is None:
            return np.full(np.shape(t), self.commands.start)
        return self.commands.at(wall)

    def _publish_stream(self) -> None:
        pacer = self._pacer
        while not self._stop.is_set():
            if self.commands is not None:  # simulate only once the commands up to then are in
                times = self.stream.next_times()
                if times is not None:
                    wait = pacer.delay(*times)
                    if wait > 0 and self._stop.wait(wait):
                        break
            message = self.stream.next_message()
            if message is None:
                break
            if message.k_changed:
                self._k_applied()
            delay = pacer.delay(float(message.rows[0, 0]), float(message.rows[-1, 0]))
            lag = pacer.first_lag()
            if lag is not None:
                self.get_logger().warning(
                    f"simulation runs {lag:.2f} s behind realtime_factor {pacer.realtime_factor:g}"
                )
            if delay > 0 and self._stop.wait(delay):
                break
            self._publish_telemetry(message.rows)
            if pacer.realtime_factor == 0:
                time.sleep(0)  # let the other threads of the process run
        if not self._stop.is_set():
            self._after_the_end()

    def _publish_telemetry(self, rows: np.ndarray) -> None:
        sid, origin = self.stream_id, self.stamp_origin_ns
        self._pub_telemetry.publish(to_rclpy(encode_telemetry(rows, sid)))
        self._pub_batch.publish(telemetry_batch(rows, origin, sid))
        for sample in telemetry_samples(rows, origin, sid):
            self._pub_sample.publish(sample)
        self.messages_published += 1
        self.samples_published += rows.shape[0]
        self.windows_published = self.stream.windows_complete

    def _after_the_end(self) -> None:
        """max_windows reached: wait until the subscribers have everything, then say finished.

        The executable (`common.spin_main`) exits when `finished` is set, so a launch file
        can react to the end (OnProcessExit).
        """
        unacked = [
            pub.topic_name
            for pub in (self._pub_telemetry, self._pub_truth, self._pub_info)
            if not pub.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S))
        ]
        if unacked:
            self.get_logger().warning(
                f"not every subscriber acknowledged {', '.join(unacked)} "
                f"within {ACK_TIMEOUT_S:g} s"
            )
        self.get_logger().info(
            f"published {self.windows_published} window(s) ({self.samples_published} "
            "samples); telemetry stopped (max_windows)"
        )
        self.finished.set()

    def destroy_node(self) -> None:
        """Stop and join the stream thread, then destroy the node."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        super().destroy_node()


def _start_line(values: Mapping[str, Any], s: ActuatorStream) -> str:
    """The log line that says what the simulated actuator runs."""
    c, follows = s.command, values["command_topic"]
    how = values["command_type"] + (
        f" ({values['command_interpolation']})" if values["command_type"] == "position" else ""
    )
    return (
        f"EMA running: k={s.k.tolist()}, {c.kind} {c.duration:g} s windows of "
        f"{s.samples_per_window} samples at {s.sample_rate:g} Hz, "
        f"{s.samples_per_message} samples/message, realtime_factor "
        f"{s.realtime_factor:g}"
        + (f", actuator {values['actuator_file']}" if values["actuator_file"] else "")
        + (f", stopping after {s.max_windows} window(s)" if s.max_windows else "")
        + (f", following the {how} commands of {follows}" if follows else "")
        + (
            f", k per cycle from {s.degradation.source} ({s.cycle_hours:g} h per cycle)"
            if s.degradation is not None
            else ""
        )
    )


def _inbox(values: Mapping[str, Any]) -> CommandInbox | TrajectoryInbox | None:
    """Where commands from outside wait (None: no `command_topic`, the command window)."""
    if not values["command_topic"]:
        return None
    rest = _command(values).offset
    if values["command_type"] == "trajectory":
        return TrajectoryInbox(start=rest)
    return CommandInbox(start=rest, mode=str(values["command_interpolation"]))


def _arrival(info: MessageInfo) -> float:
    """When a message arrived [s, time.monotonic]: the middleware's receive time.

    Not when its callback ran: the executor may have waited behind the simulation, and a
    burst of set-points would crowd into one instant.
    """
    now_mono, now_ns = time.monotonic(), time.time_ns()
    received = int(info.get("received_timestamp") or 0)
    age = (now_ns - received) / 1e9 if received > 0 else 0.0
    return now_mono - min(max(age, 0.0), 1.0)


def main(args: list[str] | None = None) -> int:
    """The `ema_node` executable."""
    return spin_main(EmaNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
