"""Figures (matplotlib, headless).  Imported only when a plot is asked for."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .telemetry import Window


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


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
