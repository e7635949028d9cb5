"""The fleet benchmark's report (benchmarks_fleet.md), rendered from the raw JSON only.

Each section is one function returning its lines; a phase not run yet says so.  The
hand-written analysis below `KEEP_MARKER` in an existing report is kept (`write`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from bench.fleet import sizing
from bench.fleet.scaling import RUNS
from ema_phm.atomic_file import write_text_atomic

#: Everything in the report below this line is hand-written and kept by --report.
KEEP_MARKER = "<!-- kept by --report: hand-written analysis below, dated by its commit -->"
#: Issue 22 targets.
TARGET_RATIO = 1.8
TARGET_OVERHEAD_PCT = 5.0
TARGET_RIGHT = 0.95
DASK_DOC = "https://distributed.dask.org/en/latest/"


def _f(v: Any, spec: str = ".1f", unit: str = "") -> str:
    """A number formatted, '-' when missing or not finite."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if isinstance(v, str):  # 'inf' as the JSON holds it
        return v
    return f"{v:{spec}}{unit}"


def _met(ok: bool | None) -> str:
    return "-" if ok is None else ("met" if ok else "**not met**")


def report(data: dict[str, Any]) -> str:
    """The whole report, section by section."""
    lines = [
        *_header(data),
        *_idle(data),
        *_commands(data),
        *_targets(data),
        *_scaling(data),
        *_memory(data),
        *_fleet(data),
        *_sizing(data),
    ]
    return "\n".join(lines).rstrip() + "\n"


def write(path: Path, data: dict[str, Any]) -> None:
    """Write the report whole, keeping the hand-written part below `KEEP_MARKER`."""
    text = report(data)
    if path.exists():
        old = path.read_text()
        if KEEP_MARKER in old:
            text += "\n" + KEEP_MARKER + old.split(KEEP_MARKER, 1)[1]
    write_text_atomic(path, text)


def _header(data: dict[str, Any]) -> list[str]:
    m, g = data.get("machine", {}), data.get("generate") or {}
    out = ["# Fleet benchmark (issue 22): Dask scaling, overhead, memory, accuracy, sizing", ""]
    if data.get("quick"):
        out += [
            "> **QUICK RUN, NOT A MEASUREMENT**: a tiny fleet and a tiny fit budget "
            "(`--quick`), only to check that the script works.  No figure below means "
            "anything.",
            "",
        ]
    out += [
        f"Machine: {m.get('cpu')}, {m.get('cores')} cores, Python {m.get('python')}, numba "
        f"{m.get('numba')}.  Commit {data.get('commit')}.  Figures are measured unless a "
        "section says it is arithmetic on them.",
        "",
    ]
    if g:
        out += [
            f"Fleet: `ema_phm.fleet.generate.generate_fleet` into {g.get('dir')}: "
            f"{g.get('units', '?')} units x {g.get('windows', '?')} flights, "
            f"{g.get('baselines', '?')} hangar baselines each, seed {g.get('seed', '?')}, "
            f"{g.get('degrading', '?')} units with a growing fault; "
            + (
                "generated earlier (not timed)."
                if g.get("reused")
                else f"{g['recordings']} recordings ({g['bytes'] / 1e6:.1f} MB) in "
                f"{g['seconds']:.0f} s, {g['s_per_recording']:.2f} s per recording "
                "(HF simulation and bag writing, one process)."
            ),
            "",
        ]
    return out


def _commands(data: dict[str, Any]) -> list[str]:
    out = ["## Commands", "", "```"]
    for key in ("generate", "scaling", "fleet"):
        cmd = (data.get(key) or {}).get("command")
        out.append(cmd if cmd else f"# {key}: not run yet")
    out += [data.get("report_command", "# report: not written yet"), "```", ""]
    return out


def _targets(data: dict[str, Any]) -> list[str]:
    s = (data.get("scaling") or {}).get("summary") or {}
    sc = (data.get("fleet") or {}).get("score") or {}
    ratio, ovh, right = s.get("ratio"), s.get("overhead_pct"), sc.get("share_right")
    return [
        "## Targets",
        "",
        "| target | measured | |",
        "|---|---:|---|",
        f"| windows/s with 2 workers / with 1 worker >= {TARGET_RATIO:g} | {_f(ratio, '.2f')} "
        f"| {_met(None if ratio is None else ratio >= TARGET_RATIO)} |",
        f"| Dask overhead per window <= {TARGET_OVERHEAD_PCT:g} % of a window's isolation | "
        f"{_f(ovh, '.1f', ' %')} | {_met(None if ovh is None else ovh <= TARGET_OVERHEAD_PCT)} |",
        f"| growing faults named right >= {TARGET_RIGHT:.0%} | {_f(right, '.1%')} | "
        f"{_met(None if right is None else right >= TARGET_RIGHT)} |",
        "",
    ]


def _run_row(r: dict[str, Any], one: dict[str, Any]) -> str:
    t = r["timing"]["all"]
    ratio = r["windows_per_s"] / one["windows_per_s"] if one["windows_per_s"] else None
    return (
        f"| {r['label']} | {r['windows']} | {r['commissioned']} | {_f(r['wall_s'])} | "
        f"{_f(r['startup_s'], '.1f')} + {_f(r['close_s'], '.1f')} | {_f(r['wall_total_s'])} | "
        f"{_f(r['windows_per_s'], '.3f')} | {_f(ratio, '.2f')} | {_f(t['median'], '.2f')} / "
        f"{_f(t['mean'], '.2f')} / {_f(t['sum'], '.0f')} |"
    )


def _scaling(data: dict[str, Any]) -> list[str]:
    sc = data.get("scaling")
    if not sc:
        return ["## Scaling", "", "Not run yet (`--scaling`).", ""]
    runs, s = sc["runs"], sc["summary"]
    return [
        "## Scaling: the same units, a plain loop, 1 worker, 2 workers",
        "",
        f"{len(sc['units'])} units ({sc['units'][0]} .. {sc['units'][-1]}), each into a fresh "
        "SQLite store.  Wall: the ingest alone (catalog, plans, fits, stores); start-up + close: "
        "`start_cluster(n)`, a Client, all workers up, and closing them; total: the three, what "
        "`ingest` with its embedded cluster costs.  windows/s = windows / total; the ratio is "
        "against 1 worker.  Isolation: each stored window's fit wall time (`wall_s`), median / "
        "mean / sum.  Commissioning (once per unit) is inside every wall time.",
        "",
        "| run | windows | commissioned | wall [s] | start-up + close [s] | total [s] | "
        "windows/s | ratio | isolation per window median / mean / sum [s] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *(_run_row(runs[k], runs["1"]) for k in RUNS),
        "",
        f"Scaling ratio (2 workers / 1 worker): **{_f(s['ratio'], '.2f')}** with start-up, "
        f"{_f(s['ratio_ingest'], '.2f')} without.",
        "",
        "Dask overhead per window = (total with 1 worker - wall of the plain loop) / windows: "
        f"**{_f(s['overhead_s_per_window'], '.3f')} s, {_f(s['overhead_pct'], '.1f')} %** of "
        f"the plain loop's mean isolation ({_f(s['mean_isolation_s'], '.2f')} s).  Without "
        "the cluster's start-up and close (the ingest's wall alone): "
        f"{_f(s['overhead_no_startup_s_per_window'], '.3f')} s, "
        f"{_f(s['overhead_no_startup_pct'], '.1f')} %.  Start-up + close: 1 worker "
        f"{_f(runs['1']['startup_s'], '.1f')} + {_f(runs['1']['close_s'], '.1f')} s, 2 workers "
        f"{_f(runs['2']['startup_s'], '.1f')} + {_f(runs['2']['close_s'], '.1f')} s.  The plain "
        "loop ran first in this process (its imports and numba cache loads included); each "
        "worker loads its own.",
        "",
        f"The three stores hold identical window results (`store.results_equal`): "
        f"**{s['identical']}**; identical commissioning: {s['commissioning_identical']}.",
        "",
    ]


def _memory(data: dict[str, Any]) -> list[str]:
    sc, fl = data.get("scaling"), data.get("fleet")
    rows = []
    if sc:
        rows += [(sc["runs"][k]["label"], sc["runs"][k]["rss"]) for k in RUNS]
    if fl:
        rows.append(("whole fleet, default cluster", fl["rss"]))
    if not rows:
        return []
    body = [
        f"| {label} | {len(r['workers'])} | {_f(r['worker_peak_mb'], '.0f')} | "
        f"{_f(r['worker_median_mb'], '.0f')} | {_f(r['main_peak_mb'], '.0f')} | "
        f"{_f(r['main_median_mb'], '.0f')} | {r['samples']} | {_f(r['cpu']['cpu_s'], '.0f')} | "
        f"{_f(r['cpu']['others_cpu_s'], '.0f')} |"
        for label, r in rows
    ]
    return [
        "## Memory and CPU",
        "",
        "Sampled every 0.5 s by a thread (psutil) while each ingest ran: the RSS of each "
        "worker process and of this process (client, scheduler and nannies of the embedded "
        "cluster, the store's writer; the fits themselves in the plain loop); CPU seconds "
        "these processes used, and CPU seconds other processes of the machine took meanwhile "
        "(machine busy time minus ours: should be near 0 on an idle machine).",
        "",
        "| run | workers | worker peak [MB] | worker median [MB] | this process peak [MB] | "
        "median [MB] | samples | CPU s, ours | CPU s, other processes |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *body,
        "",
    ]


#: Other processes' CPU, in cores on average over a run, above which the report warns.
BUSY_CORES = 0.1


def _idle(data: dict[str, Any]) -> list[str]:
    """A warning when other processes took CPU while an ingest was measured."""
    runs = []
    if data.get("scaling"):
        runs += [(r["label"], r["rss"]["cpu"]) for r in data["scaling"]["runs"].values()]
    if data.get("fleet"):
        runs.append(("whole fleet", data["fleet"]["rss"]["cpu"]))
    busy = [
        f"{label}: {c['others_cpu_s']:.0f} CPU s in {c['wall_s']:.0f} s"
        for label, c in runs
        if c["wall_s"] > 0 and c["others_cpu_s"] / c["wall_s"] > BUSY_CORES
    ]
    if not busy:
        return []
    return [
        "> **The machine was not idle**: other processes took CPU during "
        + "; ".join(busy)
        + ".  Timings and ratios of those runs are slowed by them.",
        "",
    ]


def _fleet(data: dict[str, Any]) -> list[str]:
    fl = data.get("fleet")
    if not fl:
        return ["## The whole fleet", "", "Not run yet (`--fleet`).", ""]
    rep, sc, t = fl["report"], fl["score"], fl["timing"]
    out = [
        "## The whole fleet: ingested, reported, scored against the truth",
        "",
        f"{rep['units']} units, {rep['windows_diagnosed']} windows, {rep['commissioned']} "
        f"units commissioned, on {rep['workers']} worker(s), in **{fl['wall_s']:.0f} s** end to "
        f"end ({rep['windows_diagnosed'] / fl['wall_s']:.3f} windows/s); {len(rep['failed'])} "
        f"units failed, {len(rep['refused'])} recordings refused.  Isolation per window: "
        f"first (global) mean {_f(t['first']['mean'], '.2f')} s over {t['first']['n']}, later "
        f"mean {_f(t['later']['mean'], '.2f')} s over {t['later']['n']} (fit modes "
        + ", ".join(f"{m} {v['n']}" for m, v in t["by_mode"].items())
        + f"); {t['skipped']} windows not fitted.  Reading the view "
        f"{fl['read_view_s']:.2f} s; the HTML report {fl['html_bytes'] / 1e6:.2f} MB in "
        f"{fl['write_report_s']:.1f} s; the store {fl['db_bytes'] / 1e6:.2f} MB for "
        f"{fl['db_rows']} windows.",
        "",
        f"Growing faults named with the right fault: **{sc['right']}/{sc['degrading']} "
        f"({_f(sc['share_right'], '.1%')})**.  Healthy units named with a fault (false "
        f"alarms): **{len(sc['false_alarms'])}/{sc['healthy']}**"
        + "".join(f"; {a['unit']} {a['named']} ({a['level']})" for a in sc["false_alarms"])
        + ".  Units by level: "
        + ", ".join(f"{k} {v}" for k, v in sc["levels"].items())
        + ".",
        "",
    ]
    return out + _misses(sc) + _rul(sc)


def _misses(sc: dict[str, Any]) -> list[str]:
    if not sc["misses"]:
        return ["No growing fault missed.", ""]
    return [
        "Misses (k: the unit's last counted window's estimate of the true fault's entry):",
        "",
        "| unit | true fault | final severity | named | level | k | true k |",
        "|---|---|---:|---|---|---:|---:|",
        *(
            f"| {d['unit']} | {d['truth']} | {d['final_severity']:.3f} | {d['named'] or '-'} | "
            f"{d['level']} | {_f(d['k'], '.3f')} | {_f(d['k_true'], '.3f')} |"
            for d in sc["misses"]
        ),
        "",
    ]


def _rul(sc: dict[str, Any]) -> list[str]:
    rul = [d for d in sc["units"] if d["rul_p50"] is not None]
    head = (
        f"RUL: {sc['with_rul']}/{sc['degrading']} degrading units have a RUL for the fault "
        "they are named with"
    )
    if not rul:
        return [head + ".", ""]
    return [
        head + " (p50 in cycles after the last window; the true RUL: cycles until the "
        "fault's ERROR severity, from the truth's law).",
        "",
        "| unit | fault | RUL p50 [cycles] | true RUL [cycles] |",
        "|---|---|---:|---:|",
        *(
            f"| {d['unit']} | {d['truth']} | {_f(d['rul_p50'], '.1f')} | "
            f"{d['true_rul'] if d['true_rul'] is not None else '-'} |"
            for d in rul
        ),
        "",
    ]


def _sizing(data: dict[str, Any]) -> list[str]:
    src = sizing.inputs(data)
    if src is None:
        return ["## Sizing on paper", "", "Needs --scaling or --fleet.", ""]
    body = [
        f"| {r['actuators']:,} | {r['windows_per_day']:,} | {r['cpu_s_per_day']:,.0f} "
        f"({r['cpu_s_per_day_all_first']:,.0f}) | {r['cores_100']:.2f} | {r['cores_50']:.2f} | "
        f"{r['machines']:,} | {r['rows_per_day']:,} | {r['bytes_per_day'] / 1e6:,.1f} | "
        f"{r['tasks_per_s']:.3f} | {r['scheduler_busy']:.2e} | {r['ram_mb'] / 1024:,.1f} |"
        for r in sizing.table(data)
    ]
    return [
        "## Sizing on paper (arithmetic on the measured figures above, not measured)",
        "",
        *_sizing_inputs(src),
        "",
        "| actuators | windows/day | CPU s/day (all global) | cores at 100 % | cores at 50 % | "
        "2-core machines at 50 % | store rows/day | store MB/day | Dask tasks/s | "
        "scheduler busy share | RAM [GB] |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        *body,
        "",
    ]


def _sizing_inputs(src: dict[str, Any]) -> list[str]:
    modes = ", ".join(f"{m} {n}" for m, n in src["later_modes"].items())
    return [
        f"{sizing.WINDOWS_PER_DAY} pre-flight windows per actuator per day.  Measured inputs "
        f"({src['timing_from']}): a unit's first window (a global search) "
        f"{_f(src['first_s'], '.2f')} s, its later windows {_f(src['later_s'], '.2f')} s mean "
        f"over {src['later_n']} (tracked alone {_f(src['tracked_s'], '.2f')} s; every fit "
        f"mode measured: {modes}), one core each; commissioning "
        f"{_f(src['commission_s'], '.1f')} s per unit, once.  A fleet in steady state is "
        "mostly tracked windows: CPU s/day = windows/day x the later windows' mean (in "
        "brackets: were every window a global search).  Cores = CPU s/day / 86,400; machines "
        f"of {sizing.CORES_PER_MACHINE} cores at {sizing.UTILISATION:.0%}.  Store: "
        f"{_f(src['bytes_per_window'], ',.0f')} bytes per stored window ({src['bytes_from']}: "
        "SQLite file size / windows, units and recordings tables included).",
        "",
        "Dask: one task per window; the scheduler's busy share = tasks/s x about 1 ms per task, "
        f"the overhead per task Dask's documentation states ({DASK_DOC}, Motivation), an order "
        "of magnitude rather than a figure measured here.  RAM = "
        f"machines x {sizing.CORES_PER_MACHINE} workers x the measured worker peak RSS "
        f"({_f(src['worker_rss_mb'], '.0f')} MB) + one client/scheduler process "
        f"({_f(src['main_rss_mb'], '.0f')} MB).  Commissioning a whole fleet once costs "
        "actuators x its measured time (not in the daily figures).",
    ]
