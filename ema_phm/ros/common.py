"""QoS profiles, the rclpy message conversion and the executables' main, shared by the nodes."""

from __future__ import annotations

import os
import signal
import sys
import threading
from typing import Any

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

from ..errors import EmaPhmError
from ..telemetry import qos
from ..telemetry.qos import TopicQos
from ..telemetry.wire import ArrayParts, MessageClasses, as_double_array, to_message
from . import STOP_REQUESTED, is_node_executable

#: Topics under this prefix are created relative to the node's namespace (`relative`).
NAMESPACED_PREFIX = "/ema/"


def relative(topic: str) -> str:
    """`topic` as a name relative to the node's namespace if it is one of ours.

    '/ema/telemetry' -> 'ema/telemetry': in the root namespace that still resolves to
    '/ema/telemetry' (the name bags and tools use); `-r __ns:=/left` moves it to
    '/left/ema/telemetry'.  Other names, /diagnostics included (the ROS convention), stay.
    """
    return topic[1:] if topic.startswith(NAMESPACED_PREFIX) else topic


class RelativeTopics:
    """Node mixin: publishers and subscriptions on ``/ema/...`` names are made `relative`.

    The names in `ema_phm.telemetry.wire` stay absolute (bags, tools, tests); the nodes
    pass them as they are and this mixin turns them into namespace-relative names.
    """

    def create_publisher(self, msg_type: Any, topic: str, *args: Any, **kwargs: Any) -> Any:
        """`Node.create_publisher` on `relative(topic)`."""
        return super().create_publisher(msg_type, relative(topic), *args, **kwargs)  # type: ignore[misc]

    def create_subscription(self, msg_type: Any, topic: str, *args: Any, **kwargs: Any) -> Any:
        """`Node.create_subscription` on `relative(topic)`."""
        return super().create_subscription(msg_type, relative(topic), *args, **kwargs)  # type: ignore[misc]


def qos_profile(spec: TopicQos) -> QoSProfile:
    """The rclpy profile of a `ema_phm.telemetry.qos.TopicQos` (reliable, keep last)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=spec.depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=(
            DurabilityPolicy.TRANSIENT_LOCAL if spec.latched else DurabilityPolicy.VOLATILE
        ),
    )


#: Telemetry: reliable and deep, so a burst at realtime_factor 0 is not dropped.
TELEMETRY_QOS = qos_profile(qos.TELEMETRY)
#: run_info and ground truth: latched (transient local), so late joiners get the last one.
LATCHED_QOS = qos_profile(qos.LATCHED)
#: Health, diagnostics, fitted windows.
OUTPUT_QOS = qos_profile(qos.OUTPUT)


#: rclpy's std_msgs classes, for `ema_phm.telemetry.wire.to_message`.
RCLPY_CLASSES = MessageClasses(
    array=Float64MultiArray,
    layout=MultiArrayLayout,
    dimension=MultiArrayDimension,
    data=as_double_array,
)


def to_rclpy(parts: ArrayParts) -> Float64MultiArray:
    """An rclpy Float64MultiArray holding `parts` (from a `wire.encode_*` function)."""
    return to_message(parts, RCLPY_CLASSES)


class StartUpInterrupted(BaseException):
    """A stop signal while the node was being built (`StopSignals.building`).

    A BaseException, like KeyboardInterrupt: it unwinds the node's constructor, whose
    clean-up destroys what was built, and `spin_main` returns 0.
    """


class StopSignals:
    """SIGINT/SIGTERM as a flag, for the executables (`spin_main`).

    rclpy's own handlers raise KeyboardInterrupt at whatever line the main thread is
    on and shut the context down from another thread, so a signal landing inside the
    clean-up could cut it (the bag's close) half way.  Here a signal sets `requested`;
    the spin loop polls it and the clean-up runs to its end, however many signals
    follow.  Only while the node is being built (`building`) does the first signal
    also raise `StartUpInterrupted`, so a start-up that takes seconds under load
    is abandoned at once rather than finished and then undone.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = threading.Event()
        self.received: list[int] = []
        self.building = False
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, _frame: Any) -> None:
        self.received.append(signum)
        first = not self.requested.is_set()
        self.requested.set()
        if first and self.building:
            self.building = False
            raise StartUpInterrupted(signum)

    def install(self) -> None:
        """Take over SIGINT and SIGTERM (only from the main thread)."""
        if threading.current_thread() is not threading.main_thread():
            return  # Python only lets the main thread set handlers
        for sig in self.SIGNALS:
            self._previous[sig] = signal.signal(sig, self._handle)

    def restore(self) -> None:
        """Put back the handlers `install` replaced."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()


#: Seconds between two looks at the stop flag while spinning.
SPIN_POLL_S = 0.1


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _finished(node: Any) -> bool:
    """Whether `node` says its work is done (an EmaNode after max_windows)."""
    finished = getattr(node, "finished", None)
    return isinstance(finished, threading.Event) and finished.is_set()


def _spin_until_stopped(node: Any, stop: threading.Event, name: str) -> None:
    """Spin `node` until a stop signal, an external shutdown or the node's `finished` event.

    A raising callback is reported on stderr and spinning goes on.
    """
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while not stop.is_set() and node.context.ok() and not _finished(node):
            try:
                executor.spin_once(timeout_sec=SPIN_POLL_S)
            except (ExternalShutdownException, ShutdownException):
                break
            except Exception as exc:  # noqa: BLE001 - a node never dies from a callback
                print(
                    f"[ERROR] [{name}]: a callback raised {type(exc).__name__}: {_one_line(exc)}",
                    file=sys.stderr,
                )
    finally:
        executor.shutdown(timeout_sec=1.0)


#: Exceptions that mean a bad parameter (value or type) at start-up.
PARAMETER_ERRORS: tuple[type[BaseException], ...] = (EmaPhmError, ParameterException)


def spin_main(node_cls: Any, name: str, args: list[str] | None = None) -> int:
    """The executables' main: init, build the node, spin, destroy it, shut down.

    Spins until SIGINT / SIGTERM or until the node sets its `finished` event (ema_node after
    `max_windows`); destroying the node closes any recording, exactly once.  A signal while
    the node is being built abandons the build (`StartUpInterrupted`).  In a node
    executable (`ema_phm.ros.is_node_executable`) the process then ends at once with the
    exit code (`exit_now`): everything is closed, and Python's own tear-down of numba,
    scipy and pymoo would add ~0.6 s to every stop.

    Exit codes: 0 after a stop signal (also one that arrives during start-up) or when the
    node finished, 2 with one line on stderr for a bad parameter (value, range or type) or
    bad ROS arguments.
    """
    signals = StopSignals()
    signals.install()
    if STOP_REQUESTED.is_set():  # a signal during the imports (see ema_phm.ros)
        STOP_REQUESTED.clear()
        signals.requested.set()
    try:
        rc = _run(node_cls, name, args, signals)
    finally:
        if not signals.requested.is_set():
            signals.restore()
        # else: the process is on its way out; a late second signal restored to the default
        # action would kill it (exit -2) after a clean stop, so the flag handler stays
    if is_node_executable():
        exit_now(rc)
    return rc


def exit_now(rc: int) -> None:
    """End the process with `rc` at once, stdout and stderr flushed (no interpreter tear-down)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed or broken: nothing more can be said
            pass
    os._exit(rc)


def _run(node_cls: Any, name: str, args: list[str] | None, signals: StopSignals) -> int:
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as exc:  # noqa: BLE001 - rclpy's RCLError for malformed --ros-args
        print(f"{name}: error: bad ROS arguments: {_one_line(exc)}", file=sys.stderr)
        return 2
    node = None
    try:
        node = _build(node_cls, signals)
        if signals.requested.is_set():
            return 0
        _spin_until_stopped(node, signals.requested, name)
        return 0
    except StartUpInterrupted:
        return 0
    except PARAMETER_ERRORS as exc:
        print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def _build(node_cls: Any, signals: StopSignals) -> Any:
    """`node_cls()`, abandoned by a stop signal (`StartUpInterrupted`) while it runs."""
    if signals.requested.is_set():
        raise StartUpInterrupted(signals.received[-1] if signals.received else 0)
    signals.building = True
    try:
        return node_cls()
    finally:
        signals.building = False
