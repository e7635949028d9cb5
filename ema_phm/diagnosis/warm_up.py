"""Warm-up: pay numba's compile / cache load before the first real window, not during it.

The LF kernels are compiled (or loaded from numba's cache) on their first call, which
makes the first fit seconds longer, long enough to skip windows (the warm-up itself took
0.5 s with a warm cache in docs/benchmarks_tracking.md).  `warm_up` runs the paths
`HealthMonitor._isolate` takes -- the excitation measure, a global isolation with
nuisances and intervals, and a tracked isolation from its row -- on a short synthetic
window, so those calls are cheap when telemetry comes.
No rclpy.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from ..domain.faults import NOMINAL
from ..domain.window import CHANNELS, COLUMN, Window
from ..model.belief import MonitorBelief
from ..model.monitor_model import MonitorModel
from . import excitation
from .fitness import PREDICTED_CHANNELS
from .isolation import isolate
from .isolation_settings import IsolationSettings

#: Length of the synthetic window [s]: 201 samples at 2 kHz, past window.MIN_SAMPLES.
WINDOW_S = 0.1
#: Evaluations of the warm-up's global search: two generations of the presets' DE.
GLOBAL_EVALUATIONS = 80


def synthetic_window(belief: MonitorBelief) -> Window:
    """A short healthy window the monitor model of `belief` predicts for a small sine.

    Sampled at the belief's acquisition rate, with a measured load (0) and temperature
    (the belief's reference), as ema_node publishes them.
    """
    fs = float(belief["acquisition"]["sample_rate"])
    t = np.arange(int(round(WINDOW_S * fs)) + 1, dtype=np.float64) / fs
    command = 0.03 * np.sin(2.0 * np.pi * 5.0 * t)
    temperature = float(belief["monitor"]["reference_temperature_c"])
    rows = np.zeros((t.size, len(CHANNELS)))
    rows[:, COLUMN["t"]] = t
    rows[:, COLUMN["command"]] = command
    rows[:, COLUMN["temperature"]] = temperature
    predicted = MonitorModel(Window.from_matrix(rows), belief=belief).simulate(NOMINAL)
    for j, channel in enumerate(PREDICTED_CHANNELS):
        rows[:, COLUMN[channel]] = predicted[:, j]
    gear_ratio = float(belief["mechanics"]["gear_ratio"])
    rows[:, COLUMN["theta_m"]] = rows[:, COLUMN["theta_u"]] / gear_ratio
    return Window.from_matrix(rows)


def warm_up(
    settings: IsolationSettings,
    *,
    belief: MonitorBelief | None = None,
    cancel: threading.Event | None = None,
) -> float:
    """Run every compiled path a monitor's fit uses once; return the wall time [s].

    `settings` and `belief` as the monitor's first fit will use them (belief None: the
    packaged one).  Raises IsolationCancelled when `cancel` is set meanwhile.
    """
    t0 = time.perf_counter()
    model_belief = belief or MonitorBelief.default()
    window = synthetic_window(model_belief)
    excitation.measure(window, belief=belief)  # a window this short may not pass: measured only
    # the monitor's own options, but a short global search and no excitation check
    common = {
        **settings.isolate_options(belief, cancel=cancel),
        "max_evaluations": GLOBAL_EVALUATIONS,
        "check_excitation": False,
    }
    first = isolate(window, **common)
    isolate(window, **{**common, "start": first.row})
    return time.perf_counter() - t0
