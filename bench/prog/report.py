"""The prognostics benchmark's report (docs/benchmarks_prognostics.md), from scored rows.

`report` renders the sections in order; each section is one function returning its lines.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from harness import halves
from harness.scenarios import BASELINES, LOAD_NM, SPRING_NM_PER_RAD, TEMPERATURE_C

from ema_phm.domain.faults import NAMES, NOMINAL
from prog import bias
from prog.plan import HEALTHY_CYCLES, LIFE_CYCLES, ONSET_CYCLES, THRESHOLD, TYPE_FAULTS, TYPES
from prog.score import (
    ALARM_WINDOWS,
    HORIZON_CYCLES,
    SCORE_SEED,
    SMALL_RUL,
    _median,
    _pct,
    _rul_errors,
    _severity_errors,
    counts,
    headline,
)

#: Issue 11 targets.
TARGET_AL_SHARE = 0.80
TARGET_PH_SHARE = 0.50
TARGET_COVERAGE = (0.80, 0.97)
#: Everything in the report below this line is hand-written and kept by --score.
KEEP_MARKER = "<!-- kept by --score: hand-written analysis below, dated by its commit -->"


def report(data: dict, scored: list[dict], extra: dict[str, Any]) -> str:
    """The whole report, section by section (header, targets, ..., controls)."""
    trs = {tr["index"]: tr for tr in data["plan"]}
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        by_t.setdefault(w["trajectory"], []).append(w)
    pops = halves(scored)
    hs = {k: headline(v, trs) for k, v in pops.items()}
    lines = [
        *_header(data, scored, extra, trs),
        *_targets(hs, pops),
        *_per_type(scored),
        *_per_trajectory(scored, trs),
        *_healthy(scored, trs, by_t),
        *_isolation(data["windows"], scored, by_t),
        *bias.lines(data),
        *_causes(scored, trs, by_t, hs, pops),
        *_controls(scored, hs, pops, extra),
    ]
    return "\n".join(lines).rstrip() + "\n"


def _header(data: dict, scored: list[dict], extra: dict[str, Any], trs: dict) -> list[str]:
    """Title, set-up and machine paragraphs, and the head of the targets table."""
    windows = data["windows"]
    mach = data["machine"]
    n_deg = sum(1 for s in scored if s["type"] != "healthy")
    n_h = sum(1 for s in scored if s["type"] == "healthy")
    lines = [
        "# Prognostics benchmark: run-to-failure trajectories of realistic units",
        "",
        f"{n_deg} degrading trajectories ({', '.join(f'{_count(scored, t)} {t}' for t in TYPES)}) "
        f"and {n_h} healthy ones, each on its own manufactured unit (`Unit.draw(s)`, s = "
        f"{_cycles(sorted(trs[s['index']]['unit_seed'] for s in scored))}), commissioned from "
        f"{BASELINES} healthy hangar windows as in bench_robust.py.  One window (2 s, the default "
        "command) per cycle, a pre-flight test: every cycle draws its own temperature "
        f"({TEMPERATURE_C[0]:g}..{TEMPERATURE_C[1]:+g} degC), unmeasured load "
        f"({LOAD_NM[0]:g}..{LOAD_NM[1]:+g} N*m) and hinge spring ({SPRING_NM_PER_RAD[0]:g}.."
        f"{SPRING_NM_PER_RAD[1]:g} N*m/rad); noise on every channel (bench_realistic.NOISE).  "
        "Degradation laws per trajectory (seeded): friction and backlash linear, short circuit "
        "(phase A) and eccentricity exponential, multi-fault = friction linear + eccentricity "
        f"exponential; onset {ONSET_CYCLES[0]}..{ONSET_CYCLES[1]}, target end of life "
        f"{LIFE_CYCLES[0]}..{LIFE_CYCLES[1]} cycles at severity {THRESHOLD:g} "
        "(`health.DEFAULT_ERROR`).  A trajectory runs up to the cycle before its (last) true "
        f"end of life; healthy ones {HEALTHY_CYCLES} cycles.  Isolation as the live monitor: "
        "commissioned belief, nuisances, 90 % intervals, tracked from the last explained fit, "
        "global otherwise, a tracked fit not explained redone globally.  Prognostics as the "
        "live monitor (`monitor.tracker`): a window whose fit the model explains "
        "(adequacy ok) enters the history and makes a prediction (`rul.prognose` defaults, "
        f"seed {SCORE_SEED}); one it does not explain adds nothing.  Scored by "
        "`replay.score` (alpha 0.2, lambda counted from the first window, cycle 0, so lambda "
        "is a fraction of the true life).",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores ({mach['numba_threads']} numba "
        f"threads), Python {mach['python']}, numba {mach['numba']}, shared with another "
        f"session running tests.  Isolation: `{data['command']}` "
        f"({data.get('isolate_s', math.nan) / 60:.0f} min wall for {len(windows)} windows); "
        f"scoring: `.venv/bin/python bench/bench_prognostics.py --score` "
        f"({extra['score_s']:.0f} s) with the RUL model (rul.py, trend.py) of "
        f"{extra.get('rul_version', 'an unknown commit')}.  Raw rows: "
        "docs/bench_prognostics.json.",
        "",
        "## Targets (issue 11)",
        "",
        "| target | all | even (tuned on) | odd (held out) | met? (all) | gap |",
        "|---|---:|---:|---:|---|---|",
    ]
    return lines


def _targets(hs: dict[str, dict], pops: dict[str, list[dict]]) -> list[str]:
    """The targets table, the other headline figures, and the head of the per-type table."""
    a = hs["all"]
    al_share = a["al_traj_met"] / a["trajectories"] if a["trajectories"] else math.nan
    cov = a["coverage"]
    lines = [
        "| alpha-lambda (alpha 0.2) met at every window from lambda 0.5, share of trajectories "
        ">= 80 % | "
        + " | ".join(_rate(hs[k]["al_traj_met"], hs[k]["trajectories"]) for k in pops)
        + f" | {_yes(al_share, al_share >= TARGET_AL_SHARE)} | "
        + (
            "-"
            if math.isnan(al_share) or al_share >= TARGET_AL_SHARE
            else f"{100 * (TARGET_AL_SHARE - al_share):.0f} points short"
        )
        + " |",
        "| prognostic horizon (alpha 0.2) / true life, median >= 50 % | "
        + " | ".join(f"{100 * hs[k]['ph_share_median']:.0f} %" for k in pops)
        + f" | {_yes(a['ph_share_median'], a['ph_share_median'] >= TARGET_PH_SHARE)} | "
        + (
            "-"
            if math.isnan(a["ph_share_median"]) or a["ph_share_median"] >= TARGET_PH_SHARE
            else f"{100 * (TARGET_PH_SHARE - a['ph_share_median']):.0f} points short"
        )
        + " |",
        "| 90 % RUL interval coverage 80-97 % (windows with a RUL, before the end of life) | "
        + " | ".join(
            f"{100 * hs[k]['coverage']:.0f} % ({hs[k]['coverage_windows']})" for k in pops
        )
        + f" | {_yes(cov, TARGET_COVERAGE[0] <= cov <= TARGET_COVERAGE[1])} | "
        + (
            "-"
            if math.isnan(cov) or TARGET_COVERAGE[0] <= cov <= TARGET_COVERAGE[1]
            else (
                f"{100 * (TARGET_COVERAGE[0] - cov):.0f} points under 80 %"
                if cov < TARGET_COVERAGE[0]
                else f"{100 * (cov - TARGET_COVERAGE[1]):.0f} points over 97 %"
            )
        )
        + " |",
        "| no RUL alarm on healthy trajectories (the monitor's RUL WARN: 5th percentile < "
        f"{HORIZON_CYCLES:g} cycles in {ALARM_WINDOWS} consecutive prognoses) | "
        + " | ".join(_rate(hs[k]["healthy_warn"], hs[k]["healthy"]) for k in pops)
        + f" | {_yes(a['healthy'] or math.nan, a['healthy_warn'] == 0)} | "
        + ("-" if a["healthy_warn"] == 0 else f"{a['healthy_warn']} healthy trajectories alarmed")
        + " |",
        "",
        "Also: alpha-lambda per fault history (a multi-fault trajectory holds two): "
        + ", ".join(f"{k} {_rate(hs[k]['al_fault_met'], hs[k]['fault_histories'])}" for k in pops)
        + "; alpha-lambda at the first window at or after lambda 0.5 only (`replay.score`'s "
        "`alpha_lambda`), per fault history: "
        + ", ".join(
            f"{k} {_rate(hs[k]['al_at_lambda_met'], hs[k]['fault_histories'])}" for k in pops
        )
        + "; prognostic horizon / life, worst: "
        + ", ".join(f"{k} {100 * hs[k]['ph_share_min']:.0f} %" for k in pops)
        + ".  Healthy trajectories with any fault `degrading` at any window: "
        + ", ".join(f"{k} {_rate(hs[k]['healthy_degrading'], hs[k]['healthy'])}" for k in pops)
        + "; with a RUL 5th percentile below the horizon at any single prognosis: "
        + ", ".join(f"{k} {_rate(hs[k]['healthy_below'], hs[k]['healthy'])}" for k in pops)
        + ".  Faults that do not grow in a degrading trajectory (5 per single-fault "
        "trajectory, 4 per multi-fault one) given a RUL at some window before the end: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_degrading'], hs[k]['others'])}" for k in pops)
        + "; with a RUL p5 below the horizon at a single prognosis: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_below'], hs[k]['others'])}" for k in pops)
        + "; with the monitor's RUL WARN: "
        + ", ".join(f"{k} {_rate(hs[k]['spurious_warn'], hs[k]['others'])}" for k in pops)
        + ".",
        "",
        "## Per fault type",
        "",
        "PH: prognostic horizon as a share of the true life.  alpha-lambda: met at every "
        "window from lambda 0.5.  RA: relative accuracy at lambda 0.5.  Coverage: the 90 % "
        "RUL interval holds the true RUL, over the windows with a RUL before the end of life.",
        "",
        "| fault type (fault) | histories | true life, median (min-max) | first RUL cycle, "
        "median (share of life) | true RUL at the first RUL WARN, median (min-max) | PH median | "
        "PH min | alpha-lambda from 0.5 | RA at 0.5, median (min) | coverage (windows) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    return lines


def _per_type(scored: list[dict]) -> list[str]:
    """One row per fault type (and fault of a multi-fault type)."""
    lines: list[str] = []
    for kind in TYPES:
        for name in TYPE_FAULTS[kind]:
            fs = [
                (s, s["faults"][name]) for s in scored if s["type"] == kind and name in s["faults"]
            ]
            if not fs:
                continue
            life = [f["true_eol_cycle"] for _, f in fs]
            first = [f["first_rul_cycle"] for _, f in fs if f["first_rul_cycle"] is not None]
            first_share = [
                f["first_rul_cycle"] / f["true_eol_cycle"]
                for _, f in fs
                if f["first_rul_cycle"] is not None
            ]
            ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for _, f in fs]
            al = sum(f.get("alpha_lambda_from_lambda") is True for _, f in fs)
            ra = [
                f["relative_accuracy_at_lambda"]
                for _, f in fs
                if f.get("relative_accuracy_at_lambda") is not None
            ]
            n = sum(f["windows_with_rul"] for _, f in fs)
            c = sum(
                f["interval_coverage_90"] * f["windows_with_rul"]
                for _, f in fs
                if f["windows_with_rul"]
            )
            warn = [
                f["true_eol_cycle"] - f["first_warn_cycle"]
                for _, f in fs
                if f["first_warn_cycle"] is not None
            ]
            warn_txt = (f"{_median(warn):.0f} ({min(warn)}-{max(warn)})" if warn else "-") + (
                f", {len(fs) - len(warn)} never" if len(warn) < len(fs) else ""
            )
            label = kind if kind == name else f"{kind} ({name})"
            never = len(fs) - len(first)
            lines.append(
                f"| {label} | {len(fs)} | {_median(life):.0f} ({min(life)}-{max(life)}) | "
                f"{_f(_median(first), '.0f')} ({_f(100 * _median(first_share), '.0f')} %)"
                + (f", {never} never" if never else "")
                + f" | {warn_txt} | {100 * _median(ph):.0f} % | {100 * min(ph):.0f} % | "
                f"{_rate(al, len(fs))} | "
                f"{_f(_median(ra))} ({_f(min(ra) if ra else math.nan)}) | "
                f"{_f(100 * c / n if n else math.nan, '.0f')} % ({n}) |"
            )
    return lines


def _per_trajectory(scored: list[dict], trs: dict) -> list[str]:
    """One row per fault history of every degrading trajectory."""
    lines = [
        "",
        "## Per trajectory",
        "",
        "| # | type | unit | fault | law | onset | true EoL | first RUL | PH cycles | "
        "alpha-lambda from 0.5 (windows met) | RA at 0.5 | coverage | final-window RUL 5/50/95 "
        "(true) |",
        "|---:|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for s in scored:
        tr = trs[s["index"]]
        for name, f in s["faults"].items():
            g = tr["degradation"]["faults"][name]
            eol = f["true_eol_cycle"]
            al_windows = f["al_windows"]
            last = f["rul"][-1] if f["rul"] else None
            first_rul = "-" if f["first_rul_cycle"] is None else str(f["first_rul_cycle"])
            last_txt = (
                f"{_f(last[1], '.0f')}/{_f(last[2], '.0f')}/{_f(last[3], '.0f')} ({eol - last[0]})"
                if last
                else "-"
            )
            lines.append(
                f"| {s['index']} | {s['type']} | {tr['unit_seed']} | {name} | {g['law']} "
                f"{g['rate']:.3g} | {g['onset']} | {eol} | {first_rul} | "
                f"{f['prognostic_horizon_cycles']:.0f} | "
                f"{_yes_none(f.get('alpha_lambda_from_lambda'))} "
                f"({al_windows[0]}/{al_windows[1]}) | "
                f"{_f(f.get('relative_accuracy_at_lambda'))} | "
                f"{_f(100 * f['interval_coverage_90'], '.0f') if f['windows_with_rul'] else '-'}"
                " % "
                f"| {last_txt} |"
            )
    return lines


def _healthy(scored: list[dict], trs: dict, by_t: dict[int, list[dict]]) -> list[str]:
    """The healthy trajectories' RUL alarms, and spurious RULs in degrading ones."""
    lines = [
        "",
        "## Healthy trajectories",
        "",
        "| # | unit | windows counted (isolated) | faults ever `degrading` (cycles) | RUL p5 "
        "below the horizon (cycles) | RUL WARN (cycles) |",
        "|---:|---:|---:|---|---|---|",
    ]
    for s in scored:
        if s["type"] != "healthy":
            continue
        deg = [
            f"{n} ({_cycles(a['degrading'])})" for n, a in s["alarms"].items() if a["degrading"]
        ]
        below = [f"{n} ({_cycles(a['below'])})" for n, a in s["alarms"].items() if a["below"]]
        warn = [f"{n} ({_cycles(a['warn'])})" for n, a in s["alarms"].items() if a["warn"]]
        ww = by_t.get(s["index"], [])
        lines.append(
            f"| {s['index']} | {trs[s['index']]['unit_seed']} | "
            f"{sum(counts(w) for w in ww)} ({sum('k' in w for w in ww)}) | "
            f"{'; '.join(deg) or 'none'} | {'; '.join(below) or 'none'} | "
            f"{'; '.join(warn) or 'none'} |"
        )
    spur = []
    for s in scored:
        if s["type"] == "healthy":
            continue
        for n, a in s["alarms"].items():
            if n not in s["faults"] and a["degrading"]:
                spur.append(
                    f"| {s['index']} | {s['type']} | {n} | {_cycles(a['degrading'])} | "
                    f"{_cycles(a['below']) or 'none'} | {_cycles(a['warn']) or 'none'} |"
                )
    if spur:
        lines += [
            "",
            "Spurious RULs in degrading trajectories (a fault that does not grow, given a RUL):",
            "",
            "| # | type | fault | cycles `degrading` | RUL p5 below the horizon | RUL WARN |",
            "|---:|---|---|---|---|---|",
            *spur,
        ]
    return lines


def _isolation(windows: list[dict], scored: list[dict], by_t: dict[int, list[dict]]) -> list[str]:
    """Isolation per window: walls, modes, and the windows the model does not explain."""
    iso = [w for w in windows if "k" in w]
    walls = [w["window_wall_s"] for w in iso]
    modes = {m: sum(1 for w in iso if w["mode"] == m) for m in ("tracked", "global", "restarted")}
    first_windows = sum(1 for w in iso if w["cycle"] == 0)
    errors = [w for w in windows if "error" in w]
    lines = [
        "",
        "## Isolation per window",
        "",
        f"{len(iso)} windows isolated ({len(errors)} refused for excitation).  Wall per window "
        f"(a restarted window counts both fits): median {_median(walls):.2f} s, p90 "
        f"{_pct(walls, 90):.2f} s, worst {max(walls) if walls else math.nan:.2f} s.  Tracked "
        f"from the previous fit: {_rate(modes['tracked'], len(iso))}; global search: "
        f"{_rate(modes['global'], len(iso))} (of which {first_windows} first windows); tracked "
        "then redone globally (tracked fit not explained): "
        f"{_rate(modes['restarted'], len(iso))}.",
        "",
        "| fault type | windows | tracked | global | restarted | not explained (final fit) | "
        "wall median (p90) s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for kind in (*TYPES, "healthy"):
        ww = [w for s in scored if s["type"] == kind for w in by_t.get(s["index"], []) if "k" in w]
        if not ww:
            continue
        wl = [w["window_wall_s"] for w in ww]
        lines.append(
            f"| {kind} | {len(ww)} | "
            + " | ".join(
                _rate(sum(w["mode"] == m for w in ww), len(ww))
                for m in ("tracked", "global", "restarted")
            )
            + f" | {_rate(sum(not w['adequacy_ok'] for w in ww), len(ww))} | "
            f"{_median(wl):.2f} ({_pct(wl, 90):.2f}) |"
        )
    sev_bins = (0.0, 0.1, 0.2, 0.3)
    lines += [
        "",
        "Windows the model does not explain (adequacy over its threshold: no estimate enters "
        "the history), by the true severity of the growing fault (multi-fault: the larger):",
        "",
        "| fault type | "
        + " | ".join(
            f"{lo:g}-{sev_bins[j + 1]:g}" if j + 1 < len(sev_bins) else f">= {lo:g}"
            for j, lo in enumerate(sev_bins)
        )
        + " |",
        "|---|" + "---:|" * len(sev_bins),
    ]
    for kind in TYPES:
        idx = [NAMES.index(n) for n in TYPE_FAULTS[kind]]
        ww = [w for s in scored if s["type"] == kind for w in by_t.get(s["index"], []) if "k" in w]
        cells = []
        for j, lo in enumerate(sev_bins):
            hi = sev_bins[j + 1] if j + 1 < len(sev_bins) else math.inf
            sel = [w for w in ww if lo <= max(abs(w["k_true"][i] - NOMINAL[i]) for i in idx) < hi]
            cells.append(_rate(sum(not w["adequacy_ok"] for w in sel), len(sel)))
        lines.append(f"| {kind} | " + " | ".join(cells) + " |")
    return lines


def _causes(
    scored: list[dict],
    trs: dict,
    by_t: dict[int, list[dict]],
    hs: dict[str, dict],
    pops: dict[str, list[dict]],
) -> list[str]:
    """Severity and RUL errors per fault type, and the alpha-lambda misses by cause."""
    lines = [
        "",
        "## Causes, measured",
        "",
        "Severity estimates of the growing fault against the truth, counted (explained) "
        "windows before the end of life, split at half of the true life; RUL errors from "
        "lambda 0.5 on (relative error of the median, (p50 - r*) / r*), and the 90 % RUL "
        "interval misses over the windows with a RUL: 'too long' = the 5th percentile above "
        "the true RUL, 'too short' = the 95th below it.",
        "",
        "| fault type (fault) | severity error, 1st half: median (p10, p90) | 2nd half: "
        "median (p10, p90) | k 90 % interval: median half-width, holds truth | RUL median "
        "rel. error from lambda 0.5: median (p10, p90) | RUL interval misses: too long / too "
        "short |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for kind in TYPES:
        for name in TYPE_FAULTS[kind]:
            acc: dict[str, list[float]] = {}
            racc: dict[str, list[float]] = {}
            for s in scored:
                if s["type"] != kind or name not in s["faults"]:
                    continue
                for key, v in _severity_errors(by_t[s["index"]], trs[s["index"]], name).items():
                    acc.setdefault(key, []).extend(v)
                for key, v in _rul_errors(
                    s["faults"][name], s["faults"][name]["true_eol_cycle"]
                ).items():
                    racc.setdefault(key, []).extend(v)
            if not acc:
                continue
            label = kind if kind == name else f"{kind} ({name})"
            e1, e2 = acc["err_early"], acc["err_late"]
            n_r = len(racc.get("all", []))
            rel = racc.get("rel", [])
            lines.append(
                f"| {label} | {_f(_median(e1), '+.3f')} ({_f(_pct(e1, 10), '+.3f')}, "
                f"{_f(_pct(e1, 90), '+.3f')}) | {_f(_median(e2), '+.3f')} "
                f"({_f(_pct(e2, 10), '+.3f')}, {_f(_pct(e2, 90), '+.3f')}) | "
                f"{_f(_median(acc['half']), '.3f')}, "
                f"{_f(100 * np.mean(acc['covered']), '.0f')} % | "
                f"{_f(_median(rel), '+.2f')} ({_f(_pct(rel, 10), '+.2f')}, "
                f"{_f(_pct(rel, 90), '+.2f')}) | "
                f"{_rate(int(sum(racc.get('long', []))), n_r)} / "
                f"{_rate(int(sum(racc.get('short', []))), n_r)} |"
            )
    a = hs["all"]
    lines += [
        "",
        "Windows from lambda 0.5 to the end of life (every fault history): "
        + ", ".join(f"{k} {_rate(hs[k]['al_windows_met'], hs[k]['al_windows'])}" for k in pops)
        + f" meet alpha-lambda.  The misses (all): {a['al_windows'] - a['al_windows_met']}: "
        f"{a['al_missed_none']} without a RUL, {a['al_missed_long']} with the median RUL above "
        f"the +/-20 % cone (too long), {a['al_missed_short']} below it (too short), "
        f"{a['al_missed_wide']} with the median inside but less than half the distribution "
        f"(too wide); {a['al_missed_small']} of the misses are at a true RUL of {SMALL_RUL} "
        "cycles or less, where the cone holds one whole cycle at most.",
    ]
    return lines


def _controls(
    scored: list[dict], hs: dict[str, dict], pops: dict[str, list[dict]], extra: dict[str, Any]
) -> list[str]:
    """The control and sensitivity scorings of the same isolations."""
    lines: list[str] = []
    variants = extra.get("variants", [])
    if variants:
        lines += [
            "",
            "## Controls and sensitivity (same isolations, scored again)",
            "",
            "The oracle control prognoses from the true k with the isolation's intervals "
            "moved onto it (and, when `rul.prognose` has one, without the severity scale: the "
            "truth has no bias to correct): what the RUL model does with unbiased estimates; "
            "the gap to the headline is the isolation's share.  'law known' makes the prior "
            "of each fault's true growth-law family nearly certain (every trajectory of a "
            "fault grows by the same family here): an upper bound of what a law prior can "
            "give, not a fair setting.  The noise-floor rows re-score the estimates with "
            "another `rul.prognose(noise_floor=)`.",
            "",
            "| scoring | alpha-lambda (trajectories): all / even / odd | alpha-lambda windows "
            "from 0.5 (all) | PH median: all / even / odd | coverage: all / even / odd | healthy "
            "WARN | spurious RUL / p5 below / WARN on faults that do not grow |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for label, hh in [("isolation estimates, rul.prognose defaults (headline)", hs)] + [
            (lab, h) for lab, _short, h, _sc in variants
        ]:
            al = hh["all"]
            lines.append(
                f"| {label} | "
                + " / ".join(_rate(hh[k]["al_traj_met"], hh[k]["trajectories"]) for k in pops)
                + f" | {_rate(al['al_windows_met'], al['al_windows'])} | "
                + " / ".join(f"{_f(100 * hh[k]['ph_share_median'], '.0f')} %" for k in pops)
                + " | "
                + " / ".join(f"{_f(100 * hh[k]['coverage'], '.0f')} %" for k in pops)
                + f" | {_rate(al['healthy_warn'], al['healthy'])} | "
                f"{_rate(al['spurious_degrading'], al['others'])} / "
                f"{_rate(al['spurious_below'], al['others'])} / "
                f"{_rate(al['spurious_warn'], al['others'])} |"
            )
        compared = [(short, sc) for _lab, short, _h, sc in variants if short]
        if compared:
            names = " / ".join(["estimates"] + [short for short, _ in compared])
            lines += [
                "",
                f"Per fault type, {names} (PH: median share of life; alpha-lambda: windows "
                "from lambda 0.5 meeting it; coverage of the 90 % RUL interval; RUL median "
                "relative error and 5-95 % width / true RUL, medians from lambda 0.5):",
                "",
                "| fault type (fault) | PH | alpha-lambda windows | coverage | RUL median rel. "
                "error | RUL 5-95 % width / true RUL |",
                "|---|---:|---:|---:|---:|---:|",
            ]
            for kind in TYPES:
                for name in TYPE_FAULTS[kind]:
                    cells = [
                        _type_cells(sc, kind, name) for sc in [scored] + [c for _, c in compared]
                    ]
                    if cells[0] is None:
                        continue
                    label = kind if kind == name else f"{kind} ({name})"
                    cols = list(zip(*cells, strict=True))
                    lines.append(
                        f"| {label} | " + " | ".join(" / ".join(col) for col in cols) + " |"
                    )
            lines += [
                "",
                "alpha-lambda windows (from lambda 0.5) met, by true RUL [cycles]:",
                "",
                "| scoring | " + " | ".join(_bin_names()) + " |",
                "|---|" + "---:|" * len(RUL_BINS),
                "| estimates | " + " | ".join(_al_by_bin(scored)) + " |",
            ]
            for short, sc in compared:
                lines.append(f"| {short} | " + " | ".join(_al_by_bin(sc)) + " |")
    return lines


def _rate(n: int, d: int) -> str:
    return f"{n}/{d} ({100.0 * n / d:.0f} %)" if d else "-"


def _f(v: float, fmt: str = ".2f") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)


def _type_cells(scored: list[dict], kind: str, name: str) -> tuple[str, ...] | None:
    """PH, alpha-lambda windows, coverage, RUL error and width of one fault type, as text."""
    fs = [s["faults"][name] for s in scored if s["type"] == kind and name in s["faults"]]
    if not fs:
        return None
    ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for f in fs]
    met = sum(f["al_windows"][0] for f in fs)
    n_al = sum(f["al_windows"][1] for f in fs)
    n = sum(f["windows_with_rul"] for f in fs)
    c = sum(f["interval_coverage_90"] * f["windows_with_rul"] for f in fs if f["windows_with_rul"])
    errs = [_rul_errors(f, f["true_eol_cycle"]) for f in fs]
    rel = [v for e in errs for v in e["rel"]]
    width = [v for e in errs for v in e["width"]]
    return (
        f"{100 * _median(ph):.0f} %",
        f"{100 * met / n_al:.0f} %" if n_al else "-",
        f"{_f(100 * c / n if n else math.nan, '.0f')} %",
        _f(_median(rel), "+.2f"),
        _f(_median(width), ".2f"),
    )


#: True-RUL bins [cycle] of the alpha-lambda window table (lower bounds, inclusive).
RUL_BINS = (1, 5, 10, 15, 20)


def _al_by_bin(scored: list[dict]) -> list[str]:
    """Share of windows from lambda 0.5 meeting alpha-lambda, per true-RUL bin (RUL_BINS)."""
    checks = [c for s in scored for f in s["faults"].values() for c in f["al_checks"]]
    out = []
    for j, lo in enumerate(RUL_BINS):
        hi = RUL_BINS[j + 1] if j + 1 < len(RUL_BINS) else math.inf
        sel = [ok for r, _p, ok in checks if lo <= r < hi]
        out.append(_rate(sum(sel), len(sel)))
    return out


def _bin_names() -> list[str]:
    names = []
    for j, lo in enumerate(RUL_BINS):
        hi = RUL_BINS[j + 1] if j + 1 < len(RUL_BINS) else None
        names.append(f"{lo}-{hi - 1}" if hi is not None else f">= {lo}")
    return names


def _yes_none(v: bool | None) -> str:
    """alpha-lambda's verdict: yes / no / 'no prediction' (None: none from lambda on)."""
    return "no prediction" if v is None else ("yes" if v else "no")


def _yes(value: float, ok: bool) -> str:
    """'yes' / 'no', '-' when there is nothing to judge (NaN)."""
    return "-" if isinstance(value, float) and math.isnan(value) else ("yes" if ok else "no")


def _count(scored: list[dict], kind: str) -> int:
    return sum(1 for s in scored if s["type"] == kind)


def _cycles(cs: list[int]) -> str:
    """A list of cycles as ranges: 3-7, 9."""
    if not cs:
        return ""
    out, start, prev = [], cs[0], cs[0]
    for c in cs[1:] + [None]:
        if c is not None and c == prev + 1:
            prev = c
            continue
        out.append(f"{start}" if start == prev else f"{start}-{prev}")
        if c is not None:
            start = prev = c
    return ", ".join(out)
