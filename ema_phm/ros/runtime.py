"""Run ema_phm nodes inside one process (demo, tests, reference bags, benchmarks).

`InProcessGraph` gives its nodes a private rclpy Context on its own ROS domain,
with discovery limited to this host (`discovery_range`), and spins them with a
MultiThreadedExecutor in a background thread.  Leaving the `with` block shuts the
executor down, joins its thread, destroys the nodes (which stops their own threads)
and shuts the context down -- nothing is left running.
"""

from __future__ import annotations

import os
import random
import sys
import threading
from typing import Any, Mapping, TypeVar

import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

N = TypeVar("N", bound=Node)

#: Discovery range set while the context initializes (never talk to other hosts).
DISCOVERY_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"
#: Environment variables naming a Fast DDS XML profile (Fast DDS 3, Fast DDS 2).
PROFILE_ENVS: tuple[str, ...] = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def discovery_range(env: Mapping[str, str] | None = None) -> str:
    """The discovery range an InProcessGraph initializes with.

    LOCALHOST, unless `env` (default: os.environ) asks for SYSTEM_DEFAULT and names an
    existing Fast DDS profile file: that profile then limits discovery and sockets
    itself (config/fastdds_localhost.xml), which LOCALHOST would undo by adding a UDP
    transport on every interface.
    """
    env = os.environ if env is None else env
    if env.get(DISCOVERY_ENV) == "SYSTEM_DEFAULT" and any(
        os.path.isfile(env.get(name, "")) for name in PROFILE_ENVS
    ):
        return "SYSTEM_DEFAULT"
    return "LOCALHOST"


#: rclpy's own parameters a node may be given too (name -> default, which fixes the type).
RCLPY_PARAMETERS: dict[str, Any] = {"use_sim_time": False}


def overrides(defaults: Mapping[str, Any], values: Mapping[str, Any]) -> list[Parameter]:
    """Parameter overrides with each value coerced to the type of its declared default.

    (So `k=[0, 0, ...]` or `load=1` do not trip rclpy's type checks).  Besides the
    node's own, rclpy's `RCLPY_PARAMETERS` (use_sim_time) are accepted.
    """
    defaults = {**RCLPY_PARAMETERS, **defaults}
    out = []
    for name, v in values.items():
        if name not in defaults:
            raise KeyError(f"unknown parameter {name!r}; known: {sorted(defaults)}")
        out.append(Parameter(name, value=_as_type_of(defaults[name], v)))
    return out


def _as_type_of(default: Any, value: Any) -> Any:
    """`value` coerced to the type of `default` (a list: of floats); other types as it is."""
    if isinstance(default, bool):
        return bool(value)
    if isinstance(default, float):
        return float(value)
    if isinstance(default, int):
        return int(value)
    if isinstance(default, str):
        return str(value)
    if isinstance(default, list):
        return [float(x) for x in value]
    return value


class InProcessGraph:
    """A private ROS 2 graph in this process.

    `with InProcessGraph() as g: node = g.add(EmaNode, k=...)`.
    """

    def __init__(self, domain_id: int | None = None, *, num_threads: int = 4) -> None:
        self.domain_id = random.randint(1, 100) if domain_id is None else int(domain_id)
        self.num_threads = num_threads
        self.context: Context | None = None
        self.executor: MultiThreadedExecutor | None = None
        self.nodes: list[Node] = []
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()

    def __enter__(self) -> InProcessGraph:
        self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def start(self) -> None:
        """Init the private context (discovery on this host only) and start spinning."""
        self._stopping.clear()
        old = os.environ.get(DISCOVERY_ENV)
        os.environ[DISCOVERY_ENV] = discovery_range()
        try:
            ctx = Context()
            rclpy.init(context=ctx, domain_id=self.domain_id)
        finally:
            if old is None:
                os.environ.pop(DISCOVERY_ENV, None)
            else:
                os.environ[DISCOVERY_ENV] = old
        self.context = ctx
        self.executor = MultiThreadedExecutor(num_threads=self.num_threads, context=ctx)
        self._thread = threading.Thread(target=self._spin, name="ema_phm-executor", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        """Spin until close(); a callback that raises is reported and spinning goes on.

        (rclpy's own spin() would end the thread on the first exception).
        """
        ex, ctx = self.executor, self.context
        if ex is None or ctx is None:  # not started (or closed): nothing to spin
            return
        while not self._stopping.is_set() and ctx.ok():
            try:
                ex.spin_once(timeout_sec=0.1)
            except Exception as exc:  # noqa: BLE001
                if self._stopping.is_set() or not ctx.ok():
                    break
                print(f"ema_phm: a callback raised {type(exc).__name__}: {exc}", file=sys.stderr)

    def add(self, node_cls: type[N], *, namespace: str | None = None, **params: Any) -> N:
        """Create a `node_cls` with these parameter overrides, in `namespace` if given.

        `node_cls` has a PARAMETERS table (EmaNode, MonitorNode).
        """
        if self.executor is None:
            raise RuntimeError("InProcessGraph.add before start(): no context to build in")
        table: Any = node_cls.PARAMETERS  # type: ignore[attr-defined]  # EmaNode's, MonitorNode's
        extra: dict[str, Any] = {} if namespace is None else {"namespace": namespace}
        node = node_cls(
            context=self.context, parameter_overrides=overrides(table.defaults(), params), **extra
        )
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def close(self) -> None:
        """Stop spinning, destroy the nodes and shut the context down."""
        self._stopping.set()
        if self.executor is not None:
            self.executor.shutdown()
            # callbacks cut short by the shutdown: their errors are expected, not news
            for fut in list(getattr(self.executor, "_futures", [])):
                if fut.done():
                    fut.exception()
        if self._thread is not None:
            self._thread.join(timeout=30.0)
            self._thread = None
        for node in reversed(self.nodes):
            node.destroy_node()
        self.nodes = []
        if self.context is not None:
            rclpy.try_shutdown(context=self.context)
        self.executor = None
        self.context = None
