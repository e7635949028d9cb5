"""The alpha-lambda plot of the prognostics benchmark: cone and predictions per fault type.

One panel per fault history type; time and RUL as shares of each history's true life, so
every history of a type shares the true-RUL line (1 - t/EoL) and the +/-alpha cone around
it.  Each history's median RUL is a thin line (the project's model) or a dotted one (the
straight line through the last 5); the project's 90 % intervals are a light band.  The
held-out (odd) histories only, as the headline figures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from bench.prog.compare import ALPHA, LAMBDAS, Scored
from bench.prog.plan import TYPE_FAULTS, TYPES

#: The plot's file name (in docs/).
PNG = "benchmarks_prognostics_alpha_lambda.png"


def _histories(scored: list[Scored]) -> dict[str, list[tuple[Scored, str]]]:
    out: dict[str, list[tuple[Scored, str]]] = {}
    for s in scored:
        if s.kind not in TYPES or s.index % 2 == 0:
            continue
        for name in TYPE_FAULTS[s.kind]:
            label = s.kind if len(TYPE_FAULTS[s.kind]) == 1 else f"{s.kind} ({name})"
            out.setdefault(label, []).append((s, name))
    return out


def _panel(ax, model: list[tuple[Scored, str]], line: dict[int, Scored], title: str) -> None:
    x = np.linspace(0, 1, 50)
    ax.plot(x, 1 - x, "k-", lw=1)
    ax.fill_between(x, (1 - ALPHA) * (1 - x), (1 + ALPHA) * (1 - x), color="0.85")
    for lam in LAMBDAS:
        ax.axvline(lam, color="0.6", lw=0.6, ls="--")
    for s, name in model:
        eol = s.eol[name]
        pts = [p for p in s.points[name] if p.cycle < eol and p.degrading]
        if pts:
            t = np.array([p.cycle for p in pts]) / eol
            ax.fill_between(
                t, [p.p5 / eol for p in pts], [p.p95 / eol for p in pts], color="C0", alpha=0.08
            )
            ax.plot(t, [p.p50 / eol for p in pts], "C0-", lw=0.8)
        base = [p for p in line[s.index].points[name] if p.cycle < eol and p.degrading]
        if base:
            ax.plot([p.cycle / eol for p in base], [p.p50 / eol for p in base], "C3:", lw=0.7)
    ax.set_title(title, fontsize=9)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.6)


def alpha_lambda(model: list[Scored], line: list[Scored], docs: Path) -> list[str]:
    """Draw the plot into `docs`; the file names written."""
    groups = _histories(model)
    by_index = {s.index: s for s in line}
    # a Figure of its own (Agg when saved), not pyplot: importing this module leaves
    # matplotlib's backend and pyplot's figures as they were
    fig = Figure(figsize=(11, 6.5))
    axes = fig.subplots(2, 3, sharex=True, sharey=True)
    for ax, (label, hs) in zip(axes.ravel(), sorted(groups.items()), strict=False):
        _panel(ax, hs, by_index, f"{label} ({len(hs)} held-out histories)")
    for ax in axes[-1]:
        ax.set_xlabel("time / true end of life")
    for ax in axes[:, 0]:
        ax.set_ylabel("RUL / true end of life")
    fig.suptitle(
        "alpha-lambda: +/-20 % cone (grey), true RUL (black); ema_phm median RUL (blue, band "
        "5-95 %), straight line through the last 5 (red dotted)",
        fontsize=9,
    )
    fig.tight_layout()
    out = docs / PNG
    tmp = out.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    tmp.replace(out)
    return [PNG]
