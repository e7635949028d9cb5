"""The channel map: the documented examples load, and every bad key is one line naming it."""

from __future__ import annotations

import copy
import math

import pytest

from bench.harness.rig_forms import JOINT_STATES_MAP, TABLE_MAP
from ema_phm.errors import ConfigError
from ema_phm.importing.channel_map import load_channel_map, parse_channel_map


def test_the_rig_maps_load_with_their_units_converted():
    bag = parse_channel_map(JOINT_STATES_MAP, where="m")
    assert bag.channels["load"].unknown
    assert bag.channels["theta_u"].ref.joint == "surface"
    assert bag.channels["i3eq"].ref.delay_s == pytest.approx(2e-5)
    table = parse_channel_map(TABLE_MAP, where="m")
    assert table.channels["command"].ref.factor == pytest.approx(math.pi / 180.0)
    assert table.channels["omega_m"].ref.factor == pytest.approx(2.0 * math.pi / 60.0)
    assert table.time.column == "time_s"


def _with(path: tuple, value) -> dict:
    m = copy.deepcopy(JOINT_STATES_MAP)
    node = m
    for key in path[:-1]:
        node = node[key]
    if value is _DROP:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return m


_DROP = object()

BAD = [
    (("version",), 2, "version 2"),
    (("colour",), "red", "unknown key 'colour'"),
    (("channels", "theta_u"), _DROP, "channels.theta_u is missing"),
    (("channels", "i3eq"), "unknown", "the monitor needs it"),
    (("channels", "i3eq", "unit"), "deg", "unit 'deg' is a unit of rad"),
    (("channels", "i3eq", "unit"), "furlong", "unit 'furlong' is not one of"),
    (("channels", "theta_u", "field"), "position..x", "field 'position..x'"),
    (("channels", "theta_u", "topic"), "joint_states", "topic 'joint_states'"),
    (("channels", "theta_u", "column"), "x", "give either topic"),
    (("channels", "theta_u", "index"), -1, "index -1"),
    (("channels", "theta_u", "scale"), "two", "scale: 'two' is not a finite number"),
    (("channels", "omega_m"), {"derive": "through_gear"}, "derive 'through_gear'"),
    (("channels", "command", "iq_convention"), "power", "applies to i3eq only"),
    (("channels", "i3eq", "iq_convention"), "peak", "is not one of amplitude"),
    (("windows",), {"by": "chirps"}, "by 'chirps'"),
    (("windows",), {"by": "times", "times": [[2.0, 1.0]]}, "0 <= start < end"),
    # review of 1b7cc36: a huge time crashed --stream; an integer beyond a float the parser
    (("windows",), {"by": "times", "times": [[2.0, 1e308]]}, "end <= 1e+09 s"),
    (("windows",), {"by": "times", "times": [[0, 10**400]]}, "is not a finite number"),
    (("windows",), {"by": "marker"}, "needs marker"),
    (("windows",), {"by": "length", "seconds": 0}, "seconds: 0 must be > 0"),
    (("identity", "from_name"), "(?P<colour>x)", "may name hardware_id"),
    (("identity", "from_name"), "(", "is not a regex"),
    (("identity", "purpose"), "fly", "purpose 'fly'"),
    (("identity", "hardware_id"), " rig ", "without outer spaces"),
    (("stamps",), "arrival", "stamps 'arrival'"),
]


@pytest.mark.parametrize(
    ("path", "value", "says"), BAD, ids=[" ".join(map(str, b[0])) for b in BAD]
)
def test_a_bad_map_is_one_line_naming_the_key_and_value(path, value, says):
    with pytest.raises(ConfigError) as err:
        parse_channel_map(_with(path, value), where="rig.yaml")
    text = str(err.value)
    assert says in text and "rig.yaml" in text
    assert "\n" not in text


def test_a_derived_interface_needs_its_joint():
    m = _with(("channels", "theta_u"), {"topic": "/dynamic_joint_states", "interface": "position"})
    with pytest.raises(ConfigError, match="needs the joint"):
        parse_channel_map(m, where="m")


def test_park_q_needs_three_phases():
    m = _with(("channels", "i3eq"), {"derive": "park_q", "phases": [{"column": "ia"}]})
    with pytest.raises(ConfigError, match="three phase currents"):
        parse_channel_map(m, where="m")


def test_load_names_the_file_when_it_is_not_yaml_or_missing(tmp_path):
    bad = tmp_path / "map.yaml"
    bad.write_text("channels: [\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"map\.yaml: not YAML"):
        load_channel_map(bad)
    with pytest.raises(ConfigError, match="cannot read it"):
        load_channel_map(tmp_path / "absent.yaml")


def test_custom_message_definitions_are_read_relative_to_the_map(tmp_path):
    (tmp_path / "Reading.msg").write_text("float64 value\n", encoding="utf-8")
    m = {**copy.deepcopy(JOINT_STATES_MAP), "msg_types": {"rig_msgs/msg/Reading": "Reading.msg"}}
    (tmp_path / "map.yaml").write_text(__import__("yaml").safe_dump(m), encoding="utf-8")
    cmap = load_channel_map(tmp_path / "map.yaml")
    assert cmap.msg_definitions["rig_msgs/msg/Reading"] == "float64 value\n"
    m["msg_types"] = {"Reading": "Reading.msg"}
    with pytest.raises(ConfigError, match="is not a type like pkg/msg/Name"):
        parse_channel_map(m, where="m", base=tmp_path)
