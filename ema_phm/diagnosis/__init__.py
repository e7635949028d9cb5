"""What we conclude from a window.

- `fitness`: how well a fault vector's LF prediction matches a window.
- `excitation`: whether a window excites the faults enough to be fitted.
- `isolation`: the optimizer presets that search the fault vector.
- `isolation_settings`: `FitSettings` (preset, seed, weighting, budget, nuisances), the one
  fit-settings type, and the live monitor's `IsolationSettings` over it.
- `isolation_worker`: one background thread that runs fits one at a time.
- `calibration`: fitting the LF model's nominal constants to a healthy calibration window.
- `commissioning`: fitting the monitor to one unit from its healthy recordings.
- `health`: turning an isolated fault vector into a health level and message.

Nothing here imports rclpy.
"""
