"""ema_node: the "real" EMA.  Runs the high-fidelity model without end and publishes it.

Publishes
  /ema/telemetry     std_msgs/Float64MultiArray  batches of `samples_per_message` samples,
                     dim[0] ("samples", n, 7n), dim[1] ("channels", 7, 7), rows in CHANNELS order
  /ema/ground_truth  std_msgs/Float64MultiArray  the true k (8 values, dim "k"); latched
  /ema/run_info      std_msgs/String             JSON window metadata; latched

The HF model (`HFStream`) runs in a dedicated thread, repeating the command
window; sample j is at t = j / sample_rate.  `realtime_factor` paces it
(1.0: wall clock; 2.0: twice as fast; 0.0: as fast as possible): a message is
published once wall time reaches the time of its last sample.  `max_windows` > 0
stops publishing after sample max_windows * N (N samples per window), so that
exactly that many aligned windows are out.

Every numeric parameter is checked against `ema_phm.limits` at start-up
(ConfigError naming it, its value and the allowed range).

`k` may be changed while running (`ros2 param set /ema_node k "[...]"`).  A bad
value is rejected with the FaultVectorError message.  An accepted value takes
effect at the next window boundary (so no window mixes two fault states);
ground truth and run_info are republished then.
"""
from __future__ import annotations

import json
import sys
import threading
import time
from typing import Any

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray, String

from .. import __version__
from ..physics.commands import CommandSpec, LoadSpec, default_specs
from ..errors import ConfigError
from ..physics.fault_vector import NOMINAL, validate
from ..physics.real_ema import HFStream
from ..limits import check
from .common import spin_main, GROUND_TRUTH_TOPIC, LATCHED_QOS, RUN_INFO_TOPIC, TELEMETRY_QOS, TELEMETRY_TOPIC, multiarray

NODE_NAME = "ema_node"


def defaults() -> dict[str, Any]:
    """Declared defaults (config/ema_node.yaml holds the same values; command and load
    come from config/commands.yaml)."""
    cmd, load = default_specs()
    return {
        "k": [float(v) for v in NOMINAL],
        "noise_current": 0.0,
        "noise_position": 0.0,
        "noise_speed": 0.0,
        "command_kind": cmd.kind,
        "amplitude": float(cmd.amplitude),
        "f0": float(cmd.f0),
        "f1": float(cmd.f1),
        "duration": float(cmd.duration),
        "load": float(load.value),
        "samples_per_message": 100,
        "realtime_factor": 1.0,
        "seed": 0,
        "max_windows": 0,
        "wait_for_subscribers": 0,
    }


_DESCRIPTIONS = {
    "k": "true fault vector k1..k8 in [0, 1] (changeable at run time; applied at the next window boundary)",
    "noise_current": "A RMS of white noise on I_3eq",
    "noise_position": "rad RMS of white noise on theta_u",
    "noise_speed": "rad/s RMS of white noise on omega_m",
    "command_kind": "position command: chirp | step | ramp | sine (repeated every window)",
    "amplitude": "rad at the user shaft (ramp: rad/s)",
    "f0": "Hz, chirp start / sine frequency",
    "f1": "Hz, chirp end frequency",
    "duration": "s, one window (the command period)",
    "load": "N*m at the user shaft, constant",
    "samples_per_message": "samples per /ema/telemetry message",
    "realtime_factor": "simulated seconds per wall second; 0 = as fast as possible",
    "seed": "seed of the measurement noise",
    "max_windows": "0 = publish forever; n > 0 = stop after n complete windows",
    "wait_for_subscribers": "hold the first telemetry until this many subscribers matched (0 = don't wait)",
}


#: Numeric parameters and their entry in ema_phm.limits.LIMITS.
_LIMIT_OF = {
    "noise_current": "noise_current", "noise_position": "noise_position", "noise_speed": "noise_speed",
    "amplitude": "amplitude", "f0": "frequency", "f1": "frequency", "duration": "duration", "load": "load",
    "samples_per_message": "samples_per_message", "realtime_factor": "realtime_factor", "seed": "seed",
    "max_windows": "max_windows", "wait_for_subscribers": "wait_for_subscribers",
}


def checked(values: dict[str, Any]) -> dict[str, float | int]:
    """The numeric parameters of `values`, each checked against its LIMITS entry (ConfigError naming
    the parameter, the value and the allowed range otherwise)."""
    return {name: check(limit, values[name], label=name) for name, limit in _LIMIT_OF.items() if name in values}


class EmaNode(Node):
    """The simulated actuator: HF model in a thread, telemetry + ground truth + run info out."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        try:
            self._setup()
        except BaseException:
            Node.destroy_node(self)   # a bad parameter must not leave a half-built node behind
            raise

    def _setup(self) -> None:
        d = defaults()
        for name, value in d.items():
            desc = ParameterDescriptor(description=_DESCRIPTIONS[name], read_only=(name != "k"))
            if name == "k":
                desc.type = ParameterType.PARAMETER_DOUBLE_ARRAY
            self.declare_parameter(name, value, desc)
        p = {name: self.get_parameter(name).value for name in d}
        p.update(checked(p))

        self.samples_per_message = int(p["samples_per_message"])
        self.realtime_factor = float(p["realtime_factor"])
        self.max_windows = int(p["max_windows"])
        self.wait_for_subscribers = int(p["wait_for_subscribers"])
        self.seed = int(p["seed"])
        base_cmd, _ = default_specs()
        self.command = CommandSpec(kind=str(p["command_kind"]), amplitude=float(p["amplitude"]), f0=float(p["f0"]),
                                   f1=float(p["f1"]), duration=float(p["duration"]), offset=base_cmd.offset)
        self.load = LoadSpec(kind="constant", value=float(p["load"]))
        self.noise = (float(p["noise_current"]), float(p["noise_position"]), float(p["noise_speed"]))
        self._stream = HFStream(list(p["k"]), command=self.command, load=self.load, seed=self.seed,
                                noise_current=self.noise[0], noise_position=self.noise[1],
                                noise_speed=self.noise[2])
        self.sample_rate = float(self._stream.params["acquisition"]["sample_rate"])
        self.samples_per_window = int(self._stream.samples_per_window)
        if self.samples_per_window < 2:
            raise ConfigError(f"duration {self.command.duration} s holds fewer than 2 samples at {self.sample_rate:g} Hz")

        self._pub_telemetry = self.create_publisher(Float64MultiArray, TELEMETRY_TOPIC, TELEMETRY_QOS)
        self._pub_truth = self.create_publisher(Float64MultiArray, GROUND_TRUTH_TOPIC, LATCHED_QOS)
        self._pub_info = self.create_publisher(String, RUN_INFO_TOPIC, LATCHED_QOS)

        self._lock = threading.Lock()
        self._pending_k: np.ndarray | None = None
        self._k_since_j = 0
        self._stop = threading.Event()
        #: Counters (read by tests and benches).
        self.messages_published = 0
        self.samples_published = 0
        self.windows_published = 0
        self.k_changes_applied = 0
        self.finished = threading.Event()   # set once max_windows windows are out
        self._publish_truth()

        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.context.on_shutdown(self._stop.set)
        self._thread = threading.Thread(target=self._run, name="ema_node-hf", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"EMA running: k={self._stream.k.tolist()}, {self.command.kind} "
            f"{self.command.duration:g} s windows of {self.samples_per_window} samples at {self.sample_rate:g} Hz, "
            f"{self.samples_per_message} samples/message, realtime_factor {self.realtime_factor:g}"
            + (f", stopping after {self.max_windows} window(s)" if self.max_windows else ""))

    # ----------------------------------------------------------------- parameters
    def _validate_parameters(self, params: list[Any]) -> SetParametersResult:
        for prm in params:
            if prm.name == "k":
                try:
                    validate(list(prm.value) if prm.value is not None else None)
                except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
                    return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Any]) -> None:
        for prm in params:
            if prm.name == "k":
                k = validate(list(prm.value))
                with self._lock:
                    self._pending_k = k
                self.get_logger().info(f"new k {k.tolist()} accepted; applied at the next window boundary")

    # ------------------------------------------------------------------- outputs
    def run_info(self) -> dict[str, Any]:
        """The JSON published on /ema/run_info."""
        return {
            "source": "ema_phm.ros.ema_node",
            "version": __version__,
            "sample_rate": self.sample_rate,
            "window_duration": self.samples_per_window / self.sample_rate,
            "samples_per_window": self.samples_per_window,
            "samples_per_message": self.samples_per_message,
            "command": self.command.as_dict(),
            "load": self.load.as_dict(),
            "seed": self.seed,
            "noise_current": self.noise[0],
            "noise_position": self.noise[1],
            "noise_speed": self.noise[2],
            "realtime_factor": self.realtime_factor,
            "max_windows": self.max_windows,
            "k_true": [float(v) for v in self._stream.k],
            "k_since_t": self._k_since_j / self.sample_rate,
        }

    def _publish_truth(self) -> None:
        self._pub_info.publish(String(data=json.dumps(self.run_info())))
        self._pub_truth.publish(multiarray(self._stream.k, ["k"]))

    def _apply_pending(self) -> None:
        """Apply a pending k now (the caller is at a window boundary or past the last window)."""
        with self._lock:
            k, self._pending_k = self._pending_k, None
        if k is None:
            return
        self._stream.set_k(k)
        self._k_since_j = max(self._stream.j, 0)
        self.k_changes_applied += 1
        self._publish_truth()
        self.get_logger().info(f"k = {k.tolist()} from t = {self._k_since_j / self.sample_rate:g} s")

    def _produce(self, n: int) -> np.ndarray:
        """The next n samples; a pending k takes effect exactly at a window boundary inside them."""
        parts = []
        big_n = self.samples_per_window
        while n > 0:
            j = self._stream.j
            if self._pending_k is not None and (j < 0 or j % big_n == 0):
                self._apply_pending()
            chunk = n
            if self._pending_k is not None and j >= 0:
                chunk = min(chunk, big_n - j % big_n)   # stop on the boundary, change k there
            parts.append(self._stream.advance(chunk))
            n -= chunk
        return parts[0] if len(parts) == 1 else np.vstack(parts)

    def _run(self) -> None:
        try:
            self._loop()
        except Exception as exc:  # noqa: BLE001 - a dying context is normal at shutdown
            if not self._stop.is_set() and self.context.ok():
                self.get_logger().error(f"simulation stopped: {type(exc).__name__}: {exc}")

    def _loop(self) -> None:
        while self.wait_for_subscribers and self._pub_telemetry.get_subscription_count() < self.wait_for_subscribers:
            if self._stop.wait(0.01):
                return
        big_n = self.samples_per_window
        total = self.max_windows * big_n + 1 if self.max_windows else None
        rf = self.realtime_factor
        wall0 = t_sim0 = None
        behind_warned = False
        while not self._stop.is_set():
            nxt = self._stream.j + 1
            if total is not None and nxt >= total:
                break
            n = self.samples_per_message if total is None else min(self.samples_per_message, total - nxt)
            rows = self._produce(n)
            if rf > 0:
                now = time.monotonic()
                if wall0 is None:
                    wall0, t_sim0 = now, float(rows[0, 0])
                target = wall0 + (float(rows[-1, 0]) - t_sim0) / rf
                if target > now:
                    if self._stop.wait(target - now):
                        break
                elif now - target > 1.0:   # cannot keep up: re-anchor instead of bursting
                    if not behind_warned:
                        self.get_logger().warning(f"simulation runs {now - target:.2f} s behind realtime_factor {rf:g}")
                        behind_warned = True
                    wall0, t_sim0 = now, float(rows[-1, 0])
            self._pub_telemetry.publish(multiarray(rows, ["samples", "channels"]))
            self.messages_published += 1
            self.samples_published += rows.shape[0]
            self.windows_published = self._stream.j // big_n
            if rf == 0:
                time.sleep(0)   # let the other threads of the process run
        if self._stop.is_set():
            return
        self.finished.set()
        self.get_logger().info(f"published {self.windows_published} window(s) ({self.samples_published} samples); "
                               "telemetry stopped (max_windows)")
        while not self._stop.wait(0.05):   # still honour k changes (ground truth) after the end
            if self._pending_k is not None:
                self._apply_pending()

    @property
    def k(self) -> np.ndarray:
        """The fault vector the model currently runs with."""
        return self._stream.k.copy()

    def destroy_node(self) -> None:
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return spin_main(EmaNode, "ema_node", args)


if __name__ == "__main__":
    sys.exit(main())
