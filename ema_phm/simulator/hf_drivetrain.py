"""The HF's motor-transmission dynamics (sec. 2.1.7): two inertias, a compliant reducer with play.

The motor shaft (JM, CM, Borello friction FSTm/FDTm) and the user shaft (JU, CU, Borello
friction FSTu/FDTu, the external load, the end stops) are separate bodies, coupled by the
1/500 reducer.  Everything is written at the motor shaft: the user angle theta_l = theta_u /
tau, the user-side inertia, damping and friction reflected as in Table 2.1, the reducer's
torsional stiffness K_u at the user shaft becomes tau^2 K_u.

The backlash is the dead zone of that coupling (the gap between the motor-side and the
user-side teeth, sec. 4.3): inside the gap the coupling carries no torque, in contact it
carries stiffness times penetration plus the mesh damping, and never pulls (contact only
pushes).  The thesis places its backlash "downstream the motor position sensors": the
resolver on the motor shaft reads the motor angle (commutation unaffected), the user
position sensor reads the user shaft after the play, which is what a play between the two
shafts gives.
"""

from __future__ import annotations

import math

from numba import njit

from ..physics.drivetrain import end_stops, friction_step


@njit(cache=True, error_model="numpy")
def coupling_torque(
    twist: float, twist_rate: float, stiffness: float, damping: float, half_gap: float
) -> float:
    """Torque the reducer passes from motor to user shaft [N*m at the motor shaft].

    twist = theta_m - theta_l, twist_rate its derivative; zero inside +/-half_gap, else
    stiffness * penetration + damping * twist_rate, clipped so that contact only pushes.
    """
    if twist > half_gap:
        t = stiffness * (twist - half_gap) + damping * twist_rate
        return t if t > 0.0 else 0.0
    if twist < -half_gap:
        t = stiffness * (twist + half_gap) + damping * twist_rate
        return t if t < 0.0 else 0.0
    return 0.0


@njit(cache=True, error_model="numpy")
def two_inertia_step(  # noqa: PLR0917 - numba: positional only
    th_m: float,
    w_m: float,
    th_l: float,
    w_l: float,
    t_motor: float,
    t_load: float,
    mech: tuple[float, ...],
    dt: float,
) -> tuple[float, float, float, float]:
    """One explicit (semi-implicit Euler) step of the two shafts; returns the new 4 states.

    t_motor: electromagnetic torque; t_load: external load torque reflected to the motor
    shaft (opposing positive motion).  mech = (dt/JM, dt/JU, CM, CU, FSTm, FDTm, FSTu, FDTu,
    stiffness, mesh damping, half gap, user stop), all at the motor shaft.
    """
    dtj_m, dtj_l, c_m, c_l, fs_m, fd_m, fs_l, fd_l, k_t, c_t, half_gap, stop = mech
    t_c = coupling_torque(th_m - th_l, w_m - w_l, k_t, c_t, half_gap)
    w_m = friction_step(w_m, t_motor - t_c - c_m * w_m, fs_m, fd_m, dtj_m)
    w_l = friction_step(w_l, t_c - t_load - c_l * w_l, fs_l, fd_l, dtj_l)
    th_m = th_m + w_m * dt
    th_l, w_l = end_stops(th_l + w_l * dt, w_l, stop)
    return th_m, w_m, th_l, w_l


def mesh_damping(stiffness: float, j_motor: float, j_user: float, ratio: float) -> float:
    """Damping [N*m*s/rad] giving the two-inertia mode the damping `ratio` (all at one shaft)."""
    reduced = j_motor * j_user / (j_motor + j_user)
    return 2.0 * ratio * math.sqrt(stiffness * reduced)


def first_mode(stiffness: float, j_motor: float, j_user: float) -> float:
    """Undamped first torsional mode [rad/s] of the two inertias on the stiffness."""
    return math.sqrt(stiffness * (1.0 / j_motor + 1.0 / j_user))
