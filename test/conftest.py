"""Fixtures shared by every test folder (plain helpers are in helpers.py)."""

from __future__ import annotations

import random
from collections.abc import Iterator
from pathlib import Path

import pytest

#: Fast DDS profile that binds every socket on 127.0.0.1 and discovers only this host.
LOOPBACK_PROFILE = Path(__file__).resolve().parents[1] / "config" / "fastdds_localhost.xml"


@pytest.fixture(scope="session")
def ros_domain_id() -> int:
    """A ROS domain of this test session's own, so parallel sessions do not hear each other."""
    return random.randint(1, 100)


@pytest.fixture(scope="session", autouse=True)
def ros_on_this_host(ros_domain_id: int) -> Iterator[None]:
    """Keep ROS traffic on this machine, sockets included, and on `ros_domain_id`.

    The loopback profile only holds with ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT
    (LOCALHOST makes rmw_fastrtps add a UDP transport on every interface; see the
    profile).  Set before any test starts rclpy; subprocesses the tests start inherit it.
    """
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        patch.setenv("FASTDDS_DEFAULT_PROFILES_FILE", str(LOOPBACK_PROFILE))
        # not FASTRTPS_DEFAULT_PROFILES_FILE (Fast DDS 2): Kilted's rmw warns it is deprecated
        patch.delenv("FASTRTPS_DEFAULT_PROFILES_FILE", raising=False)
        patch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SYSTEM_DEFAULT")
        patch.setenv("ROS_DOMAIN_ID", str(ros_domain_id))
        yield
