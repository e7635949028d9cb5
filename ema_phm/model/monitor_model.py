"""Low-fidelity (LF) monitor model: the single-phase equivalent of chapter 3.

States (SI): motor angle theta_m [rad], motor speed omega_m [rad/s], equivalent
current I [A], backlash output [rad, user], speed-loop integral, filter state.
Inputs: the *recorded* command [rad, user] and load [N*m, user] of a window.  A NaN
load sample means the load was not measured there: the model then assumes no load (0 N*m)
at that sample, because a monitor has nothing else to go on.
Output: I_3eq [A] after the acquisition filter, theta_u [rad], omega_m [rad/s].
Fault parameters: the normalized k of section 5.5 (fault_vector.py).
Physical parameters: `MonitorBelief` (model/belief.py), passed in; it never
reads the simulated actuator's parameters and never imports the HF model.  The kernel takes
them as one flat array (the Q_* columns, built by `lf_parameters`); other modules change it
through `MonitorModel.row_parameters`, which names belief quantities (`scaled_columns`).

It is deliberately simpler than real_ema.py (the HF model): one R-L branch with one lumped
back-EMF and no inverter, the short circuit as the form function of eq. 3.17 with the mean
working-coil fraction of eqs. 4.11-4.15, the eccentricity as the scalar
correction of eq. 3.22.  The mechanics (one rigid shaft, one lumped Borello friction,
backlash, end stops) and the controller are the same functions as the HF's (drivetrain.py).

Current loop (the belief's controller kind, physics/actuator.py).  Kind pi_dq_current: the q
axis of the drive's PI loop (its gains, delay, anti-windup and back-EMF feed-forward from the
actuator file), its voltage limited to monitor.vdc and held between interrupts, applied to
the R-L branch by its exact step response; the d axis is taken as held at 0 A and the PWM as
averaged.  Kind hysteresis_current: the thesis drives the R-L branch with sign(I_ref - I) * 48 V
(eq. 3.5), which chatters at any step coarser than ~1 us and then breaks
stick/slip detection.  We use its averaged (sliding-mode) equivalent: the
voltage that brings I to I_ref within the step, clipped to +/-48 V, with the
exact exponential R-L response when clipped.  `current_law=SIGN` keeps the
original law for the fine-step comparison (test/model/test_monitor_model.py).
"""

from __future__ import annotations

import copy
import math
import threading
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
from numba import njit, prange

from ..domain.faults import N_K, validate
from ..domain.window import Window
from ..errors import ConfigError, FaultVectorError, WindowError
from ..physics.actuator import PI_DQ_CURRENT, current_loop_gains, feedforward_constants, part_of
from ..physics.drivetrain import backlash, controller, end_stops, friction_step
from ..physics.fault_vector import clamp_shorts, physical_factors
from ..physics.signals import filter_coefficients
from .belief import MonitorBelief
from .recorded_loop import REC_OMEGA_M, REC_POSITION, REC_THETA_M, RecordedLoop

DEADBEAT, SIGN = 0, 1
SQ3_2 = math.sqrt(3.0) / 2.0

# Flat parameter vector shared by every individual of a batch (the k-independent part).
(
    Q_DT,
    Q_STEPS,
    Q_CTRL_EVERY,
    Q_POLES,
    Q_R,
    Q_L,
    Q_KE,
    Q_GT,
    Q_TMAX,
    Q_VDC,
    Q_NP,
    Q_ECC_S,
    Q_KPOS,
    Q_WMAX,
    Q_KP,
    Q_KI,
    Q_KD,
    Q_IMAX,
    Q_KTC,
    Q_GEAR,
    Q_J,
    Q_C,
    Q_FS,
    Q_FD,
    Q_BL,
    Q_STOP,
    Q_B0,
    Q_B1,
    Q_B2,
    Q_A1,
    Q_A2,
    Q_LAW,
    Q_LOAD0,
    Q_KLOAD,
    Q_IGAIN,
    Q_IOFF,
    Q_ECC_LAW,
    Q_ECC_A,
    Q_MECH,
    Q_JM,
    Q_CM,
    Q_FSM,
    Q_FDM,
    Q_STIFF,
    Q_MESH_ZETA,
    Q_POS_OFF,
    Q_FOLLOW,
    Q_SEGMENT,
    Q_KIND,
    Q_CKP,
    Q_CKI,
    Q_DELAY,
    Q_EMF_FF,
    Q_AW,
    Q_KE_HAT,
    Q_SPD_FF,
    Q_REF_A,
    Q_NPAR,
) = range(58)

#: Q_KIND of each controller kind (physics/actuator.py).
KIND_HYSTERESIS, KIND_PI_DQ = 0, 1

#: monitor.mechanics_model: the thesis's one lumped shaft with the play on the fed-back
#: position, or motor and user bodies coupled through the play by the transmission's
#: stiffness and mesh damping while the teeth touch.
MECH_LUMPED, MECH_TWO_BODY = 0, 1

#: monitor.eccentricity_law: the thesis's eq. 3.22, or the three-phase equivalent of sec. 4.5.
ECC_EQ322, ECC_THREE_PHASE = 0, 1

#: The LF's outputs, the columns of its (n, len(OUTPUTS)) result: window channels it predicts.
OUTPUTS: tuple[str, ...] = ("i3eq", "theta_u", "omega_m")
OUT_I3EQ, OUT_THETA_U, OUT_OMEGA_M = (OUTPUTS.index(n) for n in ("i3eq", "theta_u", "omega_m"))

#: The values each mode switch of the belief may take (the kernel compares them exactly).
MODES: Mapping[str, tuple[int, ...]] = MappingProxyType(
    {
        "monitor.eccentricity_law": (ECC_EQ322, ECC_THREE_PHASE),
        "monitor.mechanics_model": (MECH_LUMPED, MECH_TWO_BODY),
    }
)
CURRENT_LAWS: tuple[int, ...] = (DEADBEAT, SIGN)


def check_modes(belief: MonitorBelief, current_law: int) -> None:
    """ConfigError naming a mode switch whose value the kernel does not know."""
    for name, allowed in MODES.items():
        if belief.value(name) not in allowed:
            raise ConfigError(
                f"{belief.source}: {name} must be one of {allowed}, got {belief.value(name)!r}"
            )
    if current_law not in CURRENT_LAWS:
        raise ConfigError(f"current_law must be one of {CURRENT_LAWS}, got {current_law!r}")


#: Columns proportional to belief quantities: scaling every quantity of a column's set by one
#: factor scales the column by it (`scaled_columns`; the fitted factors of commissioning).
PROPORTIONAL: Mapping[int, frozenset[str]] = MappingProxyType(
    {
        Q_J: frozenset({"mechanics.j_motor", "mechanics.j_user"}),
        Q_JM: frozenset({"mechanics.j_motor"}),
        Q_C: frozenset({"mechanics.c_motor", "mechanics.c_user"}),
        Q_CM: frozenset({"mechanics.c_motor"}),
        Q_FS: frozenset({"mechanics.friction_static_motor", "mechanics.friction_static_user"}),
        Q_FD: frozenset({"mechanics.friction_dynamic_motor", "mechanics.friction_dynamic_user"}),
        Q_FSM: frozenset({"mechanics.friction_static_motor"}),
        Q_FDM: frozenset({"mechanics.friction_dynamic_motor"}),
        Q_BL: frozenset({"mechanics.backlash"}),
        Q_STOP: frozenset({"mechanics.end_stop"}),
        Q_R: frozenset({"monitor.r"}),
        Q_L: frozenset({"monitor.l"}),
        Q_KE: frozenset({"monitor.ke"}),
        Q_GT: frozenset({"monitor.gt"}),
        Q_STIFF: frozenset({"monitor.stiffness"}),
        Q_KP: frozenset({"controller.speed_kp"}),
        Q_KI: frozenset({"controller.speed_ki"}),
        Q_CKP: frozenset({"current_loop.kp"}),
        Q_CKI: frozenset({"current_loop.ki"}),
    }
)


def scaled_columns(quantities: Sequence[str]) -> tuple[int, ...]:
    """The columns that one factor on all of `quantities` scales (`PROPORTIONAL`).

    ConfigError when a quantity is in no column or a column depends on only some of them
    (it would not scale by the factor).
    """
    wanted = frozenset(quantities)
    unknown = sorted(wanted - frozenset().union(*PROPORTIONAL.values()))
    if unknown:
        raise ConfigError(f"the monitor model cannot scale {unknown[0]!r}")
    cols = []
    for col, deps in PROPORTIONAL.items():
        if deps <= wanted:
            cols.append(col)
        elif deps & wanted:
            raise ConfigError(
                f"scaling {', '.join(sorted(deps & wanted))} without "
                f"{', '.join(sorted(deps - wanted))} does not scale the model proportionally"
            )
    return tuple(cols)


#: Nuisance columns a row may override (`MonitorModel.simulate_batch(..., nuisance=...)`):
#: unmeasured constant load [N*m, user] and hinge stiffness [N*m/rad, user].
NUISANCE_COLUMNS: tuple[int, ...] = (Q_LOAD0, Q_KLOAD)


#: fault_vector.physical_factors compiled for the kernel: one k -> physical mapping, both models.
compiled_physical_factors = njit(cache=True, error_model="numpy")(physical_factors)


@njit(cache=True, nogil=True, error_model="numpy")
def lf_kernel(  # noqa: PLR0912, PLR0915, PLR0917 - one numba loop
    q: np.ndarray,
    k: np.ndarray,
    com: np.ndarray,
    load: np.ndarray,
    rec: np.ndarray,
    x0: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """Simulate one fault vector k over a window; write (n, len(OUTPUTS)) into out.

    The columns are I_3eq (filtered), theta_u, omega_m at every sample.  With q[Q_FOLLOW]
    the position loop reads rec[:, REC_POSITION] (the recorded loop) instead of the model's
    own position; with q[Q_SEGMENT] = m > 0 the motor angle and speed restart from
    rec[:, REC_THETA_M], rec[:, REC_OMEGA_M] every m samples (multiple shooting), the
    twist, current and controller state carried over.
    """
    n = com.shape[0]
    dt = q[Q_DT]
    steps = int(q[Q_STEPS])
    ctrl_every = int(q[Q_CTRL_EVERY])
    tc = dt * ctrl_every
    poles = q[Q_POLES]
    ff, bf, na, nb, nc, zeta, phi, gf = compiled_physical_factors(k)
    neq = (na + nb + nc) / 3.0  # eq. 4.11
    r0 = q[Q_R]
    l0 = q[Q_L] * neq  # eq. 3.8: L scales with N_tot/3 ...
    ke, gt, tmax, vdc = q[Q_KE], q[Q_GT], q[Q_TMAX], q[Q_VDC]
    scg = q[Q_NP] * 2.0 / 3.0
    ecc_c = q[Q_ECC_S] * zeta * math.cos(phi)
    ecc_s = q[Q_ECC_S] * zeta * math.sin(phi)
    # sec. 4.5: phase i's flux scales by 1 + A zeta cos(theta_m - phi - a_i), a_i its axis
    three_phase = q[Q_ECC_LAW] == ECC_THREE_PHASE
    amp = q[Q_ECC_A] * zeta
    axis = 2.0 * math.pi / 3.0 / poles
    gac, gas = amp * math.cos(phi), amp * math.sin(phi)
    gbc, gbs = amp * math.cos(phi + axis), amp * math.sin(phi + axis)
    gcc, gcs = amp * math.cos(phi - axis), amp * math.sin(phi - axis)
    kpos = q[Q_KPOS] * gf
    wmax, kp, ki, kd, imax, ktc = q[Q_WMAX], q[Q_KP], q[Q_KI], q[Q_KD], q[Q_IMAX], q[Q_KTC]
    gear, jt, ct = q[Q_GEAR], q[Q_J], q[Q_C]
    fs, fd = q[Q_FS] * ff, q[Q_FD] * ff
    two_body = q[Q_MECH] == MECH_TWO_BODY
    jm, cm_ = q[Q_JM], q[Q_CM]
    ju, cu = jt - jm, ct - cm_
    fsm, fdm = q[Q_FSM] * ff, q[Q_FDM] * ff
    fsu, fdu = fs - fsm, fd - fdm
    kt = q[Q_STIFF] * gear * gear  # transmission stiffness seen at the motor shaft
    ck = 2.0 * q[Q_MESH_ZETA] * math.sqrt(kt * jm * ju / jt)  # mesh damping, in contact
    dt_over_jm, dt_over_ju = dt / jm, dt / ju
    bl = q[Q_BL] * bf
    stop = q[Q_STOP] / gear
    b0, b1, b2, a1, a2 = q[Q_B0], q[Q_B1], q[Q_B2], q[Q_A1], q[Q_A2]
    sign_law = q[Q_LAW] == SIGN
    load0, kload = q[Q_LOAD0], q[Q_KLOAD]
    igain, ioff = q[Q_IGAIN], q[Q_IOFF]
    inv_dt = 1.0 / dt
    inv_steps = 1.0 / steps
    dt_over_j = dt / jt
    # kind pi_dq_current: the q axis of the PI loop, its voltage held until the next interrupt
    pi_dq = q[Q_KIND] == KIND_PI_DQ
    ckp, cki_tc, delay = q[Q_CKP], q[Q_CKI] * tc, int(q[Q_DELAY])
    emf_ff, aw, ke_hat = q[Q_EMF_FF], q[Q_AW], q[Q_KE_HAT]
    wff_per_rad = q[Q_SPD_FF] / (gear * dt * steps)  # command rate -> motor speed reference
    ref_a = q[Q_REF_A]

    th, w, cur = x0[0], x0[1], x0[2]
    y_bl = x0[3]
    # two-body state: user angle and speed in motor units (start: teeth centred)
    thu, wu = th, w
    gap = 0.5 * q[Q_BL] * bf / gear  # half the play, motor angle
    pos_off = q[Q_POS_OFF]
    follow = q[Q_FOLLOW] != 0.0
    segment = int(q[Q_SEGMENT])
    # the lumped play state is the true user angle; where the recorded state enters (the
    # resolver has no offset, the followed position has the sensor's) its reading adds the
    # offset.  Open-loop it is left out: the loop drives the reading to the command either way.
    lumped_off = pos_off if (not two_body and (follow or segment > 0)) else 0.0
    y_bl -= lumped_off
    # controller state consistent with the first sample: the speed-loop integral that makes
    # the current reference equal the measured current (a window may start mid-motion)
    wref0 = kpos * (com[0] - (rec[0, REC_POSITION] if follow else y_bl + lumped_off))
    if wref0 > wmax:
        wref0 = wmax
    elif wref0 < -wmax:
        wref0 = -wmax
    e_prev = wref0 - w
    integ = (cur * ktc - kp * e_prev) / ki if ki != 0.0 else 0.0
    iref = cur
    # the PI loop holding the first sample's current: its integral and the delay line
    v_app = q[Q_R] * cur + ke * w
    xq = v_app - emf_ff * ke_hat * w
    v_d1 = v_d2 = v_app
    cmdf = com[0]
    z1 = cur - b0 * cur
    z2 = b2 * cur - a2 * cur
    yf = cur
    k_ctrl = 0
    for i in range(n):
        out[i, OUT_I3EQ] = igain * yf + ioff
        out[i, OUT_THETA_U] = y_bl + lumped_off
        out[i, OUT_OMEGA_M] = w
        if i == n - 1:
            break
        if segment > 0 and i > 0 and i % segment == 0:
            # a new shooting segment: the shafts restart from the recorded motor state
            twist, slip = th - thu, w - wu
            th, w = rec[i, REC_THETA_M], rec[i, REC_OMEGA_M]
            thu, wu = th - twist, w - slip
        c0, c1 = com[i], com[i + 1]
        ld0, ld1 = load[i], load[i + 1]
        p0, p1 = rec[i, REC_POSITION], rec[i + 1, REC_POSITION]
        for j in range(steps):
            frac = j * inv_steps
            if k_ctrl == 0:
                if not two_body:
                    y_bl = backlash(gear * th, y_bl, bl)
                cmd = c0 + (c1 - c0) * frac
                if ref_a > 0.0:  # 1st-order filter on the position reference
                    cmdf += ref_a * (cmd - cmdf)
                    cmd = cmdf
                iref, integ, e_prev = controller(
                    cmd,
                    p0 + (p1 - p0) * frac if follow else y_bl + lumped_off,
                    w,
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
                    e_i = iref - igain * cur  # the loop reads the current sensor
                    v_ask = ckp * e_i + xq + emf_ff * ke_hat * w
                    # the limit is on the dq vector: the d axis holds about -we L iq of it
                    vdq = poles * w * l0 * cur
                    vq_max = math.sqrt(max(0.0, vdc * vdc - vdq * vdq))
                    v_new = v_ask
                    if v_new > vq_max:
                        v_new = vq_max
                    elif v_new < -vq_max:
                        v_new = -vq_max
                    xq += cki_tc * e_i + aw * (v_new - v_ask)
                    if delay == 0:
                        v_app = v_new
                    elif delay == 1:
                        v_app, v_d1 = v_d1, v_new
                    else:
                        v_app, v_d2, v_d1 = v_d2, v_d1, v_new
            k_ctrl += 1
            if k_ctrl == ctrl_every:
                k_ctrl = 0
            if j == 0:  # exact trig once a sample, a rotation in between (cheaper)
                te = poles * th
                s, c = math.sin(te), math.cos(te)
                sm, cm = math.sin(th), math.cos(th)
            sb = -0.5 * s - SQ3_2 * c  # sin(te - 2pi/3)
            sc = -0.5 * s + SQ3_2 * c  # sin(te + 2pi/3)
            phi_sc = scg * (na * s * s + nb * sb * sb + nc * sc * sc)  # eq. 3.17
            if three_phase:
                # balanced currents: sum of the phases' torques over their nominal sum
                phi_flux = scg * (
                    na * (1.0 + cm * gac + sm * gas) * s * s
                    + nb * (1.0 + cm * gbc + sm * gbs) * sb * sb
                    + nc * (1.0 + cm * gcc + sm * gcs) * sc * sc
                )
            else:
                phi_flux = phi_sc * (1.0 - (c * ecc_c - s * ecc_s))  # eq. 3.22
            r = phi_sc * r0
            ll = phi_sc * l0
            vb = phi_flux * ke * w  # eq. 3.15
            if pi_dq:  # the held voltage on the R-L branch: its exact step response
                if r > 0.0:
                    ifin = (v_app - vb) / r
                    cur = ifin + (cur - ifin) * math.exp(-r / ll * dt)
                else:
                    cur += (v_app - vb) / ll * dt
            elif sign_law:
                v = vdc if iref - cur >= 0.0 else -vdc
                cur += (v - r * cur - vb) / ll * dt
            else:
                v = r * iref + vb + ll * (iref - cur) * inv_dt
                if v > vdc or v < -vdc:
                    v = vdc if v > 0.0 else -vdc
                    if r > 0.0:
                        ifin = (v - vb) / r
                        cur = ifin + (cur - ifin) * math.exp(-r / ll * dt)
                    else:
                        cur += (v - vb) / ll * dt
                else:
                    cur = iref
            tm = gt * cur
            if tm > tmax:
                tm = tmax
            elif tm < -tmax:
                tm = -tmax
            tm *= phi_flux  # eq. 3.16
            # recorded load + unmeasured part: constant and hinge spring (opposes deflection)
            tl = gear * (ld0 + (ld1 - ld0) * frac + load0 + kload * y_bl)
            if not two_body:
                w = friction_step(w, tm - tl - ct * w, fs, fd, dt_over_j)
                th, w = end_stops(th + w * dt, w, stop)
            else:
                # two bodies through the play: spring-damper only while the teeth touch
                x = th - thu
                if x > gap:
                    tc_ = kt * (x - gap) + ck * (w - wu)
                elif x < -gap:
                    tc_ = kt * (x + gap) + ck * (w - wu)
                else:
                    tc_ = 0.0
                w = friction_step(w, tm - cm_ * w - tc_, fsm, fdm, dt_over_jm)
                wu = friction_step(wu, tc_ - tl - cu * wu, fsu, fdu, dt_over_ju)
                th = th + w * dt
                thu, wu = end_stops(thu + wu * dt, wu, stop)
            if two_body:
                # the user position sensor reads the user body, zero offset included
                y_bl = gear * thu + pos_off
            de = poles * w * dt
            d2 = de * de
            cd = 1.0 - d2 * (0.5 - d2 / 24.0)
            sd = de * (1.0 - d2 * (1.0 / 6.0 - d2 / 120.0))
            s, c = s * cd + c * sd, c * cd - s * sd
            dm = w * dt
            m2 = dm * dm
            cdm = 1.0 - m2 * (0.5 - m2 / 24.0)
            sdm = dm * (1.0 - m2 * (1.0 / 6.0 - m2 / 120.0))
            sm, cm = sm * cdm + cm * sdm, cm * cdm - sm * sdm
            yf_new = b0 * cur + z1
            z1 = b1 * cur - a1 * yf_new + z2
            z2 = b2 * cur - a2 * yf_new
            yf = yf_new
        if not two_body:
            y_bl = backlash(gear * th, y_bl, bl)
    return out


@njit(cache=True, parallel=True, nogil=True, error_model="numpy")
def lf_rows_kernel(  # noqa: PLR0917 - numba: positional only
    qs: np.ndarray,
    ks: np.ndarray,
    com: np.ndarray,
    load: np.ndarray,
    rec: np.ndarray,
    x0: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """Row p of ks with its own parameter row qs[p], spread over the cores."""
    for p in prange(ks.shape[0]):
        lf_kernel(qs[p], ks[p], com, load, rec, x0, out[p])
    return out


#: One parallel launch at a time: the kernel runs without the GIL (a node's other threads
#: go on meanwhile), and numba's workqueue threading layer is not safe for concurrent launches.
_ROWS_LOCK = threading.Lock()


def _launch_rows(*args: np.ndarray) -> np.ndarray:
    """`lf_rows_kernel(*args)` under `_ROWS_LOCK`."""
    with _ROWS_LOCK:
        return lf_rows_kernel(*args)


def lf_parameters(
    belief: MonitorBelief,
    sample_rate: float,
    *,
    steps_per_sample: int | None = None,
    current_law: int = DEADBEAT,
    temperature_c: float | None = None,
) -> np.ndarray:
    """The k-independent flat parameters (Q_* indices) of `belief` at `sample_rate`.

    With `temperature_c` the winding resistance follows copper and ke, gt the magnet
    flux (monitor.copper_coefficient, monitor.magnet_coefficient) from the belief's
    monitor.reference_temperature_c, where its r, ke and gt hold.
    """
    mo, co, me, acq, mon = (
        belief[s] for s in ("motor", "controller", "mechanics", "acquisition", "monitor")
    )
    check_modes(belief, current_law)
    steps = int(steps_per_sample or round(mon["steps_per_sample"]))
    if steps < 1:
        raise ConfigError(f"monitor steps_per_sample must be >= 1, got {steps}")
    dt = 1.0 / (sample_rate * steps)
    ctrl = max(1, int(round(1.0 / (co["rate_hz"] * dt))))
    q = np.zeros(Q_NPAR)
    q[Q_DT], q[Q_STEPS], q[Q_CTRL_EVERY] = dt, steps, ctrl
    q[Q_POLES] = mo["pole_pairs"]
    dt_c = 0.0 if temperature_c is None else temperature_c - mon["reference_temperature_c"]
    r_t = 1.0 + mon["copper_coefficient"] * dt_c
    flux_t = 1.0 + mon["magnet_coefficient"] * dt_c
    q[Q_R], q[Q_L] = mon["r"] * r_t, mon["l"]
    q[Q_KE], q[Q_GT] = mon["ke"] * flux_t, mon["gt"] * flux_t
    q[Q_TMAX], q[Q_VDC], q[Q_NP] = mo["max_torque"], mon["vdc"], mon["sc_gain"]
    q[Q_ECC_S] = mo["eccentricity_sensitivity"]
    q[Q_KPOS] = co["position_gain"]
    q[Q_WMAX] = co["max_speed_rpm"] * 2.0 * math.pi / 60.0
    q[Q_KP], q[Q_KI], q[Q_KD] = co["speed_kp"], co["speed_ki"], co["speed_kd"]
    q[Q_IMAX], q[Q_KTC] = co["max_current"], co["torque_gain"]
    q[Q_GEAR] = me["gear_ratio"]
    q[Q_J] = me["j_motor"] + me["j_user"]
    q[Q_C] = me["c_motor"] + me["c_user"]
    q[Q_FS] = me["friction_static_motor"] + me["friction_static_user"]
    q[Q_FD] = me["friction_dynamic_motor"] + me["friction_dynamic_user"]
    q[Q_BL] = me["backlash"]
    q[Q_STOP] = me["end_stop"]
    q[Q_B0 : Q_A2 + 1] = filter_coefficients(acq["current_filter_hz"], dt)
    q[Q_LAW] = current_law
    q[Q_IGAIN], q[Q_IOFF] = mon["current_gain"], mon["current_offset"]
    q[Q_ECC_LAW], q[Q_ECC_A] = mon["eccentricity_law"], mon["eccentricity_amplitude"]
    q[Q_MECH], q[Q_STIFF] = mon["mechanics_model"], mon["stiffness"]
    q[Q_MESH_ZETA] = mon["mesh_damping_ratio"]
    q[Q_JM], q[Q_CM] = me["j_motor"], me["c_motor"]
    q[Q_FSM], q[Q_FDM] = me["friction_static_motor"], me["friction_dynamic_motor"]
    _controller_parameters(q, belief)
    return q


def _controller_parameters(q: np.ndarray, belief: MonitorBelief) -> None:
    """Fill the kind, PI current loop, feed-forward and reference-filter columns of `q`.

    From the belief's controller kind and sections (the actuator file's), never from a
    simulated actuator.  The PI loop's gains and back-EMF feed-forward are the drive's own,
    designed on the datasheet motor (`actuator.current_loop_gains`); its voltage limit is
    monitor.vdc (`parameters.monitor_equivalents`).  The loops run at the LF's control period
    (Q_CTRL_EVERY steps), which is the drive's when controller.rate_hz divides the LF rate.
    """
    kind = belief.controller_kind
    motor = part_of("motor", belief["motor"], kind)
    loop = part_of("current_loop", belief["current_loop"], kind)
    tc = q[Q_DT] * q[Q_CTRL_EVERY]
    q[Q_KIND] = KIND_PI_DQ if kind == PI_DQ_CURRENT else KIND_HYSTERESIS
    q[Q_CKP], q[Q_CKI] = current_loop_gains(motor, loop)
    q[Q_DELAY], q[Q_EMF_FF], q[Q_AW] = loop.delay_periods, loop.emf_feedforward, loop.anti_windup
    q[Q_KE_HAT] = feedforward_constants(motor, loop)[1]
    if kind == PI_DQ_CURRENT:
        per_step = 1.0 / (belief["controller"]["rate_hz"] * q[Q_DT])
        if per_step < 1.0 - 1e-9 or abs(per_step - round(per_step)) > 1e-6:
            raise ConfigError(
                f"{belief.source}: the monitor runs the PI current loop every whole number of "
                f"its steps; controller.rate_Hz {belief['controller']['rate_hz']:g} is "
                f"{per_step:.4g} steps of {q[Q_DT]:.4g} s (set monitor.steps_per_sample so "
                "the step divides the control period)"
            )
    co = belief["controller"]
    q[Q_SPD_FF] = co["speed_feedforward"]
    f = co["reference_filter_hz"]
    q[Q_REF_A] = 1.0 - math.exp(-2.0 * math.pi * f * tc) if f > 0.0 else 0.0


def first_sample_state(window: Window) -> np.ndarray:
    """The LF start: theta_m, omega_m, I_3eq, theta_u recorded at the window's first sample."""
    return np.array(
        [window.theta_m[0], window.omega_m[0], window.i3eq[0], window.theta_u[0]], dtype=np.float64
    )


def prepare_population(ks: Sequence[float] | Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """Validate and clamp (sec. 5.5) a (P, N_K) population; rows stay in order."""
    try:
        ks = np.atleast_2d(np.asarray(ks, dtype=np.float64))
    except (TypeError, ValueError):
        raise FaultVectorError(
            f"fault vector k must be {N_K} numbers in [0, 1], got {ks!r}"
        ) from None
    if ks.ndim != 2 or ks.shape[1] != N_K:
        raise FaultVectorError(
            f"fault vector k must have {N_K} entries (population shape (P, {N_K})), "
            f"got shape {ks.shape}"
        )
    return np.ascontiguousarray(np.vstack([clamp_shorts(validate(row)) for row in ks]))


def check_sample_rate(window: Window, belief: MonitorBelief) -> None:
    """WindowError unless the window was sampled at the rate the monitor is built for.

    That rate is the belief's acquisition.sample_rate: its controller, steps and current filter
    are tied to that rate, so a window at another rate cannot be compared with it.
    """
    need = belief["acquisition"]["sample_rate"]
    got = 1.0 / window.dt
    if abs(got - need) > 1e-6 * need:
        raise WindowError(
            f"window sample rate is {got:g} Hz (step {window.dt:.6g} s over {window.n} samples); "
            f"the monitor model needs telemetry at {need:g} Hz ({belief.source}, "
            f"acquisition.sample_rate)"
        ) from None


def position_offset(window: Window, gear: float) -> float:
    """Zero offset of the user position sensor against the resolver [rad, user].

    The median of theta_u - gear * theta_m over the window (the play and the twist
    average out).
    """
    d = np.asarray(window.theta_u) - gear * np.asarray(window.theta_m)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else 0.0


def window_temperature(window: Window) -> float | None:
    """Mean measured temperature of a window [degC], None when it was not measured."""
    t = np.asarray(window.temperature, dtype=np.float64)
    t = t[np.isfinite(t)]
    return float(np.mean(t)) if t.size else None


class MonitorModel:
    """The LF model of `belief` bound to one recorded window.

    `belief` defaults to MonitorBelief.default(); `simulate(k)` / `simulate_batch(ks)`.
    Where the window's load channel is NaN (not measured) the model assumes no load,
    plus the unmeasured load a row's `nuisance` gives (see `simulate_batch`).  When the
    window carries a measured temperature, R, ke and gt are moved to it (`lf_parameters`).
    """

    def __init__(
        self,
        window: Window,
        *,
        belief: MonitorBelief | None = None,
        steps_per_sample: int | None = None,
        current_law: int = DEADBEAT,
        loop: RecordedLoop | None = None,
    ) -> None:
        self.window = window.validated()
        self.loop = loop
        self.belief = belief or MonitorBelief.default()
        check_sample_rate(self.window, self.belief)
        self.temperature_c = window_temperature(self.window)
        self.q = lf_parameters(
            self.belief,
            1.0 / self.window.dt,
            steps_per_sample=steps_per_sample,
            current_law=current_law,
            temperature_c=self.temperature_c,
        )
        self.com = np.ascontiguousarray(self.window.command)
        # NaN = not measured: assume no load, the only thing a monitor without a sensor can do
        self.load = np.ascontiguousarray(np.nan_to_num(self.window.load, nan=0.0))
        self.x0 = first_sample_state(self.window)
        # the state is the true current: undo the belief's current-sensor gain and offset
        self.x0[2] = (self.x0[2] - self.q[Q_IOFF]) / self.q[Q_IGAIN]
        self.q[Q_POS_OFF] = position_offset(self.window, self.q[Q_GEAR])
        #: whether the recorded deflection went in unfiltered (`RecordedLoop.clean`)
        self.deflection_clean = False
        if loop is None:
            self.rec = np.zeros((self.window.n, 3))
        else:
            self.deflection_clean = loop.clean(self.window, self.q[Q_GEAR])
            self.rec, seg = loop.inputs(self.window, self.q[Q_GEAR], clean=self.deflection_clean)
            self.q[Q_FOLLOW] = 1.0 if loop.follow else 0.0
            self.q[Q_SEGMENT] = seg

    def following(self, recorded: Window) -> MonitorModel:
        """This model with its loop reading `recorded`'s position, motor angle and speed.

        Command, load, parameters and start stay this window's; the deflection is processed
        as this window's was (filtered or not).  `recorded` is this window with its
        sensors' noise drawn again (`Fitness.fed_noise_fitness`).
        """
        if self.loop is None:
            raise ConfigError("an open-loop monitor model follows no recorded loop")
        if recorded.n != self.window.n:
            raise WindowError(
                f"recorded loop has {recorded.n} samples, the window {self.window.n}"
            )
        other = copy.copy(self)
        other.rec, _ = self.loop.inputs(recorded, self.q[Q_GEAR], clean=self.deflection_clean)
        return other

    def simulate(self, k: Sequence[float] | np.ndarray, *, compiled: bool = True) -> np.ndarray:
        """(n, len(OUTPUTS)): I_3eq, theta_u, omega_m for one fault vector."""
        kk = prepare_population(k)[0]
        out = np.empty((self.window.n, len(OUTPUTS)))
        kern = lf_kernel if compiled else lf_kernel.py_func
        return kern(self.q, kk, self.com, self.load, self.rec, self.x0, out)

    @property
    def step_s(self) -> float:
        """The LF integration step [s]."""
        return float(self.q[Q_DT])

    @property
    def steps_per_sample(self) -> int:
        """LF steps per telemetry sample."""
        return int(self.q[Q_STEPS])

    def row_parameters(
        self,
        nuisance: np.ndarray,
        *,
        scales: Sequence[tuple[Sequence[str], np.ndarray]] = (),
    ) -> np.ndarray:
        """(P, Q_NPAR): the model's parameters with each row's factors and nuisances applied.

        `scales`: (belief quantities, (P,) factors) pairs; each row's factor multiplies every
        named quantity (`scaled_columns` says which may be scaled together).
        `nuisance` (P, 2): unmeasured constant load [N*m] and hinge stiffness [N*m/rad],
        both at the user shaft, added to the belief's (zero by default).
        """
        nu = np.atleast_2d(np.asarray(nuisance, dtype=np.float64))
        if nu.ndim != 2 or nu.shape[1] != len(NUISANCE_COLUMNS) or not np.all(np.isfinite(nu)):
            raise WindowError(
                f"nuisance must be finite, shape (P, {len(NUISANCE_COLUMNS)}), got {nu.shape}"
            )
        qs = np.repeat(self.q[None], nu.shape[0], axis=0)
        for quantities, factor in scales:
            for col in scaled_columns(quantities):
                qs[:, col] *= factor
        for j, col in enumerate(NUISANCE_COLUMNS):
            qs[:, col] += nu[:, j]
        return qs

    def simulate_batch(self, ks: np.ndarray, *, nuisance: np.ndarray | None = None) -> np.ndarray:
        """(P, n, len(OUTPUTS)) for a population, in one call over both cores.

        `nuisance` (P, 2), optional: each row's unmeasured load (`row_parameters`).
        """
        pop = prepare_population(ks)
        out = np.empty((pop.shape[0], self.window.n, len(OUTPUTS)))
        if nuisance is not None:
            qs = self.row_parameters(nuisance)
            if qs.shape[0] != pop.shape[0]:
                raise WindowError(
                    f"nuisance has {qs.shape[0]} rows for a population of {pop.shape[0]}"
                )
            return _launch_rows(qs, pop, self.com, self.load, self.rec, self.x0, out)
        if pop.shape[0] == 1:  # waking the thread pool for one row costs more than the row
            lf_kernel(self.q, pop[0], self.com, self.load, self.rec, self.x0, out[0])
            return out
        qs = np.repeat(self.q[None], pop.shape[0], axis=0)  # every row with the window's q
        return _launch_rows(qs, pop, self.com, self.load, self.rec, self.x0, out)

    def simulate_rows(self, qs: np.ndarray, ks: np.ndarray) -> np.ndarray:
        """(P, n, len(OUTPUTS)): row p of ks with its parameter row qs[p] (`row_parameters`)."""
        pop = prepare_population(ks)
        qs = np.ascontiguousarray(np.atleast_2d(qs), dtype=np.float64)
        if qs.shape != (pop.shape[0], Q_NPAR):
            raise WindowError(f"parameter rows must have shape ({pop.shape[0]}, {Q_NPAR})")
        out = np.empty((pop.shape[0], self.window.n, len(OUTPUTS)))
        return _launch_rows(qs, pop, self.com, self.load, self.rec, self.x0, out)
