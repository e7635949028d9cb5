"""The `ema-phm prognose --plot` figure: k with intervals over cycles, and the RUL cone."""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..domain.faults import LABELS, NAMES, PREDICTED, SEVERITY_INDICES


def plot_prognosis(
    replayed: Sequence[Any],
    eol: Mapping[str, int | None],
    path: str | Path,
    *,
    alpha: float = 0.2,
) -> Path:
    """Top: every fault with a severity (not a phase) per cycle with its interval, truth dashed.

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
    _plot_k(ax_k, replayed, done, colors)
    _plot_rul(ax_r, done, eol, colors, alpha)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _plot_k(ax: Any, replayed: Sequence[Any], done: Sequence[Any], colors: list[str]) -> None:
    """Each severity entry of k per assessed cycle with its interval; its truth dashed."""
    for n, i in enumerate(SEVERITY_INDICES):
        color = colors[n % len(colors)]
        if done:
            c = np.array([r.cycle for r in done], dtype=float)
            k = np.array([r.k[i] for r in done])
            lo = np.array([r.k_low[i] for r in done])
            hi = np.array([r.k_high[i] for r in done])
            ax.errorbar(
                c,
                k,
                yerr=[k - lo, hi - k],
                fmt="o",
                ms=3,
                color=color,
                label=f"{LABELS[i]} {NAMES[i]}",
            )
        truth = [(r.cycle, r.k_true[i]) for r in replayed if r.k_true is not None]
        if truth:
            tc, tk = zip(*truth, strict=True)
            ax.plot(tc, tk, "--", color=color, lw=1)
    ax.set_ylabel("k (estimate, 90 % interval; truth dashed)")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7, ncol=4, loc="upper left")


def _plot_rul(
    ax: Any, done: Sequence[Any], eol: Mapping[str, int | None], colors: list[str], alpha: float
) -> None:
    """Predicted RUL band per fault with a RUL, against the true RUL and its cone."""
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
            _rul_band(ax, pts, name, color)
        if t_eol is not None and done:
            _true_rul(ax, min(r.cycle for r in done), t_eol, name, alpha)
    if drawn:
        ax.legend(fontsize=7, loc="upper right")
    else:
        ax.text(
            0.5,
            0.5,
            "no RUL predicted, no known end of life",
            ha="center",
            transform=ax.transAxes,
        )
    ax.set_ylim(bottom=0)
    ax.set_xlabel("cycle")
    ax.set_ylabel(f"RUL [cycles] (truth black, +/-{alpha:g} cone)")


def _rul_band(ax: Any, pts: Sequence[tuple[int, Any]], name: str, color: str) -> None:
    """The median RUL at each cycle and its 5-95 % band (an infinite p95 drawn above the top)."""
    c = np.array([p[0] for p in pts], dtype=float)
    p50 = np.array([p[1].p50 for p in pts])
    p5 = np.array([p[1].p5 for p in pts])
    p95 = np.array([p[1].p95 for p in pts])
    top = np.nanmax(np.where(np.isfinite(p95), p95, np.nan)) if np.isfinite(p95).any() else 1
    ax.fill_between(c, p5, np.where(np.isfinite(p95), p95, 2 * top), color=color, alpha=0.2)
    ax.plot(c, p50, "o-", ms=3, color=color, label=f"{name}: RUL median, 5-95 %")


def _true_rul(ax: Any, first: int, t_eol: int, name: str, alpha: float) -> None:
    """The true RUL t_EoL - t from the first assessed cycle, its (1 +/- alpha) cone, the EoL."""
    c = np.arange(first, t_eol + 1, dtype=float)
    r_true = t_eol - c
    ax.plot(c, r_true, "k-", lw=1, label=f"{name}: true RUL")
    ax.fill_between(c, (1 - alpha) * r_true, (1 + alpha) * r_true, color="k", alpha=0.07)
    ax.annotate(f"{name} true EoL {t_eol}", (t_eol, 0), fontsize=7, rotation=90)
