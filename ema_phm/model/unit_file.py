"""The unit file: a commissioned unit's belief, read and written here only.

Written by `ema-phm calibrate --baseline BAG ... --out FILE` (`diagnosis.commissioning`
fills it), read by `MonitorBelief.with_unit` and every command or node that takes a unit
file.  YAML with:

- `belief`: "section.name" of `physics.parameters.QUANTITIES` (monitor or physical sections)
  -> the value this unit's monitor believes;
- `warnings` (optional): what spoke against the unit when it was commissioned with --force;
  shown on every use;
- `commissioning`: how it was fitted (documentation; no reader depends on it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from ..atomic_file import refuse_folder, write_yaml_file
from ..errors import ConfigError
from ..physics.parameters import QUANTITIES, check_quantity, read_yaml

#: The unit file's header, above the commissioned unit's own warnings.
HEADER = (
    "# A commissioned unit: the monitor fitted to this actuator's healthy recordings\n"
    "# (`ema-phm calibrate --baseline BAG ... --out FILE`; diagnosis/commissioning.py).\n"
    "# `belief` overrides the actuator description's monitor belief; the rest documents\n"
    "# the fit.  factors multiply the description's values (a quantity it left unknown:\n"
    "# its range's geometric mean; `unknowns` gives it in its units); intervals are 90 %;\n"
    "# a factor flagged not identifiable was fitted but the baselines pin it to no better\n"
    "# than +/-10 %.\n"
)


def read_belief_values(path: str | Path, sections: Sequence[str]) -> dict[str, float]:
    """The `belief` of a unit file: "section.name" -> value, each checked, in `sections`."""
    path = Path(path)
    raw = read_yaml(path).get("belief")
    if not isinstance(raw, dict) or not raw:
        raise ConfigError(
            f"unit file {path} has no 'belief' mapping (write one with "
            f"`ema-phm calibrate --baseline BAG --out FILE`)"
        )
    changes: dict[str, float] = {}
    for name, value in raw.items():
        sec = str(name).split(".", 1)[0]
        if name not in QUANTITIES or sec not in sections:
            raise ConfigError(f"unit file {path}: unknown belief quantity {name!r}")
        changes[str(name)] = check_quantity(str(name), value, f"{path}: {name}")
    return changes


def read_warnings(path: str | Path) -> list[str]:
    """The `warnings` a unit file carries (commissioned with --force), each naming the file."""
    data = read_yaml(Path(path))
    raw = data.get("warnings") if isinstance(data, dict) else None
    if not raw:
        return []
    items = raw if isinstance(raw, list) else [raw]
    return [
        f"unit file {path} was commissioned despite: {' '.join(str(w).split())}" for w in items
    ]


def write_unit_file(
    path: str | Path,
    belief: Mapping[str, float],
    commissioning: Mapping[str, Any],
    *,
    warnings: Sequence[str] = (),
    warning_label: str = "WARNING",
) -> Path:
    """Write a unit file whole or not at all (a folder or a bad path: ConfigError)."""
    path = Path(path)
    refuse_folder(path, "unit")
    header = HEADER + "".join(f"# {warning_label}: {w}\n" for w in warnings)
    body: dict[str, Any] = {
        "belief": {k: float(v) for k, v in belief.items()},
        **({"warnings": list(warnings)} if warnings else {}),
        "commissioning": dict(commissioning),
    }
    return write_yaml_file(path, header, body, what="unit")
