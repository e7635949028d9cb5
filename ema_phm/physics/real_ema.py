"""High-fidelity (HF) model: the "real EMA" of chapter 2 with the faults of chapter 4.

States (SI): motor angle theta_m [rad], motor speed omega_m [rad/s], phase
currents i_A, i_B, i_C [A], inverter leg states (+/-1), stick flag, backlash
output [rad, user], speed-loop integral, I_3eq filter state.
Inputs: position command [rad, user], external load [N*m, user].
Outputs (at the telemetry rate): t, command, load, theta_u, theta_m, omega_m, I_3eq.
Parameters: `ActuatorParameters` (physics/parameters.py), passed in.

What it has that the monitor model (monitor_model.py) does not: three stator
phases with their own R, L and back-EMF (eqs. 4.3-4.7, per-phase short circuits),
a floating neutral solved with each phase's own inductance, a hysteresis-PWM
three-phase bridge fed by inverse Park/Clarke, torque summed from the phase
currents, I_3eq from the Park transform of the phase currents (eq. 2.2), all
integrated at high_fidelity.dt (1 us).  Like the monitor model it has one rigid
shaft (J = j_motor + j_user, viscous C = c_motor + c_user) and ONE Borello dry-
friction element whose static and dynamic levels are the sums of the motor- and
user-side values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import ConfigError
from ..limits import check
from ..telemetry.window import Window
from .commands import (
    CommandSpec,
    LoadSpec,
    command_samples,
    default_specs,
    load_samples,
    sample_times,
)
from .drivetrain import backlash, controller, end_stops, friction_step
from .fault_vector import FaultVector
from .parameters import ActuatorParameters
from .sensors import filter_coefficients

SQ3_2 = math.sqrt(3.0) / 2.0

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
    P_J,
    P_C,
    P_FS,
    P_FD,
    P_BL,
    P_STOP,
    P_B0,
    P_B1,
    P_B2,
    P_A1,
    P_A2,
    P_NPAR,
) = range(37)


# Full resumable state of the HF model (indices into the state vector).
(
    S_TH,
    S_W,
    S_IA,
    S_IB,
    S_IC,
    S_SA,
    S_SB,
    S_SC,
    S_YBL,
    S_INT,
    S_EPREV,
    S_IREF,
    S_Z1,
    S_Z2,
    S_IQF,
    S_KCTRL,
    S_NST,
) = range(17)


def consistent_start_state(
    p: np.ndarray, theta_m: float = 0.0, omega_m: float = 0.0, i_q: float = 0.0
) -> np.ndarray:
    """The HF state vector (S_* indices) of a consistent start: currents on their reference, backlash centred on the motor
    angle (no spurious play at t = 0), filter settled on i_q.
    """
    st = np.zeros(S_NST)
    te = p[P_POLES] * theta_m
    s, c = math.sin(te), math.cos(te)
    st[S_TH], st[S_W] = theta_m, omega_m
    st[S_IA], st[S_IB], st[S_IC] = (
        i_q * -s,
        i_q * (0.5 * s + SQ3_2 * c),
        i_q * (0.5 * s - SQ3_2 * c),
    )
    st[S_SA] = st[S_SB] = st[S_SC] = 1.0
    st[S_YBL] = p[P_GEAR] * theta_m
    st[S_IREF] = i_q
    st[S_Z1] = i_q - p[P_B0] * i_q
    st[S_Z2] = p[P_B2] * i_q - p[P_A2] * i_q
    st[S_IQF] = i_q
    return st


@njit(cache=True, error_model="numpy")
def hf_kernel(p, com, load, st):
    """Integrate the HF model over the samples of `com`/`load` from state `st`.

    p: flat parameters (P_* indices); com, load: samples at the telemetry rate;
    st: full state (S_* indices) at the first sample, updated in place to the
    state at the last sample, so consecutive calls continue one run.
    Returns (n, 4): theta_u, theta_m, omega_m, I_3eq (filtered).
    """
    n = com.shape[0]
    out = np.empty((n, 4))
    dt = p[P_DT]
    steps = int(p[P_STEPS])
    ctrl_every = int(p[P_CTRL_EVERY])
    tc = dt * ctrl_every
    poles = p[P_POLES]
    ra, rb, rc = p[P_RA], p[P_RB], p[P_RC]
    ga, gb, gc = 1.0 / p[P_LA], 1.0 / p[P_LB], 1.0 / p[P_LC]
    gsum = ga + gb + gc
    kea, keb, kec = p[P_KEA], p[P_KEB], p[P_KEC]
    ecc_c = p[P_ECC] * math.cos(p[P_PHI])
    ecc_s = p[P_ECC] * math.sin(p[P_PHI])
    vh = 0.5 * p[P_VDC]
    hb = 0.5 * p[P_HB]
    kpos, wmax, kp, ki, kd = p[P_KPOS], p[P_WMAX], p[P_KP], p[P_KI], p[P_KD]
    imax, ktc, gear = p[P_IMAX], p[P_KTC], p[P_GEAR]
    jt, ct, fs, fd = p[P_J], p[P_C], p[P_FS], p[P_FD]
    bl, stop = p[P_BL], p[P_STOP] / p[P_GEAR]
    b0, b1, b2, a1, a2 = p[P_B0], p[P_B1], p[P_B2], p[P_A1], p[P_A2]
    dt_over_j = dt / jt
    # the phase with the smallest inductance is the dependent one (i_A+i_B+i_C = 0)
    dep = 0
    if p[P_LB] < p[P_LA] and p[P_LB] <= p[P_LC]:
        dep = 1
    elif p[P_LC] < p[P_LA] and p[P_LC] < p[P_LB]:
        dep = 2

    th, w = st[S_TH], st[S_W]
    ia, ib, ic = st[S_IA], st[S_IB], st[S_IC]
    sa, sb, sc = st[S_SA], st[S_SB], st[S_SC]
    y_bl, integ, e_prev, iref = st[S_YBL], st[S_INT], st[S_EPREV], st[S_IREF]
    z1, z2, iqf = st[S_Z1], st[S_Z2], st[S_IQF]
    k_ctrl = int(st[S_KCTRL])
    te = poles * th
    s, c = math.sin(te), math.cos(te)
    ua, ub, uc = -s, 0.5 * s + SQ3_2 * c, 0.5 * s - SQ3_2 * c
    for i in range(n):
        out[i, 0] = y_bl
        out[i, 1] = th
        out[i, 2] = w
        out[i, 3] = iqf
        if i == n - 1:
            break
        c0, c1 = com[i], com[i + 1]
        l0, l1 = load[i], load[i + 1]
        tl = gear * l0
        for j in range(steps):
            if k_ctrl == 0:
                # control interrupt: exact trig (also renormalizes the rotation below)
                te = poles * th
                s, c = math.sin(te), math.cos(te)
                frac = j / steps
                cmd = c0 + (c1 - c0) * frac
                tl = gear * (l0 + (l1 - l0) * frac)
                y_bl = backlash(gear * th, y_bl, bl)
                iref, integ, e_prev = controller(
                    cmd, y_bl, w, integ, e_prev, kpos, wmax, kp, ki, kd, tc, ktc, imax
                )
            k_ctrl += 1
            if k_ctrl == ctrl_every:
                k_ctrl = 0
            # inverse Park/Clarke of the reference and hysteresis comparators
            ua = -s
            ub = 0.5 * s + SQ3_2 * c
            uc = 0.5 * s - SQ3_2 * c
            d = iref * ua - ia
            if d > hb:
                sa = 1.0
            elif d < -hb:
                sa = -1.0
            d = iref * ub - ib
            if d > hb:
                sb = 1.0
            elif d < -hb:
                sb = -1.0
            d = iref * uc - ic
            if d > hb:
                sc = 1.0
            elif d < -hb:
                sc = -1.0
            # back-EMF coefficients with static eccentricity (sec. 4.5)
            m = 1.0 - (c * ecc_c - s * ecc_s)
            ka, kb, kc = kea * m * ua, keb * m * ub, kec * m * uc
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
            # mechanics: one rigid shaft, Borello friction, end stops
            t_act = tm - tl - ct * w
            w = friction_step(w, t_act, fs, fd, dt_over_j)
            th, w = end_stops(th + w * dt, w, stop)
            # rotate (s, c) by the electrical increment (cheaper than sin/cos)
            de = poles * w * dt
            cd = 1.0 - 0.5 * de * de
            sd = de - de * de * de / 6.0
            s, c = s * cd + c * sd, c * cd - s * sd
            # signal acquisition: Park transform (eq. 2.2, amplitude invariant) + LPF
            iq = (2.0 / 3.0) * (ia * ua + ib * ub + ic * uc)
            iqf = b0 * iq + z1
            z1 = b1 * iq - a1 * iqf + z2
            z2 = b2 * iq - a2 * iqf
        y_bl = backlash(gear * th, y_bl, bl)
    st[S_TH], st[S_W], st[S_IA], st[S_IB], st[S_IC] = th, w, ia, ib, ic
    st[S_SA], st[S_SB], st[S_SC] = sa, sb, sc
    st[S_YBL], st[S_INT], st[S_EPREV], st[S_IREF] = y_bl, integ, e_prev, iref
    st[S_Z1], st[S_Z2], st[S_IQF], st[S_KCTRL] = z1, z2, iqf, k_ctrl
    return out


def hf_parameters(fv: FaultVector, actuator: ActuatorParameters) -> np.ndarray:
    """Flat kernel parameters (P_* indices) of `actuator` in fault state `fv` (eqs. 4.3-4.7, R/L typo fixed)."""
    mo, inv, co, me, acq, hf = (
        actuator[s]
        for s in ("motor", "inverter", "controller", "mechanics", "acquisition", "high_fidelity")
    )
    dt = hf["dt"]
    ts = 1.0 / acq["sample_rate"]
    steps = ts / dt
    ctrl = 1.0 / (co["rate_hz"] * dt)
    if abs(steps - round(steps)) > 1e-6 or abs(ctrl - round(ctrl)) > 1e-6:
        raise ConfigError(
            f"high_fidelity.dt={dt} must divide the sample period {ts} and the control period "
            f"{1.0 / co['rate_hz']}"
        )
    p = np.zeros(P_NPAR)
    p[P_DT], p[P_STEPS], p[P_CTRL_EVERY] = dt, round(steps), round(ctrl)
    p[P_POLES] = mo["pole_pairs"]
    # eqs. 4.6-4.7 as printed divide by N_i; fewer working turns must *lower* R and L,
    # so R_i = N_i Rs/2 and L_i = N_i^2 Ls/2 (and K_ei = N_i K_e, eq. 4.3).
    n = np.maximum(fv.coils, mo["min_working_coils"])
    p[P_RA : P_RC + 1] = n * mo["r_phase_to_phase"] / 2.0
    p[P_LA : P_LC + 1] = n**2 * mo["l_phase_to_phase"] / 2.0
    p[P_KEA : P_KEC + 1] = n * mo["ke_phase_peak"]
    p[P_ECC] = mo["eccentricity_sensitivity"] * fv.zeta
    p[P_PHI] = fv.phi
    p[P_VDC], p[P_HB] = inv["vdc"], inv["hysteresis_band"]
    p[P_KPOS] = co["position_gain"] * fv.gain_factor
    p[P_WMAX] = co["max_speed_rpm"] * 2.0 * math.pi / 60.0
    p[P_KP], p[P_KI], p[P_KD] = co["speed_kp"], co["speed_ki"], co["speed_kd"]
    p[P_IMAX], p[P_KTC] = co["max_current"], co["torque_gain"]
    p[P_GEAR] = me["gear_ratio"]
    p[P_J] = me["j_motor"] + me["j_user"]
    p[P_C] = me["c_motor"] + me["c_user"]
    p[P_FS] = fv.friction_factor * (me["friction_static_motor"] + me["friction_static_user"])
    p[P_FD] = fv.friction_factor * (me["friction_dynamic_motor"] + me["friction_dynamic_user"])
    p[P_BL] = me["backlash"] * fv.backlash_factor
    p[P_STOP] = me["end_stop"]
    p[P_B0 : P_A2 + 1] = filter_coefficients(acq["current_filter_hz"], dt)
    return p


def _check_run_options(
    command: CommandSpec,
    actuator: ActuatorParameters,
    *,
    seed: int | None,
    noise: tuple[float, float, float],
) -> int | None:
    """The seed as an int, or ConfigError (naming the value and its allowed range) for a
    seed, a noise RMS or a command frequency the run cannot use.
    """
    for name, v in zip(("noise_current", "noise_position", "noise_speed"), noise):
        check(name, v)
    command.check_sample_rate(actuator["acquisition"]["sample_rate"])
    return None if seed is None else int(check("seed", seed))


@dataclass(frozen=True)
class HFResult:
    """What one HF run returns: its telemetry window (with k_true)."""

    window: Window


def simulate(
    k,
    *,
    actuator: ActuatorParameters | None = None,
    command: CommandSpec | None = None,
    load: LoadSpec | None = None,
    seed: int | None = 0,
    noise_current: float = 0.0,
    noise_position: float = 0.0,
    noise_speed: float = 0.0,
    x0: tuple[float, float, float] = (0.0, 0.0, 0.0),
    compiled: bool = True,
) -> HFResult:
    """Run the HF model of `actuator` (default: ActuatorParameters.default()) for one window.

    x0 is the start (theta_m [rad], omega_m [rad/s], i_q [A]).  Noise is white and
    Gaussian with the given RMS on I_3eq [A], theta_u [rad] and omega_m [rad/s],
    drawn from `numpy.random.default_rng(seed)`.  `compiled=False` runs the same
    kernel as plain Python (slow; for cross-checks).
    """
    fv = FaultVector.from_k(k)
    actuator = actuator or ActuatorParameters.default()
    default_command, default_load = default_specs()
    command, load = command or default_command, load or default_load
    seed = _check_run_options(
        command, actuator, seed=seed, noise=(noise_current, noise_position, noise_speed)
    )
    sample_rate = actuator["acquisition"]["sample_rate"]
    t = sample_times(command.duration, sample_rate)
    com = command_samples(command, t)
    ld = load_samples(load, t)
    p = hf_parameters(fv, actuator)
    kern = hf_kernel if compiled else hf_kernel.py_func
    out = kern(p, com, ld, consistent_start_state(p, *x0))
    theta_u, theta_m, omega_m, i3eq = (
        out[:, 0].copy(),
        out[:, 1].copy(),
        out[:, 2].copy(),
        out[:, 3].copy(),
    )
    if noise_current or noise_position or noise_speed:
        rng = np.random.default_rng(seed)
        i3eq += noise_current * rng.standard_normal(t.shape)
        theta_u += noise_position * rng.standard_normal(t.shape)
        omega_m += noise_speed * rng.standard_normal(t.shape)
    meta = {
        "source": "ema_phm.physics.real_ema",
        "sample_rate": sample_rate,
        "command": command.as_dict(),
        "load": load.as_dict(),
        "seed": seed,
        "noise_current": noise_current,
        "noise_position": noise_position,
        "noise_speed": noise_speed,
    }
    win = Window(
        t=t,
        command=com,
        load=ld,
        theta_u=theta_u,
        theta_m=theta_m,
        omega_m=omega_m,
        i3eq=i3eq,
        k_true=fv.k.copy(),
        meta=meta,
    )
    return HFResult(window=win)


class HFStream:
    """The HF model of `actuator` run without end, chunk by chunk, repeating the command window.

    Used by the ROS node playing the real EMA.  `set_k` changes the fault state
    between chunks while the physical state carries on.  Sample j is at t = j*Ts;
    the command and load are those of the window at t mod duration, so with a
    chirp that ends where it starts (the default) the command stays continuous.
    """

    def __init__(
        self,
        k,
        *,
        actuator: ActuatorParameters | None = None,
        command: CommandSpec | None = None,
        load: LoadSpec | None = None,
        seed: int | None = 0,
        noise_current: float = 0.0,
        noise_position: float = 0.0,
        noise_speed: float = 0.0,
    ) -> None:
        self.actuator = actuator or ActuatorParameters.default()
        default_command, default_load = default_specs()
        self.command, self.load = command or default_command, load or default_load
        seed = _check_run_options(
            self.command,
            self.actuator,
            seed=seed,
            noise=(noise_current, noise_position, noise_speed),
        )
        self.noise = (noise_current, noise_position, noise_speed)
        self.rng = np.random.default_rng(seed)
        self.sample_rate = self.actuator["acquisition"]["sample_rate"]
        self.ts = 1.0 / self.sample_rate
        self.samples_per_window = int(round(self.command.duration / self.ts))
        self.set_k(k)
        self.state = consistent_start_state(self.p)
        self.j = -1  # index of the last sample emitted

    @property
    def params(self) -> ActuatorParameters:
        """The same object as `actuator` (ema_node reads `params["acquisition"]["sample_rate"]`)."""
        return self.actuator

    def set_k(self, k) -> None:
        """Validate and apply a new fault vector (FaultVectorError if bad; state kept)."""
        fv = FaultVector.from_k(k)
        self.p = hf_parameters(fv, self.actuator)
        self.k = fv.k.copy()

    def _inputs(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tw = (idx % self.samples_per_window) * self.ts
        return command_samples(self.command, tw), load_samples(self.load, tw)

    def advance(self, n: int) -> np.ndarray:
        """Simulate the next n samples; returns (n, 7) rows in telemetry CHANNELS order."""
        if n < 1:
            raise ConfigError(f"advance needs n >= 1 samples, got {n}")
        first = self.j + 1
        idx = np.arange(max(self.j, 0), first + n)
        com, ld = self._inputs(idx)
        out = hf_kernel(self.p, com, ld, self.state)
        if self.j >= 0:
            out, com, ld, idx = out[1:], com[1:], ld[1:], idx[1:]
        self.j = int(idx[-1])
        rows = np.column_stack(
            [idx * self.ts, com, ld, out[:, 0], out[:, 1], out[:, 2], out[:, 3]]
        )
        nc, npos, nspd = self.noise
        if nc or npos or nspd:
            noise = self.rng.standard_normal((n, 3))
            rows[:, 6] += nc * noise[:, 0]
            rows[:, 3] += npos * noise[:, 1]
            rows[:, 5] += nspd * noise[:, 2]
        return rows
