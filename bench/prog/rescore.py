"""The prognostics benchmark's --score phase: score the stored rows, then the controls.

Reads only the raw rows (docs/bench_prognostics.json), so changing rul.py / trend.py and
re-running ``--score`` re-scores the same isolations.
"""

from __future__ import annotations

import inspect
import subprocess
import time
from pathlib import Path
from typing import Any

from harness import ROOT, halves, read_rows

from ema_phm.domain.faults import NAMES
from ema_phm.prognostics.rul import PREDICTED, prognose
from prog.baseline import LAST_N, straight_line
from prog.plan import LAW
from prog.report import KEEP_MARKER, report
from prog.score import headline, score_all

Variant = tuple[str, str, dict[str, dict], list[dict]]


def _heads(sc: list[dict], trs: dict[int, dict]) -> dict[str, dict]:
    """The headline figures of all, even- and odd-numbered trajectories."""
    return {k: headline(v, trs) for k, v in halves(sc).items()}


def variants(data: dict, trs: dict[int, dict], sweep: list[float]) -> list[Variant]:
    """The control scorings: (label, short name or '', headlines, scored trajectories)."""
    out: list[Variant] = []
    params = inspect.signature(prognose).parameters
    # the truth has no bias to correct: the oracle projects to the threshold itself
    unbiased = (
        {"severity_scale": {NAMES[i]: (0.0, 0.0) for i in PREDICTED}}
        if "severity_scale" in params
        else {}
    )
    sc = score_all(data, unbiased, oracle=True)
    label = "oracle: true k, the isolation's intervals moved onto it"
    label += ", no severity scale" if unbiased else ""
    out.append((label, "oracle", _heads(sc, trs), sc))
    if "law_priors" in params:
        known = {
            name: {
                "none": 0.5,
                law: 0.499,
                ("exponential" if law == "linear" else "linear"): 0.001,
            }
            for name, law in LAW.items()
        }
        sc = score_all(data, {"law_priors": known})
        label = "estimates, growth law known (law_priors: the true family 0.499, the other 0.001)"
        out.append((label, "law known", _heads(sc, trs), sc))
    sc = score_all(data, predict=straight_line)
    label = (
        f"baseline: a straight line through the last {LAST_N} severity estimates "
        "(point RUL, no interval: its coverage means nothing)"
    )
    out.append((label, "line", _heads(sc, trs), sc))
    sc = score_all(data, every_window=True)
    label = (
        "every isolated window counted, explained or not "
        "(as `ema-phm prognose --count-unexplained`)"
    )
    out.append((label, "", _heads(sc, trs), sc))
    if sweep and "noise_floor" in params:
        for floor in sweep:
            sc = score_all(data, {"noise_floor": floor})
            out.append((f"estimates, noise_floor {floor:g}", "", _heads(sc, trs), sc))
    return out


def run_score(raw: Path, md: Path, sweep: list[float]) -> None:
    """Score the stored rows and the controls; write the report, keeping its analysis."""
    data = read_rows(raw)
    trs = {tr["index"]: tr for tr in data["plan"]}
    t0 = time.perf_counter()
    scored = score_all(data)
    score_s = time.perf_counter() - t0
    extra: dict[str, Any] = {"score_s": score_s, "variants": [], "rul_version": _rul_version()}
    extra["variants"] = variants(data, trs, sweep)
    text = report(data, scored, extra)
    if md.exists():  # the hand-written analysis below the marker survives a re-score
        old = md.read_text()
        if KEEP_MARKER in old:
            text += "\n" + KEEP_MARKER + old.split(KEEP_MARKER, 1)[1]
    md.write_text(text)
    print(f"scored {len(scored)} trajectories in {score_s:.1f} s; wrote {md}")


def _rul_version() -> str:
    """The last commit of rul.py / trend.py, and whether they differ from it."""
    files = ["ema_phm/prognostics/rul.py", "ema_phm/prognostics/trend.py"]
    try:
        commit = subprocess.run(
            ["git", "log", "-1", "--format=%h", "--", *files],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", *files],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "an unknown commit (no git)"
    return f"commit {commit}" + (" with uncommitted changes" if dirty else "")
