"""Command line, benchmarks and plots.

- `cli`: the `ema-phm` command; it assembles the subcommands of `simulate`, `diagnose`
  (isolate, calibrate), `prognose`, `demo`, `play` and `fleet`, which share `args` (checked
  option types, option groups, the one-line parser and its help formatter) and `output`
  (text by default, one JSON object with --json).
- `prognose_report`, `prognose_plot`: what `ema-phm prognose` prints and draws.
- `benchmark`: model speed and accuracy measurements.
- `plotting`: figures of windows and isolation results (matplotlib).

Nothing here imports rclpy except `ema-phm demo` (without --offline), through
`ema_phm.ros.demo`, and `ema-phm play`, through `ema_phm.ros.player`.
"""
