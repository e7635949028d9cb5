"""Fixtures shared by every test folder (plain helpers are in helpers.py)."""

from __future__ import annotations

import random
from collections.abc import Iterator

import pytest


@pytest.fixture(scope="session")
def ros_domain_id() -> int:
    """A ROS domain of this test session's own, so parallel sessions do not hear each other."""
    return random.randint(1, 100)


@pytest.fixture(scope="session", autouse=True)
def ros_on_this_host(ros_domain_id: int) -> Iterator[None]:
    """Keep ROS traffic on this machine and on `ros_domain_id` for the whole session.

    Set before any test starts rclpy; subprocesses the tests start inherit it.
    """
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        patch.setenv("ROS_DOMAIN_ID", str(ros_domain_id))
        yield
