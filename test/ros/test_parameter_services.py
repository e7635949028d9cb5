"""Both nodes' parameters, reached from another process the way `ros2 param` and rqt reach them.

Each node runs as its own executable (`python -m ema_phm.ros.<node>`); this test process is
the client, with rclpy's real service clients on the node's seven parameter services
(`list/get/set/describe_parameters`, `get_parameter_types`, `set_parameters_atomically`).
In-process tests that call `set_parameters` on the node object passed while monitor_node
advertised none of them (its service list was overwritten), so the check is made here.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest
from node_processes import start_node, stop_node

pytest.importorskip("rclpy")


PARAMETER_SERVICES = (
    "describe_parameters",
    "get_parameter_types",
    "get_parameters",
    "list_parameters",
    "set_parameters",
    "set_parameters_atomically",
)

#: A run-time parameter of each node, a legal new value, and an illegal one.
RUN_TIME = {
    "monitor_node": ("seed", 7, -1),
    "ema_node": ("k", [0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], [2.0] * 8),
}
#: The executable (module) -> the node it makes.
NODE_OF = {
    "monitor_node": "monitor_node",
    "monitor_lifecycle_node": "monitor_node",
    "ema_node": "ema_node",
}


@pytest.fixture
def client(ros_domain_id: int) -> Iterator[Any]:
    """An rclpy node of this (the client's) process on the session's private domain."""
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx, domain_id=ros_domain_id)
    node = rclpy.create_node("param_probe", context=ctx)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)


@pytest.fixture
def node_process(request: pytest.FixtureRequest, ros_domain_id: int) -> Iterator[str]:
    """The executable named by the test's parameter, started; the name of its node."""
    name = request.param
    params = ["warm_up:=false"] if name.startswith("monitor") else ["realtime_factor:=0.0"]
    params += ["max_windows:=0"] if name == "ema_node" else []
    proc = start_node(name, ros_domain_id, *params)
    try:
        yield NODE_OF[name]
    finally:
        code, err = stop_node(proc)
        assert code == 0, f"{name} exited {code}: {err}"


def _call(client: Any, srv_type: Any, name: str, request: Any) -> Any:
    from rclpy.executors import SingleThreadedExecutor

    cli = client.create_client(srv_type, name)
    executor = SingleThreadedExecutor(context=client.context)
    executor.add_node(client)
    try:
        assert cli.wait_for_service(timeout_sec=60.0), f"{name} is not served"
        future = cli.call_async(request)
        executor.spin_until_future_complete(future, timeout_sec=30.0)
        assert future.done(), f"{name} did not answer"
        return future.result()
    finally:
        executor.remove_node(client)
        executor.shutdown()
        client.destroy_client(cli)


def _advertised(client: Any, node: str, timeout: float = 60.0) -> set[str]:
    """The services of /node that the graph shows, once its parameter services appear."""
    deadline = time.monotonic() + timeout
    prefix = f"/{node}/"
    names: set[str] = set()
    while time.monotonic() < deadline:
        names = {
            s.removeprefix(prefix)
            for s, _ in client.get_service_names_and_types()
            if s.startswith(prefix)
        }
        if set(PARAMETER_SERVICES) <= names:
            break
        time.sleep(0.2)
    return names


@pytest.mark.parametrize(
    "node_process", ["monitor_node", "monitor_lifecycle_node", "ema_node"], indirect=True
)
def test_parameters_answer_another_process(client: Any, node_process: str) -> None:
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
    from rclpy.parameter import Parameter as RclpyParameter

    node = node_process
    advertised = _advertised(client, node)
    assert set(PARAMETER_SERVICES) <= advertised, f"/{node} advertises {sorted(advertised)}"

    listed = _call(client, ListParameters, f"/{node}/list_parameters", ListParameters.Request())
    name, good, bad = RUN_TIME[node]
    assert {"use_sim_time", name} <= set(listed.result.names)

    described = _call(
        client,
        DescribeParameters,
        f"/{node}/describe_parameters",
        DescribeParameters.Request(names=[name, "use_sim_time"]),
    )
    assert [d.name for d in described.descriptors] == [name, "use_sim_time"]
    assert not described.descriptors[0].read_only
    assert described.descriptors[0].description

    def set_(pname: str, value: Any) -> Any:
        msg = Parameter(name=pname, value=RclpyParameter(pname, value=value).get_parameter_value())
        reply = _call(
            client,
            SetParameters,
            f"/{node}/set_parameters",
            SetParameters.Request(parameters=[msg]),
        )
        return reply.results[0]

    def get_(pname: str) -> ParameterValue:
        reply = _call(
            client, GetParameters, f"/{node}/get_parameters", GetParameters.Request(names=[pname])
        )
        return reply.values[0]

    assert set_("use_sim_time", True).successful
    assert get_("use_sim_time").bool_value is True

    assert set_(name, good).successful
    value = get_(name)
    if value.type == ParameterType.PARAMETER_INTEGER:
        assert value.integer_value == good
    else:
        assert list(value.double_array_value) == pytest.approx(good)

    refused = set_(name, bad)
    assert not refused.successful and refused.reason, "an illegal value is refused with a reason"
    value = get_(name)
    kept = value.integer_value if value.type == ParameterType.PARAMETER_INTEGER else None
    assert kept == good or list(value.double_array_value) == pytest.approx(good)


def test_no_node_of_ours_overwrites_an_attribute_of_rclpy_node(client: Any) -> None:
    """`self._services = ...` in MonitorNode replaced rclpy's list and dropped its services."""
    import ast
    import inspect

    from rclpy.node import Node

    from ema_phm.ros.ema_node import EmaNode
    from ema_phm.ros.monitor_lifecycle_node import MonitorLifecycleNode
    from ema_phm.ros.monitor_node import MonitorNode

    rclpy_owns = set(vars(client)) | set(dir(Node))
    clashes = []
    for cls in (MonitorNode, MonitorLifecycleNode, EmaNode):
        for owner in cls.__mro__:
            if not owner.__module__.startswith("ema_phm."):
                continue
            for node in ast.walk(ast.parse(inspect.getsource(owner))):
                if (
                    isinstance(node, ast.Attribute)
                    and isinstance(node.ctx, ast.Store)
                    and isinstance(node.value, ast.Name)
                    and node.value.id == "self"
                    and node.attr in rclpy_owns
                ):
                    clashes.append(f"{owner.__name__}.{node.attr}")
    assert not clashes, f"attributes of rclpy's Node overwritten: {sorted(set(clashes))}"
