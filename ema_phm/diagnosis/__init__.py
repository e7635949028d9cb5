"""What we conclude from a window.

- `fitness`: how well a fault vector's LF prediction matches a window.
- `excitation`: whether a window excites the faults enough to be fitted.
- `isolation`: the optimizer presets that search the fault vector.
- `isolation_settings`: preset, seed, weighting, budget and health thresholds of a fit.
- `isolation_worker`: one background thread that runs fits one at a time.
- `calibration`: fitting the LF model's nominal constants to the HF.
- `health`: turning an isolated fault vector into a health level and message.
- `health_monitor`: the monitor node's decisions (telemetry in, what to publish out).
- `ground_truth`: the true fault vector over a window, as the simulated actuator announced it.
- `status_cause`: why the monitor's status is what it is, as data.

Nothing here imports rclpy.
"""
