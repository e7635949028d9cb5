"""Channels computed from other channels, when a rig does not record them.

- ``i3eq: {derive: park_q}``: the equivalent current from the three phase currents and the
  electrical angle theta_e (a recorded angle, or ``pole_pairs * theta_m``, plus
  ``angle_offset_rad``), as the drive's acquisition makes it (thesis sec. 2.1.8, eq. 2.2,
  amplitude invariant)::

      i_q = -(2/3) * (i_a sin(theta_e) + i_b sin(theta_e - 2 pi/3) + i_c sin(theta_e + 2 pi/3))

  then the acquisition's 2nd-order Butterworth low-pass at ``current_filter_Hz``
  (`physics.signals.filter_coefficients`), run at the phase currents' own rate.
- ``i3eq`` read as a drive's iq: times `channel_map.IQ_CONVENTIONS`' factor (1 for an
  amplitude-invariant iq, sqrt(2/3) for a power-invariant one, sqrt(2) for an RMS one).
- ``theta_m: {derive: through_gear}``: ``theta_u / gear_ratio``.  The backlash and the
  transmission's twist are then invisible (the two angles move as one).
- ``omega_m: {derive: rate_of_theta_m}``: the central difference of theta_m on the
  acquisition grid (`numpy.gradient`).
"""

# Heavy libraries are imported where used: `ema-phm --help` stays fast.
# ruff: noqa: PLC0415

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from ..physics.parameters import ActuatorParameters
from ..physics.signals import filter_coefficients
from .sources import Series

TWO_THIRDS_PI = 2.0 * math.pi / 3.0


def park_q(phases: tuple[Series, Series, Series], theta_e: Series) -> Series:
    """i_q (amplitude invariant) on phase A's times; the other series interpolated onto them.

    `theta_e` must be continuous (`unwrapped`, or `electrical_angle` of a continuous motor
    angle): it is interpolated as it is.
    """
    a = phases[0]
    t = a.t
    lo = max(s.t[0] for s in (*phases, theta_e))
    hi = min(s.t[-1] for s in (*phases, theta_e))
    keep = (t >= lo) & (t <= hi)
    t = t[keep]
    if t.size < 2:
        raise ConfigError("the phase currents and the angle do not overlap in time")
    ia = a.v[keep]
    ib = np.interp(t, phases[1].t, phases[1].v)
    ic = np.interp(t, phases[2].t, phases[2].v)
    th = np.interp(t, theta_e.t, theta_e.v)
    iq = -(2.0 / 3.0) * (
        ia * np.sin(th) + ib * np.sin(th - TWO_THIRDS_PI) + ic * np.sin(th + TWO_THIRDS_PI)
    )
    return Series(t=t, v=iq)


def acquisition_filtered(current: Series, actuator: ActuatorParameters) -> Series:
    """The drive's acquisition filter on a current computed at its own (median) rate."""
    from scipy.signal import lfilter, lfilter_zi

    dt = float(np.median(np.diff(current.t)))
    cutoff = actuator.acquisition.current_filter_hz
    if not 0.0 < cutoff < 0.5 / dt * (1.0 - 1e-6):  # at 2 x cutoff the filter is degenerate
        raise ConfigError(
            f"phase currents at {1.0 / dt:.6g} Hz cannot carry the acquisition filter at "
            f"{cutoff:g} Hz: record them faster than {2.0 * cutoff:g} Hz, or map i3eq to a "
            "current the drive has filtered"
        )
    b0, b1, b2, a1, a2 = filter_coefficients(cutoff, dt)
    # start at rest on the first value (no step from zero into the filter)
    b, a = [b0, b1, b2], [1.0, a1, a2]
    out, _ = lfilter(b, a, current.v, zi=lfilter_zi(b, a) * current.v[0])
    return Series(t=current.t, v=out)


def unwrapped(angle: Series) -> Series:
    """An angle logged within one turn made continuous (it must move less than pi per sample)."""
    return Series(t=angle.t, v=np.unwrap(angle.v))


def electrical_angle(theta_m: Series, actuator: ActuatorParameters, offset: float) -> Series:
    """theta_e = pole_pairs * theta_m + offset, the motor angle made continuous first.

    The mechanical angle is unwrapped, not the electrical one: between two samples the motor
    turns pole_pairs times less (a 500 Hz angle at 800 rad/s moves 1.6 rad mechanical, 3.2
    electrical, past the pi that unwrapping can tell from a wrap).
    """
    return Series(t=theta_m.t, v=actuator.motor.pole_pairs * np.unwrap(theta_m.v) + offset)


def through_gear(theta_u: Series, actuator: ActuatorParameters) -> Series:
    """The motor angle as the user angle through the gear: theta_u / gear_ratio."""
    return Series(t=theta_u.t, v=theta_u.v / actuator.mechanics.gear_ratio)


def rate_of(values: np.ndarray, dt: float) -> np.ndarray:
    """The time derivative of values sampled every dt (central differences)."""
    return np.gradient(values, dt)
