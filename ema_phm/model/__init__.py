"""The monitor's model of the actuator: what it believes and how it predicts telemetry.

- `belief`: `MonitorBelief`, the monitor's picture of the actuator (datasheet sections,
  calibration, a commissioned unit file over them).
- `monitor_model`: the low-fidelity (LF) model (chapter 3) the monitor fits over k.
- `recorded_loop`: how the LF follows the recorded loop (the recorded position and shafts).

Built from `physics` (the actuator description both sides share); never from `simulator`.
"""
