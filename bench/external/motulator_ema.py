"""motulator (Aalto University's motor-drive simulator, 0.5.0) playing the actuator.

`simulate(actuator, ...)` runs an actuator file of kind pi_dq_current in motulator and
returns a telemetry `Window` at acquisition.sample_rate, as `ema_phm.simulator.real_ema` does.

Motulator's own parts:

- the machine: `SynchronousMachine` (dq flux-linkage model, peak-valued space vectors) with
  n_p = pole_pairs, R_s = r_phase_to_phase / 2, L_d = L_q = l_phase_to_phase / 2 and
  psi_f = ke_phase_peak / pole_pairs (so 1.5 n_p psi_f = torque_constant);
- the converter: `VoltageSourceConverter` at vdc behind motulator's averaged (zero-order
  hold) inverter model, one control period of computation delay (`Model`'s `Delay(1)`);
- the current control: motulator's `CurrentController` (2DOF synchronous-frame complex
  PI in flux-linkage units, k_p = 2 alpha_c, k_i = alpha_c^2, k_t = alpha_c, anti-windup on
  the realized voltage) with alpha_c = 2 pi current_loop.bandwidth_hz, and its `PWM`
  (space-vector duty ratios, minimum-magnitude-error overmodulation, 1.5-period angle
  compensation) at controller.rate_hz.  Not our PI: no back-EMF feed-forward, a different
  zero, motulator's voltage limit;
- the solver: `Simulation` (scipy `solve_ivp`, RK45 at its default tolerances, one call per
  control period).

Ours, written in motulator's frameworks:

- the outer loops (`EmaControl`, a motulator `DriveControlSystem`): ema_phm's position P and
  speed PID (`ema_phm.physics.drivetrain.controller`) give the q-current reference; the d
  current is held at zero (a surface PM motor below base speed: motulator's MTPA tables and
  field weakening are not used);
- the mechanics (`EmaMechanics`, a motulator `Subsystem`): two inertias on a reducer of
  torsional stiffness high_fidelity.torsional_stiffness with the backlash as its dead zone
  and the mesh damping of high_fidelity.torsional_damping_ratio (contact only pushes), viscous
  damping per shaft, and per shaft a Stribeck dry friction
  (F_d + (F_s - F_d) exp(-(w / w_s)^2)) tanh(w / w_eps) in place of our HF's Borello
  stick-slip (`FrictionCurve`: an ODE solver has no stick state);
- the acquisition (`CurrentAcquisition`): the q current of the machine's true rotor frame
  through a continuous 2nd-order Butterworth at acquisition.current_filter_hz;
- the sensors: the user position read through the gear, quantized to
  high_fidelity.position_resolution, with white noise, by the position loop and the
  telemetry; the motor speed with white noise, by the speed loop and the telemetry (a new
  draw each control period); the resolver angle quantized to resolver_resolution in the
  telemetry; white noise on the I_3eq channel.

Left out: end stops (the windows stay far from them), eccentricity and coil short circuits
(motulator's machine is balanced), PWM ripple (the averaged converter).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import math
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from motulator.common.model import Subsystem
from motulator.drive.control import DriveControlSystem
from motulator.drive.control.sm import CurrentController
from motulator.drive.model import Drive, Simulation, SynchronousMachine, VoltageSourceConverter
from motulator.drive.utils import SynchronousMachinePars

from ema_phm.domain.faults import k_with
from ema_phm.domain.window import Window
from ema_phm.errors import ConfigError
from ema_phm.physics.actuator import PI_DQ_CURRENT
from ema_phm.physics.commands import (
    CommandSpec,
    LoadSpec,
    command_samples,
    default_specs,
    sample_times,
)
from ema_phm.physics.drivetrain import controller
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator.sensors import quantize

#: The motulator these windows come from.
MOTULATOR_VERSION = importlib.metadata.version("motulator")
#: Stribeck speed [rad/s at the motor shaft]: a choice, no datasheet gives it.  About 10 rpm,
#: a sliding speed of 1e-2 m/s at a 1 cm radius, inside the 1e-3..1e-2 m/s usually quoted for
#: lubricated contacts; docs/benchmarks_external.md measures what 0.3 and 8.4 rad/s change.
STRIBECK_SPEED = 1.0
#: Width of the tanh standing for the sign of the speed [rad/s], a tenth of the Stribeck speed.
SMOOTHING_SPEED = 0.1


@dataclass(frozen=True)
class FrictionCurve:
    """The Stribeck curve of each shaft's dry friction [rad/s at the motor shaft]."""

    #: speed over which the friction falls from the static to the dynamic level
    stribeck_speed: float
    #: width of the tanh that stands for the sign of the speed (no stick state)
    smoothing_speed: float

    @classmethod
    def default(cls) -> FrictionCurve:
        """`STRIBECK_SPEED` and `SMOOTHING_SPEED`, whatever the actuator."""
        return cls(STRIBECK_SPEED, SMOOTHING_SPEED)


@dataclass(frozen=True)
class Faults:
    """What differs from the actuator file: factors on its values, an unmeasured load."""

    friction: float = 1.0  # static and dynamic dry friction, both shafts (k1: 1 + 2 k1)
    damping: float = 1.0  # viscous damping c_motor and c_user (no k entry)
    gain: float = 1.0  # position-loop gain (k8: 0.5 + k8)
    inertia: float = 1.0  # j_motor and j_user (no k entry)
    load_nm: float = 0.0  # unmeasured constant load at the user shaft [N*m] (no k entry)

    def k_true(self) -> np.ndarray:
        """The k of the faults k expresses (friction, gain); the rest leave k healthy."""
        k1, k8 = (self.friction - 1.0) / 2.0, self.gain - 0.5
        if not (0.0 <= k1 <= 1.0 and 0.0 <= k8 <= 1.0):
            raise ConfigError(f"friction factor {self.friction} or gain {self.gain} outside k")
        return k_with(friction=k1, gain_drift=k8)


@dataclass(frozen=True)
class Noise:
    """White-noise RMS of the sensors (see the module docstring for who reads which)."""

    current: float = 0.0  # A, I_3eq channel
    position: float = 0.0  # rad, user position
    speed: float = 0.0  # rad/s, motor speed


def machine_pars(actuator: ActuatorParameters) -> SynchronousMachinePars:
    """Motulator's parameters of the actuator's motor (dq, amplitude-invariant)."""
    mo = actuator.motor
    l_s = mo.l_phase_to_phase / 2.0
    return SynchronousMachinePars(
        n_p=int(mo.pole_pairs),
        R_s=mo.r_phase_to_phase / 2.0,
        L_d=l_s,
        L_q=l_s,
        psi_f=mo.ke_phase_peak / mo.pole_pairs,
    )


def mechanics_pars(
    actuator: ActuatorParameters, faults: Faults, curve: FrictionCurve
) -> SimpleNamespace:
    """The two shafts' parameters at the motor shaft, with the faults' factors applied."""
    me, hf = actuator.mechanics, actuator.high_fidelity
    gear = me.gear_ratio
    j_m, j_l = faults.inertia * me.j_motor, faults.inertia * me.j_user
    k_s = hf.torsional_stiffness * gear * gear
    return SimpleNamespace(
        gear=gear,
        j_m=j_m,
        j_l=j_l,
        c_m=faults.damping * me.c_motor,
        c_l=faults.damping * me.c_user,
        fs_m=faults.friction * me.friction_static_motor,
        fd_m=faults.friction * me.friction_dynamic_motor,
        fs_l=faults.friction * me.friction_static_user,
        fd_l=faults.friction * me.friction_dynamic_user,
        k_s=k_s,
        # the mesh damping giving the first torsional mode its damping ratio
        c_s=2.0 * hf.torsional_damping_ratio * math.sqrt(k_s * j_m * j_l / (j_m + j_l)),
        half_gap=0.5 * me.backlash / gear,
        w_s=curve.stribeck_speed,
        w_eps=curve.smoothing_speed,
    )


def stribeck(w: float, f_static: float, f_dynamic: float, curve: SimpleNamespace) -> float:
    """Dry friction torque at speed w: the Stribeck curve times a smoothed sign."""
    level = f_dynamic + (f_static - f_dynamic) * math.exp(-((w / curve.w_s) ** 2))
    return level * math.tanh(w / curve.w_eps)


def coupling(twist: float, twist_rate: float, p: SimpleNamespace) -> float:
    """Torque the reducer passes to the user shaft: zero in the play, contact only pushes."""
    if twist > p.half_gap:
        return max(0.0, p.k_s * (twist - p.half_gap) + p.c_s * twist_rate)
    if twist < -p.half_gap:
        return min(0.0, p.k_s * (twist + p.half_gap) + p.c_s * twist_rate)
    return 0.0


class EmaMechanics(Subsystem):
    """The motor shaft and the user shaft (at the motor shaft) on a compliant reducer with play.

    States: motor speed and angle, user speed, twist theta_M - theta_L (motulator's
    two-mass convention).  `load(t, theta_u)` [N*m at the user shaft] opposes positive motion.
    """

    def __init__(self, par: SimpleNamespace, load: Callable[[float, float], float]) -> None:
        super().__init__()
        self.par, self.load = par, load
        self.state = SimpleNamespace(w_M=0.0, theta_M=0.0, w_L=0.0, theta_ML=0.0)
        self.sol_states = SimpleNamespace(w_M=[], theta_M=[], w_L=[], theta_ML=[])

    def user_angle(self) -> float:
        """The user shaft's angle theta_u [rad] (after the gear)."""
        s = self.state
        return self.par.gear * float(np.real(s.theta_M - s.theta_ML))

    def set_outputs(self, t: float) -> None:
        """The motor speed (to the machine), the reducer's and the load's torques."""
        s, p, out = self.state, self.par, self.out
        out.w_M = float(np.real(s.w_M))
        out.w_L = float(np.real(s.w_L))
        out.tau_S = coupling(float(np.real(s.theta_ML)), out.w_M - out.w_L, p)
        out.tau_L = p.gear * self.load(t, self.user_angle())

    def rhs(self) -> list[float]:
        """d/dt of (w_M, theta_M, w_L, theta_ML)."""
        p, out = self.par, self.out
        w_m, w_l = out.w_M, out.w_L
        t_m = float(np.real(self.inp.tau_M)) - out.tau_S - p.c_m * w_m
        t_m -= stribeck(w_m, p.fs_m, p.fd_m, p)
        t_l = out.tau_S - out.tau_L - p.c_l * w_l - stribeck(w_l, p.fs_l, p.fd_l, p)
        return [t_m / p.j_m, w_m, t_l / p.j_l, w_m - w_l]

    def meas_speed(self) -> float:
        """Motor speed [rad/s] (exact: the sensors add their errors in `EmaControl`)."""
        return float(np.real(self.state.w_M))

    def meas_position(self) -> float:
        """Motor angle [rad], unwrapped."""
        return float(np.real(self.state.theta_M))


class CurrentAcquisition(Subsystem):
    """The q current of the true rotor frame through a 2nd-order Butterworth low-pass."""

    def __init__(self, cutoff_hz: float) -> None:
        super().__init__()
        self.wc = 2.0 * math.pi * cutoff_hz
        self.inp = SimpleNamespace(i_q=0.0)
        self.state = SimpleNamespace(x=0.0, dx=0.0)
        self.sol_states = SimpleNamespace(x=[], dx=[])

    def rhs(self) -> list[float]:
        """d/dt of the filter's output and its rate."""
        x, dx = float(np.real(self.state.x)), float(np.real(self.state.dx))
        return [dx, self.wc * self.wc * (self.inp.i_q - x) - math.sqrt(2.0) * self.wc * dx]

    def output(self) -> float:
        """The filtered current [A]."""
        return float(np.real(self.state.x))


class EmaDrive(Drive):
    """Motulator's drive (converter, machine, mechanics) plus the current acquisition."""

    def __init__(
        self,
        converter: VoltageSourceConverter,
        machine: SynchronousMachine,
        mechanics: EmaMechanics,
        acquisition: CurrentAcquisition,
    ) -> None:
        super().__init__(converter=converter, machine=machine, mechanics=mechanics)
        self.acquisition = acquisition
        self.subsystems.append(acquisition)

    def interconnect(self, t: float) -> None:
        """Motulator's connections, and the machine's q current into the acquisition."""
        super().interconnect(t)
        self.acquisition.inp.i_q = float(np.imag(self.machine.out.i_s))


@dataclass
class OuterLoops:
    """ema_phm's position P and speed PID (drivetrain.controller) at each control period."""

    t: np.ndarray  # telemetry instants of the command samples [s]
    com: np.ndarray  # command samples [rad, user], read linearly in between (as the HF)
    gains: tuple[float, ...]  # kpos, wmax, kp, ki, kd, tc, ktc, imax
    ff_per_rad: float  # speed feed-forward per rad of command step between samples
    ref_a: float  # 1st-order position reference filter's step (0: none)
    integ: float = 0.0
    e_prev: float = 0.0
    cmdf: float = 0.0

    @classmethod
    def of(
        cls, actuator: ActuatorParameters, gain: float, t: np.ndarray, com: np.ndarray
    ) -> OuterLoops:
        """The loops of `actuator` with its position gain times `gain`."""
        co = actuator.controller
        tc = 1.0 / co.rate_hz
        f = co.reference_filter_hz
        gains = (
            co.position_gain * gain,
            co.max_speed_rpm * 2.0 * math.pi / 60.0,
            co.speed_kp,
            co.speed_ki,
            co.speed_kd,
            tc,
            co.torque_gain,
            co.max_current,
        )
        ts = float(t[1] - t[0])
        ff = co.speed_feedforward / (actuator.mechanics.gear_ratio * ts)
        ref_a = 1.0 - math.exp(-2.0 * math.pi * f * tc) if f > 0.0 else 0.0
        return cls(t, com, gains, ff, ref_a)

    def current_reference(self, t: float, y_pos: float, y_spd: float) -> float:
        """The q-current reference [A] from the position and speed readings at time t."""
        i = min(int(t / (self.t[1] - self.t[0]) + 1e-9), self.t.size - 2)
        cmd = float(np.interp(t, self.t, self.com))
        wff = self.ff_per_rad * float(self.com[i + 1] - self.com[i])
        if self.ref_a > 0.0:
            self.cmdf += self.ref_a * (cmd - self.cmdf)
            cmd = self.cmdf
        kpos, wmax, kp, ki, kd, tc, ktc, imax = self.gains
        iref, self.integ, self.e_prev = controller(
            cmd, y_pos, y_spd, self.integ, self.e_prev, kpos, wmax, kp, ki, kd, tc, ktc, imax, wff
        )
        return float(iref)


class Sensors:
    """The position and speed readings the loops and the telemetry take."""

    def __init__(self, actuator: ActuatorParameters, noise: Noise, rng: np.random.Generator):
        hf = actuator.high_fidelity
        self.pos_res, self.res_res = hf.position_resolution, hf.resolver_resolution
        self.noise, self.rng = noise, rng

    def read(self, mechanics: EmaMechanics) -> tuple[float, float]:
        """(user position [rad], motor speed [rad/s]) as the sensors read them now."""
        n = self.rng.standard_normal(2) if self.noise.position or self.noise.speed else (0, 0)
        y_pos = quantize(mechanics.user_angle(), self.pos_res) + self.noise.position * n[0]
        return y_pos, mechanics.meas_speed() + self.noise.speed * n[1]


class Recorder:
    """The telemetry channels, filled at the sample instants the control periods hit."""

    def __init__(self, t: np.ndarray, sample_rate: float) -> None:
        self.t, self.fs = t, sample_rate
        self.rows = np.full((t.size, 5), np.nan)  # theta_u, theta_m, omega_m, i3eq, load

    def sample(self, t: float, reading: tuple[float, float], mdl: EmaDrive, res: float) -> None:
        """Record the readings at time t if t is a telemetry instant."""
        j = round(t * self.fs)
        if abs(t * self.fs - j) > 1e-6 or not 0 <= j < self.t.size:
            return
        mech = mdl.mechanics
        theta_m = quantize(mech.meas_position(), res)
        load = mech.load(t, mech.user_angle())
        self.rows[j] = (reading[0], theta_m, reading[1], mdl.acquisition.output(), load)

    def complete(self) -> bool:
        """True when every telemetry instant was recorded."""
        return bool(np.all(np.isfinite(self.rows[:, :4])))


class EmaControl(DriveControlSystem):
    """Our outer loops on motulator's current controller and PWM (sensored, d current 0)."""

    def __init__(
        self,
        actuator: ActuatorParameters,
        loops: OuterLoops,
        sensors: Sensors,
        recorder: Recorder,
    ) -> None:
        par = machine_pars(actuator)
        super().__init__(par, 1.0 / actuator.controller.rate_hz, sensorless=False)
        self.current_ctrl = CurrentController(
            par, 2.0 * math.pi * actuator.current_loop.bandwidth_hz
        )
        self.loops, self.sensors, self.recorder = loops, sensors, recorder

    def get_feedback_signals(self, mdl: EmaDrive) -> SimpleNamespace:
        """Motulator's measurements in rotor coordinates, plus our sensors' readings."""
        fbk = super().get_feedback_signals(mdl)
        fbk.i_s = np.exp(-1j * fbk.theta_m) * fbk.i_ss
        fbk.u_s = np.exp(-1j * fbk.theta_m) * fbk.u_ss
        fbk.w_s = fbk.w_m
        fbk.y_pos, fbk.y_spd = self.sensors.read(mdl.mechanics)
        reading = (fbk.y_pos, fbk.y_spd)
        self.recorder.sample(self.clock.t, reading, mdl, self.sensors.res_res)
        return fbk

    def output(self, fbk: SimpleNamespace) -> SimpleNamespace:
        """The q-current reference from our loops, the voltage from motulator's PI and PWM."""
        ref = super().output(fbk)
        ref.i_s = 1j * self.loops.current_reference(ref.t, fbk.y_pos, fbk.y_spd)
        ref.u_s = self.current_ctrl.output(ref.i_s, fbk.i_s)
        u_ss = ref.u_s * np.exp(1j * fbk.theta_m)
        ref.d_abc = self.pwm(ref.T_s, u_ss, fbk.u_dc, fbk.w_s)
        return ref

    def update(self, fbk: SimpleNamespace, ref: SimpleNamespace) -> None:
        """Motulator's clock and its current controller's integral (on the realized voltage)."""
        super().update(fbk, ref)
        self.current_ctrl.update(ref.T_s, fbk.u_s, fbk.w_s)


def load_function(load: LoadSpec, extra_nm: float) -> Callable[[float, float], float]:
    """(t, theta_u) -> total load [N*m at the user shaft]: the profile, spring and `extra_nm`."""
    w = 2.0 * math.pi * load.frequency
    sine = load.kind == "sine"

    def total(t: float, theta_u: float) -> float:
        profile = load.value + (load.amplitude * math.sin(w * t) if sine else 0.0)
        return profile + extra_nm + load.spring * theta_u

    return total


def _check(actuator: ActuatorParameters, command: CommandSpec) -> None:
    """ConfigError unless motulator can run `actuator` on `command`."""
    if actuator.controller_kind != PI_DQ_CURRENT or actuator.current_loop.bandwidth_hz <= 0:
        raise ConfigError("motulator runs kind pi_dq_current with a bandwidth-designed loop")
    command.check_sample_rate(actuator.acquisition.sample_rate)
    periods = actuator.controller.rate_hz / actuator.acquisition.sample_rate
    if abs(periods - round(periods)) > 1e-9:
        raise ConfigError("the control rate must be a whole multiple of the sample rate")


def simulate(
    actuator: ActuatorParameters,
    *,
    command: CommandSpec | None = None,
    load: LoadSpec | None = None,
    faults: Faults = Faults(),
    noise: Noise = Noise(),
    seed: int = 0,
    curve: FrictionCurve | None = None,
    temperature_c: float = 20.0,
) -> Window:
    """One telemetry window of `actuator` simulated by motulator (module docstring).

    `curve`: the Stribeck curve (default `FrictionCurve.default()`); noise is drawn from
    `numpy.random.default_rng(seed)`.  The load channel is NaN when `load` is not measured
    or `faults.load_nm` is not zero.  k_true is `faults.k_true()`; meta["faults"] names every
    factor (inertia, damping and the load have no k entry).
    """
    default_command, default_load = default_specs()
    command, load = command or default_command, load or default_load
    _check(actuator, command)
    fs = actuator.acquisition.sample_rate
    t = sample_times(command.duration, fs)
    com = command_samples(command, t)
    rng = np.random.default_rng(seed)
    curve = curve or FrictionCurve.default()
    mechanics = EmaMechanics(
        mechanics_pars(actuator, faults, curve), load_function(load, faults.load_nm)
    )
    mdl = EmaDrive(
        VoltageSourceConverter(actuator.inverter.vdc),
        SynchronousMachine(machine_pars(actuator)),
        mechanics,
        CurrentAcquisition(actuator.acquisition.current_filter_hz),
    )
    recorder = Recorder(t, fs)
    loops = OuterLoops.of(actuator, faults.gain, t, com)
    ctrl = EmaControl(actuator, loops, Sensors(actuator, noise, rng), recorder)
    Simulation(mdl, ctrl).simulate(t_stop=command.duration + 0.5 / actuator.controller.rate_hz)
    if not recorder.complete():
        raise RuntimeError(f"motulator stopped before {command.duration} s (see its message)")
    meta = {
        "source": "motulator " + MOTULATOR_VERSION + " (bench/external/motulator_ema.py)",
        "sample_rate": fs,
        "command": command.as_dict(),
        "load": {**load.as_dict(), "unmeasured_extra_nm": faults.load_nm},
        "seed": seed,
        "noise": dataclasses.asdict(noise),
        "faults": dataclasses.asdict(faults),
        "friction_curve": dataclasses.asdict(curve),
        "temperature_c": temperature_c,
    }
    measured = load.measured and faults.load_nm == 0.0
    return _window(recorder, com, rng.standard_normal(t.size) * noise.current, measured, meta)


def _window(
    recorder: Recorder, com: np.ndarray, current_noise: np.ndarray, measured: bool, meta: dict
) -> Window:
    """The telemetry window of a finished run (the load channel NaN unless `measured`)."""
    rows, t = recorder.rows, recorder.t
    faults = Faults(**meta["faults"])
    return Window(
        t=t,
        command=com,
        load=rows[:, 4].copy() if measured else np.full(t.size, np.nan),
        theta_u=rows[:, 0].copy(),
        theta_m=rows[:, 1].copy(),
        omega_m=rows[:, 2].copy(),
        i3eq=rows[:, 3] + current_noise,
        k_true=faults.k_true(),
        meta=meta,
        temperature=np.full(t.size, float(meta["temperature_c"])),
    )
