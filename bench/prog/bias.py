"""Per-trajectory severity bias of the isolation: estimated over true severity, per fault.

For each degrading trajectory and each fault it grows, the median over its explained windows
with a true severity >= MIN_SEVERITY of (estimated severity / true severity - 1).  A bias
that differs from unit to unit is what the RUL model cannot correct (docs/severity_bias.md).
"""

from __future__ import annotations

import statistics

from bench.prog.plan import TYPE_FAULTS, TYPES
from ema_phm.domain.faults import NAMES, NOMINAL

#: Windows below this true severity are left out (their ratio is noise over a small number).
MIN_SEVERITY = 0.2


def per_trajectory(data: dict) -> dict[str, list[float]]:
    """Fault-history label ("friction", "multi_fault (eccentricity)", ...) -> biases [%]."""
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        if "k" in w and w.get("adequacy_ok", True):
            by_t.setdefault(int(w["trajectory"]), []).append(w)
    out: dict[str, list[float]] = {}
    for plan in data["plan"]:
        kind = plan["type"]
        if kind not in TYPES or kind == "healthy":
            continue
        for name in TYPE_FAULTS[kind]:
            i = NAMES.index(name)
            ratios = [
                abs(w["k"][i] - NOMINAL[i]) / abs(w["k_true"][i] - NOMINAL[i]) - 1.0
                for w in by_t.get(int(plan["index"]), [])
                if abs(w["k_true"][i] - NOMINAL[i]) >= MIN_SEVERITY
            ]
            label = kind if len(TYPE_FAULTS[kind]) == 1 else f"{kind} ({name})"
            if ratios:
                out.setdefault(label, []).append(100.0 * statistics.median(ratios))
    return out


def lines(data: dict) -> list[str]:
    """The report's section: per fault history, the per-trajectory biases and their range."""
    rows = [
        "",
        "## Per-trajectory severity bias",
        "",
        "Median over a trajectory's explained windows with true severity >= "
        f"{MIN_SEVERITY:g} of (estimated / true severity - 1), in %; target (issue 19): within "
        "+/-5 % for every trajectory.",
        "",
        "| fault history | trajectories | per trajectory | min | max | within +/-5 % |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for label, biases in per_trajectory(data).items():
        within = sum(abs(b) <= 5.0 for b in biases)
        rows.append(
            f"| {label} | {len(biases)} | {' '.join(f'{b:+.1f}' for b in biases)} | "
            f"{min(biases):+.1f} | {max(biases):+.1f} | {within}/{len(biases)} |"
        )
    return rows
