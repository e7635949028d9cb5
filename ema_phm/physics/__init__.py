"""What a datasheet says the actuator is, and the physics both sides share.

- `parameters`: the reader of `config/ema.yaml` (`ActuatorParameters`, immutable) and the
  packaged config folder.
- `actuator`: the typed parts of an actuator (motor, inverter, controller and its kind,
  mechanics, acquisition, HF-only) that `ActuatorParameters.motor`, ... return.
- `actuator_file`: actuator files (`load_actuator`, `write_actuator`; units in every key), the
  packaged thesis actuator `config/actuators/thesis_ema.yaml`.
- `commands`: position command and load torque profiles (the test command is the actuator's).
- `fault_vector`: the normalized fault vector k and its physical factors.
- `drivetrain`: compiled controller, Borello friction, backlash and end-stop steps (the LF's
  lumped shaft; the HF uses the controller, friction and end-stop steps).
- `signals`: the acquisition filter both models apply, and a recorded signal's noise.

The simulator (`ema_phm.simulator`) and the monitor's model (`ema_phm.model`) both build on
this package; it imports neither.  Nothing here imports rclpy.
"""
