"""The calibration file: the monitor's ke and gt in nominal conditions, read and written here.

Written by `ema-phm calibrate --out FILE` (`diagnosis.calibration` fits the values), read by
`MonitorBelief.with_calibration`.  YAML with `monitor: {ke, gt}` (what the belief takes) and,
as documentation, `before`, `after`, `evaluations` and `date`.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path
from typing import Any, Mapping

from ..atomic_file import refuse_folder, write_yaml_file
from ..errors import ConfigError
from ..physics.parameters import check_quantity, read_yaml

#: What `ema-phm calibrate` writes above the values.
HEADER = (
    "# Monitor-model calibration in nominal conditions (thesis section 6.2).\n"
    "# Written by `ema-phm calibrate --out FILE`: ke and gt of the LF are fitted\n"
    "# (coarse scan of ke, then Nelder-Mead on both) so that the nominal LF current\n"
    "# matches the nominal HF I_3eq on the calibration window of config/commands.yaml\n"
    "# (a chirp that reaches the voltage limit, where ke matters).\n"
    "# mse_* are means of (I_HF - I_LF)^2 over the window's samples, in A^2\n"
    "# (thesis: 0.1292 -> 0.0644 A^2 with ke = 0.085897, gt = 0.080072).\n"
)


def read_ke_gt(path: str | Path) -> dict[str, float]:
    """The monitor.ke and monitor.gt of a calibration file, each checked (ConfigError)."""
    path = Path(path)
    mon = read_yaml(path).get("monitor")
    if not isinstance(mon, dict) or "ke" not in mon or "gt" not in mon:
        raise ConfigError(
            f"calibration file {path} must hold monitor.ke and monitor.gt, got {mon!r}"
        )
    return {
        f"monitor.{name}": check_quantity(f"monitor.{name}", mon[name], f"{path}: monitor.{name}")
        for name in ("ke", "gt")
    }


def write_calibration_file(
    path: str | Path, ke: float, gt: float, documentation: Mapping[str, Any]
) -> Path:
    """Write a calibration file whole or not at all (`documentation`: before, after, ...)."""
    path = Path(path)
    refuse_folder(path, "calibration")
    body = {
        "monitor": {"ke": float(ke), "gt": float(gt)},
        **documentation,
        "date": _dt.date.today().isoformat(),
    }
    return write_yaml_file(path, HEADER, body, what="calibration")
