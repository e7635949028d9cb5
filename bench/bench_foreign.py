#!/usr/bin/env python3
"""A foreign population, kept apart from all tuning: units, environments and loads off the map.

Usage (from the repo root):
    nice -n 10 .venv/bin/python -m bench.bench_foreign --jobs 2   # the default run
    .venv/bin/python -m bench.bench_foreign --quick --out DIR  # a few minutes
    .venv/bin/python -m bench.bench_foreign --report-only          # report from the saved rows

Nothing in the package is chosen on this population: it is reported, not tuned on.  Every
other benchmark draws its units with `Unit.draw` from config/unit_tolerances.yaml (truncated
normal, 3 sigma = the band), its environments and noise from ema_phm/simulator/envelope.py,
and its loads as an unmeasured constant with a hinge spring.  This one draws from another map:

- Units (`draw_unit`, ``numpy.random.default_rng((FIRST_SEED + i, UNIT_STREAM))``), three
  kinds in turn (`KIND_CYCLE`): "corner" (3-4 keys at the edge of their declared band, signs
  drawn, the rest the datasheet: in-spec), "inside" (every key uniform inside its declared
  band: in-spec) and "wide" (every key uniform inside twice its declared band, factors kept
  >= 0.25, the package's limit: almost always out-of-band).  `in_spec` classifies a unit.
- Commissioning (`hangar`, stream `HANGAR_STREAM`): 2 healthy baselines at 0..40 degC with an
  unmeasured load of -20..20 N*m and a spring of 0..600 N*m/rad; one set of sensor noise for
  both (the hangar day), per channel: current and speed 0.5-2x the envelope's NOISE
  (log-uniform), user position log-uniform in FINE_POSITION (1-2e-5 rad RMS) on every third
  unit and in 0.5-2x NOISE (2.5e-5..1e-4) on the others.  Reviewed and commissioned as
  `ema-phm calibrate --baseline` does (`commissioning.review`, then `commission` and its
  `unexplained`), refused unless forced exactly where the CLI refuses; the unit file is then
  written with --force's marks and read back with `belief_for`, as `isolate --unit` reads it.
- Windows (`window_env`, stream `WINDOW_STREAM`): each its own temperature (-40..+85 degC),
  its own noise per channel (drawn as the hangar's, the fine position band on every third
  window, `fine_window`, a cycle apart from the loads') and its own load, one of
  `LOAD_KINDS` in turn: an unmeasured
  constant (-100..100 N*m) with a spring (0..4000 N*m/rad), a measured constant (-150..150)
  with a spring, a measured sine (offset -50..50, amplitude 20..100 N*m, 0.5..5 Hz) with a
  spring (0..2000).  The cases: `HEALTHY` healthy windows and every fault at the thesis's
  medium severity (`MEDIUM`: friction 0.5, backlash 0.6, short circuit A 0.4 and, at the
  same level, B and C, eccentricity 0.4, gain 0.4).
- Each window is isolated twice, as `ema-phm isolate` does (`FitSettings()`: default
  preset and fitness, nuisances searched, 90 % intervals; `health.assess_isolation`): with
  the commissioned unit (accepted, or forced where the CLI refused) and with the packaged
  belief (uncommissioned).  Isolation seed = the window's noise seed.

Seeds: units FIRST_SEED .. FIRST_SEED + units - 1 (9000..; every other benchmark's unit seeds
are below 200 or drawn by the fleet generator from its own streams), noise seeds
`SIM_SEED_BASE` + 1000 i + j (>= 9,000,000; the others' are below 200,000), random streams
41, 43, 47 (the others': 7, 11, 23, 31, 37).  Deterministic for a given --units and --seed.

Scored per slice (in-spec commissioned / forced / uncommissioned, out-of-band), each count
with its denominator and a 95 % Wilson interval, beside the tuned population's figures from
the committed rows of bench_robust (bench/results/bench_robust_recorded.json, the fitness the
monitor runs by default) where they exist.
Raw rows: bench/results/bench_foreign.json; report: docs/benchmarks_foreign.md (the
hand-written analysis below `bench.harness.KEEP_MARKER` is kept when the report is rewritten).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import (
    OUT_HELP,
    RESULTS,
    cli,
    command_line,
    out_dirs,
    pool,
    read_rows,
    stamp,
    write_report,
    write_rows,
)
from bench.harness.foreign import (
    FINE_POSITION,
    FIRST_SEED,
    LOAD_KINDS,
    SIM_SEED_BASE,
    TEMPERATURE_C,
    commissioned_unit,
    simulate,
    window_env,
)
from bench.harness.scenarios import NOISE, PHASE_AMOUNT, PHASE_INDEX, cases
from ema_phm.diagnosis import adequacy, health, uncertainty
from ema_phm.diagnosis.isolation import isolate
from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import N_K, NOMINAL, fault
from ema_phm.errors import ExcitationError
from ema_phm.physics.tolerances import OFFSET_KEYS
from ema_phm.simulator import real_ema

# ----------------------------------------------------------------------------- cases

#: Healthy windows per unit (default run; --quick: 1).
HEALTHY = 2
#: The single-fault case of each fault at the thesis's medium severity (short circuits B and
#: C at short circuit A's).
SC_MEDIUM = 0.4


def medium_cases() -> list[tuple[str, np.ndarray, int]]:
    """(name, true k, fault index) of every fault at its medium severity."""
    out = [(name, k, int(single)) for name, k, single, tag in cases() if tag == "medium"]
    for name in ("short_circuit_b", "short_circuit_c"):
        k = NOMINAL.copy()
        idx = fault(name).index
        k[idx] = SC_MEDIUM
        label = f"short circuit {name[-1].upper()} medium (k{idx + 1}={SC_MEDIUM:g})"
        out.append((label, k, idx))
    return sorted(out, key=lambda c: c[2])


#: --quick's faults: friction and short circuit B (a probe that first showed the gap).
QUICK_FAULTS = (0, 3)


def _fit(window: Any, belief: Any, seed: int) -> dict:
    """`ema-phm isolate` of `window` with `belief` (None: packaged): the row's fields."""
    settings = FitSettings(seed=seed)
    try:
        res = isolate(window, **settings.isolate_options(belief))
    except ExcitationError as exc:
        return {"error": str(exc)}
    verdict = health.assess_isolation(res)
    return {
        "k": [float(v) for v in res.k],
        "k_interval": [[float(a), float(b)] for a, b in res.k_interval],
        "percent_err": float(res.percent_err),
        "adequacy_statistic": float(res.adequacy.statistic),
        "adequacy_threshold": float(res.adequacy.threshold),
        "explained": bool(res.adequacy.ok),
        "level": int(verdict.level),
        "dominant": int(verdict.dominant),
        "message": verdict.message,
        "nuisance": {k: float(v) for k, v in res.nuisance.items()},
        "wall_s": float(res.wall_s),
    }


def run_unit(job: tuple[int, int, int, tuple[int, ...] | None]) -> dict:
    """Draw, commission and isolate every window of unit `index` (a pool job)."""
    index, seed, healthy, faults = job
    t0 = time.perf_counter()
    unit, belief, record = commissioned_unit(index, seed, SIM_SEED_BASE)
    kind = record["kind"]
    said = record["commissioning"]
    out = {"index": index, "unit_seed": seed + index, **record}
    todo: list[tuple[str, np.ndarray, int | None]] = [
        (f"healthy #{h + 1}", NOMINAL.copy(), None) for h in range(healthy)
    ]
    todo += [c for c in medium_cases() if faults is None or c[2] in faults]
    rows = []
    for j, (name, k, single) in enumerate(todo, start=1):
        env = window_env(index, j, seed)
        run_seed = SIM_SEED_BASE + 1000 * index + j
        window = simulate(unit, k, env, run_seed)
        for mode, b in (("commissioned", belief), ("uncommissioned", None)):
            row = {
                "index": index,
                "unit_seed": seed + index,
                "kind": kind,
                "in_spec": out["in_spec"],
                "accepted": said["accepted"],
                "mode": mode,
                "scenario": name,
                "k_true": [float(v) for v in k],
                "single_fault": single,
                "run_seed": run_seed,
                **env,
                **_fit(window, b, run_seed),
            }
            rows.append(row)
            print(
                f"unit {index:2d} {kind:6s} {mode:14s} {name:34s} "
                f"adequacy={row.get('adequacy_statistic', float('nan')):6.2f} "
                f"{health.LEVEL_NAMES.get(row.get('level', -1), 'error')}",
                flush=True,
            )
    out["rows"] = rows
    out["wall_s"] = time.perf_counter() - t0
    return out


def _warm() -> None:
    """JIT warm-up of a worker (not timed)."""
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)


def run(units: int, seed: int, quick: bool, *, jobs: int, raw: Path, cmdline: str) -> dict:
    healthy, faults = (1, QUICK_FAULTS) if quick else (HEALTHY, None)
    todo = [(i, seed, healthy, faults) for i in range(units)]
    done: list[dict] = []
    # the machine stamp starts numba's threading layer: taken after the pool has forked
    partial = {"command": cmdline, "quick": quick, "seed": seed}
    t0 = time.perf_counter()
    if jobs > 1:
        with pool(jobs, _warm) as p:
            for res in p.imap_unordered(run_unit, todo):
                done.append(res)
                write_rows(raw, {**partial, "units": sorted(done, key=lambda u: u["index"])})
    else:
        _warm()
        for job in todo:
            done.append(run_unit(job))
            write_rows(raw, {**partial, "units": done})
    total = time.perf_counter() - t0
    done.sort(key=lambda u: u["index"])
    return {**partial, **stamp(cmdline), "total_s": total, "units": done}


# ----------------------------------------------------------------------------- scoring


def wilson(n: int, d: int, z: float = 1.959964) -> tuple[float, float]:
    """95 % Wilson score interval of n successes in d trials (as fractions)."""
    if d == 0:
        return (math.nan, math.nan)
    p = n / d
    den = 1.0 + z * z / d
    centre = (p + z * z / (2 * d)) / den
    half = z * math.sqrt(p * (1 - p) / d + z * z / (4 * d * d)) / den
    return (max(0.0, centre - half), min(1.0, centre + half))


def rate(n: int, d: int) -> str:
    """'n/d (p %, 95 % lo-hi)'."""
    if d == 0:
        return "-"
    lo, hi = wilson(n, d)
    return f"{n}/{d} ({100 * n / d:.0f} %; {100 * lo:.0f}-{100 * hi:.0f})"


def covered(row: dict) -> list[bool]:
    """Per k entry with a meaning, whether the reported 90 % interval holds the truth."""
    iv, kt, k = np.array(row["k_interval"]), np.array(row["k_true"]), np.array(row["k"])
    out = []
    for i in range(N_K):
        if i == PHASE_INDEX and not (kt[PHASE_AMOUNT] > 0 and iv[PHASE_AMOUNT, 0] > 0):
            continue  # no phase without eccentricity
        lo, hi = iv[i]
        if i == PHASE_INDEX:
            d = (kt[i] - k[i] + 0.5) % 1.0 - 0.5
            out.append(bool(abs(d) <= (hi - lo) / 2 + 1e-12))
        else:
            out.append(bool(lo - 1e-12 <= kt[i] <= hi + 1e-12))
    return out


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def figures(rows: list[dict]) -> dict:
    """The acceptance figures of a set of rows (each count with its denominator)."""
    rows = [r for r in rows if "k" in r]
    healthy = [r for r in rows if r["single_fault"] is None]
    fault_rows = [r for r in rows if r["single_fault"] is not None]
    explained = [r for r in healthy if r["explained"]]
    cov = [c for r in fault_rows for c in covered(r)]
    e = [r["percent_err"] for r in fault_rows]
    return {
        "healthy": len(healthy),
        "healthy_explained": len(explained),
        "healthy_warn": sum(r["explained"] and r["level"] >= health.WARN for r in healthy),
        "healthy_error": sum(r["explained"] and r["level"] >= health.ERROR for r in healthy),
        "faults": len(fault_rows),
        "withheld": sum(not r["explained"] for r in fault_rows),
        "missed": sum(r["level"] == health.OK for r in fault_rows),
        "named": sum(
            r["explained"] and r["level"] >= health.WARN and r["dominant"] == r["single_fault"]
            for r in fault_rows
        ),
        "covered": sum(cov),
        "entries": len(cov),
        "median": statistics.median(e) if e else math.nan,
        "p90": _pct(e, 90),
    }


def tuned_rows(path: Path) -> list[dict] | None:
    """The tuned population's rows (bench_robust, recorded loop) in this benchmark's form.

    Medium-severity single faults and healthy windows of its drawn units, judged as the
    monitor judges them today: adequacy against `adequacy.FOLLOWED_THRESHOLD`, 90 % intervals
    `uncertainty.Z90 * uncertainty.FOLLOWED_SCALE * k_std`, `health.assess`.
    """
    if not path.exists():
        return None
    out = []
    for r in read_rows(path)["rows"]:
        if r["population"] != "realistic" or "k" not in r:
            continue
        healthy = r["scenario"].startswith("healthy")
        if not healthy and r["severity_tag"] != "medium":
            continue
        k, std = np.array(r["k"]), np.array(r["k_std"])
        half = uncertainty.Z90 * uncertainty.FOLLOWED_SCALE * std
        iv = np.column_stack([np.clip(k - half, 0, 1), np.clip(k + half, 0, 1)])
        stat, th = r["adequacy_statistic"], adequacy.FOLLOWED_THRESHOLD
        v = health.assess(
            k,
            k_true=r["k_true"],
            k_interval=iv,
            adequacy={"statistic": stat, "threshold": th, "ok": stat <= th},
        )
        out.append(
            {
                "k": list(k),
                "k_interval": iv.tolist(),
                "k_true": r["k_true"],
                "single_fault": None if healthy else r["single_fault"],
                "percent_err": r["percent_err"],
                "explained": stat <= th,
                "level": v.level,
                "dominant": v.dominant,
                "adequacy_statistic": stat,
            }
        )
    return out


# ----------------------------------------------------------------------------- report

#: Everything in the report below this line is hand-written and kept by --report-only and runs.
TUNED_FILE = "bench_robust_recorded.json"


def slices(units: list[dict]) -> list[tuple[str, list[dict]]]:
    """(label, rows) of each population slice."""
    rows = [r for u in units for r in u["rows"]]

    def pick(spec: bool, mode: str, accepted: bool | None = None) -> list[dict]:
        return [
            r
            for r in rows
            if r["in_spec"] == spec
            and r["mode"] == mode
            and (accepted is None or r["accepted"] == accepted)
        ]

    return [
        ("in-spec, commissioned (accepted)", pick(True, "commissioned", True)),
        ("in-spec, commissioned with --force (refused)", pick(True, "commissioned", False)),
        ("in-spec, uncommissioned", pick(True, "uncommissioned")),
        ("out-of-band, commissioned (accepted)", pick(False, "commissioned", True)),
        ("out-of-band, commissioned with --force", pick(False, "commissioned", False)),
        ("out-of-band, uncommissioned", pick(False, "uncommissioned")),
    ]


def refusal(said: dict) -> str:
    """What a refusal was about: the kind of the first problem `commission_like_cli` met."""
    if said["accepted"]:
        return "accepted"
    first = said["problems"][0]
    for words, kind in (
        ("looks faulty", "a baseline looks faulty"),
        ("disagree", "baselines disagree"),
        ("thesis fit", "not explained, open loop"),
        ("recorded fit", "not explained, recorded loop"),
    ):
        if words in first:
            return kind
    return "baseline not excited" if said["refused_at"] == "review" else "not explained"


def _headline_row(label: str, f: dict) -> str:
    return (
        f"| {label} | {rate(f['healthy_explained'], f['healthy'])} | "
        f"{rate(f['healthy_warn'], f['healthy'])} | {rate(f['healthy_error'], f['healthy'])} | "
        f"{rate(f['withheld'], f['faults'])} | {rate(f['missed'], f['faults'])} | "
        f"{rate(f['named'], f['faults'])} | {rate(f['covered'], f['entries'])} | "
        f"{f['median']:.2f} | {f['p90']:.2f} |"
    )


def _band(noise: float) -> str:
    if noise <= FINE_POSITION[1] * (1 + 1e-9):
        return "1-2e-5 (fine)"
    if noise < NOISE["noise_position"]:
        return "2.5-5e-5"
    return "5e-5-1e-4"


BANDS = ("1-2e-5 (fine)", "2.5-5e-5", "5e-5-1e-4")


def _intro(data: dict, units: list[dict]) -> list[str]:
    mach = data["machine"]
    n_spec = sum(u["in_spec"] for u in units)
    n_rows = sum(len(u["rows"]) for u in units)
    title = "# A foreign population, kept apart from all tuning"
    if data.get("quick"):
        title += " (--quick run: a smoke test, not the benchmark's figures)"
    return [
        title,
        "",
        f"{len(units)} units off the generator's map (seeds {units[0]['unit_seed']}.."
        f"{units[-1]['unit_seed']}; {n_spec} in-spec, {len(units) - n_spec} out-of-band), "
        f"{n_rows} isolations.  Nothing in the package was chosen on them.  How they are drawn: "
        "the docstring of bench/bench_foreign.py (corner, inside and twice-the-band units; "
        f"operation at {TEMPERATURE_C[0]:g}..{TEMPERATURE_C[1]:+g} degC, noise 0.5-2x the "
        "benchmark envelope's per channel and a fine user-position sensor (1-2e-5 rad RMS) on "
        "every third unit and window, drawn anew for every window; unmeasured and measured "
        "constant loads and measured sine loads, springs to 4000 N*m/rad; every fault at the "
        "thesis's medium severity and healthy windows; each window isolated as "
        "`ema-phm isolate` does, with the unit commissioned as `ema-phm calibrate --baseline` "
        "does it (and with --force where that refuses) and without commissioning).",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores ({mach['numba_threads']} numba "
        f"threads), Python {mach['python']}, numba {mach['numba']}.  Command: "
        f"`{data['command']}` ({data.get('total_s', math.nan) / 60:.0f} min wall, at nice 10 "
        "on a shared machine); the report alone: "
        f"`{data['command'].split(' --')[0]} --report-only"
        + (" --quick" if data.get("quick") else "")
        + "`.",
        "",
        "Rates: count/denominator (per cent; 95 % Wilson interval, per cent).",
    ]


def _commissioning(units: list[dict]) -> list[str]:
    groups = (
        ("in-spec", [u for u in units if u["in_spec"]]),
        ("out-of-band", [u for u in units if not u["in_spec"]]),
    )
    kinds = sorted({refusal(u["commissioning"]) for u in units} - {"accepted"})
    lines = [
        "",
        "## Commissioning",
        "",
        "| units | refused by `calibrate --baseline` | "
        + " | ".join(f"first reason: {k}" for k in kinds)
        + " |",
        "|---|---:|" + "---:|" * len(kinds),
    ]
    for label, group in groups:
        said = [u["commissioning"] for u in group]
        lines.append(
            f"| {label} | {rate(sum(not c['accepted'] for c in said), len(said))} | "
            + " | ".join(str(sum(refusal(c) == k for c in said)) for k in kinds)
            + " |"
        )
    lines += [
        "",
        "Refusals by the hangar's user-position noise (rad RMS):",
        "",
        "| hangar position noise | in-spec refused | out-of-band refused |",
        "|---|---:|---:|",
    ]
    for band in BANDS:
        cells = []
        for _label, group in groups:
            g = [u for u in group if _band(u["hangar"]["noise"]["noise_position"]) == band]
            cells.append(rate(sum(not u["commissioning"]["accepted"] for u in g), len(g)))
        lines.append(f"| {band} | " + " | ".join(cells) + " |")
    return lines


def _headline(units: list[dict], tuned: list[dict] | None) -> list[str]:
    lines = [
        "",
        "## Headline (the acceptance figures)",
        "",
        "Healthy WARN / ERROR count windows the monitor explains and claims a fault on; a "
        'healthy window held back as not explained is counted under "explained" only.  '
        'Withheld: a fault window answered "the monitor model does not explain this window".  '
        "Missed: a fault window reported OK.  Named: explained, WARN or above, the true fault "
        "named.  Coverage: every k entry with a meaning of every fault window (the phase k7 "
        "only where the eccentricity is present), the interval the monitor reports.  %err: eq. "
        "6.4, every fault window.",
        "",
        "| slice | healthy explained | healthy WARN | healthy ERROR | fault windows withheld | "
        "missed (OK) | right fault named | 90 % intervals hold the truth | median %err | "
        "90th pct %err |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for label, rows in slices(units):
        lines.append(_headline_row(label, figures(rows)))
    if tuned:
        label = (
            "tuned population (bench_robust, recorded loop, commissioned; medium severities "
            "and healthy windows)"
        )
        lines.append(_headline_row(label, figures(tuned)))
    lines += [
        "",
        "Targets (foreign population): in-spec refused 0 %; healthy explained >= 97 % "
        "commissioned, >= 90 % uncommissioned; healthy WARN <= 1 %, ERROR 0; withheld <= 5 %; "
        "missed <= 2 %; named >= 90 %; coverage 85-97 %.",
    ]
    return lines


def _beside(units: list[dict], tuned: list[dict] | None) -> list[str]:
    lines = ["", "## Beside the tuned population", ""]
    if not tuned:
        return [*lines, f"(no tuned rows: bench/results/{TUNED_FILE} is missing)"]
    acc, t = figures(slices(units)[0][1]), figures(tuned)
    lines += [
        f"The tuned rows ({TUNED_FILE}: `Unit.draw` units commissioned from 2 hangar "
        "baselines at the envelope's noise, flight at -20..+70 degC with an unmeasured "
        "constant load and spring; measured with the monitor of the commit that wrote "
        "them, judged here with today's threshold and interval scale) hold no short "
        "circuit B or C, no uncommissioned window and no commissioning verdict.",
        "",
        "| figure | foreign, in-spec commissioned (accepted) | tuned | gap (foreign - tuned) |",
        "|---|---:|---:|---:|",
    ]
    for name, key, den in (
        ("healthy explained", "healthy_explained", "healthy"),
        ("healthy WARN", "healthy_warn", "healthy"),
        ("fault windows withheld", "withheld", "faults"),
        ("missed (OK)", "missed", "faults"),
        ("right fault named", "named", "faults"),
        ("90 % intervals hold the truth", "covered", "entries"),
    ):
        a = acc[key] / acc[den] if acc[den] else math.nan
        b = t[key] / t[den] if t[den] else math.nan
        lines.append(
            f"| {name} | {rate(acc[key], acc[den])} | {rate(t[key], t[den])} | "
            f"{100 * (a - b):+.0f} points |"
        )
    for name, key in (("median %err", "median"), ("90th pct %err", "p90")):
        lines.append(f"| {name} | {acc[key]:.2f} | {t[key]:.2f} | {acc[key] - t[key]:+.2f} |")
    return lines


def _per_fault(rows: list[dict]) -> list[str]:
    lines = [
        "",
        "## Per fault",
        "",
        "Right fault named / withheld / missed, and median %err, per slice (commissioned = "
        "accepted or forced).",
        "",
        "| fault | in-spec commissioned | in-spec uncommissioned | out-of-band commissioned | "
        "out-of-band uncommissioned |",
        "|---|---|---|---|---|",
    ]
    for name, _k, idx in medium_cases():
        cells = []
        for spec in (True, False):
            for mode in ("commissioned", "uncommissioned"):
                rr = [
                    r
                    for r in rows
                    if r["single_fault"] == idx and r["in_spec"] == spec and r["mode"] == mode
                ]
                f = figures(rr)
                cells.append(
                    f"{f['named']}/{f['faults']} named, {f['withheld']} withheld, "
                    f"{f['missed']} OK; %err {f['median']:.1f}"
                    if rr
                    else "-"
                )
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def _by(rows: list[dict], title: str, text: str, groups: list[tuple[str, Any]]) -> list[str]:
    """A table of healthy explained, withheld, named and %err per group and mode."""
    lines = [
        "",
        f"## {title}",
        "",
        text,
        "",
        "| group | mode | healthy explained | withheld | named | median %err |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for label, keep in groups:
        for mode in ("commissioned", "uncommissioned"):
            f = figures([r for r in rows if r["mode"] == mode and keep(r)])
            lines.append(
                f"| {label} | {mode} | {rate(f['healthy_explained'], f['healthy'])} | "
                f"{rate(f['withheld'], f['faults'])} | {rate(f['named'], f['faults'])} | "
                f"{f['median']:.2f} |"
            )
    return lines


def _corner(u: dict) -> str:
    if u["kind"] != "corner":
        return ""
    moved = [
        f"{k} {v:+.3g}" if k in OFFSET_KEYS else f"{k} {v:.3g}"
        for k, v in u["unit"].items()
        if (v != 0.0 if k in OFFSET_KEYS else v != 1.0)
    ]
    return " (" + ", ".join(moved) + ")"


def _units(units: list[dict]) -> list[str]:
    lines = [
        "",
        "## Units",
        "",
        "| unit | seed | kind | in-spec | keys outside the band | hangar noise I / theta_u "
        "/ omega | commissioning | healthy reference ratio, open / recorded loop | "
        "windows explained, comm. / uncomm. |",
        "|---:|---:|---|---|---|---|---|---|---|",
    ]
    for u in units:
        c = u["commissioning"]
        n = u["hangar"]["noise"]
        verdict = "accepted" if c["accepted"] else f"refused: {refusal(c)}"
        ratios = " / ".join(
            f"{ref['ratio']:.2f}"
            for fit in ("thesis", "recorded")
            for ref in c["references"]
            if ref["fit"] == fit
        )
        rr = [r for r in u["rows"] if "k" in r]
        ex = [
            sum(r["explained"] for r in rr if r["mode"] == m)
            for m in ("commissioned", "uncommissioned")
        ]
        per = len(rr) // 2
        lines.append(
            f"| {u['index']} | {u['unit_seed']} | {u['kind']}{_corner(u)} | "
            f"{'yes' if u['in_spec'] else 'no'} | {', '.join(u['outside']) or '-'} | "
            f"{n['noise_current']:.3g} / {n['noise_position']:.2g} / {n['noise_speed']:.3g} | "
            f"{verdict} | {ratios} | {ex[0]}/{per} / {ex[1]}/{per} |"
        )
    lines += ["", "Refusal reasons (first problem of each refused unit):", ""]
    refused = [u for u in units if not u["commissioning"]["accepted"]]
    lines += [f"- unit {u['index']}: {u['commissioning']['problems'][0]}" for u in refused]
    if not refused:
        lines.append("- none")
    walls = [u["wall_s"] for u in units]
    lines += [
        "",
        f"Wall per unit (simulation, commissioning and its isolations, one worker): median "
        f"{statistics.median(walls) / 60:.1f} min, longest {max(walls) / 60:.1f} min.",
    ]
    return lines


def report(data: dict, tuned: list[dict] | None) -> str:
    """The Markdown report of a run's rows (`tuned`: the tuned population's, or None)."""
    units = sorted(data["units"], key=lambda u: u["index"])
    rows = [r for u in units for r in u["rows"] if "k" in r]
    noise_text = (
        "Every unit, commissioned (accepted or forced) and uncommissioned, by the noise the "
        "window's user-position sensor had [rad RMS]."
    )
    load_text = "Every unit, by the window's load profile (`LOAD_KINDS`)."
    lines = [
        *_intro(data, units),
        *_commissioning(units),
        *_headline(units, tuned),
        *_beside(units, tuned),
        *_per_fault(rows),
        *_by(
            rows,
            "By the operating window's user-position noise",
            noise_text,
            [(b, lambda r, b=b: _band(r["noise"]["noise_position"]) == b) for b in BANDS],
        ),
        *_by(
            rows,
            "By load profile",
            load_text,
            [(k, lambda r, k=k: r["load"]["kind"] == k) for k in LOAD_KINDS],
        ),
        *_units(units),
        "",
    ]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = cli(
        __doc__,
        quick="3 units (one of each kind), a healthy, a friction and a short circuit B window",
        seed=(FIRST_SEED, f"first unit seed (default {FIRST_SEED})"),
        jobs=(1, "worker processes, one unit each (default 1)"),
        out=(None, OUT_HELP),
    )
    ap.add_argument("--units", type=int, default=None, help="units (default 16; --quick 3)")
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args()
    units = args.units or (3 if args.quick else 16)
    rows_dir, report_dir = out_dirs(args.out)
    suffix = "_quick" if args.quick else ""
    raw = rows_dir / f"bench_foreign{suffix}.json"
    md = report_dir / f"benchmarks_foreign{suffix}.md"
    if not args.report_only:
        cmdline = command_line(
            "bench_foreign",
            *(["--quick"] if args.quick else []),
            flags=[
                ("--units", units, 3 if args.quick else 16),
                ("--seed", args.seed, FIRST_SEED),
                ("--jobs", args.jobs, 1),
            ],
        )
        data = run(units, args.seed, args.quick, jobs=args.jobs, raw=raw, cmdline=cmdline)
        write_rows(raw, data)
    data = read_rows(raw)
    write_report(md, report(data, tuned_rows(RESULTS / TUNED_FILE)))
    print(f"wrote {raw} and {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
