"""Physical parameters of the EMA, read from `config/ema.yaml` (+ calibration).

`load_params()` returns a nested dict of floats; the models turn it into the flat
arrays their compiled kernels take.  Files are found next to the package source
(development checkout) or under `share/ema_phm/config` (installed).
"""
from __future__ import annotations

import math
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from ..errors import ConfigError

_SECTIONS = ("motor", "inverter", "controller", "mechanics", "acquisition", "high_fidelity", "monitor")


def config_dir() -> Path:
    """The folder holding ema.yaml: repo checkout first, then the install prefix."""
    here = Path(__file__).resolve().parent.parent / "config"
    if (here / "ema.yaml").is_file():
        return here
    for prefix in (Path(sys.prefix), Path(sys.base_prefix)):
        cand = prefix / "share" / "ema_phm" / "config"
        if (cand / "ema.yaml").is_file():
            return cand
    try:  # colcon / ROS install
        from ament_index_python.packages import get_package_share_directory  # type: ignore
        cand = Path(get_package_share_directory("ema_phm")) / "config"
        if (cand / "ema.yaml").is_file():
            return cand
    except Exception:  # noqa: BLE001 - absent ament index is normal for pip users
        pass
    raise ConfigError(f"cannot find config/ema.yaml (looked in {here} and {sys.prefix}/share/ema_phm/config)")


def read_yaml(path: Path) -> dict[str, Any]:
    try:
        with open(path, encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except FileNotFoundError:
        raise ConfigError(f"config file not found: {path}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file {path} is not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path} must hold a mapping, got {type(data).__name__}")
    return data


def _number(val: Any, where: str) -> float:
    # PyYAML reads '1e5' (no dot, no sign) as a string: accept numeric strings too
    try:
        if isinstance(val, bool):
            raise ValueError
        out = float(val)
    except (TypeError, ValueError):
        raise ConfigError(f"{where} must be a finite number, got {val!r}") from None
    if not math.isfinite(out):
        raise ConfigError(f"{where} must be a finite number, got {val!r}")
    return out


def _check(params: dict[str, Any], path: Path) -> None:
    for sec in _SECTIONS:
        if not isinstance(params.get(sec), dict):
            raise ConfigError(f"{path}: section {sec!r} is missing")
        for key, val in params[sec].items():
            params[sec][key] = _number(val, f"{path}: {sec}.{key}")
    for sec, key in (("motor", "r_phase_to_phase"), ("motor", "l_phase_to_phase"), ("mechanics", "j_motor"),
                     ("acquisition", "sample_rate"), ("high_fidelity", "dt"), ("controller", "rate_hz"),
                     ("monitor", "steps_per_sample"), ("inverter", "vdc")):
        if params[sec][key] <= 0:
            raise ConfigError(f"{path}: {sec}.{key} must be > 0, got {params[sec][key]}")


@lru_cache(maxsize=8)
def _load(path_str: str, calibration_str: str) -> dict[str, Any]:
    path = Path(path_str)
    params = read_yaml(path)
    _check(params, path)
    cal = Path(calibration_str)
    if calibration_str and cal.is_file():
        data = read_yaml(cal)
        mon = data.get("monitor", {})
        for key in ("ke", "gt"):
            if key in mon:
                params["monitor"][key] = float(mon[key])
    return params


def load_params(path: str | Path | None = None, *, calibrated: bool = True) -> dict[str, Any]:
    """Parameters as nested dicts of floats (a fresh copy each call).

    With `calibrated`, the monitor's ke and gt come from calibration.yaml beside
    ema.yaml when that file exists (section 6.2).
    """
    base = Path(path) if path is not None else config_dir() / "ema.yaml"
    cal = base.with_name("calibration.yaml") if calibrated else Path("")
    loaded = _load(str(base), str(cal) if calibrated else "")
    return {sec: dict(vals) if isinstance(vals, dict) else vals for sec, vals in loaded.items()}


def clear_cache() -> None:
    _load.cache_clear()
