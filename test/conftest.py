"""Fixtures shared by every test folder (plain helpers are in helpers.py)."""

from __future__ import annotations

import os
import random
import sys
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


@pytest.fixture(scope="module")
def ema_phm_on_path(tmp_path_factory) -> dict[str, str]:
    """An environment with `ema-phm` from this checkout on PATH, as a user's shell has it."""
    root = Path(__file__).resolve().parents[1]
    bin_dir = tmp_path_factory.mktemp("bin")
    shim = bin_dir / "ema-phm"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m ema_phm.tools.cli "$@"\n')
    shim.chmod(0o755)
    env = dict(os.environ)
    # an in-process Dask cluster (the fleet tests) leaves its workers' thread limits in this
    # process's environment; a user's shell has none, and a fit's last bits follow them
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        env.pop(name, None)
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH")) if p)
    env["MPLBACKEND"] = "Agg"
    return env
