"""What we conclude from a window.

- `fitness`: how well a fault vector's LF prediction matches a window.
- `excitation`: whether a window excites the faults enough to be fitted.
- `isolation`: the optimizer presets that search the fault vector.
- `calibration`: fitting the LF model's nominal constants to the HF.
- `health`: turning an isolated fault vector into a health level and message.

Nothing here imports rclpy.
"""
