#!/usr/bin/env python3
"""Why the monitor does not explain the thesis actuator under a 200 Hz PI current loop.

Usage (repo root):  .venv/bin/python -m bench.studies.slow_current_loop

docs/benchmarks_external.md: with an 800 Hz loop the monitor explains the thesis actuator's
healthy windows, with a 200 Hz loop it does not, in our HF and in motulator's drive alike.
The suspected cause was the monitor model's current loop, which runs the q axis only (the d
axis held at 0 A).  This study measures how much the d axis could explain, on our HF (which
runs both axes), healthy and noise-free, default command, for each bandwidth and for each
inverter the actuator file can describe (sine-triangle PWM or averaged), noise-free and with
the external benchmark's sensor noise on each sensor alone and on all:

- the d and q currents of the HF (its phase currents, Park at the electrical angle);
- the residual of I_3eq between the HF and the monitor model at the true (nominal) k,
  open loop and following the recorded loop (the fitness the monitor uses);
- the share of that residual's variance a least-squares fit on the d axis's terms takes
  (i_d, its rate, and we * i_d, the dq coupling into the q voltage): a linear, same-instant
  estimate of what those terms explain;
- the strongest spectral line of I_3eq above 50 Hz in each model (the position loop's limit
  cycle, docs/benchmarks_external.md) and its amplitude;
- the monitor's own default fitness at the true k (`model_error`), what the telemetry's
  white noise adds to it (`noise_fitness`) and what the noise of the recorded loop it
  follows adds (`fed_noise_fitness`), and the adequacy statistic the monitor judges with
  them (`diagnosis.adequacy.judge`: explained below its threshold).

Nothing here is tuned, and the HF is not changed: the inverter is a value of the actuator
file (``current_loop.pwm``).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from bench.harness.pi_drives import noise_of, thesis_pi
from ema_phm.diagnosis.adequacy import judge
from ema_phm.diagnosis.fitness import LOOPS, Fitness
from ema_phm.domain.faults import NOMINAL
from ema_phm.model.belief import MonitorBelief
from ema_phm.model.monitor_model import OUT_I3EQ, MonitorModel
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema

BANDWIDTHS = (800.0, 200.0)
INVERTERS = {"pwm": 1.0, "averaged": 0.0}
#: Sensors with noise: none, each alone, all (the averaged inverter: none and all only).
NOISY = ((), ("current",), ("position",), ("speed",), ("current", "position", "speed"))


def rms(x: np.ndarray) -> float:
    """Root mean square."""
    return float(np.sqrt(np.mean(np.square(x))))


def dq(phases: np.ndarray, theta_m: np.ndarray, poles: float) -> tuple[np.ndarray, np.ndarray]:
    """(i_d, i_q) of phase currents A, B, C at the motor angle (the HF's own Park transform)."""
    s, c = np.sin(poles * theta_m), np.cos(poles * theta_m)
    ia, ib, ic = phases.T
    sq = math.sqrt(3.0) / 2.0
    i_d = (2.0 / 3.0) * (ia * c + ib * (sq * s - 0.5 * c) - ic * (0.5 * c + sq * s))
    i_q = (2.0 / 3.0) * (-ia * s + ib * (0.5 * s + sq * c) + ic * (0.5 * s - sq * c))
    return i_d, i_q


def line(x: np.ndarray, rate: float, above_hz: float = 50.0) -> tuple[float, float]:
    """(frequency [Hz], amplitude) of the strongest spectral line of x above `above_hz`."""
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(x.size))) * 4.0 / x.size
    f = np.fft.rfftfreq(x.size, 1.0 / rate)
    band = f > above_hz
    i = int(np.argmax(np.where(band, spec, 0.0)))
    return float(f[i]), float(spec[i])


def d_axis_share(residual: np.ndarray, i_d: np.ndarray, we: np.ndarray, rate: float) -> float:
    """Share of the residual's variance a least-squares fit on the d axis's terms takes."""
    terms = np.column_stack([i_d, np.gradient(i_d) * rate, we * i_d, np.ones_like(i_d)])
    coef, *_ = np.linalg.lstsq(terms, residual, rcond=None)
    left = residual - terms @ coef
    return 1.0 - float(np.var(left) / np.var(residual))


def one(actuator: ActuatorParameters, noisy: tuple[str, ...]) -> dict[str, float]:
    """The figures of one actuator's healthy window (module docstring).

    `noisy`: the sensors with the external benchmark's noise (`noise_of`, seed 0), in the
    HF's loop and in the telemetry; the others ideal.
    """
    n = {s: v if s in noisy else 0.0 for s, v in noise_of(actuator).items()}
    hf = real_ema.simulate(
        NOMINAL,
        actuator=actuator,
        noise_current=n["current"],
        noise_position=n["position"],
        noise_speed=n["speed"],
    )
    w = hf.window.without_truth()
    rate = 1.0 / w.dt
    poles = float(actuator.as_dict()["motor"]["pole_pairs"])
    i_d, i_q = dq(hf.phase_currents, w.theta_m, poles)
    belief = MonitorBelief.for_actuator(actuator)
    out = {"i3eq_rms_A": rms(w.i3eq), "id_rms_A": rms(i_d), "iq_rms_A": rms(i_q)}
    for mode, loop in (("open", None), ("followed", LOOPS["recorded"])):
        lf = MonitorModel(w, belief=belief, loop=loop).simulate(NOMINAL)[:, OUT_I3EQ]
        residual = w.i3eq - lf
        out[f"{mode}_residual_rms_A"] = rms(residual)
        out[f"{mode}_d_axis_share"] = d_axis_share(residual, i_d, poles * w.omega_m, rate)
        out[f"{mode}_lf_line_hz"], out[f"{mode}_lf_line_A"] = line(lf, rate)
    out["hf_line_hz"], out["hf_line_A"] = line(w.i3eq, rate)
    fit = Fitness(w, belief=belief)  # the monitor's default fitness, at the true k
    x = np.asarray(NOMINAL, dtype=float)
    out["hunting_rms_A"], out["loop_hunts"] = fit.hunting_rms, float(fit.loop_hunts)
    out["model_error"] = fit.adequacy_fitness(x)
    out["noise_fitness"] = fit.noise_fitness
    out["fed_noise_fitness"] = fit.fed_noise_fitness(x)
    verdict = judge(
        out["model_error"],
        belief=belief,
        noise_fitness=fit.noise_fitness,
        followed=fit.follows,
        fed_noise_fitness=out["fed_noise_fitness"],
    )
    out["adequacy"], out["adequacy_threshold"] = verdict.statistic, verdict.threshold
    return out


def _rounded(v: object) -> object:
    return round(v, 4) if isinstance(v, float) else v


def main() -> int:
    """Print one JSON row per bandwidth, inverter and noisy sensors."""
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    for noisy in NOISY:
        for bw in BANDWIDTHS:
            for name, pwm in INVERTERS.items():
                if name != "pwm" and noisy not in {(), NOISY[-1]}:
                    continue
                actuator = thesis_pi(bw).with_values({"current_loop.pwm": pwm})
                row = {"bandwidth_hz": bw, "inverter": name, "noisy": "+".join(noisy)}
                row |= one(actuator, noisy)
                print(json.dumps({k: _rounded(v) for k, v in row.items()}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
