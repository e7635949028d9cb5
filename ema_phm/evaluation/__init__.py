"""Evaluation beside the monitor: scoring its answers against a ground truth.

Only here, in the simulator and in the tools that drive them is the truth read (a recording's
true k, a degradation description); the monitor side never imports this package.

- `truth`: true end of life of each fault and the prognostic metrics of a replay against it.
- `live_truth`: the live %err of each fit against /ema/ground_truth (eq. 6.4).
"""
