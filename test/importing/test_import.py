"""`import_recordings`: a window written in a rig's forms comes back as it was.

Round trips through a JointState bag (MCAP and sqlite3), CSV and Parquet; what real logs
have (jitter, a faster channel, a gap); the derived channels; the windowing rules; identity;
and that a failure or a second import changes nothing.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from bench.harness import rig_forms
from ema_phm.domain.faults import NOMINAL, k_with
from ema_phm.domain.window import Window
from ema_phm.errors import BagError, ConfigError
from ema_phm.importing import derive
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.importer import import_recordings, path_name
from ema_phm.importing.sources import Series
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf
from ema_phm.telemetry.bags import read_window

ACTUATOR = ActuatorParameters.default()
CHANNELS = ("command", "theta_u", "theta_m", "omega_m", "i3eq", "temperature")


@pytest.fixture(scope="module")
def rig_window() -> Window:
    """A 1 s chirp after 0.5 s of rest, the temperature measured."""
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window.without_truth()
    w = dataclasses.replace(w, temperature=np.full(w.n, 31.5))
    return rig_forms.with_rest(w, 0.5)


def _import(sources, cmap_data, out: Path, **kw):
    cmap = parse_channel_map(cmap_data, where="map.yaml")
    return import_recordings([Path(s) for s in sources], cmap, ACTUATOR, out, **kw)


def _largest_error(got: Window, source: Window) -> dict[str, float]:
    start = round(got.meta["source_start_s"] / got.dt)
    return {
        c: float(np.max(np.abs(getattr(got, c) - getattr(source, c)[start : start + got.n])))
        for c in CHANNELS
    }


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_joint_state_bag_comes_back_sample_for_sample(storage, rig_window, tmp_path):
    bag = rig_forms.joint_states_bag(tmp_path / "rig", rig_window, storage=storage)
    report = _import([bag], rig_forms.JOINT_STATES_MAP, tmp_path / "out")
    assert len(report.written) == 1
    got = read_window(report.written[0]).validated()
    # the excitation (1 s) from 0.1 s before it starts
    assert got.duration == pytest.approx(1.1, abs=2 * got.dt)
    assert got.meta["source_start_s"] == pytest.approx(0.4, abs=got.dt)
    for channel, err in _largest_error(got, rig_window).items():
        assert err < 1e-9 * max(1.0, float(np.max(np.abs(getattr(rig_window, channel))))), channel
    assert np.isnan(got.load).all()
    assert got.meta["hardware_id"] == "rig-1" and got.meta["cycle"] == 0
    assert got.meta["channels"]["load"] == "unknown"


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_comes_back_with_its_units_converted(suffix, rig_window, tmp_path):
    path = rig_forms.table(tmp_path / f"rig{suffix}", rig_window)
    report = _import([path], rig_forms.TABLE_MAP, tmp_path / "out")
    got = read_window(report.written[0])
    for channel, err in _largest_error(got, rig_window).items():
        scale = max(1.0, float(np.max(np.abs(getattr(rig_window, channel)))))
        assert err < 1e-9 * scale, channel


def test_jittered_stamps_cost_little(rig_window, tmp_path):
    """Header stamps 20 us RMS off the true sample times (4 % of a step)."""
    bag = rig_forms.joint_states_bag(tmp_path / "rig", rig_window, jitter_s=2e-5, seed=3)
    got = read_window(_import([bag], rig_forms.JOINT_STATES_MAP, tmp_path / "out").written[0])
    err = _largest_error(got, rig_window)
    span = float(np.ptp(rig_window.theta_u))
    assert 0 < err["theta_u"] < 0.1 * span


def test_a_faster_channel_is_low_passed_before_it_is_sampled(tmp_path):
    """A 3 kHz tone at 20 kHz would alias to 1 kHz on the 2 kHz grid: it is removed."""
    rate = 20_000.0
    t = np.arange(0, 2.0, 1 / rate)
    slow = 0.1 * np.sin(2 * np.pi * 5 * t)
    table = _table_from(tmp_path / "fast.csv", t, slow + 0.05 * np.sin(2 * np.pi * 3000 * t))
    m = _table_map(by={"by": "length", "seconds": 1.0})
    got = read_window(_import([table], m, tmp_path / "out").written[0])
    truth = 0.1 * np.sin(2 * np.pi * 5 * got.t)
    middle = slice(100, -100)  # away from the filter's edges
    assert np.max(np.abs(got.theta_u[middle] - truth[middle])) < 0.005


def test_a_gap_splits_the_recording_and_no_window_spans_it(rig_window, tmp_path):
    t = np.arange(0, 6.0, 1 / 2000.0)
    keep = (t < 2.5) | (t > 2.6)
    table = _table_from(tmp_path / "gappy.csv", t[keep], 0.01 * np.sin(t[keep]))
    report = _import([table], _table_map(by={"by": "length", "seconds": 1.0}), tmp_path / "out")
    (src,) = report.sources
    assert src.stretches == 2
    assert src.seconds_in_gaps == pytest.approx(0.1, abs=0.002)
    assert src.windows == 2 + 3  # whole seconds in 0-2.5 s and in 2.6-6 s
    for path in report.written:
        w = read_window(path)
        start = w.meta["source_start_s"]
        assert start + w.duration < 2.5 or start > 2.6


def test_windows_by_a_time_list_count_what_was_not_recorded(tmp_path):
    t = np.arange(0, 3.0, 1 / 2000.0)
    table = _table_from(tmp_path / "rig.csv", t, 0.01 * np.sin(t))
    rule = {"by": "times", "times": [[0.5, 1.5], [2.5, 3.5]]}
    report = _import([table], _table_map(by=rule), tmp_path / "out")
    assert report.sources[0].windows == 1
    assert report.sources[0].windows_dropped == 1


def test_windows_by_a_marker_column(tmp_path):
    t = np.arange(0, 4.0, 1 / 2000.0)
    marker = ((t > 1.0) & (t < 2.0)) | ((t > 3.0) & (t < 3.2))
    table = _table_from(tmp_path / "rig.csv", t, 0.01 * np.sin(t), bit_active=marker.astype(float))
    rule = {"by": "marker", "marker": {"column": "bit_active"}, "min_duration_s": 0.5}
    report = _import([table], _table_map(by=rule), tmp_path / "out")
    (path,) = report.written
    w = read_window(path)
    assert w.meta["source_start_s"] == pytest.approx(1.0, abs=1e-3)
    assert w.duration == pytest.approx(1.0, abs=2e-3)


def test_derived_motor_angle_and_speed(rig_window, tmp_path):
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["channels"]["theta_m"] = {"derive": "through_gear"}
    m["channels"]["omega_m"] = {"derive": "rate_of_theta_m"}
    path = rig_forms.table(tmp_path / "rig.csv", rig_window)
    got = read_window(_import([path], m, tmp_path / "out").written[0])
    start = round(got.meta["source_start_s"] / got.dt)
    theta_u = rig_window.theta_u[start : start + got.n]
    assert np.allclose(got.theta_m, theta_u / ACTUATOR.mechanics.gear_ratio)
    assert np.allclose(got.omega_m, np.gradient(got.theta_m, got.dt))
    assert "no motor encoder" in got.meta["channels"]["theta_m"]


def test_park_q_of_phase_currents_is_the_filtered_q_current():
    rate, pole_pairs = 40_000.0, ACTUATOR.motor.pole_pairs
    t = np.arange(0, 0.2, 1 / rate)
    theta_m = 300.0 * t  # rad, the motor turning at 300 rad/s
    theta_e = pole_pairs * theta_m
    iq = 2.0 + 0.5 * np.sin(2 * np.pi * 20 * t)
    phases = tuple(
        Series(t, -iq * np.sin(theta_e - k * 2 * math.pi / 3)) for k in (0, 1, -1)
    )  # id = 0: the inverse (amplitude-invariant) Park transform
    got = derive.park_q(phases, derive.electrical_angle(Series(t, theta_m), ACTUATOR, 0.0))
    assert np.allclose(got.v, iq, atol=1e-12)
    filtered = derive.acquisition_filtered(got, ACTUATOR)
    assert filtered.v[0] == pytest.approx(iq[0])  # starts at rest on the first value
    assert np.max(np.abs(filtered.v - iq)) < 0.05  # 20 Hz passes the 1 kHz filter


def test_phase_currents_too_slow_for_the_acquisition_filter_are_refused():
    t = np.arange(0, 0.1, 1 / 1500.0)
    with pytest.raises(ConfigError, match="record them faster than 2000 Hz"):
        derive.acquisition_filtered(Series(t, np.ones_like(t)), ACTUATOR)


def test_a_drive_iq_in_the_power_invariant_convention_is_rescaled(rig_window, tmp_path):
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["channels"]["i3eq"]["iq_convention"] = "power"
    path = rig_forms.table(tmp_path / "rig.csv", rig_window)
    got = read_window(_import([path], m, tmp_path / "out").written[0])
    start = round(got.meta["source_start_s"] / got.dt)
    expected = rig_window.i3eq[start : start + got.n] * math.sqrt(2 / 3)
    assert np.allclose(got.i3eq, expected)


def test_identity_from_file_names_and_hostile_ids_never_reach_the_path(rig_window, tmp_path):
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["identity"] = {"from_name": r"^(?P<run_id>.+)__c(?P<cycle>\d+)\.csv$"}
    path = rig_forms.table(tmp_path / "..%2F..%2Fetc <b>x<b>__c7.csv", rig_window)
    hostile = "../../etc/<b>x</b>"
    (written,) = _import([path], m, tmp_path / "out", overrides={"hardware_id": hostile}).written
    assert Path(written).resolve().is_relative_to((tmp_path / "out").resolve())
    got = read_window(written)
    assert got.meta["hardware_id"] == hostile
    assert got.meta["run_id"] == "..%2F..%2Fetc <b>x<b>"
    assert got.meta["cycle"] == 7
    assert Path(written).parent.parent.name == path_name(hostile)
    for bad in ("..", ".", "a/b", "", ".hidden"):
        safe = path_name(bad)
        assert "/" not in safe and not safe.startswith(".") and safe


def test_a_cycle_from_the_name_needs_one_window_per_file(tmp_path):
    t = np.arange(0, 3.0, 1 / 2000.0)
    _table_from(tmp_path / "u1_c3.csv", t, 0.01 * np.sin(t))
    m = _table_map(by={"by": "length", "seconds": 1.0})
    m["identity"] = {"from_name": r"(?P<hardware_id>u\d)_c(?P<cycle>\d+)"}
    with pytest.raises(ConfigError, match="gives cycle 3 but it holds 2 windows"):
        _import([tmp_path / "u1_c3.csv"], m, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_importing_twice_changes_nothing_and_a_conflict_changes_nothing(rig_window, tmp_path):
    path = rig_forms.table(tmp_path / "rig.csv", rig_window)
    out = tmp_path / "out"
    first = _import([path], rig_forms.TABLE_MAP, out)
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    again = _import([path], rig_forms.TABLE_MAP, out)
    assert again.written == [] and again.unchanged == first.written
    other = dataclasses.replace(rig_window, i3eq=rig_window.i3eq + 0.1)
    rig_forms.table(tmp_path / "other.csv", other)
    with pytest.raises(ConfigError, match="already exists with other content"):
        _import([tmp_path / "other.csv"], rig_forms.TABLE_MAP, out)
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before


@pytest.mark.parametrize(
    ("change", "error", "says"),
    [
        ({"theta_u": {"topic": "/surface/angle"}}, BagError, "has no topic /surface/angle"),
        ({"theta_u": {"topic": "/joint_states", "joint": "flap"}}, BagError, "joint 'flap'"),
        ({"theta_u": {"topic": "/joint_states", "field": "angle"}}, BagError, "no field 'angle'"),
        ({"theta_u": {"topic": "/joint_states", "field": "name", "index": 0}}, BagError, "str"),
        ({"theta_u": {"column": "surface_rad"}}, ConfigError, "names a table column"),
    ],
    ids=["topic", "joint", "field", "type", "column"],
)
def test_a_bag_without_what_the_map_names_is_one_line(change, error, says, rig_window, tmp_path):
    bag = rig_forms.joint_states_bag(tmp_path / "rig", rig_window)
    m = copy.deepcopy(rig_forms.JOINT_STATES_MAP)
    m["channels"].update(change)
    with pytest.raises(error, match=says) as err:
        _import([bag], m, tmp_path / "out")
    assert "\n" not in str(err.value)
    assert not (tmp_path / "out").exists()


def test_a_table_with_a_missing_or_text_column_or_time_going_back_is_one_line(tmp_path):
    t = np.arange(0, 1.0, 1 / 2000.0)
    path = _table_from(tmp_path / "rig.csv", t, 0.01 * t)
    m = _table_map(by={"by": "length", "seconds": 0.5})
    m["channels"]["theta_u"] = {"column": "surface"}
    with pytest.raises(ConfigError, match="has no column 'surface'"):
        _import([path], m, tmp_path / "out")
    text = path.read_text(encoding="utf-8").replace("\n0.0005,", "\nlate,", 1)
    (tmp_path / "text.csv").write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="column 'time_s' holds string"):
        _import([tmp_path / "text.csv"], _table_map(by={"by": "length"}), tmp_path / "out")
    back = np.concatenate([t[:10], t[9:8:-1], t[11:]])
    _table_from(tmp_path / "back.csv", back, 0.01 * back)
    with pytest.raises(ConfigError, match="time column 'time_s' does not increase at row 10"):
        _import([tmp_path / "back.csv"], _table_map(by={"by": "length"}), tmp_path / "out")


def test_a_source_that_is_neither_bag_nor_table_is_named(tmp_path):
    (tmp_path / "log.txt").write_text("x", encoding="utf-8")
    with pytest.raises(ConfigError, match="neither a ROS 2 bag"):
        _import([tmp_path / "log.txt"], rig_forms.TABLE_MAP, tmp_path / "out")


# -- helpers -----------------------------------------------------------------------------


def _table_from(path: Path, t: np.ndarray, theta_u: np.ndarray, **extra: np.ndarray) -> Path:
    """A CSV with the rig columns of `rig_forms.TABLE_MAP` around a user angle `theta_u`."""
    import pyarrow as pa
    from pyarrow import csv

    theta_m = theta_u / ACTUATOR.mechanics.gear_ratio
    columns = {
        "time_s": t,
        "command_deg": np.degrees(theta_u),
        "surface_rad": theta_u,
        "motor_rad": theta_m,
        # a repeated time (the step-back case) must not divide by zero
        "motor_rpm": np.gradient(theta_m) / np.maximum(np.gradient(t), 1e-9) * 60 / (2 * math.pi),
        "current_A": 0.5 + 0.0 * t,
        "temperature_C": 25.0 + 0.0 * t,
        **extra,
    }
    csv.write_csv(pa.table(columns), path)
    return path


def _table_map(*, by: dict) -> dict:
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = by
    return m


INTERFACE_VALUE = "string[] interface_names\nfloat64[] values\n"
DYNAMIC_JOINT_STATE = (
    "std_msgs/Header header\nstring[] joint_names\n"
    "control_msgs/InterfaceValue[] interface_values\n"
)


def test_a_dynamic_joint_state_bag_reads_through_the_maps_own_message_types(tmp_path):
    """control_msgs is not in the Kilted store: the map gives its .msg files."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    (tmp_path / "InterfaceValue.msg").write_text(INTERFACE_VALUE, encoding="utf-8")
    (tmp_path / "DynamicJointState.msg").write_text(DYNAMIC_JOINT_STATE, encoding="utf-8")
    store = get_typestore(Stores.ROS2_KILTED)
    store.register(get_types_from_msg(INTERFACE_VALUE, "control_msgs/msg/InterfaceValue"))
    store.register(get_types_from_msg(DYNAMIC_JOINT_STATE, "control_msgs/msg/DynamicJointState"))
    djs = store.types["control_msgs/msg/DynamicJointState"]
    value_t = store.types["control_msgs/msg/InterfaceValue"]
    header_t, stamp_t = (
        store.types["std_msgs/msg/Header"],
        store.types["builtin_interfaces/msg/Time"],
    )
    t = np.arange(0, 1.5, 1 / 2000.0)
    angle = 0.01 * np.sin(2 * np.pi * t)
    with Writer(tmp_path / "rig", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/dynamic_joint_states", djs.__msgtype__, typestore=store)
        for i, ti in enumerate(t):
            ns = rig_forms.START_NS + round(ti * 1e9)
            motor = angle[i] / ACTUATOR.mechanics.gear_ratio
            msg = djs(
                header=header_t(stamp=stamp_t(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""),
                joint_names=["surface", "motor"],
                interface_values=[
                    value_t(
                        interface_names=["position", "command"],
                        values=np.array([angle[i], angle[i]]),
                    ),
                    value_t(
                        interface_names=["position", "velocity", "current"],
                        values=np.array([motor, 0.0, 0.5]),
                    ),
                ],
            )
            writer.write(conn, ns, store.serialize_cdr(msg, djs.__msgtype__))

    def dyn(joint: str, interface: str, **kw) -> dict:
        return {"topic": "/dynamic_joint_states", "joint": joint, "interface": interface, **kw}

    m = {
        "version": 1,
        "identity": {"hardware_id": "rig-2"},
        "msg_types": {
            "control_msgs/msg/InterfaceValue": str(tmp_path / "InterfaceValue.msg"),
            "control_msgs/msg/DynamicJointState": str(tmp_path / "DynamicJointState.msg"),
        },
        "windows": {"by": "length", "seconds": 1.0},
        "channels": {
            "command": dyn("surface", "command"),
            "load": "unknown",
            "theta_u": dyn("surface", "position"),
            "theta_m": dyn("motor", "position"),
            "omega_m": {"derive": "rate_of_theta_m"},
            "i3eq": dyn("motor", "current", unit="A"),
            "temperature": "unknown",
        },
    }
    (written,) = _import([tmp_path / "rig"], m, tmp_path / "out").written
    got = read_window(written)
    assert np.allclose(got.theta_u, angle[: got.n]) and np.allclose(got.i3eq, 0.5)
    m["channels"]["i3eq"] = dyn("motor", "voltage")
    with pytest.raises(BagError, match="interface 'voltage' is not in"):
        _import([tmp_path / "rig"], m, tmp_path / "out2")


def test_park_q_of_the_hfs_phase_currents_is_its_acquired_current():
    """The HF's phase currents at 20 kHz, through park_q and the filter: its own I_3eq.

    The HF filters at its 1 us step, the import at the 20 kHz samples, where the hysteresis
    ripple aliases: measured 2.3 % RMS apart on this short circuit window.
    """
    fast = ACTUATOR.with_values({"acquisition.sample_rate": 20000.0})
    res = hf.simulate(
        k_with(short_circuit_b=0.4), actuator=fast, command=CommandSpec(duration=0.5)
    )
    w, ph = res.window, res.phase_currents
    phases = tuple(Series(w.t, ph[:, j]) for j in range(3))
    angle = derive.electrical_angle(Series(w.t, w.theta_m), ACTUATOR, 0.0)
    got = derive.acquisition_filtered(derive.park_q(phases, angle), ACTUATOR).v
    rms = float(np.sqrt(np.mean(w.i3eq**2)))
    assert float(np.sqrt(np.mean((got - w.i3eq) ** 2))) < 0.05 * rms


def test_a_target_that_cannot_be_written_leaves_nothing_written(rig_window, tmp_path):
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["identity"] = {"from_name": r"^(?P<hardware_id>.*)\.csv$"}
    a = rig_forms.table(tmp_path / "unitA.csv", rig_window)
    b = rig_forms.table(tmp_path / "unitB.csv", rig_window)
    out = tmp_path / "out"
    out.mkdir()
    (out / "unitB").write_text("a file where a unit's folder goes", encoding="utf-8")
    with pytest.raises(ConfigError, match="cannot create") as err:
        _import([a, b], m, out)
    assert "\n" not in str(err.value)
    assert sorted(p.name for p in out.iterdir()) == ["unitB"]  # unitA was not left behind


def test_a_move_that_fails_leaves_no_folder_behind(rig_window, tmp_path, monkeypatch):
    """The second window's move fails: the first is put back and the folders made removed."""
    import errno
    import os

    from ema_phm.importing import importer

    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = {"by": "length", "seconds": 0.5}
    src = rig_forms.table(tmp_path / "rig.csv", rig_window)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("the user's", encoding="utf-8")
    calls = []
    real = os.rename  # the module is os itself: patched, os.rename is this function

    def rename(a, b):
        calls.append(b)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device", str(b))
        real(a, b)

    monkeypatch.setattr(importer.os, "rename", rename)
    with pytest.raises(ConfigError, match="No space left"):
        _import([src], m, out)
    assert len(calls) >= 3  # one moved, one failed, the first put back
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]  # rig-1/life-1 removed too


def test_excitation_windows_never_share_a_sample():
    from ema_phm.importing.channel_map import WindowRule
    from ema_phm.importing.segments import by_excitation

    rate = 2000.0
    t = np.arange(0, 3, 1 / rate)
    cmd = np.where(((t > 0.2) & (t < 1.0)) | ((t > 1.3) & (t < 2.5)), np.sin(2 * np.pi * 5 * t), 0)
    got = by_excitation(cmd, rate, WindowRule(by="excitation", max_pause_s=0.25, settle_s=0.2))
    assert len(got) == 2 and got[0][1] < got[1][0]


def test_a_gap_in_one_phase_current_is_a_gap_in_the_current(tmp_path):
    import pyarrow as pa
    from pyarrow import csv

    rate = 40_000.0
    t = np.arange(0, 3.0, 1 / rate)
    theta_m = 300.0 * t
    theta_e = ACTUATOR.motor.pole_pairs * theta_m
    cols = {
        "time_s": t,
        "command_deg": np.degrees(0.002 * theta_m),
        "surface_rad": 0.002 * theta_m,
    }
    cols |= {"motor_rad": theta_m, "temperature_C": 25.0 + 0 * t}
    for name, shift in (("ia", 0), ("ib", 1), ("ic", -1)):
        cols[name] = -2.0 * np.sin(theta_e - shift * 2 * math.pi / 3)
    gap = (t > 1.5) & (t < 1.6)
    ib = pa.array(cols["ib"], mask=gap)  # phase B not logged for 0.1 s
    table = pa.table({**{k: v for k, v in cols.items() if k != "ib"}, "ib": ib})
    with (tmp_path / "phases.csv").open("wb") as f:
        csv.write_csv(table, f)
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = {"by": "length", "seconds": 1.0}
    m["channels"] |= {
        "omega_m": {"derive": "rate_of_theta_m"},
        "i3eq": {"derive": "park_q", "phases": [{"column": c} for c in ("ia", "ib", "ic")]},
    }
    report = _import([tmp_path / "phases.csv"], m, tmp_path / "out")
    assert report.sources[0].stretches == 2 and report.sources[0].windows == 2
    got = read_window(report.written[0])
    assert np.allclose(got.i3eq[50:], 2.0, atol=0.01)  # after the filter's first samples


def test_a_motor_angle_logged_slowly_and_wrapped_gives_the_right_q_current():
    """500 Hz, one turn wrapped, 800 rad/s: 3.2 rad electrical per sample, past pi."""
    slow = np.arange(0, 0.2, 1 / 500.0)
    theta_m = Series(slow, np.mod(800.0 * slow, 2 * math.pi))
    fast = np.arange(0, 0.2, 1 / 40_000.0)
    theta_e = ACTUATOR.motor.pole_pairs * 800.0 * fast
    phases = tuple(Series(fast, -np.sin(theta_e - k * 2 * math.pi / 3)) for k in (0, 1, -1))
    got = derive.park_q(phases, derive.electrical_angle(theta_m, ACTUATOR, 0.0))
    assert got.t[-1] == pytest.approx(slow[-1], abs=1e-4)
    assert np.allclose(got.v, 1.0, atol=1e-6)


def test_a_boolean_marker_column_and_bad_names_are_read_or_named(tmp_path):
    t = np.arange(0, 3.0, 1 / 2000.0)
    marker = (t > 1.0) & (t < 2.0)
    path = _table_from(tmp_path / "u1_cX.csv", t, 0.01 * np.sin(t), bit=marker)
    m = _table_map(by={"by": "marker", "marker": {"column": "bit"}, "min_duration_s": 0.5})
    assert len(_import([path], m, tmp_path / "out").written) == 1
    m["identity"] = {"from_name": r"(?P<hardware_id>u\d)_c(?P<cycle>\w+)"}
    with pytest.raises(ConfigError, match="gives cycle 'X', not a whole number"):
        _import([path], m, tmp_path / "out2")


def test_a_map_that_is_not_yaml_names_the_line(tmp_path):
    bad = tmp_path / "map.yaml"
    bad.write_text("version: 1\nchannels: {command: [\n", encoding="utf-8")
    from ema_phm.importing.channel_map import load_channel_map

    with pytest.raises(ConfigError, match=r"not YAML at line \d+, column \d+"):
        load_channel_map(bad)


def test_no_window_at_all_is_one_line_saying_why(tmp_path):
    t = np.arange(0, 1.5, 1 / 2000.0)
    path = _table_from(tmp_path / "short.csv", t, 0.01 * np.sin(t))
    with pytest.raises(ConfigError, match=r"longest stretch .* is 1\.500 s.*windows of 2 s"):
        _import([path], _table_map(by={"by": "length", "seconds": 2.0}), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_name_off_the_pattern_is_fine_when_a_flag_names_the_unit(rig_window, tmp_path):
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["identity"] = {"from_name": r"^sortie(?P<cycle>\d+)\.csv$"}
    path = rig_forms.table(tmp_path / "hangar_a.csv", rig_window)
    with pytest.raises(ConfigError, match=r"does not match identity.from_name '\^sortie"):
        _import([path], m, tmp_path / "out")
    (written,) = _import([path], m, tmp_path / "out", overrides={"hardware_id": "u1"}).written
    assert read_window(written).meta["hardware_id"] == "u1"
