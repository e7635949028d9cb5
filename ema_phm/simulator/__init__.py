"""The simulated actuator: everything that plays the real EMA and its life.

- `real_ema`: the high-fidelity (HF) model of the PMSM-driven EMA (chapter 2, sec. 4.2-4.6).
- `hf_drivetrain`: its two shafts on a compliant reducer whose dead zone is the backlash.
- `sensors`: what its sensors get wrong (`SensorSpec`: gains, offsets, noise, quantization).
- `unit`: how one manufactured unit differs from its datasheet (`Unit.draw`, `Tolerances`).
- `degradation`: how faults grow over cycles, and the true end of life.
- `envelope`: the temperatures, loads and noise of a realistic flight and hangar.
- `actuator_stream`: the HF as an endless stream of telemetry (ema_node's logic).
- `pacing`: a simulated stream paced against the wall clock.

The monitor side (`model`, `diagnosis`, `monitor`, `prognostics`) never imports this package
(test/test_structure.py): the monitor reads only recordings and what a datasheet says.
"""
