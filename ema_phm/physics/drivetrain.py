"""Compiled steps of the controller and the mechanics, used by both models.

- `controller`: the digital position/speed controller (the same device in both models).
- `friction_step`: one Borello dry-friction element (eq. 4.1): the LF applies it to its one
  lumped shaft, the HF to each of its two shafts (hf_drivetrain.py).
- `backlash`: the play operator the LF applies to the fed-back position (sec. 4.3); the HF's
  backlash is the dead zone of its compliant reducer instead (hf_drivetrain.py).
- `end_stops`: mechanical stops, on the LF's lumped (motor) angle and on the HF's user shaft.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, error_model="numpy")
def friction_step(w: float, t_act: float, fs: float, fd: float, dt_over_j: float) -> float:
    """Borello dry friction (eq. 4.1), one explicit step; returns the new speed."""
    if w == 0.0:
        if abs(t_act) <= fs:
            return 0.0
        return (t_act - math.copysign(fd, t_act)) * dt_over_j
    w_new = w + (t_act - math.copysign(fd, w)) * dt_over_j
    if w_new * w < 0.0:  # speed crossed zero inside the step: stick there
        return 0.0
    return w_new


@njit(cache=True, error_model="numpy")
def backlash(x: float, y: float, width: float) -> float:
    """Play operator: output y follows x once x leaves the band y +/- width/2."""
    h = 0.5 * width
    if x - y > h:
        return x - h
    if x - y < -h:
        return x + h
    return y


@njit(cache=True, error_model="numpy")
def end_stops(th: float, w: float, stop: float) -> tuple[float, float]:
    """Mechanical stops at +/-stop (the angle given): hold there, no speed into the stop."""
    if th > stop:
        th = stop
        if w > 0.0:  # noqa: PLR1730 - the kernels' branch form, kept for bit-identical results
            w = 0.0
    elif th < -stop:
        th = -stop
        if w < 0.0:  # noqa: PLR1730 - the kernels' branch form, kept for bit-identical results
            w = 0.0
    return th, w


@njit(cache=True, error_model="numpy")
def controller(  # noqa: PLR0917 - numba: positional only
    cmd: float,
    y: float,
    w: float,
    integ: float,
    e_prev: float,
    kpos: float,
    wmax: float,
    kp: float,
    ki: float,
    kd: float,
    tc: float,
    ktc: float,
    imax: float,
    wff: float,
) -> tuple[float, float, float]:
    """Position P loop (+ speed feed-forward wff) -> speed reference -> speed PID -> current.

    The speed reference is limited to +/-wmax, the current reference to +/-imax and
    divided by the controller's own torque gain ktc.  Returns (i_ref, integ, e_prev).
    """
    wref = kpos * (cmd - y) + wff
    if wref > wmax:
        wref = wmax
    elif wref < -wmax:
        wref = -wmax
    err = wref - w
    integ += err * tc
    iref = (kp * err + ki * integ + kd * (err - e_prev) / tc) / ktc
    if iref > imax:
        iref = imax
    elif iref < -imax:
        iref = -imax
    return iref, integ, err
