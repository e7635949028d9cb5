"""The benchmarks of ema_phm, run as modules from the repository root.

``python -m bench.<name>`` runs a regression benchmark (its report in docs/benchmarks*.md, its
raw rows in bench/results/) or a tool that makes packaged data (make_reference_bags: bags/;
healthy_level: an actuator file's ``monitor`` section); ``python -m bench.studies.<name>`` runs
a one-off study (bench/studies/).  Shared parts: harness (CLI, machine stamp, raw rows,
scenarios), prog (prognostics), fleet (the fleet benchmark), external (other simulators).
"""
