"""Command line, benchmarks and plots.

- `cli`: the `ema-phm` command.
- `benchmark`: model speed and accuracy measurements.
- `plotting`: figures of windows and isolation results (matplotlib).

Nothing here imports rclpy except `ema-phm demo`, through `ema_phm.ros.demo`.
"""
