#!/usr/bin/env python3
"""The severity scale of the fault table (`Fault.severity_scale`) from bench_robust's raw rows.

Per fault with a RUL: over the realistic single-fault windows of that fault (severities
0.2-0.8, every unit), the median and the robust sd (1.4826 x MAD) of estimated severity /
true severity - 1.  The three short circuits share one scale (only phase A is benchmarked).

    .venv/bin/python -m bench.studies.severity_scale [bench/results/bench_robust_recorded.json]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from bench.harness import RESULTS
from ema_phm.domain.faults import NAMES, NOMINAL, SEVERITY_SCALE


def scales(rows: list[dict]) -> dict[str, tuple[float, float]]:
    """Fault name -> (median, robust sd) of estimate / truth - 1 (see the module doc)."""
    out = {}
    for i, name in enumerate(NAMES):
        ratios = []
        for r in rows:
            if r.get("population") != "realistic" or "k" not in r or r.get("single_fault") != i:
                continue
            true = abs(r["k_true"][i] - NOMINAL[i])
            if 0.2 <= true <= 0.8:
                ratios.append(abs(r["k"][i] - NOMINAL[i]) / true - 1.0)
        if ratios:
            med = float(np.median(ratios))
            out[name] = (med, float(1.4826 * np.median(np.abs(np.array(ratios) - med))))
    return out


def main() -> int:
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else RESULTS / "bench_robust_recorded.json"
    rows = json.loads(path.read_text())["rows"]
    for name, (med, sd) in scales(rows).items():
        now = SEVERITY_SCALE.get(name)
        print(f"{name:16s} median {med:+.3f}  robust sd {sd:.3f}   (fault table now: {now})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
