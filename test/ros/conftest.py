"""Fixtures of the ROS tests (rclpy imported only when a test asks for one)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest


@pytest.fixture
def graph(ros_domain_id: int) -> Iterator[Any]:
    """A private in-process graph; afterwards no thread it started may be left."""
    from node_helpers import wait_until

    from ema_phm.ros.runtime import InProcessGraph

    before = set(threading.enumerate())
    g = InProcessGraph(ros_domain_id)
    g.start()
    try:
        yield g
    finally:
        g.close()
        assert wait_until(lambda: not (set(threading.enumerate()) - before), 5.0), (
            f"threads left after shutdown: {set(threading.enumerate()) - before}"
        )
