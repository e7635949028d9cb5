"""Simulators of other code bases playing the actuator (bench/bench_external.py).

Benchmark-only: they import optional packages (requirements.txt's benchmark block, setup.py's
"bench" extra) that ema_phm never imports.
"""
