"""High-fidelity (HF) model: the "real EMA" of chapter 2 with the faults of chapter 4.

States (SI, at the motor shaft): motor angle theta_m and speed omega_m, user angle
theta_l = theta_u / tau and speed (separate bodies, hf_drivetrain.py), phase currents
i_A, i_B, i_C [A], inverter leg states (+/-1), speed-loop integral, last speed error,
current reference, I_3eq filter state (the controller's sensor readings are recomputed from
the shaft states at each interrupt).
Inputs: position command [rad, user], external load profile [N*m, user].
Outputs (at the telemetry rate): t, command, load, theta_u, theta_m, omega_m, I_3eq,
temperature, as the sensors read them (`sensors.SensorSpec`).
Parameters: `ActuatorParameters` (physics/parameters.py), passed in.

What it has that the monitor model (monitor_model.py) does not (docs/models.md):

- three stator phases with their own R, L and back-EMF (eqs. 4.3-4.7, per-phase short
  circuits), a floating neutral solved with each phase's own inductance, a hysteresis-PWM
  bridge fed by inverse Park/Clarke, torque summed from the phase currents;
- the Table 2.1 back-EMF constant 0.0752/2 (torque 0.0564 N*m/A), not the controller's gain;
- static eccentricity per phase from the air gap (sec. 4.5, `eccentricity_factors`);
- two inertias with their own damping and Borello friction, a compliant reducer with the
  backlash as its dead zone, end stops on the user shaft (hf_drivetrain.py);
- the signal acquisition of sec. 2.1.8 (Park transform eq. 2.2 of the measured phase
  currents, scaled by 2/3 so I_3eq is the phase amplitude; Butterworth filter) and
  imperfect sensors read by the loops (sensors.py);
- a spring load -spring * theta_u on the user shaft, and a load channel that may be
  unmeasured (NaN).

Everything is integrated at high_fidelity.dt (1 us); the controller runs at
controller.rate_hz, with the current loop of its kind (physics/actuator.py): the thesis's
hysteresis comparators on the phase currents, or a PI loop on the measured d and q currents
whose voltage, delayed by the computation (the inverse Park transform advanced by the angle
the rotor turns meanwhile, as drives do), reaches the phases through a sine-triangle PWM at
the control rate or an averaged inverter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import njit

from ..domain.faults import NOMINAL
from ..domain.window import CHANNELS, Window
from ..errors import ConfigError
from ..limits import check
from ..physics.actuator import (
    PI_DQ_CURRENT,
    current_loop_gains,
    feedforward_constants,
    voltage_limit,
)
from ..physics.commands import (
    CommandSpec,
    LoadSpec,
    calibration_spec,
    command_samples,
    default_specs,
    load_samples,
    sample_times,
)
from ..physics.drivetrain import controller
from ..physics.fault_vector import FaultVector
from ..physics.parameters import ActuatorParameters
from ..physics.signals import filter_coefficients
from .hf_drivetrain import mesh_damping, two_inertia_step
from .sensors import SensorSpec, quantize

SQ3_2 = math.sqrt(3.0) / 2.0

#: Mechanical angle of the axis of phases A, B, C [rad] (electrical 0, +2pi/3, -2pi/3 over
#: 2 pole pairs; phase B's back-EMF lags A's by 2pi/3 electrical).  See eccentricity_factors.
PHASE_AXES_ELECTRICAL = (0.0, 2.0 * math.pi / 3.0, -2.0 * math.pi / 3.0)

# Index of each entry of the flat parameter vector the kernel takes.
(
    P_DT,
    P_STEPS,
    P_CTRL_EVERY,
    P_POLES,
    P_RA,
    P_RB,
    P_RC,
    P_LA,
    P_LB,
    P_LC,
    P_KEA,
    P_KEB,
    P_KEC,
    P_ECC,
    P_PHI,
    P_VDC,
    P_HB,
    P_KPOS,
    P_WMAX,
    P_KP,
    P_KI,
    P_KD,
    P_IMAX,
    P_KTC,
    P_GEAR,
    P_JM,
    P_JU,
    P_CM,
    P_CU,
    P_FSM,
    P_FDM,
    P_FSU,
    P_FDU,
    P_KT,
    P_CT,
    P_HALF_GAP,
    P_STOP,
    P_SPRING,
    P_B0,
    P_B1,
    P_B2,
    P_A1,
    P_A2,
    P_CUR_GAIN,
    P_POS_OFF,
    P_SPD_GAIN,
    P_POS_RES,
    P_RES_RES,
    P_NOISE_POS,
    P_NOISE_SPD,
    P_KIND,
    P_CKP,
    P_CKI,
    P_DELAY,
    P_VMAX,
    P_EMF_FF,
    P_AW,
    P_PWM,
    P_LS_HAT,
    P_KE_HAT,
    P_SPD_FF,
    P_REF_A,
    P_NPAR,
) = range(63)

#: P_KIND of each controller kind (physics/actuator.py).
KIND_HYSTERESIS, KIND_PI_DQ = 0, 1


# Full resumable state of the HF model (indices into the state vector).
(
    S_TH,
    S_W,
    S_THL,
    S_WL,
    S_IA,
    S_IB,
    S_IC,
    S_SA,
    S_SB,
    S_SC,
    S_INT,
    S_EPREV,
    S_IREF,
    S_Z1,
    S_Z2,
    S_IQF,
    S_XD,
    S_XQ,
    S_VA,
    S_VB,
    S_VC,
    S_D1A,
    S_D1B,
    S_D1C,
    S_D2A,
    S_D2B,
    S_D2C,
    S_CMDF,
    S_NST,
) = range(29)

# Columns of the kernel's output (the phase currents as the current sensors read them).
O_THETA_U, O_THETA_M, O_OMEGA_M, O_I3EQ, O_LOAD, O_IA, O_IB, O_IC, O_NCOL = range(9)


def eccentricity_factors(theta_m: float, zeta: float, phi: float, amplitude: float) -> np.ndarray:
    """Back-EMF factor of phases A, B, C under static eccentricity (sec. 4.5).

    Sec. 4.5 gives the air gap under the rotor as g'(theta_r) = g0 + x0 cos(theta_r) and the
    HF law K_eA = K_eA C_eA (1 + zeta cos(theta_r)).  The magnet flux crossing a gap g is,
    for a gap small next to the magnet, proportional to 1/g, so to first order in
    zeta = x0/g0 (eq. 3.18) it is scaled by 1 + zeta cos(theta_r) with theta_r the rotor's
    mechanical angle from the SMALLEST gap -- the thesis's printed sign.  The eccentricity
    direction phi is k7 of sec. 5.5, "the direction of the minimum air gap" (here a
    mechanical angle: the full circle of k7 is one mechanical turn).  Phase i collects the
    flux at its own axis, at mechanical angle a_i = e_i / P (electrical axes e_i = 0,
    +2pi/3, -2pi/3 for A, B, C), so

        K_ei(theta_m) = K_e N_i (1 + A zeta cos(theta_m - phi - a_i)),

    A = high_fidelity.eccentricity_amplitude (1: the thesis's HF law as printed, not the
    LF's empirical 0.42 of eq. 3.22).  The modulation is at the MECHANICAL angle (the
    sub-harmonics of sec. 4.5), each phase shifted by its own axis.  Model limits, the
    thesis's too: the gap pattern turns with theta_r as in sec. 4.5's law (a gap fixed to
    the stator would give each phase a constant imbalance instead), and each phase's flux is
    read at one axis (diametrically opposite coil groups in series would cancel the
    first-order term).
    """
    poles = 2.0
    axes = np.array(PHASE_AXES_ELECTRICAL) / poles
    return 1.0 + amplitude * zeta * np.cos(theta_m - phi - axes)


def consistent_start_state(
    p: np.ndarray, theta_m: float = 0.0, omega_m: float = 0.0, i_q: float = 0.0
) -> np.ndarray:
    """The HF state vector (S_* indices) of a consistent start.

    Currents on their reference, the user shaft at the motor angle (no twist, the teeth
    centred in the backlash) and speed, filter settled on i_q.  Consistent with no load at
    t = 0 (under a load the reducer would start twisted by load/stiffness).
    """
    st = np.zeros(S_NST)
    te = p[P_POLES] * theta_m
    s, c = math.sin(te), math.cos(te)
    st[S_TH], st[S_W], st[S_THL], st[S_WL] = theta_m, omega_m, theta_m, omega_m
    st[S_IA], st[S_IB], st[S_IC] = (
        i_q * -s,
        i_q * (0.5 * s + SQ3_2 * c),
        i_q * (0.5 * s - SQ3_2 * c),
    )
    st[S_SA] = st[S_SB] = st[S_SC] = 1.0
    st[S_IREF] = i_q * p[P_CUR_GAIN]  # the comparators hold the MEASURED current on it
    st[S_Z1] = i_q - p[P_B0] * i_q
    st[S_Z2] = p[P_B2] * i_q - p[P_A2] * i_q
    st[S_IQF] = i_q
    if p[P_KIND] == KIND_PI_DQ:
        # the PI loop holding i_q: its integrals and the voltages in the delay line
        we = p[P_POLES] * omega_m
        vd = -we * p[P_LA] * i_q
        vq = p[P_RA] * i_q + p[P_KEA] * omega_m
        st[S_XD] = vd + p[P_EMF_FF] * we * p[P_LS_HAT] * i_q
        st[S_XQ] = vq - p[P_EMF_FF] * p[P_KE_HAT] * omega_m
        ua, ub, uc = -s, 0.5 * s + SQ3_2 * c, 0.5 * s - SQ3_2 * c
        da, db, dc = c, SQ3_2 * s - 0.5 * c, -(0.5 * c + SQ3_2 * s)
        v = (vd * da + vq * ua, vd * db + vq * ub, vd * dc + vq * uc)
        st[S_VA : S_VC + 1] = st[S_D1A : S_D1C + 1] = st[S_D2A : S_D2C + 1] = v
    return st


def settled_angle(p: np.ndarray, command: float) -> float:
    """Motor angle [rad] at which the position sensor reads `command`: a drive at rest holds it.

    The sensor reads gear * theta + its zero offset, so a unit whose sensor is offset rests
    off the command by that offset (its loop settled before the window), not at theta = 0;
    a command past an end stop rests at the stop.
    """
    stop = p[P_STOP]
    return min(stop, max(-stop, command - p[P_POS_OFF])) / p[P_GEAR]


@njit(cache=True, error_model="numpy")
def _high_fraction(r: float, x0: float, x1: float) -> float:
    """Share of a carrier segment going linearly from x0 to x1 that lies below r."""
    if x1 == x0:
        return 1.0 if r > x0 else 0.0
    f = (r - x0) / (x1 - x0) if x1 > x0 else (r - x1) / (x0 - x1)
    return min(1.0, max(0.0, f))


@njit(cache=True, error_model="numpy")
def pwm_leg(r: float, m0: float, m1: float) -> float:
    """Mean switched leg state (-1..1) of sine-triangle PWM over the period fraction m0..m1.

    r = v / vdc in [-1/2, 1/2]: the leg is high while r is above the carrier, a triangle over
    [-1/2, 1/2] that falls from its peak at m = 0 to its valley at m = 1/2 and rises back; the
    mean over a whole period is 2 r, exactly, whatever the integration step.
    """
    if m1 <= 0.5:
        f = _high_fraction(r, 0.5 - 2.0 * m0, 0.5 - 2.0 * m1)
    elif m0 >= 0.5:
        f = _high_fraction(r, 2.0 * m0 - 1.5, 2.0 * m1 - 1.5)
    else:  # the step holds the valley
        a, b = 0.5 - m0, m1 - 0.5
        f = (
            a * _high_fraction(r, 0.5 - 2.0 * m0, -0.5)
            + b * _high_fraction(r, -0.5, 2.0 * m1 - 1.5)
        ) / (a + b)
    return 2.0 * f - 1.0


@njit(cache=True, nogil=True, error_model="numpy")  # nogil: ema_node serves meanwhile
def hf_kernel(  # noqa: PLR0912, PLR0915 - one numba loop
    p: np.ndarray, com: np.ndarray, load: np.ndarray, noise: np.ndarray, st: np.ndarray
) -> np.ndarray:
    """Integrate the HF model over the samples of `com`/`load` from state `st`.

    p: flat parameters (P_* indices); com, load: samples at the telemetry rate (load: the
    profile at the user shaft, the spring moment is added here); noise: standard normals
    (rows, ticks, 2) for the position and speed readings at each control interrupt of each
    sample (indexed modulo its shape, so one (1, 1, 2) row of zeros serves a noise-free run);
    st: full state (S_* indices) at the first sample, updated in place to the state at the
    last sample, so consecutive calls continue one run.
    Returns (n, O_NCOL): the readings of theta_u, theta_m, omega_m, I_3eq (filtered, gain
    applied; offset and noise are added by the caller), the total load at the user shaft and
    the three phase currents (gain applied, before the acquisition).
    """
    n = com.shape[0]
    out = np.empty((n, O_NCOL))
    dt = p[P_DT]
    steps = int(p[P_STEPS])
    ctrl_every = int(p[P_CTRL_EVERY])
    tc = dt * ctrl_every
    poles = p[P_POLES]
    ra, rb, rc = p[P_RA], p[P_RB], p[P_RC]
    ga, gb, gc = 1.0 / p[P_LA], 1.0 / p[P_LB], 1.0 / p[P_LC]
    gsum = ga + gb + gc
    kea, keb, kec = p[P_KEA], p[P_KEB], p[P_KEC]
    ecc = p[P_ECC]
    # cos(theta_m - phi - a_i) = cm * cos(phi + a_i) + sm * sin(phi + a_i)
    eac, eas = math.cos(p[P_PHI]), math.sin(p[P_PHI])
    ebc, ebs = math.cos(p[P_PHI] + math.pi / 3.0), math.sin(p[P_PHI] + math.pi / 3.0)
    ecc_, ecs = math.cos(p[P_PHI] - math.pi / 3.0), math.sin(p[P_PHI] - math.pi / 3.0)
    vh = 0.5 * p[P_VDC]
    hb = 0.5 * p[P_HB]
    kpos, wmax, kp, ki, kd = p[P_KPOS], p[P_WMAX], p[P_KP], p[P_KI], p[P_KD]
    imax, ktc, gear = p[P_IMAX], p[P_KTC], p[P_GEAR]
    mech = (
        dt / p[P_JM],
        dt / p[P_JU],
        p[P_CM],
        p[P_CU],
        p[P_FSM],
        p[P_FDM],
        p[P_FSU],
        p[P_FDU],
        p[P_KT],
        p[P_CT],
        p[P_HALF_GAP],
        p[P_STOP] / gear,
    )
    spring = p[P_SPRING]
    b0, b1, b2, a1, a2 = p[P_B0], p[P_B1], p[P_B2], p[P_A1], p[P_A2]
    cgain, pos_off, sgain = p[P_CUR_GAIN], p[P_POS_OFF], p[P_SPD_GAIN]
    pos_res, res_res = p[P_POS_RES], p[P_RES_RES]
    npos, nspd = p[P_NOISE_POS], p[P_NOISE_SPD]
    nr, nt = noise.shape[0], noise.shape[1]
    pi_dq = p[P_KIND] == KIND_PI_DQ
    ckp, cki_tc, vmax = p[P_CKP], p[P_CKI] * tc, p[P_VMAX]
    delay, emf_ff, aw, pwm = int(p[P_DELAY]), p[P_EMF_FF], p[P_AW], p[P_PWM] != 0.0
    ls_hat, ke_hat = p[P_LS_HAT], p[P_KE_HAT]
    wff_per_rad = p[P_SPD_FF] / (gear * dt * steps)  # command rate -> motor speed reference
    ref_a = p[P_REF_A]
    # the phase with the smallest inductance is the dependent one (i_A+i_B+i_C = 0)
    dep = 0
    if p[P_LB] < p[P_LA] and p[P_LB] <= p[P_LC]:
        dep = 1
    elif p[P_LC] < p[P_LA] and p[P_LC] < p[P_LB]:
        dep = 2

    th, w, thl, wl = st[S_TH], st[S_W], st[S_THL], st[S_WL]
    ia, ib, ic = st[S_IA], st[S_IB], st[S_IC]
    sa, sb, sc = st[S_SA], st[S_SB], st[S_SC]
    integ, e_prev, iref = st[S_INT], st[S_EPREV], st[S_IREF]
    z1, z2, iqf = st[S_Z1], st[S_Z2], st[S_IQF]
    xd, xq, cmdf = st[S_XD], st[S_XQ], st[S_CMDF]
    va, vb, vc = st[S_VA], st[S_VB], st[S_VC]
    d1a, d1b, d1c = st[S_D1A], st[S_D1B], st[S_D1C]
    d2a, d2b, d2c = st[S_D2A], st[S_D2B], st[S_D2C]
    s, c, sm, cm = 0.0, 1.0, 0.0, 1.0
    for i in range(n):
        # sensor readings at the sample instant (the control interrupt of tick 0 reads these)
        y_pos = quantize(gear * thl + pos_off, pos_res) + npos * noise[i % nr, 0, 0]
        y_spd = sgain * w + nspd * noise[i % nr, 0, 1]
        l_tot = load[i] + spring * gear * thl
        out[i, O_THETA_U] = y_pos
        out[i, O_THETA_M] = quantize(th, res_res)
        out[i, O_OMEGA_M] = y_spd
        out[i, O_I3EQ] = cgain * iqf
        out[i, O_LOAD] = l_tot
        out[i, O_IA], out[i, O_IB], out[i, O_IC] = cgain * ia, cgain * ib, cgain * ic
        if i == n - 1:
            break
        c0, c1 = com[i], com[i + 1]
        l0, l1 = load[i], load[i + 1]
        tl = gear * l_tot
        for j in range(steps):
            # the load (profile + hinge spring) is physics: updated every step
            tl = gear * (l0 + (l1 - l0) * (j / steps) + spring * gear * thl)
            if j % ctrl_every == 0:
                # control interrupt: exact trig (also renormalizes the rotations below)
                tick = j // ctrl_every
                te = poles * th
                s, c = math.sin(te), math.cos(te)
                sm, cm = math.sin(th), math.cos(th)
                frac = j / steps
                cmd = c0 + (c1 - c0) * frac
                if tick > 0:
                    y_pos = quantize(gear * thl + pos_off, pos_res)
                    y_pos += npos * noise[i % nr, tick % nt, 0]
                    y_spd = sgain * w + nspd * noise[i % nr, tick % nt, 1]
                if ref_a > 0.0:  # 1st-order filter on the position reference
                    cmdf += ref_a * (cmd - cmdf)
                    cmd = cmdf
                iref, integ, e_prev = controller(
                    cmd,
                    y_pos,
                    y_spd,
                    integ,
                    e_prev,
                    kpos,
                    wmax,
                    kp,
                    ki,
                    kd,
                    tc,
                    ktc,
                    imax,
                    wff_per_rad * (c1 - c0),
                )
                if pi_dq:
                    # PI on the measured d and q currents (Park at this interrupt's angle)
                    ua = -s
                    ub = 0.5 * s + SQ3_2 * c
                    uc = 0.5 * s - SQ3_2 * c
                    idm = (
                        cgain
                        * (2.0 / 3.0)
                        * (ia * c + ib * (SQ3_2 * s - 0.5 * c) - ic * (0.5 * c + SQ3_2 * s))
                    )
                    iqm = cgain * (2.0 / 3.0) * (ia * ua + ib * ub + ic * uc)
                    we = poles * y_spd
                    ed, eq = -idm, iref - iqm
                    vd = ckp * ed + xd - emf_ff * we * ls_hat * iqm
                    vq = ckp * eq + xq + emf_ff * (we * ls_hat * idm + ke_hat * y_spd)
                    mag = math.sqrt(vd * vd + vq * vq)
                    cut = vmax / mag if mag > vmax else 1.0
                    xd += cki_tc * ed + aw * (cut - 1.0) * vd
                    xq += cki_tc * eq + aw * (cut - 1.0) * vq
                    vd *= cut
                    vq *= cut
                    # the rotor turns while the voltage waits and is held: the usual angle
                    # advance of (delay + 1/2) periods in the inverse Park transform
                    adv = we * (delay + 0.5) * tc
                    ca, sa_ = math.cos(adv), math.sin(adv)
                    vd, vq = vd * ca - vq * sa_, vd * sa_ + vq * ca
                    # phase voltages (inverse Park), min-max zero sequence, inside the bridge
                    na_ = vd * c + vq * ua
                    nb_ = vd * (SQ3_2 * s - 0.5 * c) + vq * ub
                    nc_ = -vd * (0.5 * c + SQ3_2 * s) + vq * uc
                    v0 = -0.5 * (max(na_, nb_, nc_) + min(na_, nb_, nc_))
                    na_ = min(vh, max(-vh, na_ + v0))
                    nb_ = min(vh, max(-vh, nb_ + v0))
                    nc_ = min(vh, max(-vh, nc_ + v0))
                    # the computation delay: applied `delay` interrupts later
                    if delay == 0:
                        va, vb, vc = na_, nb_, nc_
                    elif delay == 1:
                        va, vb, vc = d1a, d1b, d1c
                        d1a, d1b, d1c = na_, nb_, nc_
                    else:
                        va, vb, vc = d2a, d2b, d2c
                        d2a, d2b, d2c = d1a, d1b, d1c
                        d1a, d1b, d1c = na_, nb_, nc_
            ua = -s
            ub = 0.5 * s + SQ3_2 * c
            uc = 0.5 * s - SQ3_2 * c
            if pi_dq:
                if pwm:
                    # sine-triangle PWM at the control rate (the interrupt at the carrier's
                    # peak): each leg's mean over this step, so the edges fall between steps
                    m0 = (j % ctrl_every) / ctrl_every
                    m1 = m0 + 1.0 / ctrl_every
                    sa = pwm_leg(va / (2.0 * vh), m0, m1)
                    sb = pwm_leg(vb / (2.0 * vh), m0, m1)
                    sc = pwm_leg(vc / (2.0 * vh), m0, m1)
                else:  # averaged inverter: the legs' mean output over a period
                    sa, sb, sc = va / vh, vb / vh, vc / vh
            else:
                # inverse Park/Clarke of the reference; hysteresis on the MEASURED currents
                d = iref * ua - cgain * ia
                if d > hb:
                    sa = 1.0
                elif d < -hb:
                    sa = -1.0
                d = iref * ub - cgain * ib
                if d > hb:
                    sb = 1.0
                elif d < -hb:
                    sb = -1.0
                d = iref * uc - cgain * ic
                if d > hb:
                    sc = 1.0
                elif d < -hb:
                    sc = -1.0
            # back-EMF coefficients with static eccentricity per phase (eccentricity_factors)
            ka = kea * (1.0 + ecc * (cm * eac + sm * eas)) * ua
            kb = keb * (1.0 + ecc * (cm * ebc + sm * ebs)) * ub
            kc = kec * (1.0 + ecc * (cm * ecc_ + sm * ecs)) * uc
            fa = vh * sa - ra * ia - ka * w
            fb = vh * sb - rb * ib - kb * w
            fc = vh * sc - rc * ic - kc * w
            vn = (ga * fa + gb * fb + gc * fc) / gsum  # floating neutral, own inductances
            tm = ka * ia + kb * ib + kc * ic
            if dep == 0:
                ib += (fb - vn) * gb * dt
                ic += (fc - vn) * gc * dt
                ia = -ib - ic
            elif dep == 1:
                ia += (fa - vn) * ga * dt
                ic += (fc - vn) * gc * dt
                ib = -ia - ic
            else:
                ia += (fa - vn) * ga * dt
                ib += (fb - vn) * gb * dt
                ic = -ia - ib
            # mechanics: two shafts, compliant reducer with play, end stops on the user shaft
            th, w, thl, wl = two_inertia_step(th, w, thl, wl, tm, tl, mech, dt)
            # rotate (s, c) by the electrical and (sm, cm) by the mechanical increment
            dm = w * dt
            de = poles * dm
            cd = 1.0 - 0.5 * de * de
            sd = de - de * de * de / 6.0
            s, c = s * cd + c * sd, c * cd - s * sd
            cd = 1.0 - 0.5 * dm * dm
            sd = dm - dm * dm * dm / 6.0
            sm, cm = sm * cd + cm * sd, cm * cd - sm * sd
            # signal acquisition: Park transform (eq. 2.2, amplitude invariant) + LPF
            iq = (2.0 / 3.0) * (ia * ua + ib * ub + ic * uc)
            iqf = b0 * iq + z1
            z1 = b1 * iq - a1 * iqf + z2
            z2 = b2 * iq - a2 * iqf
    st[S_TH], st[S_W], st[S_THL], st[S_WL] = th, w, thl, wl
    st[S_IA], st[S_IB], st[S_IC] = ia, ib, ic
    st[S_SA], st[S_SB], st[S_SC] = sa, sb, sc
    st[S_INT], st[S_EPREV], st[S_IREF] = integ, e_prev, iref
    st[S_Z1], st[S_Z2], st[S_IQF] = z1, z2, iqf
    st[S_XD], st[S_XQ], st[S_CMDF] = xd, xq, cmdf
    st[S_VA], st[S_VB], st[S_VC] = va, vb, vc
    st[S_D1A], st[S_D1B], st[S_D1C] = d1a, d1b, d1c
    st[S_D2A], st[S_D2B], st[S_D2C] = d2a, d2b, d2c
    return out


def _step_counts(actuator: ActuatorParameters) -> tuple[float, int, int]:
    """dt, HF steps per telemetry sample and per control interrupt; ConfigError if not whole."""
    dt = actuator.high_fidelity.dt
    ts = 1.0 / actuator.acquisition.sample_rate
    tcontrol = 1.0 / actuator.controller.rate_hz
    steps, ctrl = ts / dt, tcontrol / dt
    if abs(steps - round(steps)) > 1e-6 or abs(ctrl - round(ctrl)) > 1e-6:
        raise ConfigError(
            f"high_fidelity.dt={dt} must divide the sample period {ts} and the control period "
            f"{tcontrol}"
        )
    if round(steps) % round(ctrl) != 0:
        raise ConfigError(
            f"the control period {tcontrol} s must divide the sample period {ts} s "
            f"(controller.rate_hz, acquisition.sample_rate)"
        )
    return dt, round(steps), round(ctrl)


def _electrical_parameters(p: np.ndarray, fv: FaultVector, actuator: ActuatorParameters) -> None:
    """Fill the motor, inverter and controller entries of `p` (eqs. 4.3-4.7, R/L typo fixed)."""
    mo, inv, co = actuator.motor, actuator.inverter, actuator.controller
    p[P_POLES] = mo.pole_pairs
    # eqs. 4.6-4.7 as printed divide by N_i; fewer working turns must *lower* R and L,
    # so R_i = N_i Rs/2 and L_i = N_i^2 Ls/2 (and K_ei = N_i K_e, eq. 4.3).
    n = np.maximum(fv.coils, mo.min_working_coils)
    p[P_RA : P_RC + 1] = n * mo.r_phase_to_phase / 2.0
    p[P_LA : P_LC + 1] = n**2 * mo.l_phase_to_phase / 2.0
    p[P_KEA : P_KEC + 1] = n * mo.ke_phase_peak
    p[P_ECC] = actuator.high_fidelity.eccentricity_amplitude * fv.zeta
    p[P_PHI] = fv.phi  # mechanical direction of the eccentricity (eccentricity_factors)
    p[P_VDC], p[P_HB] = inv.vdc, inv.hysteresis_band
    p[P_KPOS] = co.position_gain * fv.gain_factor
    p[P_WMAX] = co.max_speed_rpm * 2.0 * math.pi / 60.0
    p[P_KP], p[P_KI], p[P_KD] = co.speed_kp, co.speed_ki, co.speed_kd
    p[P_IMAX], p[P_KTC] = co.max_current, co.torque_gain
    _current_loop_parameters(p, actuator)


def _current_loop_parameters(p: np.ndarray, actuator: ActuatorParameters) -> None:
    """Fill the kind, PI current loop, feed-forward and reference-filter entries of `p`.

    The loop's gains and feed-forward constants are the drive's own, from the datasheet motor
    of the actuator file: a fault changes the motor, never them.
    """
    co, loop, mo = actuator.controller, actuator.current_loop, actuator.motor
    tc = 1.0 / co.rate_hz
    p[P_KIND] = KIND_PI_DQ if co.kind == PI_DQ_CURRENT else KIND_HYSTERESIS
    p[P_CKP], p[P_CKI] = current_loop_gains(mo, loop)
    p[P_DELAY], p[P_VMAX] = loop.delay_periods, voltage_limit(loop, actuator.inverter)
    p[P_EMF_FF], p[P_AW], p[P_PWM] = loop.emf_feedforward, loop.anti_windup, loop.pwm
    p[P_LS_HAT], p[P_KE_HAT] = feedforward_constants(mo, loop)
    p[P_SPD_FF] = co.speed_feedforward
    f = co.reference_filter_hz
    p[P_REF_A] = 1.0 - math.exp(-2.0 * math.pi * f * tc) if f > 0.0 else 0.0


def _mechanical_parameters(p: np.ndarray, fv: FaultVector, actuator: ActuatorParameters) -> None:
    """Fill the two-shaft entries of `p`, everything at the motor shaft (hf_drivetrain.py)."""
    me, hf = actuator.mechanics, actuator.high_fidelity
    gear = me.gear_ratio
    p[P_GEAR] = gear
    p[P_JM], p[P_JU] = me.j_motor, me.j_user
    p[P_CM], p[P_CU] = me.c_motor, me.c_user
    # the friction fault scales the dry friction of both shafts, as the thesis's does
    p[P_FSM] = fv.friction_factor * me.friction_static_motor
    p[P_FDM] = fv.friction_factor * me.friction_dynamic_motor
    p[P_FSU] = fv.friction_factor * me.friction_static_user
    p[P_FDU] = fv.friction_factor * me.friction_dynamic_user
    p[P_KT] = hf.torsional_stiffness * gear * gear
    p[P_CT] = mesh_damping(p[P_KT], p[P_JM], p[P_JU], hf.torsional_damping_ratio)
    p[P_HALF_GAP] = 0.5 * me.backlash * fv.backlash_factor / gear
    p[P_STOP] = me.end_stop


def hf_parameters(
    fv: FaultVector,
    actuator: ActuatorParameters,
    *,
    sensors: SensorSpec | None = None,
    spring: float = 0.0,
) -> np.ndarray:
    """Flat kernel parameters (P_* indices) of `actuator` in fault state `fv`.

    Built from the actuator's typed parts (physics/actuator.py), for either controller kind.
    `sensors` (default: ideal) gives the gains, offset and noise levels the loops read;
    `spring` [N*m/rad at the user shaft] the load's spring moment -spring * theta_u.
    """
    sensors = sensors or SensorSpec()
    dt, steps, ctrl = _step_counts(actuator)
    p = np.zeros(P_NPAR)
    p[P_DT], p[P_STEPS], p[P_CTRL_EVERY] = dt, steps, ctrl
    _electrical_parameters(p, fv, actuator)
    _mechanical_parameters(p, fv, actuator)
    p[P_SPRING] = spring
    p[P_B0 : P_A2 + 1] = filter_coefficients(actuator.acquisition.current_filter_hz, dt)
    p[P_CUR_GAIN], p[P_POS_OFF] = sensors.current_gain, sensors.position_offset
    p[P_SPD_GAIN] = sensors.speed_gain
    p[P_POS_RES] = actuator.high_fidelity.position_resolution
    p[P_RES_RES] = actuator.high_fidelity.resolver_resolution
    p[P_NOISE_POS], p[P_NOISE_SPD] = sensors.noise_position, sensors.noise_speed
    return p


def resolve_sensors(sensors: SensorSpec | None, noise: tuple[float, float, float]) -> SensorSpec:
    """`sensors`, or an ideal SensorSpec with the `noise_*` shortcut levels (not both)."""
    if sensors is None:
        nc, npos, nspd = noise
        return SensorSpec(noise_current=nc, noise_position=npos, noise_speed=nspd)
    if any(noise):
        raise ConfigError(
            "give the noise either in sensors= or as noise_current/noise_position/noise_speed, "
            f"not both (got sensors={sensors} and noise {noise})"
        )
    return sensors


def _check_run_options(
    command: CommandSpec,
    actuator: ActuatorParameters,
    *,
    seed: int | None,
    temperature_c: float | None,
) -> int | None:
    """The seed as an int, or ConfigError naming a seed, command or temperature it cannot use."""
    command.check_sample_rate(actuator.acquisition.sample_rate)
    if temperature_c is not None and (
        isinstance(temperature_c, bool)
        or not isinstance(temperature_c, (int, float))
        or not math.isfinite(temperature_c)
    ):
        raise ConfigError(f"temperature_c must be a finite number or None, got {temperature_c!r}")
    return None if seed is None else int(check("seed", seed))


def _loop_noise(
    rng: np.random.Generator, sensors: SensorSpec, rows: int, ticks: int
) -> np.ndarray:
    """Standard normals for the loop readings, or one zero row when the loops read no noise."""
    if not (sensors.noise_position or sensors.noise_speed):
        return np.zeros((1, 1, 2))
    return rng.standard_normal((rows, ticks, 2))


def _measured_current(
    i3eq: np.ndarray, sensors: SensorSpec, rng: np.random.Generator
) -> np.ndarray:
    """The I_3eq channel: the acquired current plus the channel's offset and noise."""
    out = i3eq + sensors.current_offset
    if sensors.noise_current:
        out = out + sensors.noise_current * rng.standard_normal(i3eq.shape)
    return out


def _load_channel(total: np.ndarray, load: LoadSpec) -> np.ndarray:
    """The load channel: the total load at the user shaft, or NaN when it is not measured."""
    return total.copy() if getattr(load, "measured", True) else np.full_like(total, np.nan)


def _temperature_channel(n: int, temperature_c: float | None) -> np.ndarray:
    """The measured temperature channel [degC]: constant, or NaN when unknown."""
    return np.full(n, np.nan if temperature_c is None else float(temperature_c))


@dataclass(frozen=True)
class HFResult:
    """What one HF run returns: its telemetry window (with k_true).

    `phase_currents`: (n, 3) phases A, B, C at the window's samples, as the current sensors
    read them before the drive's acquisition turns them into I_3eq (gain, no noise), for a
    rig that logs them instead (`ema-phm import`'s ``park_q``).
    """

    window: Window
    phase_currents: np.ndarray | None = None


@dataclass(frozen=True)
class _Run:
    """The validated inputs of one HF run."""

    fv: FaultVector
    actuator: ActuatorParameters
    command: CommandSpec
    load: LoadSpec
    sensors: SensorSpec
    seed: int | None
    temperature_c: float | None


def _prepare_run(
    k: Sequence[float] | np.ndarray,
    *,
    actuator: ActuatorParameters | None,
    command: CommandSpec | None,
    load: LoadSpec | None,
    sensors: SensorSpec | None,
    noise: tuple[float, float, float],
    seed: int | None,
    temperature_c: float | None,
) -> _Run:
    """Defaults filled in and every option checked (ConfigError / FaultVectorError naming it)."""
    actuator = actuator or ActuatorParameters.default()
    default_command, default_load = default_specs()
    command, load = command or default_command, load or default_load
    seed = _check_run_options(command, actuator, seed=seed, temperature_c=temperature_c)
    return _Run(
        fv=FaultVector.from_k(k),
        actuator=actuator,
        command=command,
        load=load,
        sensors=resolve_sensors(sensors, noise),
        seed=seed,
        temperature_c=temperature_c,
    )


def _window_of(
    run: _Run, t: np.ndarray, com: np.ndarray, out: np.ndarray, rng: np.random.Generator
) -> Window:
    """The telemetry window of one run from the kernel's output."""
    meta = {
        "source": "ema_phm.simulator.real_ema",
        "sample_rate": run.actuator.acquisition.sample_rate,
        "command": run.command.as_dict(),
        "load": run.load.as_dict(),
        "seed": run.seed,
        "sensors": run.sensors.as_dict(),
        "temperature_c": run.temperature_c,
        # the shortcuts' names, kept for readers of older windows' metadata
        "noise_current": run.sensors.noise_current,
        "noise_position": run.sensors.noise_position,
        "noise_speed": run.sensors.noise_speed,
    }
    return Window(
        t=t,
        command=com,
        load=_load_channel(out[:, O_LOAD], run.load),
        theta_u=out[:, O_THETA_U].copy(),
        theta_m=out[:, O_THETA_M].copy(),
        omega_m=out[:, O_OMEGA_M].copy(),
        i3eq=_measured_current(out[:, O_I3EQ], run.sensors, rng),
        k_true=run.fv.k.copy(),
        meta=meta,
        temperature=_temperature_channel(t.size, run.temperature_c),
    )


def simulate(
    k: Sequence[float] | np.ndarray,
    *,
    actuator: ActuatorParameters | None = None,
    command: CommandSpec | None = None,
    load: LoadSpec | None = None,
    sensors: SensorSpec | None = None,
    seed: int | None = 0,
    noise_current: float = 0.0,
    noise_position: float = 0.0,
    noise_speed: float = 0.0,
    temperature_c: float | None = None,
    x0: tuple[float, float, float] | None = None,
    compiled: bool = True,
) -> HFResult:
    """Run the HF model of `actuator` (default: ActuatorParameters.default()) for one window.

    `sensors` (default: ideal, apart from the position and resolver resolutions of the
    actuator's high_fidelity section) says what the sensors get wrong; `noise_*` are
    shortcuts for an otherwise ideal SensorSpec with those RMS levels (not with `sensors`).
    Noise is drawn from `numpy.random.default_rng(seed)`.  `temperature_c` fills the
    measured temperature channel (None: NaN); it does not change the physics (the caller
    gives the actuator its parameters at that temperature).  x0 is the start (theta_m
    [rad], omega_m [rad/s], i_q [A]); None: at rest where the position loop holds the first
    command (`settled_angle`).  `compiled=False` runs the same kernel as plain Python (slow;
    for cross-checks).
    """
    run = _prepare_run(
        k,
        actuator=actuator,
        command=command,
        load=load,
        sensors=sensors,
        noise=(noise_current, noise_position, noise_speed),
        seed=seed,
        temperature_c=temperature_c,
    )
    t = sample_times(run.command.duration, run.actuator.acquisition.sample_rate)
    com = command_samples(run.command, t)
    p = hf_parameters(
        run.fv, run.actuator, sensors=run.sensors, spring=getattr(run.load, "spring", 0.0)
    )
    rng = np.random.default_rng(run.seed)
    noise = _loop_noise(rng, run.sensors, t.size, int(p[P_STEPS] // p[P_CTRL_EVERY]))
    kern = hf_kernel if compiled else hf_kernel.py_func
    st = consistent_start_state(p, *((settled_angle(p, com[0]), 0.0, 0.0) if x0 is None else x0))
    st[S_CMDF] = com[0]  # a reference filter starts settled on the first command
    out = kern(p, com, load_samples(run.load, t), noise, st)
    return HFResult(
        window=_window_of(run, t, com, out, rng),
        phase_currents=out[:, [O_IA, O_IB, O_IC]].copy(),
    )


class HFStream:
    """The HF model of `actuator` run without end, chunk by chunk, repeating the command window.

    Used by the ROS node playing the real EMA.  `set_k` changes the fault state
    between chunks while the physical state carries on.  Sample j is at t = j*Ts;
    the command and load are those of the window at t mod duration, so with a
    chirp that ends where it starts (the default) the command stays continuous.
    Options as `simulate`'s.
    """

    def __init__(
        self,
        k: Sequence[float] | np.ndarray,
        *,
        actuator: ActuatorParameters | None = None,
        command: CommandSpec | None = None,
        load: LoadSpec | None = None,
        sensors: SensorSpec | None = None,
        seed: int | None = 0,
        noise_current: float = 0.0,
        noise_position: float = 0.0,
        noise_speed: float = 0.0,
        temperature_c: float | None = None,
    ) -> None:
        self._run = _prepare_run(
            k,
            actuator=actuator,
            command=command,
            load=load,
            sensors=sensors,
            noise=(noise_current, noise_position, noise_speed),
            seed=seed,
            temperature_c=temperature_c,
        )
        self.actuator, self.command, self.load = (
            self._run.actuator,
            self._run.command,
            self._run.load,
        )
        self.sensors = self._run.sensors
        self.rng = np.random.default_rng(self._run.seed)
        self.sample_rate = self.actuator.acquisition.sample_rate
        self.ts = 1.0 / self.sample_rate
        self.samples_per_window = int(round(self.command.duration / self.ts))
        self.set_k(k)
        first = self._inputs(np.zeros(1, dtype=np.int64))[0][0]
        self.state = consistent_start_state(self.p, settled_angle(self.p, first))
        self.state[S_CMDF] = first
        self.j = -1  # index of the last sample emitted
        self._last_command = float(first)  # the command of sample j
        self._last_reading_noise = np.zeros(2)  # loop noise of sample j (already emitted)

    def set_k(self, k: Sequence[float] | np.ndarray) -> None:
        """Validate and apply a new fault vector (FaultVectorError if bad; state kept)."""
        fv = FaultVector.from_k(k)
        self.p = hf_parameters(
            fv, self.actuator, sensors=self.sensors, spring=getattr(self.load, "spring", 0.0)
        )
        self.k = fv.k.copy()

    def _inputs(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tw = (idx % self.samples_per_window) * self.ts
        return command_samples(self.command, tw), load_samples(self.load, tw)

    def _noise(self, rows: int) -> np.ndarray:
        """Loop noise for `rows` samples; the first row's reading is the one already emitted."""
        ticks = int(self.p[P_STEPS] // self.p[P_CTRL_EVERY])
        noise = _loop_noise(self.rng, self.sensors, rows, ticks)
        if noise.shape[0] == rows:
            if self.j >= 0:
                noise[0, 0] = self._last_reading_noise
            self._last_reading_noise = noise[-1, 0].copy()
        return noise

    def advance(self, n: int, commands: np.ndarray | None = None) -> np.ndarray:
        """Simulate the next n samples; returns (n, len(CHANNELS)) rows in CHANNELS order.

        `commands`: the n samples' position commands [rad] (a rig commanded from outside);
        None: the command window's.
        """
        if n < 1:
            raise ConfigError(f"advance needs n >= 1 samples, got {n}")
        first = self.j + 1
        idx = np.arange(max(self.j, 0), first + n)
        com, ld = self._inputs(idx)
        if commands is not None:
            given = np.asarray(commands, dtype=np.float64)
            if given.shape != (n,) or not np.all(np.isfinite(given)):
                raise ConfigError(f"advance needs {n} finite commands, got shape {given.shape}")
            com = given if self.j < 0 else np.concatenate([[self._last_command], given])
        self._last_command = float(com[-1])
        out = hf_kernel(self.p, com, ld, self._noise(idx.size), self.state)
        if self.j >= 0:
            out, com, idx = out[1:], com[1:], idx[1:]
        self.j = int(idx[-1])
        channels = {
            "t": idx * self.ts,
            "command": com,
            "load": _load_channel(out[:, O_LOAD], self.load),
            "theta_u": out[:, O_THETA_U],
            "theta_m": out[:, O_THETA_M],
            "omega_m": out[:, O_OMEGA_M],
            "i3eq": _measured_current(out[:, O_I3EQ], self.sensors, self.rng),
            "temperature": _temperature_channel(n, self._run.temperature_c),
        }
        return np.column_stack([channels[c] for c in CHANNELS])


def calibration_window(actuator: ActuatorParameters | None = None) -> Window:
    """The healthy window of `actuator` on the calibration command (noise-free sensors).

    What `ema-phm calibrate` fits the packaged calibration to (`diagnosis.calibration`).
    """
    return simulate(NOMINAL, actuator=actuator, command=calibration_spec()).window
