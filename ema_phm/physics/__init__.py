"""What the actuator is: parameters, commands, fault vector and the two models.

- `parameters`: the only reader of `config/ema.yaml` and calibration files: `ActuatorParameters`
  (what the simulated actuator is) and `MonitorBelief` (what the monitor believes), immutable.
- `actuator`: the typed parts of an actuator (motor, inverter, controller and its kind,
  mechanics, acquisition, HF-only) that `ActuatorParameters.motor`, ... return.
- `actuator_file`: actuator files (`load_actuator`, `write_actuator`; units in every key), the
  packaged thesis actuator `config/actuators/thesis_ema.yaml`.
- `commands`: position command and load torque profiles.
- `fault_vector`: the normalized fault vector k and its error measures.
- `real_ema`: the high-fidelity (HF) model that plays the real actuator.
- `monitor_model`: the low-fidelity (LF) model the monitor fits.
- `unit`: how one manufactured unit differs from its datasheet, and its temperature.
- `sensors`: the HF's imperfect sensors (`SensorSpec`) and the acquisition Butterworth both
  models apply.
- `drivetrain`: compiled controller, Borello friction, backlash and end-stop steps (the LF's
  lumped shaft; the HF uses the controller, friction and end-stop steps).
- `hf_drivetrain`: the HF's two shafts on a compliant reducer whose dead zone is the backlash.
- `actuator_stream`: the HF as an endless stream of telemetry messages (ema_node's logic).
- `pacing`: pacing a simulated stream against the wall clock.

Nothing here imports rclpy.
"""
