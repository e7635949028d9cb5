"""A window in a rig's forms, imported back, fitted and scored beside the native window.

What `bench_import` (our HF's drawn units) and `bench_external --import-forms` (motulator's
drive) share: the forms and channel subsets a rig logs (`VARIANTS`), writing a window in one
and importing it (`imported`), the fit as `ema-phm isolate` runs it (`fit`), and the scoring
and report tables (`equivalence`, `per_form`, `speed` and their lines).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import pool, rig_forms, stamp, write_rows
from ema_phm.diagnosis import health
from ema_phm.diagnosis.isolation import isolate
from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import NAMES, percent_err
from ema_phm.domain.window import Window
from ema_phm.errors import ExcitationError
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.importer import import_recordings
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.telemetry.bags import read_window

#: Seeds of the native and bag fits (the seed-to-seed spread); the other forms use the first.
SEEDS = (0, 1, 2)
PHASE = NAMES.index("eccentricity_phase")


def _csv_map(change: dict[str, Any]) -> dict[str, Any]:
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = {"by": "length", "seconds": 2.0}
    m["channels"].update(change)
    return m


BAG_MAP = {**copy.deepcopy(rig_forms.JOINT_STATES_MAP), "windows": {"by": "length"}}
#: form -> (how the source is written, the map that reads it)
VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "bag": ("bag", BAG_MAP),
    "csv": ("csv", _csv_map({})),
    "parquet": ("parquet", _csv_map({})),
    "no_encoder": (
        "csv",
        _csv_map(
            {"theta_m": {"derive": "through_gear"}, "omega_m": {"derive": "rate_of_theta_m"}}
        ),
    ),
    "no_speed": ("csv", _csv_map({"omega_m": {"derive": "rate_of_theta_m"}})),
    "no_temperature": ("csv", _csv_map({"temperature": "unknown"})),
    "iq_1khz": ("csv_iq_1khz", _csv_map({})),
    "phases_20khz": (
        "csv_phases",
        _csv_map(
            {"i3eq": {"derive": "park_q", "phases": [{"column": c} for c in ("ia", "ib", "ic")]}}
        ),
    ),
}
#: The rate a rig logs its phase currents at (the `phases_20khz` form's own HF run).
PHASE_RATE = 20_000.0

Fast = tuple[Window, np.ndarray]  # a window simulated at PHASE_RATE, and its phase currents


def _write_source(folder: Path, form: str, w: Window, fast: Fast | None) -> Path:
    """The window as a rig logs it in `form` (`csv_phases`: the fast run, phases for I_3eq)."""
    if form == "csv_phases":
        assert fast is not None
        window, phases = fast
        cols = {name: phases[:, i] for i, name in enumerate(("ia", "ib", "ic"))}
        return rig_forms.table(folder / "log.csv", window.without_truth(), cols)
    if form == "bag":
        return rig_forms.joint_states_bag(folder / "log", w)
    if form == "csv_iq_1khz":
        thinned = w.i3eq.copy()
        thinned[1::2] = np.nan  # a 1 kHz current beside 2 kHz positions: empty cells
        return rig_forms.table(folder / "log.csv", dataclasses.replace(w, i3eq=thinned))
    return rig_forms.table(folder / f"log.{form}", w)


def imported(
    form: str,
    cmap_data: dict[str, Any],
    w: Window,
    fast: Fast | None,
    actuator: ActuatorParameters | None = None,
) -> tuple[Window, dict[str, float]]:
    """The window written in `form`, imported back; and the import's time and source size.

    `actuator`: whose acquisition the import puts the log on (default: the thesis actuator).
    """
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        src = _write_source(folder, form, w.without_truth(), fast)
        size = sum(p.stat().st_size for p in [src, *src.rglob("*")] if p.is_file())
        cmap = parse_channel_map(cmap_data, where=form)
        t0 = time.perf_counter()
        act = actuator or ActuatorParameters.default()
        report = import_recordings([src], cmap, act, folder / "out")
        wall = time.perf_counter() - t0
        (path,) = report.written
        got = read_window(path)
    return dataclasses.replace(got, k_true=w.k_true), {"import_s": wall, "bytes": size}


def fit(w: Window, seed: int, belief: MonitorBelief | None = None) -> dict[str, Any]:
    """`ema-phm isolate` of `w` (`belief`; None: the packaged one): the row's fields."""
    try:
        res = isolate(w, **FitSettings(seed=seed).isolate_options(belief))
    except ExcitationError as exc:
        return {"error": str(exc)}
    verdict = health.assess_isolation(res)
    return {
        "k": [float(v) for v in res.k],
        "percent_err": float(res.percent_err),
        "explained": bool(res.adequacy.ok),
        "level": int(verdict.level),
        "dominant": int(verdict.dominant),
        "unseen": sorted(int(i) for i in res.unseen),
        "wall_s": float(res.wall_s),
    }


def _gap(a: list[float], b: list[float]) -> float:
    """Largest |a - b| over the entries that are amounts (the phase left out)."""
    d = np.abs(np.asarray(a) - np.asarray(b))
    d[PHASE] = 0.0
    return float(d.max())


def equivalence(rows: list[dict[str, Any]]) -> dict[str, list[float]]:
    """Per window and seed: bag vs native at that seed; native seed s vs seed s'."""
    fits: dict[tuple[int, str, str, int], list[float]] = {
        (r["index"], r["window"], r["form"], r["seed"]): r["k"] for r in rows if "k" in r
    }
    imp, spread = [], []
    for idx, win, form, s in fits:
        if form != "native":
            continue
        if (idx, win, "bag", s) in fits:
            imp.append(_gap(fits[idx, win, "bag", s], fits[idx, win, "native", s]))
        for s2 in SEEDS:
            if s2 > s and (idx, win, "native", s2) in fits:
                spread.append(_gap(fits[idx, win, "native", s2], fits[idx, win, "native", s]))
    return {"import": imp, "seed": spread}


def _seen_err(r: dict[str, Any]) -> float:
    """%err (eq. 6.4) over the entries the recording shows."""
    k, kt = np.array(r["k"]), np.array(r["k_true"])
    k[r["unseen"]] = kt[r["unseen"]]  # an entry held unseen adds no error
    return float(percent_err(k, kt))


def per_form(
    rows: list[dict[str, Any]], forms: tuple[str, ...] = ("native", *VARIANTS)
) -> dict[str, dict[str, Any]]:
    """Per form (seed 0): %err, false alarms, named, withheld, claims on unseen faults."""
    out = {}
    for form in forms:
        rs = [r for r in rows if r["form"] == form and r["seed"] == 0 and "k" in r]
        healthy = [r for r in rs if r["window"] == "healthy"]
        faulty = [r for r in rs if r["window"] != "healthy"]
        claimed = [r for r in rs if r["explained"] and r["level"] >= health.WARN]
        out[form] = {
            "n": len(rs),
            "err": [r["percent_err"] for r in rs],
            "seen_err": [_seen_err(r) for r in rs],
            "false_alarms": (sum(r in claimed for r in healthy), len(healthy)),
            "named": (
                sum(r in claimed and NAMES[r["dominant"]] == r["window"] for r in faulty),
                len(faulty),
            ),
            "withheld": (sum(not r["explained"] for r in rs), len(rs)),
            "unseen_claims": sum(r["dominant"] in r["unseen"] for r in claimed),
            "errors": sum(1 for r in rows if r["form"] == form and "error" in r),
        }
    return out


def speed(
    rows: list[dict[str, Any]], forms: tuple[str, ...] = tuple(VARIANTS)
) -> dict[str, tuple[float, float]]:
    """Per form: (recordings per second, source MB per second) of the imports."""
    out = {}
    for form in forms:
        rs = [r for r in rows if r["form"] == form and r["seed"] == 0 and "bytes" in r]
        wall = sum(r["import_s"] for r in rs) if rs else 0.0
        if wall > 0:
            out[form] = (len(rs) / wall, sum(r["bytes"] for r in rs) / 1e6 / wall)
    return out


# ----------------------------------------------------------------------------- report


def _pct(values: list[float], q: float) -> float:
    v = [x for x in values if math.isfinite(x)]
    return float(np.percentile(v, q)) if v else math.nan


def _share(pair: tuple[int, int]) -> str:
    n, d = pair
    return "-" if d == 0 else f"{n}/{d}"


def equivalence_lines(eq: dict[str, list[float]]) -> list[str]:
    imp, seed = eq["import"], eq["seed"]
    within = sum(d <= _pct(seed, 90) for d in imp)
    return [
        "## Imported against native",
        "",
        "The largest k difference (amounts; the phase left out) between a window fitted as",
        "ema_phm recorded it and the same window written as a rig's bag and imported, at the",
        "same seed, beside the difference between two seeds of the native fit:",
        "",
        "| | windows x seeds | median | 90th percentile | largest |",
        "|---|---:|---:|---:|---:|",
        f"| bag vs native, same seed | {len(imp)} | {_pct(imp, 50):.4f} | {_pct(imp, 90):.4f} "
        f"| {max(imp, default=math.nan):.4f} |",
        f"| native seed vs native seed | {len(seed)} | {_pct(seed, 50):.4f} | "
        f"{_pct(seed, 90):.4f} | {max(seed, default=math.nan):.4f} |",
        "",
        f"{within} of {len(imp)} imported fits are within the native fits' 90th-percentile "
        "seed-to-seed difference.",
        "",
    ]


def form_lines(forms: dict[str, dict[str, Any]]) -> list[str]:
    lines = [
        "## Forms and channel subsets (seed 0)",
        "",
        "| form | fits | median %err | median %err, entries shown | false alarms (healthy) "
        "| fault named | withheld | claims on an unseen fault | fit errors |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for form, f in forms.items():
        lines.append(
            f"| {form} | {f['n']} | {_pct(f['err'], 50):.2f} | {_pct(f['seen_err'], 50):.2f} | "
            f"{_share(f['false_alarms'])} | {_share(f['named'])} | {_share(f['withheld'])} | "
            f"{f['unseen_claims']} | {f['errors']} |"
        )
    return [*lines, ""]


def speed_lines(rows: list[dict[str, Any]], forms: tuple[str, ...] = tuple(VARIANTS)) -> list[str]:
    """The report's import-speed table (`speed`)."""
    return [
        "## Import speed (one process, the write of the source not counted)",
        "",
        "| form | recordings / s | source MB / s |",
        "|---|---:|---:|",
        *(f"| {f} | {r:.1f} | {mb:.2f} |" for f, (r, mb) in speed(rows, forms).items()),
        "",
    ]


def run_jobs(
    todo: list[Any], job: Any, warm: Any, *, jobs: int, raw: Path, partial: dict[str, Any]
) -> dict[str, Any]:
    """`job` of each item of `todo` on `jobs` workers (`warm` first in each), rows saved.

    `partial` (with ``command``) goes into the saved rows, then its stamp and the wall time.
    """
    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with pool(max(1, jobs), warm) as p:
        for got in p.imap_unordered(job, todo):
            rows.extend(got)
            write_rows(raw, {**partial, "rows": rows})
    return {
        **partial,
        **stamp(partial["command"]),
        "total_s": time.perf_counter() - t0,
        "rows": rows,
    }
