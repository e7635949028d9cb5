"""ROS 2 nodes around ema_phm (the only part of the package that imports rclpy).

- `ema_node`: the simulated "real" EMA (HF model) publishing telemetry.
- `monitor_node`: assembles windows, isolates faults, publishes health and diagnostics.
- `demo.run_demo`: both nodes in one process for one window (used by `ema-phm demo`).

Importing this package does not import rclpy; its modules do.
"""
