"""Multi-window bags: one window per operating cycle, with the true k of every window.

`write_cycle_bag` writes what `ema-phm simulate --windows N --degradation FILE` produces:
a rosbag2 MCAP bag in the layout of `bags.write_window` (README, "Topics and bag layout")
holding N consecutive windows as ema_node streams them:

- ``/ema/run_info`` once, first: the run's JSON (sample rate, ``samples_per_window``,
  ``window_duration``, ``windows`` = N, ``cycle_hours``, the ``degradation`` description,
  command, load, seed, sensors, unit, ...);
- ``/ema/ground_truth`` at the start of every window (log time = its first sample's): the
  k that cycle runs with;
- ``/ema/telemetry`` in batches of ``samples_per_message`` samples: samples 0 .. N*S
  (S samples per window), continuous, consecutive windows sharing their boundary sample.

`read_cycle_windows` reads such a bag back as one `Window` per cycle (samples cS .. (c+1)S,
``k_true`` = the ground truth logged at or before its first sample, ``meta`` = the run_info
plus ``cycle`` = c).  A bag a monitor node recorded (it holds ``/ema/window``) is read as
its fitted windows instead (`window_assembler.read_fitted_windows`), each window's cycle
the one the monitor gave it (windows cut by excitation) or else its start time over the
window duration.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..domain.window import TIME_COLUMN, Window
from ..errors import BagError, WindowError
from .bag_codec import EPOCH_OFFSET_NS, ROSBAGS_CLASSES, string_msg
from .bag_reader import ground_truth, read_messages, run_info_object, telemetry_rows
from .bag_recorder import new_bag
from .window_assembler import read_fitted_windows
from .wire import (
    FLOAT64_MULTIARRAY,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    STRING,
    TELEMETRY_TOPIC,
    WINDOW_TOPIC,
    encode_ground_truth,
    encode_run_info,
    encode_telemetry,
    to_message,
)

#: run_info keys a multi-window bag must hold to be cut into windows.
REQUIRED_RUN_INFO: tuple[str, ...] = ("sample_rate", "samples_per_window")


def log_time_ns(t: float) -> int:
    """Log time of a sample time, as `bags.write_window` stamps it."""
    return min(2**63 - 1, EPOCH_OFFSET_NS + round(float(t) * 1e9))


def write_cycle_bag(
    path: str | Path,
    cycles: Iterable[tuple[int, np.ndarray, np.ndarray]],
    run_info: Mapping[str, Any],
    *,
    samples_per_message: int = 100,
) -> int:
    """Write the cycles of `degradation.simulate_cycles` as a new bag; return how many.

    `cycles` yields (cycle, k, new rows) in cycle order (cycle 0 first).  The bag is removed
    again when writing fails or is interrupted.
    """
    path = Path(path)
    if samples_per_message < 1:
        raise BagError(f"samples_per_message must be >= 1, got {samples_per_message}")
    try:
        info = encode_run_info(dict(run_info))
    except (TypeError, ValueError) as exc:
        raise WindowError(f"cannot write {path}: run_info is not JSON ({exc})") from None
    if path.exists() or path.is_symlink():
        raise BagError(f"refusing to overwrite {path}: it already exists")
    topics = {
        RUN_INFO_TOPIC: STRING,
        GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY,
        TELEMETRY_TOPIC: FLOAT64_MULTIARRAY,
    }
    written = 0
    with new_bag(path, topics) as rec:
        last_t = 0.0
        for cycle, k, given in cycles:
            if cycle != written:
                raise WindowError(f"cannot write {path}: cycle {cycle} follows {written - 1}")
            rows = np.asarray(given, dtype=np.float64)
            if rows.ndim != 2 or rows.shape[0] == 0:
                raise WindowError(f"cannot write {path}: cycle {cycle} has no samples")
            # cycle c >= 1 starts on the previous cycle's last sample (the shared boundary)
            t_start = float(rows[0, TIME_COLUMN]) if cycle == 0 else last_t
            if cycle == 0:
                rec.write(RUN_INFO_TOPIC, string_msg(info), log_time_ns(t_start))
            truth = to_message(encode_ground_truth(k), ROSBAGS_CLASSES)
            rec.write(GROUND_TRUTH_TOPIC, truth, log_time_ns(t_start))
            for i in range(0, rows.shape[0], samples_per_message):
                block = rows[i : i + samples_per_message]
                msg = to_message(encode_telemetry(block), ROSBAGS_CLASSES)
                rec.write(TELEMETRY_TOPIC, msg, log_time_ns(block[0, TIME_COLUMN]))
            last_t = float(rows[-1, TIME_COLUMN])
            written += 1
        if written == 0:
            raise WindowError(f"cannot write {path}: no cycles")
    return written


def read_cycle_windows(path: str | Path) -> list[Window]:
    """One `Window` per cycle of a multi-window bag (see the module docstring).

    BagError naming the bag when it has no run_info with ``sample_rate`` and
    ``samples_per_window``, no telemetry, a gap or step back in the telemetry's sample
    indices, or not one complete window.  Samples before the first window boundary (a
    recording joined mid-window) and a trailing incomplete window are left out.
    """
    path = Path(path)
    info, truths, blocks, has_windows = _scan(path)
    if has_windows:
        return _fitted_cycles(path)
    if info is None or any(key not in info for key in REQUIRED_RUN_INFO):
        raise BagError(
            f"bag {path} has no {RUN_INFO_TOPIC} with {' and '.join(REQUIRED_RUN_INFO)}: "
            "cannot cut it into windows (a rig's recordings: `ema-phm import --map MAP.yaml`, "
            "then give the folder it wrote; a simulated life: `ema-phm simulate --windows N`)"
        )
    if not blocks:
        raise BagError(f"bag {path}: {TELEMETRY_TOPIC} has no messages")
    fs, n = _window_layout(path, info)
    data = np.concatenate(blocks)
    j = np.rint(data[:, TIME_COLUMN] * fs).astype(np.int64)
    steps = np.diff(j)
    if steps.size and not np.all(steps == 1):
        i = int(np.flatnonzero(steps != 1)[0])
        raise BagError(
            f"bag {path}: telemetry sample {i + 1} (t = {data[i + 1, TIME_COLUMN]:.9g} s) does "
            f"not follow sample {i} (t = {data[i, TIME_COLUMN]:.9g} s); a multi-window bag must "
            "be continuous"
        )
    skip = int(-j[0] % n)  # a recording joined mid-window starts at the next boundary
    data, j = data[skip:], j[skip:]
    windows = max(data.shape[0] - 1, 0) // n
    if windows < 1:
        raise BagError(
            f"bag {path}: {data.shape[0]} samples hold no complete window of {n + 1} samples"
        )
    out = []
    first_cycle = int(j[0] // n)  # the stream's sample 0 starts cycle 0
    for w in range(windows):
        rows = data[w * n : (w + 1) * n + 1]
        stamp = log_time_ns(rows[0, TIME_COLUMN])
        before = [k for t, k in truths if t <= stamp]
        k_true = before[-1] if before else None
        out.append(
            Window.from_matrix(rows, k_true=k_true, meta={**info, "cycle": first_cycle + w})
        )
    return out


def _scan(
    path: Path,
) -> tuple[dict[str, Any] | None, list[tuple[int, np.ndarray]], list[np.ndarray], bool]:
    """(first run_info, ground truths, telemetry blocks, whether it has `/ema/window`)."""
    info: dict[str, Any] | None = None
    truths: list[tuple[int, np.ndarray]] = []
    blocks: list[np.ndarray] = []
    messages = read_messages(
        path, [RUN_INFO_TOPIC, GROUND_TRUTH_TOPIC, TELEMETRY_TOPIC, WINDOW_TOPIC]
    )
    try:
        for topic, _type, t_ns, msg in messages:
            if topic == WINDOW_TOPIC:
                return info, truths, blocks, True
            if topic == RUN_INFO_TOPIC:
                info = info or run_info_object(path, msg.data)  # the first one describes the run
            elif topic == GROUND_TRUTH_TOPIC:
                truths.append((t_ns, ground_truth(path, msg, t_ns)))
            else:
                blocks.append(telemetry_rows(path, len(blocks), msg))
    finally:
        messages.close()
    return info, truths, blocks, False


def _fitted_cycles(path: Path) -> list[Window]:
    """The windows a monitor recorded on `/ema/window`, each with its cycle in `meta`."""
    out: list[Window] = []
    for fitted in read_fitted_windows(path):
        duration = float(fitted.meta.get("window_duration", fitted.duration) or fitted.duration)
        cycle = fitted.meta.get("cycle")  # the monitor's own number, when the stream gave one
        if cycle is None:
            cycle = int(round(float(fitted.t[0]) / duration)) if duration > 0 else len(out)
        out.append(
            Window.from_matrix(
                fitted.matrix(), k_true=fitted.k_true, meta={**fitted.meta, "cycle": cycle}
            )
        )
    return out


def _window_layout(path: Path, info: Mapping[str, Any]) -> tuple[float, int]:
    """(sample rate, samples per window) of a run_info; BagError naming bad values."""
    try:
        fs = float(info["sample_rate"])
        n = int(info["samples_per_window"])
    except (TypeError, ValueError):
        raise BagError(
            f"bag {path}: run_info sample_rate {info['sample_rate']!r} / samples_per_window "
            f"{info['samples_per_window']!r} are not numbers"
        ) from None
    if not (np.isfinite(fs) and fs > 0 and n >= 2):
        raise BagError(
            f"bag {path}: run_info sample_rate {fs!r} must be > 0 and samples_per_window {n!r} "
            ">= 2"
        )
    return fs, n
