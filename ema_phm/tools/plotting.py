"""Figures (matplotlib, headless).  Imported only when a plot is asked for."""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..domain.faults import LABELS, N_K
from ..domain.window import Window
from ..errors import ConfigError
from ..model.belief import MonitorBelief

if TYPE_CHECKING:
    from ..diagnosis.isolation import IsolationResult


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def writable_formats() -> tuple[str, ...]:
    """File suffixes (without the dot) matplotlib's savefig knows how to write."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted(FigureCanvasBase.get_supported_filetypes()))


def check_plot_path(path: Path, *, label: str = "plot file") -> Path:
    """`path` if a figure can be saved there, else ConfigError naming it and the problem.

    Meant to run before long work: the suffix must be a format matplotlib writes and
    the folder must exist and accept a new file (tried for real, so it holds for root too).
    """
    suffix = path.suffix.lower().lstrip(".")
    formats = writable_formats()
    if suffix not in formats:
        raise ConfigError(
            f"{label} {str(path)!r}: matplotlib cannot write "
            f"{path.suffix or 'files without a suffix'!r}; "
            f"use .png or one of {', '.join('.' + f for f in formats)}"
        ) from None
    folder = path.parent
    if not folder.is_dir():
        raise ConfigError(
            f"{label} {str(path)!r}: folder {str(folder)!r} does not exist or is not a folder"
        ) from None
    if path.is_dir():
        raise ConfigError(f"{label} {str(path)!r} is a folder, not a file") from None
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".ema-phm-plot-check-"):
            pass
    except OSError as exc:
        raise ConfigError(
            f"{label} {str(path)!r}: cannot write in folder {str(folder)!r} "
            f"({os.strerror(exc.errno) if exc.errno else exc})"
        ) from None
    return path


def plot_window(window: Window, path: Path, *, lf: np.ndarray | None = None) -> Path:
    """Command/position and I_3eq of a window; with `lf`, the monitor's traces over it."""
    plt = _plt()
    fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    ax[0].plot(window.t, window.command, label="command", lw=1)
    ax[0].plot(window.t, window.theta_u, label="user position (HF)", lw=1)
    if lf is not None:
        ax[0].plot(window.t, lf[:, 1], "--", label="user position (LF)", lw=1)
    ax[0].set_ylabel("rad")
    ax[0].legend(loc="upper left")
    ax[1].plot(window.t, window.i3eq, label="I_3eq (HF)", lw=1)
    if lf is not None:
        ax[1].plot(window.t, lf[:, 0], "--", label="I (LF)", lw=1)
    ax[1].set_ylabel("A")
    ax[1].set_xlabel("s")
    ax[1].legend(loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _fitted_lf(
    window: Window, result: IsolationResult, belief: MonitorBelief | None
) -> np.ndarray:
    """The monitor model's traces at the fitted k (and fitted nuisances, if any).

    The model the fit used: following the recorded loop or not (`fitness_name`), with the
    nuisances the window's load channel calls for (the unmeasured load, or the current
    offset where the load is measured: `nuisance.searched`).
    """
    from ..diagnosis.fitness import WEIGHTINGS, Fitness

    name = getattr(result, "fitness_name", "thesis")
    weights = name if name in WEIGHTINGS else "thesis"
    fit = Fitness(window, weights=weights, belief=belief, nuisance=True)
    nu = getattr(result, "nuisance", {}) or {}
    if fit.nuisances and all(n.name in nu for n in fit.nuisances):  # part of the fit
        values = np.array([[nu[n.name] for n in fit.nuisances]])
        return fit.predict(result.k[None], values)[0]
    return fit.model.simulate(result.k)


def _k_bars(ax: Any, result: IsolationResult) -> None:
    """Fitted k (with its 90 % interval when known) beside the true k, one pair per fault."""
    x = np.arange(N_K)
    iv = getattr(result, "k_interval", None)
    if iv is None:
        ax.bar(x - 0.2, result.k, 0.4, label="fitted")
    else:  # the 90 % interval as an error bar around the fitted value
        err = np.abs(np.vstack([result.k - iv[:, 0], iv[:, 1] - result.k]))
        ax.bar(x - 0.2, result.k, 0.4, yerr=err, capsize=3, label="fitted, 90 % interval")
    if result.k_true is not None:
        ax.bar(x + 0.2, result.k_true, 0.4, label="true")
    ax.set_xticks(x, list(LABELS))
    ax.set_ylim(0, 1)
    title = "fault vector" + (
        "" if result.percent_err is None else f"  (%err {result.percent_err:.2f})"
    )
    ax.set_title(title)
    ax.legend()


def _convergence(ax: Any, result: IsolationResult) -> None:
    """Best fitness against evaluations, log scale."""
    if result.history:
        ev, f = zip(*result.history, strict=True)
        ax.semilogy(ev, f)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best fitness")
    ax.set_title("convergence")


def plot_isolation(
    window: Window, result: IsolationResult, path: Path, *, belief: MonitorBelief | None = None
) -> Path:
    """Plot HF vs fitted LF current and position, k bars (fitted with 90 % intervals, true).

    The LF is the monitor model of `belief` (default MonitorBelief.default()).
    """
    plt = _plt()
    lf = _fitted_lf(window, result, belief)
    fig = plt.figure(figsize=(12, 8))
    gs = fig.add_gridspec(3, 2)
    a = fig.add_subplot(gs[0, :])
    a.plot(window.t, window.i3eq, lw=1, label="I_3eq recorded (HF)")
    a.plot(window.t, lf[:, 0], "--", lw=1, label="I fitted monitor (LF)")
    a.set_ylabel("A")
    a.legend(loc="upper left")
    b = fig.add_subplot(gs[1, :], sharex=a)
    b.plot(window.t, window.theta_u - window.command, lw=1, label="recorded position - command")
    b.plot(
        window.t, lf[:, 1] - window.command, "--", lw=1, label="fitted monitor position - command"
    )
    b.set_ylabel("rad")
    b.set_xlabel("s")
    b.legend(loc="upper left")
    _k_bars(fig.add_subplot(gs[2, 0]), result)
    _convergence(fig.add_subplot(gs[2, 1]), result)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
