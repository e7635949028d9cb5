#!/usr/bin/env python3
"""Where the per-unit bias of the monitor's severity estimates comes from (a measurement).

Usage (from the repo root):
    .venv/bin/python -m bench.studies.bench_severity_bias      # about 10 min on 2 cores
    .venv/bin/python -m bench.studies.bench_severity_bias --units 2 --jobs 1 --out /tmp/sb

One fault at a time, FRICTION (k1 = 0.3) and SHORT (k3 = short_circuit_a = 0.3), on
UNITS drawn units ``Unit.draw(100 + i)`` (the prognostics benchmark's seeds), isolated as
bench_robust.py / bench_prognostics.py do: ``isolate(window, belief=..., nuisance=True,
intervals=True)``, default preset, isolation seed = the row's noise seed.  The candidate
sources of bias are switched on one at a time (SETTINGS):

- unit: the datasheet unit ``Unit()`` or the drawn unit, or a unit with ONE key of
  unit.py at the edge of its tolerance band (+/- band, 3 sigma) and every other key at
  the datasheet ("single-key" rows);
- belief: the packaged belief, or the unit commissioned (``commission``) from the 2 hangar
  windows of harness.scenarios.hangar (its temperatures and small unmeasured loads) either
  noise-free ("quiet") or with NOISE as the benchmarks do ("bench");
- temperature: 20 degC or drawn uniform in harness.scenarios.TEMPERATURE_C;
- unmeasured load: none or a constant load and hinge spring drawn in harness.scenarios'
  ranges;
- noise: none or harness.scenarios.NOISE on every channel.

The drawn temperature and load of unit i come from ``default_rng((100 + i, 31))``; the
noise seed of a fault window is 7000 + 10 * (100 + i) + fault index (+ 5 in the "another
noise seed" settings).  Rows where the unit
is the datasheet one still use i for the environment and the seeds, so every setting has
UNITS rows.  Relative severity error = |k_i - nominal_i| / true severity - 1 of the fault
injected.  Writes <out>.json (every row) and <out>.md (the table) and prints the table.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
import time
from pathlib import Path

from bench.harness import cli, machine, pool, write_rows
from bench.harness.scenarios import (
    NOISE,
    environment,
    hangar_windows,
    sim_kw,
)
from ema_phm.diagnosis.commissioning import commission
from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate
from ema_phm.domain.faults import NAMES, NOMINAL
from ema_phm.domain.faults import fault as fault_record
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.physics.tolerances import OFFSET_KEYS, UNIT_KEYS, Tolerances
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

FIRST_UNIT = 100
UNITS = 8
SEVERITY = 0.3
#: fault name -> index in k
FAULTS = {name: fault_record(name).index for name in ("friction", "short_circuit_a")}
#: name -> (unit: "datasheet" | "drawn", belief: "packaged" | "quiet" | "bench",
#:          temperature drawn?, load drawn?, noise?[, noise seed offset])
SETTINGS = {
    "A ideal (datasheet unit, packaged belief, 20 C, no load, no noise)": (
        "datasheet",
        "packaged",
        False,
        False,
        False,
    ),
    "B A + noise": ("datasheet", "packaged", False, False, True),
    "C A + drawn temperature": ("datasheet", "packaged", True, False, False),
    "D A + drawn unmeasured load": ("datasheet", "packaged", False, True, False),
    "E A + temperature + load + noise": ("datasheet", "packaged", True, True, True),
    "E0 A + temperature + load (no noise)": ("datasheet", "packaged", True, True, False),
    "E2 E with another noise seed": ("datasheet", "packaged", True, True, True, 5),
    "B2 B with another noise seed": ("datasheet", "packaged", False, False, True, 5),
    "F drawn unit, packaged belief (no commissioning)": (
        "drawn",
        "packaged",
        False,
        False,
        False,
    ),
    "G drawn unit, commissioned quiet": ("drawn", "quiet", False, False, False),
    "H drawn unit, commissioned as the benchmarks (noisy hangar)": (
        "drawn",
        "bench",
        False,
        False,
        False,
    ),
    "I H + temperature + load + noise (benchmark replica)": ("drawn", "bench", True, True, True),
}
#: single-key rows: that key at +/- its band, everything else datasheet, commissioned quiet,
#: fault window at 20 C, no load, no noise.
SINGLE = "single-key"


def edge_unit(key: str, sign: int) -> Unit:
    band = Tolerances.load().bands[key]
    return Unit(**{key: (0.0 if key in OFFSET_KEYS else 1.0) + sign * band})


def sim_kwargs(unit: Unit, temperature_c: float, load: float, spring: float, noise: bool):
    command, _ = default_specs()
    env = {"temperature_c": temperature_c, "load_nm": load, "spring_nm_per_rad": spring}
    return sim_kw(unit, ActuatorParameters.default(), command, env, NOISE if noise else {})


def do_commission(task: tuple) -> tuple:
    """(tag, unit spec, noisy hangar?, hangar seed) -> (tag, values, factors)."""
    tag, spec, noisy, u = task
    unit = Unit.parse(spec)
    command, _ = default_specs()
    windows = hangar_windows(
        u, unit, ActuatorParameters.default(), command, noise=NOISE if noisy else {}
    )
    com = commission(windows)
    return tag, dict(com.values), dict(com.factors)


def do_isolate(task: dict) -> dict:
    unit = Unit.parse(task["unit"])
    k = NOMINAL.copy()
    i = FAULTS[task["fault"]]
    k[i] = SEVERITY
    e = task["env"]
    window = real_ema.simulate(
        k,
        seed=task["seed"],
        **sim_kwargs(
            unit, e["temperature_c"], e["load_nm"], e["spring_nm_per_rad"], task["noise"]
        ),
    ).window
    belief = None
    if task["belief_values"] is not None:
        belief = MonitorBelief.default().commissioned_with(task["belief_values"])
    res = isolate(
        window,
        belief=belief,
        preset=DEFAULT_PRESET,
        seed=task["seed"],
        nuisance=True,
        intervals=True,
    )
    est = abs(float(res.k[i]) - float(NOMINAL[i]))
    out = {key: v for key, v in task.items() if key != "belief_values"}
    out.update(
        k=[float(v) for v in res.k],
        rel_err=est / SEVERITY - 1.0,
        adequacy_statistic=float(res.adequacy.statistic),
        adequacy_ok=bool(res.adequacy.ok),
        nuisance={a: float(b) for a, b in res.nuisance.items()},
        wall_s=float(res.wall_s),
    )
    return out


def plan(units: list[int], only: set[str] | None = None) -> tuple[list[tuple], list[dict]]:
    """Commissioning tasks and isolation tasks (belief filled in after commissioning)."""
    com_tasks: list[tuple] = []
    iso: list[dict] = []
    for u in units:
        drawn = Unit.draw(u).spec()
        com_tasks += [(("quiet", u), drawn, False, u), (("bench", u), drawn, True, u)]
        env = environment(u, stream=31)  # draws of its own, not bench_realistic's
        for name, (which, belief, temp, load, noise, *off) in SETTINGS.items():
            if only is not None and name.split()[0] not in only:
                continue
            for fault, i in FAULTS.items():
                iso.append(
                    {
                        "setting": name,
                        "unit_seed": u,
                        "unit": Unit().spec() if which == "datasheet" else drawn,
                        "belief": (belief, u),
                        "fault": fault,
                        "env": {
                            "temperature_c": env["temperature_c"] if temp else 20.0,
                            "load_nm": env["load_nm"] if load else 0.0,
                            "spring_nm_per_rad": env["spring_nm_per_rad"] if load else 0.0,
                        },
                        "noise": noise,
                        "seed": 7000 + 10 * u + i + (off[0] if off else 0),
                    }
                )
    quiet = {"temperature_c": 20.0, "load_nm": 0.0, "spring_nm_per_rad": 0.0}
    for key in UNIT_KEYS if only is None or SINGLE in only else ():
        for sign in (1, -1):
            spec = edge_unit(key, sign).spec()
            tag = ("quiet", f"{key}{'+' if sign > 0 else '-'}")
            com_tasks.append((tag, spec, False, units[0]))
            for fault, i in FAULTS.items():
                iso.append(
                    {
                        "setting": SINGLE,
                        "key": key,
                        "sign": sign,
                        "unit_seed": None,
                        "unit": spec,
                        "belief": tag,
                        "fault": fault,
                        "env": quiet,
                        "noise": False,
                        "seed": 7000 + i,
                    }
                )
    return com_tasks, iso


def _stats(v: list[float]) -> dict:
    return {
        "n": len(v),
        "median": statistics.median(v),
        "sd": statistics.stdev(v) if len(v) > 1 else 0.0,
        "min": min(v),
        "max": max(v),
    }


def _pct(x: float) -> str:
    return f"{100 * x:+.1f}"


def table(rows: list[dict], coms: dict) -> str:
    lines = [
        f"Relative severity error (estimate / {SEVERITY} - 1), %, over units; "
        "per-unit values in unit order.",
        "",
        "| setting | fault | n | median | sd | min | max | per unit |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in SETTINGS:
        for fault in FAULTS:
            rs = sorted(
                (r for r in rows if r["setting"] == name and r["fault"] == fault),
                key=lambda r: r["unit_seed"],
            )
            if not rs:
                continue
            s = _stats([r["rel_err"] for r in rs])
            per = " ".join(_pct(r["rel_err"]) for r in rs)
            lines.append(
                f"| {name} | {fault} | {s['n']} | {_pct(s['median'])} | {100 * s['sd']:.1f} | "
                f"{_pct(s['min'])} | {_pct(s['max'])} | {per} |"
            )
    lines += [
        "",
        "Single-key units (one key at +/- its tolerance band, the rest datasheet; "
        "commissioned quiet; fault window 20 C, no load, no noise): relative severity "
        "error, %, and the commissioned factors.",
        "",
        "| key | band | fault: friction (+ / -) | short_circuit_a (+ / -) | "
        "commissioned friction factor (+ / -) |",
        "|---|---|---|---|---|",
    ]
    bands = Tolerances.load().bands
    for key in UNIT_KEYS:
        cell = {}
        for fault in FAULTS:
            for sign in (1, -1):
                r = [
                    x
                    for x in rows
                    if x["setting"] == SINGLE
                    and x["key"] == key
                    and x["sign"] == sign
                    and x["fault"] == fault
                ]
                cell[fault, sign] = _pct(r[0]["rel_err"]) if r else "-"
        ff = [
            coms.get(json.dumps(["quiet", f"{key}{s}"]), {}).get("factors", {}).get("friction")
            for s in "+-"
        ]
        ffs = " / ".join("-" if f is None else f"{f:.3f}" for f in ff)
        lines.append(
            f"| {key} | {bands[key]:g} | {cell['friction', 1]} / {cell['friction', -1]} | "
            f"{cell['short_circuit_a', 1]} / {cell['short_circuit_a', -1]} | {ffs} |"
        )
    # friction: what the commissioning error predicts (friction factor 1 + 2 k1)
    lines += [
        "",
        "Friction, drawn units: the commissioned friction factor against the unit's "
        "effective one (friction * current_gain / torque_constant, what the telemetry "
        "shows in the datasheet's torque per measured ampere), and the relative error that "
        "mismatch alone predicts, (1 + 2*0.3) * ratio = 1 + 2*k1_hat.",
        "",
        "| unit | friction | current_gain / torque_constant | effective | commissioned "
        "quiet | bench | predicted (quiet) | measured G | predicted (bench) | measured H |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    units = sorted({r["unit_seed"] for r in rows if r["unit_seed"] is not None})
    for u in units:
        unit = Unit.draw(u)
        eff = unit.friction * unit.current_gain / unit.torque_constant
        cells = []
        for tag, setting in (("quiet", "G"), ("bench", "H")):
            if json.dumps([tag, u]) not in coms:
                continue
            f = coms[json.dumps([tag, u])]["factors"]["friction"]
            pred = ((1 + 2 * SEVERITY) * eff / f - 1) / 2 / SEVERITY - 1
            m = [
                r["rel_err"]
                for r in rows
                if r["setting"].startswith(setting + " ")
                and r["unit_seed"] == u
                and r["fault"] == "friction"
            ]
            cells.append((f, pred, m[0] if m else math.nan))
        if len(cells) < 2:
            continue
        lines.append(
            f"| {u} | {unit.friction:.3f} | {unit.current_gain / unit.torque_constant:.3f} | "
            f"{eff:.3f} | {cells[0][0]:.3f} | {cells[1][0]:.3f} | {_pct(cells[0][1])} | "
            f"{_pct(cells[0][2])} | {_pct(cells[1][1])} | {_pct(cells[1][2])} |"
        )
    return "\n".join(lines) + "\n"


def _init() -> None:
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)  # JIT warm-up


def main() -> int:
    ap = cli(__doc__.split("\n")[0], raw_description=False, jobs=(2, None))
    ap.add_argument("--units", type=int, default=UNITS)
    ap.add_argument(
        "--only",
        default=None,
        help="comma-separated setting labels (A, B, ..., I, single-key) to run; default all",
    )
    ap.add_argument("--out", default="/tmp/severity_bias", help="writes OUT.json and OUT.md")
    args = ap.parse_args()

    t0 = time.perf_counter()
    units = list(range(FIRST_UNIT, FIRST_UNIT + args.units))
    only = None if args.only is None else set(args.only.split(","))
    com_tasks, iso = plan(units, only)
    if only is not None and not ({"G", "H", "I", SINGLE} & only):
        com_tasks = [c for c in com_tasks if c[0][0] == "quiet" and c[0][1] == -1]
    with pool(args.jobs, initializer=_init) as workers:
        coms = {}
        for tag, values, factors in workers.imap_unordered(do_commission, com_tasks):
            coms[json.dumps(list(tag))] = {"values": values, "factors": factors}
            print(f"commissioned {tag}: {factors}", flush=True)
        for t in iso:
            belief, who = t["belief"]
            t["belief_values"] = (
                None if belief == "packaged" else coms[json.dumps([belief, who])]["values"]
            )
            t["belief"] = [belief, who]
        rows = []
        for r in workers.imap_unordered(do_isolate, iso):
            rows.append(r)
            print(
                f"{len(rows):3d}/{len(iso)} {r['setting'][:2]} {r.get('key', r['unit_seed'])} "
                f"{r['fault']:16s} rel_err={100 * r['rel_err']:+6.1f} % "
                f"adequacy_ok={r['adequacy_ok']} wall={r['wall_s']:.1f}s",
                flush=True,
            )
    wall = time.perf_counter() - t0
    out = Path(args.out)
    write_rows(
        out.with_suffix(".json"),
        {
            "machine": machine(),
            "command": " ".join(sys.argv),
            "wall_s": wall,
            "names": list(NAMES),
            "commissioning": coms,
            "rows": rows,
        },
    )
    text = table(rows, coms)
    print(text)
    print(f"wall {wall:.0f} s")
    out.with_suffix(".md").write_text(text + f"\nwall {wall:.0f} s\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
