#!/usr/bin/env python3
"""Two runs of bench_robust side by side, on the rows both have, judged with today's constants.

Usage (from the repo root):
    .venv/bin/python -m bench.studies.old_beside_new OLD.json NEW.json

Rows are matched by (population, unit seed, scenario); only those in both runs count.  Both
runs are judged with the package's interval scale and adequacy threshold as they are now
(`uncertainty.FOLLOWED_SCALE`, `adequacy.FOLLOWED_THRESHOLD` for recorded-loop rows), not
re-chosen, so a moved figure is the monitor's doing.  Per population (ideal, realistic):
fault windows and healthy windows, median and 90th-percentile %err, healthy WARN / ERROR,
fault windows withheld (not explained), missed (reported OK), right fault named at WARN or
above, and the 90 % coverage.  The commissioned factors of each unit beside each other.
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import numpy as np

from bench.bench_robust import _interval, verdict
from bench.harness import read_rows
from ema_phm.diagnosis import adequacy, health, uncertainty


def _key(row: dict) -> tuple:
    return (row["population"], row["unit_seed"], row["scenario"])


def _covered(row: dict, scale: float) -> tuple[int, int]:
    iv = _interval(row, scale)
    truth = np.asarray(row["k_true"], dtype=float)
    inside = (iv[:, 0] <= truth + 1e-9) & (truth - 1e-9 <= iv[:, 1])
    return int(inside.sum()), int(inside.size)


def figures(rows: list[dict]) -> dict[str, str]:
    """The compared figures of `rows` (one run, one population)."""
    scale, threshold = uncertainty.FOLLOWED_SCALE, adequacy.FOLLOWED_THRESHOLD
    fault = [r for r in rows if not r["scenario"].startswith("healthy")]
    healthy = [r for r in rows if r["scenario"].startswith("healthy")]
    vs = {id(r): verdict(r, scale, threshold) for r in rows}
    unexplained = [r for r in fault if r["adequacy_statistic"] > threshold]
    missed = [r for r in fault if vs[id(r)].level == health.OK]
    named = [
        r
        for r in fault
        if r["single_fault"] is not None
        and r["adequacy_statistic"] <= threshold
        and vs[id(r)].level >= health.WARN
        and vs[id(r)].dominant == r["single_fault"]
    ]
    singles = [r for r in fault if r["single_fault"] is not None]
    e = [r["percent_err"] for r in fault]
    cov = [_covered(r, scale) for r in fault]
    return {
        "fault windows": str(len(fault)),
        "median %err": f"{statistics.median(e):.2f}" if e else "-",
        "90th pct %err": f"{float(np.percentile(e, 90)):.2f}" if e else "-",
        "healthy windows": str(len(healthy)),
        "healthy not explained": f"{sum(r['adequacy_statistic'] > threshold for r in healthy)}",
        "healthy WARN": str(sum(vs[id(r)].level >= health.WARN for r in healthy)),
        "healthy ERROR": str(sum(vs[id(r)].level >= health.ERROR for r in healthy)),
        "fault windows withheld": str(len(unexplained)),
        "missed (OK)": str(len(missed)),
        "single faults named": f"{len(named)}/{len(singles)}",
        "90 % coverage": f"{sum(c[0] for c in cov)}/{sum(c[1] for c in cov)}",
    }


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__.split("Usage")[1].split("\n")[2].strip(), file=sys.stderr)
        return 2
    old, new = (read_rows(Path(p)) for p in sys.argv[1:3])
    keys = [{_key(r) for r in run["rows"] if "k" in r} for run in (old, new)]
    shared = keys[0] & keys[1]
    print(f"old: {old['command']}\nnew: {new['command']}\nrows in both: {len(shared)}\n")
    for population in ("ideal", "realistic"):
        pick = [
            sorted((r for r in run["rows"] if _key(r) in shared and r["population"] == population),
                   key=_key)
            for run in (old, new)
        ]  # fmt: skip
        if not pick[0]:
            continue
        a, b = figures(pick[0]), figures(pick[1])
        print(f"| {population} | old | new |\n|---|---:|---:|")
        for name in a:
            print(f"| {name} | {a[name]} | {b[name]} |")
        print()
    units = {u["unit_seed"]: u for u in new["units"]}
    print("| unit | old factors | new factors |\n|---:|---|---|")
    for u in old["units"]:
        if u["unit_seed"] in units:
            fo, fn = u["factors"], units[u["unit_seed"]]["factors"]
            print(
                f"| {u['unit_seed']} | "
                + ", ".join(f"{k} {v:.3f}" for k, v in fo.items())
                + " | "
                + ", ".join(f"{k} {v:.3f}" for k, v in fn.items())
                + " |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
