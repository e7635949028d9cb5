#!/usr/bin/env python3
"""Commissioning on drives their actuator file does not describe: is every one flagged.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_commissioning_misfit [--units 3] [--levels none,all]
    .venv/bin/python -m bench.bench_commissioning_misfit --report   # docs/ from the rows

For each packaged actuator (config/actuators/thesis_ema.yaml, hysteresis current control;
config/actuators/small_pi_ema.yaml, a PI current loop in dq) and drawn units (`Unit.draw(s)`,
s = 0 .. units - 1) in the benchmarks' hangar (`harness.scenarios.hangar_windows`: two
baselines per unit, own temperature, small unmeasured load), noise-free ("none") or with the
benchmarks' noise on every channel ("all"; the current noise is 1 % of the actuator's own
current range), the unit is simulated on the drive its file describes ("healthy": nothing
may be flagged) or on one it does not (`misfits`: the other current-loop kind, the gear
ratio 5 % and 20 % off, twice the inertia, a 200 Hz current loop: for the PI drive described
as 800 Hz, for the thesis drive a PI loop described as its hysteresis comparators), then
commissioned against the file's belief (`MonitorBelief.for_actuator`).  A case is flagged
when commissioning does not explain the unit (`CommissioningResult.unexplained`) or warns
(a pinned factor at a search bound or outside the manufacturing spread).  Rows go to
bench/results/bench_commissioning_misfit.json, the table to docs/benchmarks_commissioning.md.
"""

from __future__ import annotations

import dataclasses
import json

from bench.harness import DOCS, RESULTS, cli, machine
from bench.harness.scenarios import NOISE, hangar_windows
from ema_phm.diagnosis.commissioning import UNEXPLAINED_RATIO, commission
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator import HYSTERESIS_CURRENT, PI_DQ_CURRENT
from ema_phm.physics.actuator_file import load_actuator, packaged_actuator_path
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator.unit import Unit

ROWS = RESULTS / "bench_commissioning_misfit.json"
REPORT = DOCS / "benchmarks_commissioning.md"
ACTUATORS = {"thesis_ema": "thesis_ema.yaml", "small_pi_ema": "small_pi_ema.yaml"}
#: The PI current loop a hysteresis drive is swapped for (and the bandwidth of the slow one).
PI_SWAP_HZ = 800.0
SLOW_LOOP_HZ = 200.0


def _scaled(base: ActuatorParameters, factor: float, *names: str) -> ActuatorParameters:
    return base.with_values({n: factor * base.value(n) for n in names})


def _other_kind(base: ActuatorParameters) -> ActuatorParameters:
    """The same actuator with the other current-loop kind."""
    if base.controller_kind == PI_DQ_CURRENT:
        return dataclasses.replace(base, controller_kind=HYSTERESIS_CURRENT)
    return dataclasses.replace(
        base.with_values({"current_loop.bandwidth_hz": PI_SWAP_HZ}), controller_kind=PI_DQ_CURRENT
    )


def misfits(base: ActuatorParameters) -> dict[str, ActuatorParameters]:
    """The drive each case simulates; every one is commissioned against `base`'s file."""
    gear, inertia = "mechanics.gear_ratio", ("mechanics.j_motor", "mechanics.j_user")
    out = {
        "healthy": base,
        "other current-loop kind": _other_kind(base),
        "gear x0.95": _scaled(base, 0.95, gear),
        "gear x1.2": _scaled(base, 1.2, gear),
        "inertia x2": _scaled(base, 2.0, *inertia),
    }
    if base.controller_kind == PI_DQ_CURRENT:
        out["current loop 200 Hz (file: 800)"] = base.with_values(
            {"current_loop.bandwidth_hz": SLOW_LOOP_HZ}
        )
    else:  # the case: a 200 Hz PI loop under the thesis's 2000 rad/s speed loop
        out["PI current loop 200 Hz (file: hysteresis)"] = dataclasses.replace(
            base.with_values({"current_loop.bandwidth_hz": SLOW_LOOP_HZ}),
            controller_kind=PI_DQ_CURRENT,
        )
    return out


def _noise(level: str, actuator: ActuatorParameters) -> dict[str, float]:
    if level == "none":
        return {}
    scale = actuator.controller.max_current / ActuatorParameters.default().controller.max_current
    return {**NOISE, "noise_current": NOISE["noise_current"] * scale}


def _row(name: str, case: str, level: str, u: int, drive: ActuatorParameters) -> dict:
    base = load_actuator(packaged_actuator_path().parent / ACTUATORS[name])
    command, _ = default_specs()
    windows = hangar_windows(u, Unit.draw(u), drive, command, noise=_noise(level, base))
    res = commission(windows, belief=MonitorBelief.for_actuator(base))
    unexplained = res.unexplained()
    return {
        "actuator": name,
        "case": case,
        "level": level,
        "unit": u,
        "factors": res.factors,
        "at_bound": res.at_bound,
        "outside_spread": res.outside_spread,
        "ratios": [r.ratio for r in res.references],
        "unexplained": bool(unexplained),
        "flagged": bool(unexplained or res.warnings),
        "warnings": list(res.warnings),
        "wall_s": res.wall_s,
    }


def run(units: int, levels: list[str]) -> list[dict]:
    """Every actuator x case x level x unit; rows already in ROWS are kept, not rerun."""
    rows = json.loads(ROWS.read_text()) if ROWS.exists() else []
    done = {(r["actuator"], r["case"], r["level"], r["unit"]) for r in rows}
    for name, file in ACTUATORS.items():
        base = load_actuator(packaged_actuator_path().parent / file)
        for case, drive in misfits(base).items():
            for level in levels:
                for u in range(units):
                    if (name, case, level, u) in done:
                        continue
                    rows.append(_row(name, case, level, u, drive))
                    print(json.dumps(rows[-1]), flush=True)
                    ROWS.write_text(json.dumps(rows, indent=1))
    return rows


def _line(sel: list[dict]) -> str:
    r = sel[0]
    ratios = [x for row in sel for x in row["ratios"]]
    flagged = sum(row["flagged"] for row in sel)
    why = sorted({w.split(" ")[1] for row in sel for w in row["warnings"]})
    return (
        f"| {r['actuator']} | {r['case']} | {r['level']} | {flagged}/{len(sel)} | "
        f"{sum(row['unexplained'] for row in sel)}/{len(sel)} | "
        f"{min(ratios):.3g}-{max(ratios):.3g} | {', '.join(why) or '-'} |"
    )


def report(rows: list[dict]) -> str:
    """The markdown table of the rows."""
    keys = sorted({(r["actuator"], r["case"], r["level"]) for r in rows}, key=str)
    m = machine()
    lines = [
        "# Commissioning on drives the actuator file does not describe",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores ({m['numba_threads']} numba threads), "
        f"Python {m['python']}, numba {m['numba']}.  Command: "
        "`.venv/bin/python -m bench.bench_commissioning_misfit --units 3` (resumes from "
        "bench/results/bench_commissioning_misfit.json; `--report` rewrites "
        "this page).  What each case is: the script's docstring.",
        "",
        "flagged = not explained (model error above "
        f"UNEXPLAINED_RATIO {UNEXPLAINED_RATIO:g} x the file's expected healthy level, open "
        "loop or recorded loop) or a warning (a pinned factor at a search bound, or outside "
        "the manufacturing spread).  On `healthy` every flag is a false one.",
        "",
        "| actuator | drive simulated | noise | flagged | not explained | ratios (both "
        "references) | factors warned of |",
        "|---|---|---|---|---|---|---|",
    ]
    for key in keys:
        lines.append(_line([r for r in rows if (r["actuator"], r["case"], r["level"]) == key]))
    lines += ["", "## Summary", ""] + _summary(rows) + ["", READING]
    return "\n".join(lines) + "\n"


def _summary(rows: list[dict]) -> list[str]:
    out = []
    for name in ACTUATORS:
        own = [r for r in rows if r["actuator"] == name]
        bad = [r for r in own if r["case"] != "healthy"]
        good = [r for r in own if r["case"] == "healthy"]
        out.append(
            f"- {name}: mis-described drives flagged {sum(r['flagged'] for r in bad)}/"
            f"{len(bad)}; healthy units flagged {sum(r['flagged'] for r in good)}/{len(good)}."
        )
    return out


#: How to read the table (the cases the flag misses, and why).
READING = """What is missed is a current loop the commissioning chirp cannot tell apart.  The
baselines are the default 0.5-4.5 Hz chirp: at those frequencies an 800 Hz PI loop and
hysteresis comparators both make the current the speed loop asks for, and the monitor of
either kind explains the other within its healthy level (ratios at most 3.6 above).  A slow
loop is caught only where it interacts with the speed loop, and not always: the thesis's
2000 rad/s speed loop over a 200 Hz PI current loop (the issue's case) is flagged in 4 of the
6 runs above (every run with noise, 1 of 3 noise-free); the small actuator's 500 rad/s speed
loop barely feels its 200 Hz loop, and commissioning explains that unit (a stiffness factor
at its bound on 2 of 6).
Wrong gear ratios and twice the inertia are flagged on both actuators: not explained, or
explained only by a factor outside the manufacturing spread."""


def main() -> None:
    ap = cli(None, raw_description=False)
    ap.add_argument("--units", type=int, default=3)
    ap.add_argument("--levels", default="none,all")
    ap.add_argument("--report", action="store_true", help="only rewrite the report")
    args = ap.parse_args()
    rows = json.loads(ROWS.read_text()) if args.report else run(args.units, args.levels.split(","))
    REPORT.write_text(report(rows))
    print(f"wrote {REPORT}")


if __name__ == "__main__":
    main()
