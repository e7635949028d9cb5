"""The node executables as processes.

Bad parameters exit 2 with one line, the first SIGINT/SIGTERM always stops them (also during
start-up), a second one cannot cut the recording's close.  Each process runs on its own random
domain, sockets on 127.0.0.1 only (test/conftest.py).
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

ROOT = Path(__file__).resolve().parents[2]


def _env() -> dict[str, str]:
    return dict(
        os.environ,  # the session's loopback-only transport (test/conftest.py)
        ROS_DOMAIN_ID=str(random.randint(1, 100)),
        PYTHONUNBUFFERED="1",
    )


def _start(node: str, *params: str) -> subprocess.Popen:
    args = [sys.executable, "-m", f"ema_phm.ros.{node}"]
    if params:
        args += ["--ros-args"] + [x for p in params for x in ("-p", p)]
    return subprocess.Popen(
        args, env=_env(), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _finish(proc: subprocess.Popen, timeout: float) -> tuple[int | None, str, str]:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        return None, out, err
    return proc.returncode, out, err


@pytest.mark.parametrize(
    "node,param,words",
    [
        ("ema_node", "seed:=abc", "'seed'"),
        ("ema_node", "k:=3", "'k'"),
        (
            "ema_node",
            "samples_per_message:=1000000000",
            "samples_per_message must be an integer in [1, 10000]",
        ),
        ("ema_node", "duration:=10000000.0", "duration must be a number in [0.05, 60] s"),
        (
            "ema_node",
            "degradation:=/nonexistent/wear.yaml",
            "degradation file not found: /nonexistent/wear.yaml",
        ),
        ("monitor_node", "seed:=4294967296", "seed must be an integer in [0, 2147483647]"),
        (
            "monitor_node",
            "actuator_file:=/nonexistent/ema.yaml",
            "actuator_file: config file not found: /nonexistent/ema.yaml",
        ),
        (
            "monitor_node",
            "max_evaluations:=1000000000000",
            "max_evaluations must be an integer in [0, 200000]",
        ),
    ],
)
def test_bad_parameter_exits_2_with_one_line(node, param, words):
    rc, _out, err = _finish(_start(node, param), 30.0)
    assert rc == 2, (rc, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{node}: error: ") and words in lines[0], err


def _stop_trials(node: str, trials: int) -> list[tuple[str, float, int | None, float]]:
    """Start `node`, send SIGINT or SIGTERM after a delay (start-up included), time the exit."""
    rng = random.Random(7)
    outcome = []
    for i in range(trials):
        sig = (signal.SIGINT, signal.SIGTERM)[i % 2]
        delay = 0.2 + 2.8 * i / max(trials - 1, 1) + rng.uniform(0.0, 0.1)
        proc = _start(node, "realtime_factor:=1.0") if node == "ema_node" else _start(node)
        time.sleep(delay)
        t0 = time.monotonic()
        proc.send_signal(sig)
        rc, _out, err = _finish(proc, 10.0)
        outcome.append(
            (sig.name, round(delay, 2), rc, round(time.monotonic() - t0, 2), err.strip()[-300:])
        )
    return outcome


#: s a stop may take in these trials: the target is 1 s (measured 0.01-0.3 s on 2 busy
#: cores); before issue 17 a stop during start-up took 2-6 s (the whole start-up, then
#: the clean-up, then Python's tear-down of numba, scipy and pymoo).
STOP_WITHIN_S = 2.0


@pytest.mark.parametrize("node,trials", [("ema_node", 12), ("monitor_node", 8)])
def test_first_signal_always_stops_the_node(node, trials):
    """Issues 7 and 17: a signal during start-up was ignored, gave a traceback or took seconds.

    Now every trial exits with 0 at once, whatever the delay (imports, build, spinning).
    """
    outcome = _stop_trials(node, trials)
    print("signal, delay s, exit code, stop s:", [o[:4] for o in outcome])
    bad = [o for o in outcome if o[2] != 0 or o[3] > STOP_WITHIN_S]
    assert not bad, bad


BUILD_INTERRUPTED = """
import os, signal, sys, time
from ema_phm.ros import common

steps = []

class SlowStartUp:  # a node whose build takes long: a signal must abandon it
    def __init__(self):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(600):
                time.sleep(0.05)  # 30 s unless interrupted
            steps.append("built")
        except BaseException as exc:
            steps.append(type(exc).__name__)  # the constructor's own clean-up runs
            raise

    def destroy_node(self):
        steps.append("destroyed")

rc = common.spin_main(SlowStartUp, "node")
print(rc, steps)
"""


def test_a_signal_while_the_node_is_built_abandons_the_build():
    """Issue 17 item 9: spin_main waited for the node to be fully built before stopping."""
    proc = _run_script(BUILD_INTERRUPTED)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "0 ['StartUpInterrupted']", proc.stdout + proc.stderr


def test_second_signal_does_not_cut_the_recording(tmp_path):
    bag = tmp_path / "rec"
    proc = _start("monitor_node", f"record_bag:={bag}", "heartbeat_period:=0.05")
    mcap = bag / "rec.mcap"
    deadline = time.monotonic() + 60.0
    while not (mcap.exists() and mcap.stat().st_size > 0) and time.monotonic() < deadline:
        time.sleep(0.05)
    # the node is built and recording once a chunk of messages reached the file (chunks are
    # sealed every second; one without a message is not written); a fresh clone compiles for
    # seconds after opening the bag, and a signal during the build abandons it
    # (test_a_signal_while_the_node_is_built_...).  The file is created empty and its header
    # written at once just after: measured from 0 bytes, the header was taken for a chunk
    # (a fresh-clone CI run signalled before anything was recorded)
    opened = mcap.stat().st_size
    while mcap.stat().st_size <= opened and time.monotonic() < deadline:
        time.sleep(0.05)
    assert mcap.stat().st_size > opened, "nothing recorded within 60 s"
    proc.send_signal(signal.SIGINT)
    time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    proc.send_signal(signal.SIGTERM)
    rc, out, err = _finish(proc, 20.0)
    assert rc == 0, err
    assert (out + err).count(f"bag {bag} closed") == 1, out + err
    assert (bag / "metadata.yaml").is_file()
    from ema_phm.telemetry import bags

    assert sum(1 for _ in bags.read_messages(bag)) > 0


LATE_SIGNAL = """
import os, signal, sys, time
from ema_phm.ros import common

class StoppedAtOnce:  # a node whose start-up is interrupted by a first SIGINT
    def __init__(self):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.1)  # let the handler run

    def destroy_node(self):
        pass

rc = common.spin_main(StoppedAtOnce, "node")
os.kill(os.getpid(), signal.SIGINT)  # a second signal landing after the clean-up
time.sleep(0.3)
sys.exit(rc)
"""


def test_a_late_second_signal_after_the_clean_up_does_not_kill_the_process():
    """A second SIGINT after the clean-up leaves a cleanly stopped node at exit 0.

    Found in the suite: spin_main restored the default handler, and the late signal
    turned a clean stop into exit -2.
    """
    proc = _run_script(LATE_SIGNAL)
    assert proc.returncode == 0, proc.stderr


def _run_script(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code],
        env=_env(),
        cwd=ROOT,
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
