"""Open the monitor's recording: a new rosbag2 MCAP directory named by the user."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import Mapping

from ..errors import ConfigError
from .bag_recorder import BagRecorder


def expand_path(template: str, *, now: datetime | None = None) -> str:
    """`template` with '{stamp}' replaced by the start time (YYYYmmdd-HHMMSS)."""
    return template.replace("{stamp}", (now or datetime.now()).strftime("%Y%m%d-%H%M%S"))


def open_recording(template: str, topics: Mapping[str, str]) -> tuple[BagRecorder, str]:
    """A BagRecorder for `topics` (name -> type) at the expanded path, its folder created.

    ConfigError if the folder cannot be made, BagError if the bag exists.
    """
    path = expand_path(template)
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"record_bag {path}: cannot create its folder: {exc}") from None
    return BagRecorder(path, topics=dict(topics)), path
