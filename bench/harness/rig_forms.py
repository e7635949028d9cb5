"""A window written as rigs record it: the foreign forms `ema-phm import` reads.

The tests, the guide (docs/your_recordings.md) and the import benchmark write ema_phm's own
windows in these forms, then import them back:

- `joint_states_bag`: a ROS 2 bag (MCAP or sqlite3) as a ros2_control rig records it:
  ``/joint_states`` (sensor_msgs/JointState: joints ``surface`` and ``motor``, position and
  velocity), ``/motor/current`` (std_msgs/Float64), ``/surface/command`` (std_msgs/Float64),
  ``/motor/temperature`` (sensor_msgs/Temperature), each stamped in its header;
- `table`: a CSV or Parquet file, one row per sample, the command in degrees and the motor
  speed in rpm (units a map converts);
- `JOINT_STATES_MAP` and `TABLE_MAP`: the channel maps that read them.
"""

# Heavy libraries are imported where used: `ema-phm --help` stays fast.
# ruff: noqa: PLC0415

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ema_phm.domain.window import Window

#: Log time of the first sample: a rig's wall clock, not zero.
START_NS = 1_780_000_000_000_000_000

JOINT_STATES_MAP: dict[str, Any] = {
    "version": 1,
    "identity": {"hardware_id": "rig-1", "run_id": "life-1"},
    "windows": {"by": "excitation"},
    "channels": {
        # Float64 has no header: its time is when the bag received it, 20 us late
        "command": {"topic": "/surface/command", "field": "data", "delay_s": 2.0e-5},
        "load": "unknown",
        "theta_u": {"topic": "/joint_states", "joint": "surface", "field": "position"},
        "theta_m": {"topic": "/joint_states", "joint": "motor", "field": "position"},
        "omega_m": {"topic": "/joint_states", "joint": "motor", "field": "velocity"},
        "i3eq": {"topic": "/motor/current", "field": "data", "unit": "A", "delay_s": 2.0e-5},
        "temperature": {"topic": "/motor/temperature", "field": "temperature"},
    },
}

TABLE_MAP: dict[str, Any] = {
    "version": 1,
    "identity": {"hardware_id": "rig-1", "run_id": "life-1"},
    "time": {"column": "time_s"},
    "windows": {"by": "excitation"},
    "channels": {
        "command": {"column": "command_deg", "unit": "deg"},
        "load": "unknown",
        "theta_u": {"column": "surface_rad"},
        "theta_m": {"column": "motor_rad"},
        "omega_m": {"column": "motor_rpm", "unit": "rpm"},
        "i3eq": {"column": "current_A", "unit": "A"},
        "temperature": {"column": "temperature_C", "unit": "degC"},
    },
}


def with_rest(w: Window, rest_s: float) -> Window:
    """`w` after `rest_s` of its first sample held: a rig standing still before its test.

    Under an unmeasured load that is not how the HF window itself starts (see `rig_copy`).
    Nothing is added after the window, where the actuator still moves.
    """
    rate = 1.0 / w.dt
    n = round(rest_s * rate)
    cols = {
        name: np.concatenate([np.full(n, getattr(w, name)[0]), getattr(w, name)])
        for name in ("command", "load", "theta_u", "theta_m", "omega_m", "i3eq", "temperature")
    }
    t = np.arange(cols["command"].size) / rate
    return Window(t=t, **cols, meta=dict(w.meta))


#: The rig's topics and their message types.
RIG_TOPICS = {
    "/joint_states": "sensor_msgs/msg/JointState",
    "/motor/current": "std_msgs/msg/Float64",
    "/surface/command": "std_msgs/msg/Float64",
    "/motor/temperature": "sensor_msgs/msg/Temperature",
}


def rig_messages(
    w: Window, *, jitter_s: float = 0.0, seed: int = 0
) -> Iterator[tuple[str, Any, int]]:
    """(topic, message, receive time [ns]) of each sample of `w`, as the rig publishes them.

    Header stamps carry `jitter_s` RMS; every message is received 20 us after its sample.
    The messages are rosbags' classes (rclpy's have the same fields).
    """
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    joint_state = store.types["sensor_msgs/msg/JointState"]
    temperature = store.types["sensor_msgs/msg/Temperature"]
    header_t = store.types["std_msgs/msg/Header"]
    stamp_t = store.types["builtin_interfaces/msg/Time"]
    float64 = store.types["std_msgs/msg/Float64"]
    rng = np.random.default_rng(seed)
    for i in range(w.n):
        ns = START_NS + round((w.t[i] + jitter_s * rng.standard_normal()) * 1e9)
        header = header_t(
            stamp=stamp_t(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=""
        )
        receive_ns = START_NS + round(w.t[i] * 1e9) + 20_000
        yield (
            "/joint_states",
            joint_state(
                header=header,
                name=["surface", "motor"],
                position=np.array([w.theta_u[i], w.theta_m[i]]),
                velocity=np.array([0.0, w.omega_m[i]]),
                effort=np.array([], dtype=np.float64),
            ),
            receive_ns,
        )
        yield "/motor/current", float64(data=float(w.i3eq[i])), receive_ns
        yield "/surface/command", float64(data=float(w.command[i])), receive_ns
        yield (
            "/motor/temperature",
            temperature(header=header, temperature=float(w.temperature[i]), variance=0.0),
            receive_ns,
        )


def joint_states_bag(
    path: Path, w: Window, *, storage: str = "mcap", jitter_s: float = 0.0, seed: int = 0
) -> Path:
    """Write `w` as a rig's bag (`rig_messages`), MCAP or sqlite3."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {
            topic: writer.add_connection(topic, kind, typestore=store)
            for topic, kind in RIG_TOPICS.items()
        }
        for topic, msg, receive_ns in rig_messages(w, jitter_s=jitter_s, seed=seed):
            writer.write(conns[topic], receive_ns, store.serialize_cdr(msg, RIG_TOPICS[topic]))
    return path


def table(path: Path, w: Window, extra: dict[str, np.ndarray] | None = None) -> Path:
    """Write `w` as a CSV or Parquet table (by the suffix), in the columns of `TABLE_MAP`.

    `extra`: more columns (e.g. phase currents), one value per sample.
    """
    import pyarrow as pa

    data = pa.table(
        {
            **(extra or {}),
            "time_s": w.t,
            "command_deg": np.degrees(w.command),
            "surface_rad": w.theta_u,
            "motor_rad": w.theta_m,
            "motor_rpm": w.omega_m * 60.0 / (2.0 * np.pi),
            "current_A": w.i3eq,
            "temperature_C": w.temperature,
        }
    )
    with path.open("wb") as f:  # a file object: pyarrow would read '%2F' in a path as '/'
        if path.suffix == ".csv":
            from pyarrow import csv

            csv.write_csv(data, f)
        else:
            from pyarrow import parquet

            parquet.write_table(data, f)
    return path


def rig_copy(native: Path, rig: Path, *, form: str = "bag", rest_s: float = 0.0) -> list[Path]:
    """Every one-window recording under `native` rewritten as a rig logged it, into `rig`.

    Names carry what a rig's log names would: ``baseline-B`` for a baseline (run_info
    ``purpose: baseline``), ``flight-CCC`` for cycle C; `form` is "bag" (`joint_states_bag`),
    "csv" or "parquet" (`table`).  Each log has `rest_s` of rest before the window (default
    none: an HF window starts untwisted with its unmeasured load already acting, so a held
    first sample before it is not a rig at rest under that load, and the monitor misfits it).
    Returns the paths written, in the order of the native recordings.
    """
    from ema_phm.telemetry.bags import read_window

    rig.mkdir(parents=True, exist_ok=True)
    out = []
    for bag in sorted(p.parent for p in native.rglob("metadata.yaml")):
        w = read_window(bag).without_truth()
        purpose, cycle = w.meta.get("purpose"), int(w.meta["cycle"])
        name = f"baseline-{cycle + 1}" if purpose == "baseline" else f"flight-{cycle:03d}"
        logged = with_rest(w, rest_s)
        if form == "bag":
            out.append(joint_states_bag(rig / name, logged))
        else:
            out.append(table(rig / f"{name}.{form}", logged))
    return out
