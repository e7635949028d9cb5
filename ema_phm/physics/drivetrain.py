"""Pieces both models share because they describe one actuator and one controller.

They are the digital position/speed controller, Borello dry friction, backlash, end stops.

The models differ where the thesis makes them differ (electrical side: three phases
and a hysteresis inverter vs one R-L branch; integration step); these are the same
device in both: one rigid shaft, one lumped Borello friction, one backlash, the stops.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, error_model="numpy")
def friction_step(w, t_act, fs, fd, dt_over_j):
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
def backlash(x, y, width):
    """Play operator: output y follows x once x leaves the band y +/- width/2."""
    h = 0.5 * width
    if x - y > h:
        return x - h
    if x - y < -h:
        return x + h
    return y


@njit(cache=True, error_model="numpy")
def end_stops(th, w, stop):
    """Mechanical stops at +/-stop (motor angle): hold there, no speed into the stop."""
    if th > stop:
        th = stop
        if w > 0.0:
            w = 0.0
    elif th < -stop:
        th = -stop
        if w < 0.0:
            w = 0.0
    return th, w


@njit(cache=True, error_model="numpy")
def controller(cmd, y, w, integ, e_prev, kpos, wmax, kp, ki, kd, tc, ktc, imax):
    """Position P loop -> speed reference -> speed PID -> current reference.

    The speed reference is limited to +/-wmax, the current reference to +/-imax and
    divided by the controller's own torque gain ktc.  Returns (i_ref, integ, e_prev).
    """
    wref = kpos * (cmd - y)
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
