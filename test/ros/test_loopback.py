"""Every UDP socket a node opens is on 127.0.0.1 (config/fastdds_localhost.xml, test/conftest.py).

The sockets of a process are read from /proc (its fds, then /proc/net/udp and udp6), the
same facts `ss -lunp` shows.  A control run without the profile proves the check can fail.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from ema_phm.ros.runtime import discovery_range  # noqa: E402 - after importorskip

ROOT = Path(__file__).resolve().parents[2]
PROFILE = ROOT / "config" / "fastdds_localhost.xml"

if not Path("/proc/net/udp").is_file():
    pytest.skip("needs Linux /proc/net/udp", allow_module_level=True)


def _hex_ipv4(field: str) -> str:
    """'0100007F:1F40' -> '127.0.0.1' (the kernel writes the address little-endian)."""
    raw = bytes.fromhex(field.split(":", maxsplit=1)[0])
    return ".".join(str(b) for b in reversed(raw))


def udp_sockets(pid: int) -> list[str]:
    """The local addresses of the UDP sockets `pid` holds ("udp6:..." for IPv6 ones)."""
    inodes = set()
    fd_dir = Path(f"/proc/{pid}/fd")
    for fd in fd_dir.iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue  # closed meanwhile
        if target.startswith("socket:["):
            inodes.add(target[len("socket:[") : -1])
    found = []
    for table, v6 in (("/proc/net/udp", False), ("/proc/net/udp6", True)):
        if not Path(table).is_file():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            cols = line.split()
            if len(cols) > 9 and cols[9] in inodes:
                found.append(("udp6:" + cols[1]) if v6 else _hex_ipv4(cols[1]))
    return found


#: A node that publishes one topic and sleeps: enough for Fast DDS to open all its sockets.
TINY_NODE = """
import time, rclpy
from rclpy.node import Node
from std_msgs.msg import String
rclpy.init()
node = Node("loopback_probe")
node.create_publisher(String, "probe", 10)
print("ready", flush=True)
time.sleep(30)
"""


def _sockets_of(
    args: list[str], env: dict[str, str], *, stop: int = signal.SIGTERM, settle_s: float = 1.0
) -> list[str]:
    proc = subprocess.Popen(
        args, env=env, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        deadline = time.monotonic() + 60.0
        socks: list[str] = []
        while time.monotonic() < deadline and proc.poll() is None:
            socks = udp_sockets(proc.pid)
            if socks:
                break
            time.sleep(0.1)
        time.sleep(settle_s)  # discovery opens its last sockets shortly after the first
        if proc.poll() is None:
            socks = udp_sockets(proc.pid)
        assert socks, f"no UDP socket seen; output: {proc.stdout.read() if proc.poll() else ''}"
        return socks
    finally:
        if proc.poll() is None:
            proc.send_signal(stop)
            try:
                proc.communicate(timeout=20.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()


def test_the_session_uses_the_loopback_profile_with_fastrtps():
    from rclpy.utilities import get_rmw_implementation_identifier

    assert os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILE)
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
    assert get_rmw_implementation_identifier() == "rmw_fastrtps_cpp"
    assert discovery_range() == "SYSTEM_DEFAULT"


def test_in_process_graph_falls_back_to_localhost_without_a_profile(tmp_path):
    assert discovery_range({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}) == "LOCALHOST"
    assert discovery_range({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"}) == "LOCALHOST"
    missing = {
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
        "FASTDDS_DEFAULT_PROFILES_FILE": str(tmp_path / "none.xml"),
    }
    assert discovery_range(missing) == "LOCALHOST"


def test_ema_node_binds_only_loopback_sockets():
    env = dict(os.environ, PYTHONUNBUFFERED="1")  # the session's env: profile + SYSTEM_DEFAULT
    socks = _sockets_of([sys.executable, "-m", "ema_phm.ros.ema_node"], env)
    assert all(addr == "127.0.0.1" for addr in socks), socks


def test_without_the_profile_sockets_are_bound_beyond_loopback():
    """The control: rmw_fastrtps's LOCALHOST range alone binds 0.0.0.0 (so the check can fail)."""
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
    }
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    socks = _sockets_of([sys.executable, "-c", TINY_NODE], env, stop=signal.SIGKILL)
    assert any(addr != "127.0.0.1" for addr in socks), socks
