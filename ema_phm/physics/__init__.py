"""What the actuator is: parameters, commands, fault vector and the two models.

- `parameters`: the only reader of `config/ema.yaml` and calibration files: `ActuatorParameters`
  (what the simulated actuator is) and `MonitorBelief` (what the monitor believes), immutable.
- `commands`: position command and load torque profiles.
- `fault_vector`: the normalized fault vector k and its error measures.
- `real_ema`: the high-fidelity (HF) model that plays the real actuator.
- `monitor_model`: the low-fidelity (LF) model the monitor fits.
- `sensors`: the current-acquisition Butterworth both models apply.
- `drivetrain`: compiled controller, friction, backlash and end-stop steps used by both models.
- `actuator_stream`: the HF as an endless stream of telemetry messages (ema_node's logic).
- `pacing`: pacing a simulated stream against the wall clock.

Nothing here imports rclpy.
"""
