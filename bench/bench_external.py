#!/usr/bin/env python3
"""Cross-simulator validation: the monitor on motulator's telemetry, beside our own HF's.

Usage (from the repo root; motulator is pinned in requirements.txt's benchmark block):
    nohup .venv/bin/python -m bench.bench_external > /tmp/bench_external.log 2>&1 &
    .venv/bin/python -m bench.bench_external --import-forms --jobs 2   # a rig's forms
    .venv/bin/python -m bench.bench_external --report-only   # report from the saved rows
    .venv/bin/python -m bench.bench_external --fresh         # forget the saved rows

Actuators (kind pi_dq_current, each at current-loop bandwidths of 800 and 200 Hz): the
thesis actuator (`ActuatorParameters.default()`) with a PI current loop in dq
(`thesis_pi`), and config/actuators/small_pi_ema.yaml (`small_pi`).  The monitor's belief
is always `MonitorBelief.for_actuator(the same actuator)`: the monitor reads the actuator
file, never motulator's internals.

Scenarios (`scenarios`), each simulated by motulator (bench/external/motulator_ema.py) and
by our HF (`real_ema.simulate`, the actuator file as it is: sine-triangle PWM) with the
same faults, noise levels (`noise_of`) and seed: healthy windows, friction k1 = 0.3 and
0.6, position gain k8 = 0.7 and 0.3 (truth in k); viscous damping x10, inertia x1.3 and an
unmeasured constant load (no k entry: k_true is healthy).  Every window is isolated
(`isolate(..., nuisance=True, intervals=True)`, default preset and fitness) with the
packaged belief of the actuator ("uncommissioned") and with that belief commissioned on
two healthy baselines of the same simulator (`commission`).  Scored as bench_robust scores
(`health.assess_isolation`): OK / WARN / ERROR, the fault named (WARN or more, dominant
fault, model adequate), withheld (adequacy not ok).  Also the I_3eq RMS difference between
the two simulators on the nominal chirp, and its dependence on motulator's friction curve.

``--import-forms`` measures something else on the same drive: `ema-phm import` of another
code base's windows.  thesis_pi 800 Hz's motulator windows (3 healthy, friction k1 = 0.3 and
0.6, gain k8 = 0.7 and 0.3; the same seeds and cache as above), each taken as a rig without
a load cell records it (`unloaded`: the rig's forms carry no load), are written in
`harness.import_forms.VARIANTS`' forms (bag, CSV, Parquet; no encoder, no speed, no
temperature, a 1 kHz current; not the 20 kHz phase currents: `motulator_ema.simulate` gives
the 2 kHz acquired window only), imported with the user's description of the drive and
fitted as ``ema-phm isolate`` fits them (`import_forms.fit`) with that description
commissioned on motulator's two baselines (native and bag at seeds 0, 1, 2; the rest at 0),
and scored by `import_forms`' scoring.  Rows: bench/results/bench_import_external.json;
report: docs/benchmarks_import_external.md (``--import-forms --jobs 2``, ~14 min;
``--import-forms --report-only`` renders the stored rows).

Rows go to bench/results/bench_external.json after every window (a re-run resumes from them;
motulator windows are cached under build/bench_external/ and reused when their metadata
holds the same faults, noise, friction curve and seed), the report to
docs/benchmarks_external.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import (
    OUT_HELP,
    ROOT,
    cli,
    command_line,
    git_commit,
    machine,
    out_dirs,
    read_rows,
    write_report,
    write_rows,
)
from bench.harness import import_forms as forms
from bench.harness.pi_drives import noise_of, thesis_pi
from ema_phm.diagnosis import health
from ema_phm.diagnosis.commissioning import commission, review
from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate
from ema_phm.domain.faults import NAMES, NOMINAL, fault
from ema_phm.domain.window import Window
from ema_phm.errors import ExcitationError
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator_file import load_actuator, write_actuator
from ema_phm.physics.commands import LoadSpec
from ema_phm.physics.parameters import HF_SECTION, ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.sensors import SensorSpec

try:
    from bench.external import motulator_ema as mot
except ImportError as _exc:  # motulator is a benchmark-only dependency
    mot = None
    MISSING = f"motulator is not importable ({_exc}); pip install -r requirements.txt"
else:
    MISSING = ""

SMALL_PI = ROOT / "config" / "actuators" / "small_pi_ema.yaml"
#: (actuator, current-loop bandwidth [Hz]) in the order they run.
CONFIGS: tuple[tuple[str, float], ...] = (
    ("thesis_pi", 800.0),
    ("small_pi", 800.0),
    ("thesis_pi", 200.0),
    ("small_pi", 200.0),
)
SIMULATORS = ("motulator", "hf")
HEALTHY = 3
BASELINES = 2
#: The unmeasured load: this share of the torque the motor holds through the gear (6 %,
#: bench_robust's largest drawn hinge moment on the thesis actuator).
LOAD_SHARE = 0.06
CACHE = ROOT / "build" / "bench_external"


def described(name: str, actuator: ActuatorParameters) -> ActuatorParameters:
    """What the monitor is told of `actuator`: the file its user would write and load.

    thesis_pi: a user's own file, written to build/bench_external/described/ and read back
    (PI kind, bandwidth, delay and every datasheet section; no high_fidelity section and no
    healthy levels, only the monitor's steps_per_sample); small_pi: the packaged file (its
    healthy levels measured on drawn units of that actuator).
    """
    if not actuator.source.startswith("thesis actuator"):
        return actuator
    sections = {s: dict(v) for s, v in actuator.as_dict().items() if s != HF_SECTION}
    user = ActuatorParameters.from_sections(
        sections,
        source="a user's description",
        controller_kind=actuator.controller_kind,
        monitor_values={
            "monitor.steps_per_sample": actuator.monitor_values["monitor.steps_per_sample"]
        },
    )
    bw = actuator.current_loop.bandwidth_hz
    (CACHE / "described").mkdir(parents=True, exist_ok=True)
    path = write_actuator(
        user,
        CACHE / "described" / f"thesis_pi_{bw:g}.yaml",
        title=(f"The thesis actuator with a {bw:g} Hz PI current loop, as its user describes it"),
    )
    return load_actuator(path)


def small_pi(bandwidth: float) -> ActuatorParameters:
    """config/actuators/small_pi_ema.yaml at `bandwidth` (800 Hz: the file as it is)."""
    return load_actuator(SMALL_PI).with_values({"current_loop.bandwidth_hz": bandwidth})


def actuator_of(name: str, bandwidth: float) -> ActuatorParameters:
    """The actuator a config names."""
    return (thesis_pi if name == "thesis_pi" else small_pi)(bandwidth)


@dataclass(frozen=True)
class Scenario:
    """One window's faults: `kind` healthy, in_k (truth in k) or outside (no k entry)."""

    name: str
    faults: Any  # motulator_ema.Faults
    kind: str
    fault: str = ""  # the k fault a named result should name (kind in_k)


def scenarios(actuator: ActuatorParameters, healthy: int) -> list[Scenario]:
    """The healthy windows and the fault scenarios of one actuator."""
    f = mot.Faults
    load = LOAD_SHARE * actuator.motor.max_torque / actuator.mechanics.gear_ratio
    out = [Scenario(f"healthy #{i + 1}", f(), "healthy") for i in range(healthy)]
    return out + [
        Scenario("friction k1=0.3", f(friction=1.6), "in_k", "friction"),
        Scenario("friction k1=0.6", f(friction=2.2), "in_k", "friction"),
        Scenario("gain k8=0.7", f(gain=1.2), "in_k", "gain_drift"),
        Scenario("gain k8=0.3", f(gain=0.8), "in_k", "gain_drift"),
        Scenario("viscous damping x10", f(damping=10.0), "outside"),
        Scenario("inertia x1.3", f(inertia=1.3), "outside"),
        Scenario(f"unmeasured load {load:.3g} N*m", f(load_nm=load), "outside"),
    ]


def hf_window(actuator: ActuatorParameters, faults: Any, seed: int) -> Window:
    """Our HF on the same faults: k for friction and gain, the file's values for the rest."""
    me = actuator.mechanics
    changed = actuator.with_values(
        {
            "mechanics.j_motor": me.j_motor * faults.inertia,
            "mechanics.j_user": me.j_user * faults.inertia,
            "mechanics.c_motor": me.c_motor * faults.damping,
            "mechanics.c_user": me.c_user * faults.damping,
        }
    )
    n = noise_of(actuator)
    sensors = SensorSpec(
        noise_current=n["current"], noise_position=n["position"], noise_speed=n["speed"]
    )
    load = LoadSpec(value=faults.load_nm, measured=faults.load_nm == 0.0)
    return real_ema.simulate(
        faults.k_true(),
        actuator=changed,
        load=load,
        sensors=sensors,
        seed=seed,
        temperature_c=20.0,
    ).window


def _cached(path: Path, make: Any, expect: dict[str, Any]) -> Window:
    """The window stored at `path` if its meta holds `expect`, else `make()` stored there."""
    if path.exists():
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            if all(meta.get(k) == v for k, v in expect.items()):
                return Window.from_matrix(z["m"], k_true=z["k"], meta=meta | {"cached": str(path)})
    w = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, m=w.matrix(), k=w.k_true, meta=json.dumps(w.meta, default=str))
    tmp.replace(path)
    return w


def _expect(faults: Any, noise: Any, curve: Any, seed: int) -> dict[str, Any]:
    """The meta a cached motulator window must hold to stand for these settings."""
    return json.loads(
        json.dumps(
            {
                "faults": dataclasses.asdict(faults),
                "noise": dataclasses.asdict(noise),
                "friction_curve": dataclasses.asdict(curve),
                "seed": seed,
            }
        )
    )


def window(sim: str, cfg: str, actuator: ActuatorParameters, sc: Scenario, seed: int) -> Window:
    """The window of scenario `sc` from simulator `sim` (motulator's cached on disk)."""
    if sim == "hf":
        return hf_window(actuator, sc.faults, seed)
    n = mot.Noise(**noise_of(actuator))
    name = f"{cfg}_{sc.name}_{seed}".replace(" ", "_").replace("*", "").replace("=", "")
    return _cached(
        CACHE / f"{name}.npz",
        lambda: mot.simulate(actuator, faults=sc.faults, noise=n, seed=seed),
        _expect(sc.faults, n, mot.FrictionCurve.default(), seed),
    )


def diagnose(win: Window, belief: MonitorBelief, seed: int) -> dict[str, Any]:
    """One isolation of `win` judged by `health.assess_isolation` (or the refusal)."""
    try:
        res = isolate(win, belief=belief, seed=seed, nuisance=True, intervals=True)
    except ExcitationError as exc:
        return {"error": str(exc)}
    a = health.assess_isolation(res)
    adequate = res.adequacy is None or res.adequacy.ok
    return {
        "k": [float(v) for v in res.k],
        "percent_err": float(res.percent_err),
        "level": health.LEVEL_NAMES[a.level],
        "dominant": NAMES[a.dominant],
        "named": NAMES[a.dominant] if a.level >= health.WARN and adequate else "",
        "adequacy_statistic": float(res.adequacy.statistic) if res.adequacy else None,
        "adequacy_threshold": float(res.adequacy.threshold) if res.adequacy else None,
        "adequate": bool(adequate),
        "nuisance": {k: float(v) for k, v in res.nuisance.items()},
        "message": a.message,
        "wall_s": float(res.wall_s),
        "evaluations": int(res.evaluations),
    }


def commissioned(
    baselines: list[Window], belief: MonitorBelief, stored: dict | None
) -> tuple[MonitorBelief, dict]:
    """The belief commissioned on `baselines` (or on the `stored` result of an earlier run)."""
    if stored is None:
        checks, problems = review(
            baselines, [f"#{b + 1}" for b in range(len(baselines))], belief=belief
        )
        res = commission(baselines, belief=belief, checks=checks)
        problems += res.unexplained()
        stored = {
            "factors": dict(res.factors),
            "identifiable": dict(res.identifiable),
            "values": {k: float(v) for k, v in res.values.items()},
            "warnings": list(getattr(res, "warnings", [])),
            "wall_s": float(res.wall_s),
            # what `ema-phm calibrate --baseline` would answer without --force
            "verdict": f"refused: {problems[0]}" if problems else "accepted",
            "references": [r.as_dict() for r in res.references],
            "commit": git_commit()["commit"],
        }
    return belief.commissioned_with(stored["values"]), stored


@dataclass
class Run:
    """The rows and commissionings so far, written out after each window."""

    path: Path
    data: dict[str, Any]
    #: perf_counter at the start, less the wall time of the runs this one resumes
    t0: float = 0.0

    def done(self, key: tuple) -> bool:
        """True when the row of `key` is stored."""
        return any(_key(r) == key for r in self.data["rows"])

    def add(self, row: dict[str, Any]) -> None:
        """Store one row (and write the file)."""
        self.data["rows"].append(row)
        self.data["wall_s"] = time.perf_counter() - self.t0
        write_rows(self.path, self.data)
        print(
            f"{row['simulator']:9s} {row['config']:17s} {'C' if row['commissioned'] else 'U'} "
            f"{row['scenario']:28s} {row.get('level', 'refused'):5s} "
            f"named={row.get('named') or '-':12s} "
            f"%err={row.get('percent_err', float('nan')):6.2f} "
            f"adequacy={row.get('adequacy_statistic') or float('nan'):5.2f} "
            f"wall={row.get('wall_s', 0.0):5.1f}s",
            flush=True,
        )


def _key(row: dict[str, Any]) -> tuple:
    return (row["simulator"], row["config"], row["scenario"], row["commissioned"])


def config_name(name: str, bandwidth: float) -> str:
    """'thesis_pi 800 Hz'."""
    return f"{name} {bandwidth:g} Hz"


def run_config(run: Run, ci: int, name: str, bandwidth: float, healthy: int) -> None:
    """Every scenario of one actuator at one bandwidth, in both simulators."""
    actuator = actuator_of(name, bandwidth)
    cfg = config_name(name, bandwidth)
    packaged = MonitorBelief.for_actuator(described(name, actuator))
    base = Scenario("baseline", mot.Faults(), "healthy")
    for sim in SIMULATORS:
        key = f"{sim} {cfg}"
        t0 = time.perf_counter()
        baselines = [
            window(sim, cfg, actuator, base, 1000 * ci + 900 + b) for b in range(BASELINES)
        ]
        belief, stored = commissioned(baselines, packaged, run.data["commissioning"].get(key))
        if key not in run.data["commissioning"]:
            run.data["commissioning"][key] = stored | {
                "with_baselines_s": time.perf_counter() - t0
            }
            print(f"{key}: commissioned: {stored['factors']}", flush=True)
        for si, sc in enumerate(scenarios(actuator, healthy)):
            seed = 1000 * ci + 10 * si + 1
            todo = [c for c in (False, True) if not run.done((sim, cfg, sc.name, c))]
            if not todo:
                continue
            t0 = time.perf_counter()
            win = window(sim, cfg, actuator, sc, seed)
            sim_s = time.perf_counter() - t0
            for c in todo:
                row = {"simulator": sim, "config": cfg, "scenario": sc.name, "commissioned": c}
                row["commit"] = run.data["commit"]
                row |= {"kind": sc.kind, "fault": sc.fault, "seed": seed, "sim_s": sim_s}
                row |= {"k_true": [float(v) for v in win.k_true], "faults": vars(sc.faults)}
                run.add(row | diagnose(win, belief if c else packaged, seed))


#: Motulator friction curves the I_3eq difference is also measured with (Stribeck speed,
#: smoothing speed [rad/s at the motor shaft]); the default curve is the benchmark's.
CURVES = ((0.3, 0.03), (8.4, 0.84))


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def current_difference(run: Run, name: str, bandwidth: float) -> None:
    """I_3eq RMS difference motulator vs our HF on the nominal chirp, noise-free."""
    cfg = config_name(name, bandwidth)
    if cfg in run.data["current"]:
        return
    actuator = actuator_of(name, bandwidth)
    hf = {
        pwm: real_ema.simulate(
            NOMINAL, actuator=actuator.with_values({"current_loop.pwm": pwm}), temperature_c=20.0
        ).window
        for pwm in (1.0, 0.0)
    }
    slug = cfg.replace(" ", "_")
    default, none = mot.FrictionCurve.default(), mot.Noise()
    m = _cached(
        CACHE / f"{slug}_nominal.npz",
        lambda: mot.simulate(actuator),
        _expect(mot.Faults(), none, default, 0),
    )
    entry: dict[str, Any] = {
        "rms_hf": _rms(hf[1.0].i3eq),
        "rms_motulator": _rms(m.i3eq),
        "diff_hf_pwm": _rms(m.i3eq - hf[1.0].i3eq),
        "diff_hf_averaged": _rms(m.i3eq - hf[0.0].i3eq),
        "theta_u_diff": _rms(m.theta_u - hf[1.0].theta_u),
        "theta_u_rms": _rms(hf[1.0].theta_u),
        "curve": [default.stribeck_speed, default.smoothing_speed],
        "curves": [],
    }
    if bandwidth == 800.0:  # the friction curve's weight, at one bandwidth
        for ws, eps in CURVES:
            mc = _cached(
                CACHE / f"{slug}_nominal_curve_{ws:g}_{eps:g}.npz",
                lambda ws=ws, eps=eps: mot.simulate(actuator, curve=mot.FrictionCurve(ws, eps)),
                _expect(mot.Faults(), none, mot.FrictionCurve(ws, eps), 0),
            )
            entry["curves"].append([ws, eps, _rms(mc.i3eq - hf[0.0].i3eq)])
    run.data["current"][cfg] = entry
    write_rows(run.path, run.data)
    print(f"{cfg}: I_3eq difference {entry}", flush=True)


# ----------------------------------------------------------------------------- report


def outcome(row: dict[str, Any]) -> str:
    """A window's verdict in words: refused, not explained, OK, or the level and the fault."""
    if "error" in row:
        return "refused (excitation)"
    if not row["adequate"]:
        return "not explained"
    if row["level"] == "OK":
        return "OK"
    return f"{row['level']} {row['dominant']}"


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Healthy OK, right fault named, %err and the outside-k outcomes of one row group."""
    healthy = [r for r in rows if r["kind"] == "healthy"]
    in_k = [r for r in rows if r["kind"] == "in_k"]
    faulty = [r for r in rows if r["kind"] != "healthy"]
    errs = [r["percent_err"] for r in in_k if "percent_err" in r]
    own = [
        100.0 * abs(r["k"][fault(r["fault"]).index] - r["k_true"][fault(r["fault"]).index])
        for r in in_k
        if "k" in r
    ]
    outside = {r["scenario"].split(" ")[0]: outcome(r) for r in rows if r["kind"] == "outside"}
    return {
        "healthy": len(healthy),
        "healthy_ok": sum(r.get("level") == "OK" for r in healthy),
        "in_k": len(in_k),
        "named_right": sum(r.get("named") == r["fault"] for r in in_k),
        "err_median": float(np.median(errs)) if errs else float("nan"),
        "err_min": min(errs) if errs else float("nan"),
        "err_max": max(errs) if errs else float("nan"),
        "own_median": float(np.median(own)) if own else float("nan"),
        "faulty": len(faulty),
        "withheld": sum("error" not in r and not r["adequate"] for r in faulty),
        "outside": outside,
    }


def _pct(n: int, d: int) -> str:
    return f"{n}/{d} ({100.0 * n / d:.0f} %)" if d else "-"


def headline(rows: list[dict[str, Any]], commissioned: bool) -> list[str]:
    """The headline table of one commissioning state: every config, both simulators."""
    lines = [
        "| actuator | simulator | healthy OK | right fault named | %err median (min-max) "
        "| the fault's own entry (points) | damping x10 | inertia x1.3 | unmeasured load "
        "| withheld |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, bw in CONFIGS:
        cfg = config_name(name, bw)
        for sim in SIMULATORS:
            group = [
                r
                for r in rows
                if r["config"] == cfg
                and r["simulator"] == sim
                and r["commissioned"] == commissioned
            ]
            if not group:
                continue
            s = summary(group)
            o = s["outside"]
            lines.append(
                f"| {cfg} | {sim} | {_pct(s['healthy_ok'], s['healthy'])} | "
                f"{_pct(s['named_right'], s['in_k'])} | {s['err_median']:.2f} "
                f"({s['err_min']:.2f}-{s['err_max']:.2f}) | {s['own_median']:.2f} | "
                f"{o.get('viscous', '-')} | "
                f"{o.get('inertia', '-')} | {o.get('unmeasured', '-')} | "
                f"{_pct(s['withheld'], s['faulty'])} |"
            )
    return lines


def targets(rows: list[dict[str, Any]]) -> list[str]:
    """Issue 20's targets on motulator telemetry, commissioned, per config: met or not."""
    lines = [
        "| actuator | healthy OK >= 95 % | friction/gain named >= 95 % | %err median <= 3 % "
        "| damping x10 never a k fault at WARN |",
        "|---|---|---|---|---|",
    ]
    for name, bw in CONFIGS:
        cfg = config_name(name, bw)
        group = [
            r
            for r in rows
            if r["config"] == cfg and r["simulator"] == "motulator" and r["commissioned"]
        ]
        if not group:
            continue
        s = summary(group)
        damping = s["outside"].get("viscous")
        cells = (
            None if not s["healthy"] else s["healthy_ok"] >= 0.95 * s["healthy"],
            None if not s["in_k"] else s["named_right"] >= 0.95 * s["in_k"],
            None if not s["in_k"] else s["err_median"] <= 3.0,
            None if damping is None else damping in ("OK", "not explained"),
        )
        words = ["-" if c is None else "met" if c else "**not met**" for c in cells]
        lines.append(f"| {cfg} | " + " | ".join(words) + " |")
    return lines


def per_window(rows: list[dict[str, Any]]) -> list[str]:
    """Every window: the verdict, %err, adequacy and the fitted nuisances."""
    lines = [
        "| actuator | scenario | simulator | commissioned | verdict | %err | adequacy | "
        "nuisances |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        nu = ", ".join(
            f"{k} {v:.3g}" for k, v in r.get("nuisance", {}).items() if k != "temperature_c"
        )
        err = f"{r['percent_err']:.2f}" if "percent_err" in r and r["kind"] != "outside" else "-"
        stat = f"{r['adequacy_statistic']:.2f}" if r.get("adequacy_statistic") else "-"
        lines.append(
            f"| {r['config']} | {r['scenario']} | {r['simulator']} | "
            f"{'yes' if r['commissioned'] else 'no'} | {outcome(r)} | {err} | {stat} | {nu} |"
        )
    return lines


def currents(data: dict[str, Any]) -> list[str]:
    """The I_3eq difference table and the friction-curve sensitivity."""
    lines = [
        "| actuator | I_3eq RMS, HF | I_3eq RMS, motulator | difference vs HF (PWM) | "
        "difference vs HF (averaged) | theta_u difference / RMS |",
        "|---|---|---|---|---|---|",
    ]
    curves = []
    order = [config_name(*c) for c in CONFIGS]
    for cfg, e in sorted(data["current"].items(), key=lambda item: order.index(item[0])):
        lines.append(
            f"| {cfg} | {e['rms_hf']:.3f} A | {e['rms_motulator']:.3f} A | "
            f"{e['diff_hf_pwm']:.3f} A | {e['diff_hf_averaged']:.3f} A | "
            f"{e['theta_u_diff']:.2e} / {e['theta_u_rms']:.2e} rad |"
        )
        for ws, eps, d in [[*e["curve"], e["diff_hf_averaged"]], *e["curves"]]:
            curves.append(f"| {cfg} | {ws:.3g} | {eps:.3g} | {d:.3f} A |")
    return [
        *lines,
        "",
        "The same difference (against the averaged HF) with other motulator friction curves "
        "(the first row of each actuator is the benchmark's curve):",
        "",
        "| actuator | Stribeck speed [rad/s] | smoothing speed [rad/s] | I_3eq difference |",
        "|---|---|---|---|",
        *curves,
    ]


CANNOT_COMPARE = """\
- **Coil short circuits (k3-k5) and eccentricity (k6, k7)**: motulator's `SynchronousMachine`
  is a balanced dq machine, with no per-phase windings and no air-gap law; no scenario.
- **Backlash (k2)**: motulator has no play; the motulator mechanics here are ours
  (`EmaMechanics`, the nominal play as a dead zone), so a backlash scenario would compare our
  law with itself written twice.  None is run.
- **PWM ripple**: motulator is run with its averaged converter (zero-order hold); our HF runs
  the actuator file as it is (sine-triangle PWM).  The I_3eq table gives the HF both ways.
- **The friction law**: our HF's Borello model sticks at zero speed; an ODE solver has no
  stick state, so motulator's shafts have a Stribeck curve with a tanh in place of the sign.
  k1's meaning (static and dynamic levels x (1 + 2 k1)) maps onto both, but the curve's shape
  is a choice with no datasheet behind it, and it moves the current (table above).
- **The current controller**: motulator's 2DOF complex-vector PI (no back-EMF feed-forward,
  a different zero, motulator's overmodulation) is not the PI the monitor believes in
  (`current_loop_gains`, with feed-forward).  That difference is part of what is measured,
  not a defect of either.
- **%err of the faults outside k** (damping, inertia, load): k_true is healthy there, so a
  %err would only measure how little k moved; those rows are scored by their verdict.
- **Temperature, unit tolerances, sensor gains and offsets**: both simulators run the
  datasheet unit at 20 degC with white noise only; this is not bench_robust's population.
- **End stops, load springs, speed feed-forward**: not exercised by these windows."""

SIMPLIFIED = """\
motulator 0.5.0's own parts: the machine (`SynchronousMachine`, R_s = r/2, L_d = L_q = l/2,
psi_f = ke / pole pairs), the converter (`VoltageSourceConverter` behind the zero-order-hold
inverter model, one period of computation delay), the current controller (`CurrentController`,
alpha_c = 2 pi bandwidth, with motulator's `PWM` and its 1.5-period angle compensation) and
the solver (`Simulation`: scipy RK45 at its default tolerances, one call per control
period).  Ours, written in motulator's frameworks (bench/external/motulator_ema.py): the
outer position P and speed PID loops (`ema_phm.physics.drivetrain.controller`, i_d held at 0:
motulator's MTPA and field weakening unused), the two-mass mechanics on a compliant reducer
with the play as a dead zone and per-shaft Stribeck friction (motulator's `TwoMassMechanicalSystem`
has neither play nor dry friction), the 2nd-order Butterworth acquisition of the true q
current, and the sensors (position quantized and noisy, speed noisy, resolver quantized).
The Stribeck speed is 1 rad/s and the tanh width 0.1 rad/s at the motor shaft, for both
actuators (`motulator_ema.STRIBECK_SPEED`: a choice; the I_3eq table shows what 0.3 and 8.4
rad/s change).  The thesis actuator's PI variant (`thesis_pi`, built in code, no file) keeps
its 20 kHz control rate; its monitor values set steps_per_sample 10, as an actuator file's
monitor section would (the monitor runs the PI loop once per LF step and refuses the
packaged 100 us step, two control periods)."""


def _commissioning(data: dict[str, Any]) -> list[str]:
    lines = [
        "| simulator, actuator | without --force | inertia | friction | damping | stiffness "
        "| not identifiable | commissioning's warnings |",
        "|---|---|---|---|---|---|---|---|",
    ]
    order = [f"{sim} {config_name(*c)}" for c in CONFIGS for sim in SIMULATORS]
    for key, c in sorted(data["commissioning"].items(), key=lambda item: order.index(item[0])):
        f, ok = c["factors"], c["identifiable"]
        off = ", ".join(n for n, v in ok.items() if not v) or "-"
        lines.append(
            f"| {key} | {c.get('verdict', 'not recorded')} | {f['inertia']:.3f} | "
            f"{f['friction']:.3f} | {f['damping']:.3f} | "
            f"{f['stiffness']:.3f} | {off} | {'; '.join(c.get('warnings', [])) or '-'} |"
        )
    return lines


def _noise_words() -> str:
    """The noise RMS of each actuator, in words."""
    out = []
    for name in dict(CONFIGS):
        n = noise_of(actuator_of(name, 800.0))
        out.append(f"{name} {n['current']:.3g} A, {n['position']:.2g} rad, {n['speed']:.3g} rad/s")
    return "; ".join(out)


def _head(data: dict[str, Any]) -> list[str]:
    m, rows = data["machine"], data["rows"]
    walls = [r["wall_s"] for r in rows if "wall_s" in r]
    return [
        "# Cross-simulator validation: the monitor on motulator's telemetry",
        "",
        f"Measured with `{data['command']}` (bench/bench_external.py; raw rows "
        "`bench/results/bench_external.json`) on "
        f"{m['cpu']}, {m['cores']} cores, Python {m['python']}, numba {m['numba']}, numpy "
        f"{m['numpy']}, motulator {data['motulator']}, at commit {data['commit']}"
        f"{' with uncommitted changes in ema_phm/' if data['dirty'] else ''}"
        + "".join(f", with the rows of `{c}` merged in" for c in data.get("merged", []))
        + "; "
        f"{len(rows)} isolations, {np.median(walls) if walls else float('nan'):.1f} s median "
        f"each, {data.get('wall_s', float('nan')) / 60:.0f} min of process wall time in all.",
        *(f"{note}" for note in data.get("notes", [])),
        "",
        "Each window: one 2 s chirp (0.03 rad, 0.5-4.5 Hz), white noise on every channel "
        f"(`noise_of`: {_noise_words()}), 20 degC, isolated by "
        "`isolate(..., nuisance=True, intervals=True)` "
        f"(preset {DEFAULT_PRESET}, default fitness) with `MonitorBelief.for_actuator` of the "
        "same actuator ('no': packaged, uncommissioned) and with that belief commissioned on "
        f"{BASELINES} healthy windows of the same simulator ('yes').  {HEALTHY} healthy "
        "windows per actuator and simulator, one window per fault scenario: small counts, "
        "so each percentage is a handful of windows.",
        "",
        "Scoring as bench_robust's: *healthy OK* = level OK (no WARN, no 'not explained'); "
        "*%err* of eq. 6.4 over the friction and gain windows (every k entry counts); *the "
        "fault's own entry*: the median of |k_i - k_i true| of the faulty entry alone, in "
        "points of k; "
        "*right fault named* = WARN or ERROR, the dominant fault the true one, the model "
        "adequate; *withheld* = fault windows the monitor says it does not explain "
        "(adequacy above its threshold); the outside-k columns give the verdict: OK (the "
        "nuisances and k within thresholds absorbed it), not explained, or the level and "
        "the fault claimed.",
    ]


def report(data: dict[str, Any]) -> str:
    """docs/benchmarks_external.md from the stored rows."""
    rows = data["rows"]
    lines = [*_head(data), ""]
    for c, title in ((False, "Uncommissioned"), (True, "Commissioned")):
        lines += [f"## {title}", "", *headline(rows, c), ""]
    if data.get("reading"):  # what the person who ran it read in the rows, kept with them
        lines += ["## Reading", "", *data["reading"], ""]
    lines += [
        "## Issue 20's targets (motulator, commissioned, the matching actuator file)",
        "",
        *targets(rows),
        "",
        "## I_3eq: motulator against our HF on the nominal chirp (noise-free)",
        "",
        *currents(data),
        "",
        "## Commissioning factors",
        "",
        *_commissioning(data),
        "",
        "## What cannot be compared",
        "",
        CANNOT_COMPARE,
        "",
        "## What the motulator model is, and what was simplified",
        "",
        SIMPLIFIED,
        "",
        "## Every window",
        "",
        *per_window(rows),
        "",
    ]
    return "\n".join(lines)


# --------------------------------------------- --import-forms: the drive in a rig's forms
#: (actuator, bandwidth) whose motulator windows are written in a rig's forms, and its index in
#: CONFIGS (its windows' seeds are 1000 x index + ...).
NAME, BANDWIDTH = "thesis_pi", 800.0
CONFIG_INDEX = 0
FORMS = tuple(f for f in forms.VARIANTS if f != "phases_20khz")
#: The fault each in-k scenario's k names (bench_import's rows name windows by fault).
WINDOW_NAMES = {"friction": "friction", "gain_drift": "gain_drift"}


def forms_scenarios() -> list[tuple[int, Scenario]]:
    """(bench_external's scenario index, scenario): the healthy and in-k ones."""
    actuator = actuator_of(NAME, BANDWIDTH)
    every = scenarios(actuator, HEALTHY)
    return [(i, sc) for i, sc in enumerate(every) if sc.kind in ("healthy", "in_k")]


def unloaded(w: Window) -> Window:
    """`w` as a rig without a load cell records it (its load channel unknown, NaN).

    The rig's forms carry no load (`rig_forms`: ``load: unknown``); motulator's windows
    record their load (0 N*m here), and a native fit that knew it would not be the same
    information as the imported one (with the load known, bag and native differed by
    0.0067 in k, median, against a seed-to-seed 0.0008).
    """
    return dataclasses.replace(w, load=np.full(w.n, np.nan))


def forms_belief() -> MonitorBelief:
    """The described drive's belief, commissioned on motulator's two healthy baselines."""
    actuator = actuator_of(NAME, BANDWIDTH)
    cfg = config_name(NAME, BANDWIDTH)
    base = Scenario("baseline", mot.Faults(), "healthy")
    baselines = [
        window("motulator", cfg, actuator, base, 1000 * CONFIG_INDEX + 900 + b)
        for b in range(BASELINES)
    ]
    packaged = MonitorBelief.for_actuator(described(NAME, actuator))
    belief, _stored = commissioned([unloaded(w) for w in baselines], packaged, None)
    return belief


_BELIEF: MonitorBelief | None = None


def _forms_warm() -> None:
    """Each worker commissions once (the same baselines: the same belief)."""
    global _BELIEF  # noqa: PLW0603 - one belief per worker process
    _BELIEF = forms_belief()


def forms_window(job: tuple[int, str]) -> list[dict[str, Any]]:
    """Every form and forms.fit of one scenario's window (a pool job)."""
    si, name = job
    assert _BELIEF is not None
    actuator = actuator_of(NAME, BANDWIDTH)
    sc = dict(forms_scenarios())[si]
    seed = 1000 * CONFIG_INDEX + 10 * si + 1
    w = unloaded(window("motulator", config_name(NAME, BANDWIDTH), actuator, sc, seed))
    base = {"index": si, "scenario": name}
    base["window"] = "healthy" if sc.kind == "healthy" else WINDOW_NAMES[sc.fault]
    assert w.k_true is not None
    base["k_true"] = [float(v) for v in w.k_true]
    todo: list[tuple[str, Window, dict[str, float], tuple[int, ...]]] = [
        ("native", w, {}, forms.SEEDS)
    ]
    told = described(NAME, actuator)
    for form in FORMS:
        kind, cmap = forms.VARIANTS[form]
        got, cost = forms.imported(kind, cmap, w, None, told)
        todo.append((form, got, cost, forms.SEEDS if form == "bag" else forms.SEEDS[:1]))
    rows = []
    for form, fitted, cost, seeds in todo:
        for s in seeds:
            row = {**base, "form": form, "seed": s, **cost, **forms.fit(fitted, s, _BELIEF)}
            rows.append(row)
            print(
                f"{name:18s} {form:15s} seed {s} %err {row.get('percent_err', math.nan):6.2f} "
                f"{NAMES[row['dominant']] if 'dominant' in row else '-'}",
                flush=True,
            )
    return rows


def forms_run(jobs: int, raw: Path, cmdline: str) -> dict[str, Any]:
    """Every window's rows, written after each window."""
    todo = [(i, sc.name) for i, sc in forms_scenarios()]
    partial = {"command": cmdline, "drive": config_name(NAME, BANDWIDTH)}
    return forms.run_jobs(todo, forms_window, _forms_warm, jobs=jobs, raw=raw, partial=partial)


def forms_report(data: dict[str, Any]) -> str:
    """The Markdown report of the import-forms rows."""
    rows = data["rows"]
    m = data.get("machine", {})
    return "\n".join(
        [
            "# `ema-phm import` on another simulator's drive (motulator)",
            "",
            f"Command: `{data['command']}`; the drive: {data['drive']} (motulator), "
            f"{len({r['index'] for r in rows})} windows; "
            f"{data.get('total_s', math.nan) / 60:.1f} min on {m.get('cpu', '?')}, "
            f"{m.get('cores', '?')} cores, Python {m.get('python', '?')}. What is measured "
            "and how: `bench/bench_external.py`'s docstring (--import-forms); the same scoring as "
            "[benchmarks_import](benchmarks_import.md).",
            "",
            *forms.equivalence_lines(forms.equivalence(rows)),
            *forms.form_lines(forms.per_form(rows, ("native", *FORMS))),
            *forms.speed_lines(rows, FORMS),
        ]
    )


def _stamp() -> dict[str, Any]:
    """The commit, whether ema_phm/ differs from it, and the motulator version."""
    return git_commit() | {"motulator": mot.MOTULATOR_VERSION, "machine": machine()}


def _args() -> argparse.Namespace:
    ap = cli(__doc__, out=(None, OUT_HELP))
    ap.add_argument("--healthy", type=int, default=HEALTHY, help="healthy windows per actuator")
    ap.add_argument(
        "--configs",
        default="",
        help="only these actuators, e.g. small_pi:800,small_pi:200 (a second process with its "
        "own --out; --merge its rows into the first's)",
    )
    ap.add_argument("--merge", default="", help="add another run's bench_external.json, render")
    ap.add_argument(
        "--import-forms",
        action="store_true",
        help="instead: thesis_pi 800 Hz's motulator windows written in a rig's forms, imported "
        "and fitted beside the native ones (bench_import_external.json, "
        "benchmarks_import_external.md; with --report-only: render those rows)",
    )
    ap.add_argument("--jobs", type=int, default=2, help="--import-forms: worker processes")
    ap.add_argument("--report-only", action="store_true", help="render the stored rows")
    ap.add_argument(
        "--fresh", action="store_true", help="forget the stored rows and cached windows first"
    )
    ap.add_argument(
        "--redo",
        action="store_true",
        help="forget the stored rows and commissionings of --configs (not the cached windows)",
    )
    return ap.parse_args()


def merge(data: dict[str, Any], other: dict[str, Any]) -> dict[str, Any]:
    """`data` with the rows, commissionings and currents of `other` it lacks, wall times summed."""
    have = {_key(r) for r in data["rows"]}
    data["rows"] += [r for r in other["rows"] if _key(r) not in have]
    data["commissioning"] = other["commissioning"] | data["commissioning"]
    data["current"] = other["current"] | data["current"]
    data["wall_s"] = data.get("wall_s", 0.0) + other.get("wall_s", 0.0)
    data["merged"] = [*data.get("merged", []), other["command"]]
    return data


def main_import_forms(args: argparse.Namespace) -> int:
    """--import-forms: measure (or, with --report-only, render) the drive in a rig's forms."""
    rows_dir, docs_dir = out_dirs(args.out)
    raw = rows_dir / "bench_import_external.json"
    if not args.report_only:
        if mot is None:
            print(f"bench_external: {MISSING}", file=sys.stderr)
            return 2
        cmdline = command_line(
            "bench_external", "--import-forms", flags=[("--jobs", args.jobs, 2)]
        )
        write_rows(raw, forms_run(args.jobs, raw, cmdline))
    text = forms_report(read_rows(raw))
    write_report(docs_dir / "benchmarks_import_external.md", text)
    print(text)
    return 0


def main() -> int:
    args = _args()
    if args.import_forms:
        return main_import_forms(args)
    rows_dir, report_dir = out_dirs(args.out)
    raw, md = rows_dir / "bench_external.json", report_dir / "benchmarks_external.md"
    if args.report_only or args.merge:
        data = read_rows(raw)
        if args.merge:
            write_rows(raw, merge(data, read_rows(Path(args.merge))))
        md.write_text(report(data))
        return 0
    if mot is None:
        print(f"bench_external: {MISSING}", file=sys.stderr)
        return 2
    flags = [("--healthy", args.healthy, HEALTHY), ("--configs", args.configs, None)]
    cmd = command_line("bench_external", flags=flags)
    if args.fresh:
        shutil.rmtree(CACHE, ignore_errors=True)
    data = read_rows(raw) if raw.exists() and not args.fresh else {}
    data = {"rows": [], "commissioning": {}, "current": {}, **data, "command": cmd}
    data |= _stamp()
    run = Run(raw, data, time.perf_counter() - data.get("wall_s", 0.0))
    print(f"bench_external: {len(data['rows'])} rows stored, resuming", flush=True)
    chosen = {c for c in args.configs.split(",") if c}
    if args.redo and not chosen:
        print(
            "bench_external: --redo needs --configs (the actuators to measure again)",
            file=sys.stderr,
        )
        return 2
    if args.redo:
        names = {config_name(n, bw) for n, bw in CONFIGS if f"{n}:{bw:g}" in chosen}
        data["rows"] = [r for r in data["rows"] if r["config"] not in names]
        data["commissioning"] = {
            k: v for k, v in data["commissioning"].items() if k.split(" ", 1)[1] not in names
        }
    for ci, (name, bw) in enumerate(CONFIGS):
        if chosen and f"{name}:{bw:g}" not in chosen:
            continue
        current_difference(run, name, bw)
        run_config(run, ci, name, bw, args.healthy)
        data["wall_s"] = time.perf_counter() - run.t0
        write_rows(raw, data)
    md.write_text(report(data))
    print(f"wrote {md}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
