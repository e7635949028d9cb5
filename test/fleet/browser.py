"""Headless Chromium for the fleet tests: load a page, read its log for console messages."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

#: A page console message as `--enable-logging=stderr` writes it.  Chromium 156 (Debian 12):
#: ``[pid:tid:MMDD/hhmmss.us:INFO:CONSOLE:1] "text", source: file:///p.html (1)``, every level
#: alike (console.log and console.error are both INFO), an uncaught exception as
#: ``"Uncaught Error: text"``; older versions wrote ``INFO:CONSOLE(1)]``.  The level cannot
#: be told apart, so any console message counts: the report's page writes none.
CONSOLE_LINE = re.compile(r":CONSOLE(?::\d+|\(\d+\))\]")


def console_messages(stderr: str) -> list[str]:
    """Lines of Chromium's log that report a page console message or an uncaught error."""
    return [line for line in stderr.splitlines() if CONSOLE_LINE.search(line)]


def chromium() -> str:
    found = shutil.which("chromium")
    if found:
        return found
    if os.environ.get("CI") == "true":
        pytest.fail("chromium must be installed in CI (scripts/system_packages.sh installs it)")
    pytest.skip("chromium is not installed (apt-get install chromium)")


def load(
    page: Path, *, window_size: tuple[int, int] | None = None
) -> subprocess.CompletedProcess[str]:
    """Open `page` in headless Chromium (no network, a fresh profile); DOM on stdout.

    `window_size`: the viewport (width, height) in CSS pixels (default: Chromium's).
    """
    exe = chromium()
    size = [] if window_size is None else [f"--window-size={window_size[0]},{window_size[1]}"]
    with tempfile.TemporaryDirectory(prefix="ema-phm-chromium-") as profile:
        return subprocess.run(
            [
                exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--disable-extensions",
                f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                "--timeout=10000", *size, "--dump-dom", page.resolve().as_uri(),
            ],
            capture_output=True, text=True, timeout=60, check=False,
        )  # fmt: skip
