"""The parameter tables: declared once, and config/*.yaml and docs/ros.md agree with them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")

from ema_phm.domain.faults import N_K  # noqa: E402
from ema_phm.errors import ConfigError, FaultVectorError  # noqa: E402
from ema_phm.ros.ema_node_parameters import ema_node_parameters  # noqa: E402
from ema_phm.ros.monitor_node_parameters import monitor_node_parameters  # noqa: E402
from ema_phm.ros.parameters import ParameterSpec  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TABLES = {"ema_node": ema_node_parameters(), "monitor_node": monitor_node_parameters()}


#: Parameters with one number per fault: not repeated in the config files (adding a fault
#: touches the fault table, not every file that lists k).
PER_FAULT = ("k", "warn_threshold", "error_threshold", "failure_thresholds")


def _yaml_params(name: str) -> dict:
    data = yaml.safe_load((ROOT / "config" / f"{name}.yaml").read_text(encoding="utf-8"))
    assert list(data) == ["/**"], "keyed by /** so the file applies under any namespace"
    return data["/**"]["ros__parameters"]


#: Where the parameter tables are documented (the ROS 2 page of the docs).
ROS_DOC = ROOT / "docs" / "ros.md"


def _readme_rows(node: str) -> list[tuple[str, str]]:
    """(parameter, default) cells of the docs table after the line starting with `node`."""
    lines = ROS_DOC.read_text(encoding="utf-8").splitlines()
    section = lines.index("## Parameters")
    start = next(i for i in range(section, len(lines)) if lines[i].startswith(f"`{node}`"))
    rows, in_table = [], False
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            in_table = True
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif in_table:
            break
    body = [r for r in rows[1:] if not re.fullmatch(r"[-: ]*", "".join(r))]
    return [(r[0], r[1]) for r in body]


def _cell(text: str) -> str:
    return text.strip().strip("`")


@pytest.mark.parametrize("node", sorted(TABLES))
def test_config_yaml_equals_declared_defaults(node):
    """Every parameter but the per-fault lists, whose defaults are the fault table's."""
    defaults = TABLES[node].defaults()
    per_fault = {name for name in PER_FAULT if name in defaults}
    assert per_fault, f"{node} has no per-fault parameter"
    expected = {name: v for name, v in defaults.items() if name not in per_fault}
    assert _yaml_params(node) == expected
    assert all(len(defaults[name]) == N_K for name in per_fault)


@pytest.mark.parametrize("node", sorted(TABLES))
def test_readme_table_lists_each_parameter_with_its_default(node):
    rows = _readme_rows(node)
    assert [_cell(name) for name, _ in rows] == TABLES[node].names
    defaults = TABLES[node].defaults()
    for name, default in rows:
        assert yaml.safe_load(_cell(default)) == defaults[_cell(name)], (name, default)


def test_every_number_carries_its_range_the_dynamic_ones_too():
    """Issue 17: the run-time numbers (monitor seed, max_evaluations) had no range (no slider)."""
    for table in TABLES.values():
        for spec in table:
            desc = spec.descriptor()
            assert desc.description and desc.read_only is not spec.dynamic
            if spec.limit is not None:
                assert desc.integer_range or desc.floating_point_range, spec.name
            else:
                assert not (desc.integer_range or desc.floating_point_range), spec.name
    monitor = TABLES["monitor_node"]
    dynamic_numbers = [s.name for s in monitor if s.dynamic and type(s.default) in (int, float)]
    assert dynamic_numbers == ["seed", "max_evaluations"]
    seed = monitor["seed"].descriptor().integer_range[0]
    assert (seed.from_value, seed.to_value, seed.step) == (0, 2**31 - 1, 0)
    evals = monitor["max_evaluations"].descriptor().integer_range[0]
    assert (evals.from_value, evals.to_value) == (0, 200_000)
    seed = TABLES["ema_node"]["seed"].descriptor()
    assert (seed.integer_range[0].from_value, seed.integer_range[0].to_value) == (0, 2**31 - 1)
    f1 = TABLES["ema_node"]["f1"].descriptor()
    assert (f1.floating_point_range[0].from_value, f1.floating_point_range[0].to_value) == (
        0.0,
        1000.0,
    )
    assert (
        "[0, 200000]"
        in TABLES["monitor_node"]["max_evaluations"].descriptor().additional_constraints
    )


@pytest.mark.parametrize(
    "node,name,value,error,words",
    [
        (
            "ema_node",
            "seed",
            2**32,
            ConfigError,
            r"seed must be an integer in \[0, 2147483647\], got 4294967296",
        ),
        ("ema_node", "noise_speed", float("nan"), ConfigError, "noise_speed must be a number"),
        ("ema_node", "command_kind", "square", ConfigError, "unknown command kind 'square'"),
        ("ema_node", "k", [0.5] * (N_K - 1), FaultVectorError, f"{N_K} entries"),
        ("monitor_node", "preset", "nope", ConfigError, "unknown preset 'nope'"),
        ("monitor_node", "fitness", "nope", ConfigError, "unknown fitness weighting 'nope'"),
        (
            "monitor_node",
            "heartbeat_period",
            0.0,
            ConfigError,
            r"heartbeat_period must be a number in \[0.01, 3600\] s",
        ),
        (
            "monitor_node",
            "colour",
            "red",
            ConfigError,
            r"unknown monitor_node parameter\(s\) \['colour'\]",
        ),
    ],
)
def test_bad_values_are_named(node, name, value, error, words):
    with pytest.raises(error, match=words):
        TABLES[node].validated({name: value})


def test_validated_keeps_the_declared_type():
    out = TABLES["ema_node"].validated({"load": 1, "seed": 3.0, "k": [0.0] * 6 + [0.5, 0.5]})
    assert out["load"] == 1.0 and isinstance(out["load"], float)
    assert out["seed"] == 3 and isinstance(out["seed"], int)


def test_defaults_are_fresh_copies():
    table = TABLES["monitor_node"]
    table.defaults()["warn_threshold"].append(9.0)
    assert len(table.defaults()["warn_threshold"]) == N_K


def test_dynamic_names():
    assert TABLES["ema_node"].dynamic_names == ["k"]
    assert TABLES["monitor_node"].dynamic_names == [
        "preset",
        "seed",
        "fitness",
        "max_evaluations",
        "tracking",
        "warn_threshold",
        "error_threshold",
    ]


def test_a_spec_without_checks_accepts_anything():
    assert ParameterSpec("hardware_id", "x", "id").validate("anything") == "anything"


def test_the_config_file_applies_under_any_namespace(tmp_path, ros_domain_id):
    """`/**` keys: the installed file sets a node's parameters also under -r __ns:=/left."""
    import rclpy
    from rclpy.context import Context

    from ema_phm.ros.monitor_node import MonitorNode

    data = yaml.safe_load((ROOT / "config" / "monitor_node.yaml").read_text(encoding="utf-8"))
    data["/**"]["ros__parameters"].update(seed=7, hardware_id="left_ema")
    params = tmp_path / "monitor_node.yaml"
    params.write_text(yaml.safe_dump(data), encoding="utf-8")
    ctx = Context()
    args = ["--ros-args", "--params-file", str(params), "-r", "__ns:=/left"]
    rclpy.init(args=args, context=ctx, domain_id=ros_domain_id)
    try:
        node = MonitorNode(context=ctx)
        try:
            assert node.get_fully_qualified_name() == "/left/monitor_node"
            assert node.get_parameter("seed").value == 7
            assert node.get_parameter("hardware_id").value == "left_ema"
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)


def test_own_leaves_rclpy_parameters_to_rclpy():
    """Issue 17: use_sim_time was refused as an unknown parameter at run time."""
    from rclpy.parameter import Parameter

    params = [Parameter("use_sim_time", value=True), Parameter("seed", value=3)]
    assert TABLES["monitor_node"].own(params) == {"seed": 3}


def test_whole_numbers_are_taken_for_float_parameters():
    """Issue 17: `-p k:=[0,0,0,0,0,0,0,1]` was refused by rclpy's type check (DOUBLE_ARRAY)."""
    from rclpy.parameter import Parameter

    t = Parameter.Type
    k, load, seed, sim = TABLES["ema_node"].as_declared(
        [
            Parameter("k", t.INTEGER_ARRAY, [0, 0, 0, 0, 0, 0, 0, 1]),
            Parameter("load", t.INTEGER, 1),
            Parameter("seed", t.INTEGER, 3),
            Parameter("use_sim_time", t.BOOL, True),
        ]
    )
    assert (k.type_, k.value) == (t.DOUBLE_ARRAY, [0.0] * 7 + [1.0])
    assert (load.type_, load.value) == (t.DOUBLE, 1.0)
    assert (seed.type_, seed.value) == (t.INTEGER, 3)  # an integer parameter stays one
    assert sim.type_ == t.BOOL
