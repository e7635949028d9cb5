#!/usr/bin/env python3
"""Fit fingerprints: numbers a change that should move none must leave bit-identical.

Usage (repo root): .venv/bin/python -m bench.fingerprints [--out FILE.json]

Prints SHA-256 prefixes of three things a refactor must leave bit-identical on one machine:
an HF window (noise on every channel, a temperature), an LF batch of three fault vectors on
it, and a seeded global isolation with intervals (its k).  Run it before and after the change
on the same machine and compare (floats differ between machines: never compare across).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import numpy as np

from ema_phm.diagnosis.isolation import isolate
from ema_phm.model.monitor_model import MonitorModel
from ema_phm.simulator import real_ema

#: The window's true k and the LF batch's rows (arbitrary, fixed).
K = [0.1, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5]
BATCH = [K, [0.0] * 6 + [0.5, 0.5], [0.3, 0.1, 0.0, 0.0, 0.1, 0.0, 0.4, 0.6]]


def _digest(values: np.ndarray) -> str:
    data = np.ascontiguousarray(values, dtype=np.float64).tobytes()
    return hashlib.sha256(data).hexdigest()[:16]


def fingerprints() -> dict[str, object]:
    """The three fingerprints, and the isolated k for a reader."""
    window = real_ema.simulate(
        K, seed=3, noise_current=0.05, noise_position=5e-5, noise_speed=0.5, temperature_c=30.0
    ).window
    batch = MonitorModel(window).simulate_batch(np.array(BATCH))
    result = isolate(window, seed=1, intervals=True)
    return {
        "hf_window": _digest(window.matrix()),
        "lf_batch": _digest(batch),
        "isolate_k": _digest(np.asarray(result.k)),
        "k": [round(float(v), 12) for v in result.k],
    }


def main() -> int:
    """Print the fingerprints as JSON (and write them with --out)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="also write the JSON here")
    args = parser.parse_args()
    text = json.dumps(fingerprints(), indent=1)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
