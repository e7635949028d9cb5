"""The `ema-phm prognose --plot` figure: k with intervals over cycles, and the RUL cone."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..domain.faults import NAMES
from ..prognostics.rul import PREDICTED


def plot_prognosis(
    replayed: Sequence[Any],
    eol: Mapping[str, int | None],
    path: str | Path,
    *,
    alpha: float = 0.2,
) -> Path:
    """Top: k1..k6 and k8 per cycle with their intervals, the truth dashed.

    Bottom: per fault with a RUL or a known end of life, the predicted RUL (median, 5-95 %
    band) at each cycle against the true RUL t_EoL - t and its (1 +/- alpha) cone.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    done = [r for r in replayed if not r.skipped]
    fig, (ax_k, ax_r) = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    shown = [*PREDICTED, 7]
    for n, i in enumerate(shown):
        color = colors[n % len(colors)]
        if done:
            c = np.array([r.cycle for r in done], dtype=float)
            k = np.array([r.k[i] for r in done])
            lo = np.array([r.k_low[i] for r in done])
            hi = np.array([r.k_high[i] for r in done])
            ax_k.errorbar(
                c,
                k,
                yerr=[k - lo, hi - k],
                fmt="o",
                ms=3,
                color=color,
                label=f"k{i + 1} {NAMES[i]}",
            )
        truth = [(r.cycle, r.k_true[i]) for r in replayed if r.k_true is not None]
        if truth:
            tc, tk = zip(*truth)
            ax_k.plot(tc, tk, "--", color=color, lw=1)
    ax_k.set_ylabel("k (estimate, 90 % interval; truth dashed)")
    ax_k.set_ylim(-0.02, 1.02)
    ax_k.legend(fontsize=7, ncol=4, loc="upper left")
    drawn = False
    for n, i in enumerate(PREDICTED):
        name = NAMES[i]
        color = colors[n % len(colors)]
        pts = [
            (r.cycle, r.prognosis.fault(name).rul_cycles)
            for r in done
            if r.prognosis.fault(name).status == "degrading"
        ]
        t_eol = eol.get(name)
        if not pts and t_eol is None:
            continue
        drawn = True
        if pts:
            c = np.array([p[0] for p in pts], dtype=float)
            p50 = np.array([p[1].p50 for p in pts])
            p5 = np.array([p[1].p5 for p in pts])
            p95 = np.array([p[1].p95 for p in pts])
            top = (
                np.nanmax(np.where(np.isfinite(p95), p95, np.nan)) if np.isfinite(p95).any() else 1
            )
            ax_r.fill_between(
                c, p5, np.where(np.isfinite(p95), p95, 2 * top), color=color, alpha=0.2
            )
            ax_r.plot(c, p50, "o-", ms=3, color=color, label=f"{name}: RUL median, 5-95 %")
        if t_eol is not None and done:
            c = np.arange(min(r.cycle for r in done), t_eol + 1, dtype=float)
            r_true = t_eol - c
            ax_r.plot(c, r_true, "k-", lw=1, label=f"{name}: true RUL")
            ax_r.fill_between(c, (1 - alpha) * r_true, (1 + alpha) * r_true, color="k", alpha=0.07)
            ax_r.annotate(f"{name} true EoL {t_eol}", (t_eol, 0), fontsize=7, rotation=90)
    if drawn:
        ax_r.legend(fontsize=7, loc="upper right")
    else:
        ax_r.text(
            0.5,
            0.5,
            "no RUL predicted, no known end of life",
            ha="center",
            transform=ax_r.transAxes,
        )
    ax_r.set_ylim(bottom=0)
    ax_r.set_xlabel("cycle")
    ax_r.set_ylabel(f"RUL [cycles] (truth black, +/-{alpha:g} cone)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
