"""Drives with a PI current loop that the external benchmark and its studies share."""

from __future__ import annotations

from ema_phm.physics.actuator import PI_DQ_CURRENT
from ema_phm.physics.parameters import ActuatorParameters


def thesis_pi(bandwidth: float) -> ActuatorParameters:
    """The thesis actuator with a PI current loop in dq (every other value default()'s).

    Its monitor values set steps_per_sample 10 (an actuator file's monitor section would): the
    monitor runs the PI loop once per LF step, and the packaged 5 (100 us) is two of the
    thesis's 20 kHz control periods (the LF refuses it, monitor_model.py).
    """
    sections = ActuatorParameters.default().as_dict()
    sections["current_loop"] = {**sections["current_loop"], "bandwidth_hz": bandwidth}
    return ActuatorParameters.from_sections(
        sections,
        source=f"thesis actuator, {PI_DQ_CURRENT} {bandwidth:g} Hz (bench/harness/pi_drives.py)",
        controller_kind=PI_DQ_CURRENT,
        monitor_values={"monitor.steps_per_sample": 10.0},
    )


def noise_of(actuator: ActuatorParameters) -> dict[str, float]:
    """Sensor noise RMS, bench_robust's rules: 1 % of the current range, 5e-5 rad, 2.5 LSB.

    The speed noise is 2.5 resolver steps differentiated over one telemetry sample (0.48
    rad/s on the thesis actuator, bench_robust's 0.5).
    """
    return {
        "current": 0.01 * actuator.controller.max_current,
        "position": 5.0e-5,
        "speed": 2.5
        * actuator.high_fidelity.resolver_resolution
        * actuator.acquisition.sample_rate,
    }
