"""`ema-phm demo`: the main job on bundled defaults, with the ROS 2 nodes or (--offline) not."""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ..domain import faults
from ..errors import ConfigError
from .args import ProgressBar, actuator_of, add_actuator_arg, belief_of, limited, plot_path
from .output import add_json_arg, emit, wants_json

#: True k of the demo's simulated EMA: several faults at once, the gain drifted.
DEMO_K = faults.k_with(
    friction=0.3,
    backlash=0.2,
    short_circuit_b=0.25,
    eccentricity=0.3,
    eccentricity_phase=0.3,
    gain_drift=0.6,
)

#: What the demo's %err is printed next to: the thesis measured a twin monitor, noise-free.
THESIS_FIGURE = "thesis, twin monitor, no noise: 1-7 % in ~12 min; this HF is not a twin"


def add_demo(subparsers: Any) -> None:
    """The `demo` subcommand."""
    d = subparsers.add_parser("demo", help="the main job on bundled defaults")
    d.add_argument(
        "--k",
        default=",".join(f"{v:g}" for v in DEMO_K),
        help="true fault vector of the simulated EMA",
    )
    d.add_argument(
        "--seed", type=limited("seed"), default=0, help="the sensors' noise and the optimizer"
    )
    d.add_argument(
        "--noise-current",
        type=limited("noise_current"),
        default=0.225,
        help="A RMS (1 %% of 22.5 A)",
    )
    add_actuator_arg(
        d,
        what="the actuator simulated and the monitor's belief (with --offline only: the "
        "demo's nodes run the packaged actuator)",
    )
    d.add_argument("--plot", type=plot_path, default=None, help="PNG to draw (--offline only)")
    d.add_argument(
        "--offline",
        action="store_true",
        help="library only: simulate and isolate without ROS 2 nodes",
    )
    add_json_arg(d, what="the true and fitted k, the verdict and the fit")
    d.set_defaults(func=_cmd_demo)


def _cmd_demo(args: argparse.Namespace) -> int:
    """Main job on bundled defaults.

    ema_node plays the faulty EMA for one window, monitor_node isolates it, the health result is
    printed (--offline: no ROS 2).
    """
    k = faults.parse(args.k)
    if args.offline:
        return _demo_offline(args, k)
    if args.plot is not None:
        raise ConfigError("demo --plot draws with --offline only")
    if args.actuator is not None:
        raise ConfigError(
            "demo --actuator runs with --offline only: the demo's nodes run the packaged "
            "actuator (for the nodes, set both nodes' actuator_file parameter)"
        )
    return _demo_with_nodes(args, k)


def _demo_with_nodes(args: argparse.Namespace, k: np.ndarray) -> int:
    """Both nodes in one process for one window; print the monitor's health result."""
    from ..ros.demo import run_demo  # the only path of the CLI that loads rclpy

    if not wants_json(args):
        print(
            f"starting ema_node (true k = {np.round(k, 4).tolist()}, current noise "
            f"{args.noise_current:g} A RMS) and monitor_node in one process, localhost only ...",
            flush=True,
        )
    h = run_demo(k=k.tolist(), seed=args.seed, ema_params={"noise_current": args.noise_current})
    lines = [
        f"/ema/health after one {h['window_t1'] - h['window_t0']:g} s window: level "
        f"{h['level']}: {h['message']}",
        f"  fitted k = {np.round(h['k'], 4).tolist()}",
    ]
    if h.get("k_interval") is not None:
        lines.append(f"  90 % intervals = {np.round(h['k_interval'], 3).tolist()}")
    lines.append(f"  true   k = {np.round(h['k_true'], 4).tolist()}")
    if h.get("nuisance"):
        lines.append(f"  nuisances = { {n: round(v, 3) for n, v in h['nuisance'].items()} }")
    lines.append(
        f"  %err (eq. 6.4) = {h['percent_err']:.3f}   {h['evaluations']} evaluations in "
        f"{h['elapsed_s']:.2f} s "
        f"(preset {h['preset']}; {THESIS_FIGURE})"
    )
    emit(args, {str(key): _plain(value) for key, value in h.items()}, lines)
    return 0


def _plain(value: object) -> object:
    """`value` with numpy arrays and numbers as lists and Python numbers (for JSON)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _demo_offline(args: argparse.Namespace, k: np.ndarray) -> int:
    """Simulate one window with the HF model and isolate it with the library, no ROS 2."""
    from ..diagnosis import health
    from ..diagnosis.isolation import DEFAULT_PRESET, isolate, preset_budget
    from ..simulator import real_ema

    actuator = actuator_of(args)
    belief = belief_of(args)
    w = real_ema.simulate(
        k, actuator=actuator, seed=args.seed, noise_current=args.noise_current
    ).window
    if not wants_json(args):  # what is simulated, before the fit's wait
        print(
            f"real EMA (HF model): {w.duration:g} s chirp "
            f"{w.meta['command']['f0']:g}->{w.meta['command']['f1']:g} Hz, "
            f"{w.n} samples at {1 / w.dt:g} Hz, current noise {args.noise_current:g} A RMS\n"
            f"  true k = {np.round(k, 4).tolist()}",
            flush=True,
        )
    bar = ProgressBar(preset_budget(DEFAULT_PRESET))
    try:
        res = isolate(
            w, belief=belief, seed=args.seed, on_progress=bar, nuisance=True, intervals=True
        )
    finally:
        bar.close()
    verdict = health.assess_isolation(res)
    assert res.k_interval is not None  # asked for with intervals=True
    lines = [
        f"monitor (LF model + {res.preset}): {res.evaluations} evaluations in {res.wall_s:.2f} s",
        f"  {verdict.message}",
        f"  fitted k = {np.round(res.k, 4).tolist()}",
        f"  90 % intervals = {np.round(res.k_interval, 3).tolist()}",
        f"  %err (eq. 6.4) = {res.percent_err:.3f}   ({THESIS_FIGURE})",
    ]
    data: dict[str, object] = {
        "k_true": [float(v) for v in k],
        "k": [float(v) for v in res.k],
        "k_interval": _plain(res.k_interval),
        "level": health.LEVEL_NAMES[verdict.level],
        "message": verdict.message,
        "percent_err": res.percent_err,
        "evaluations": res.evaluations,
        "wall_s": res.wall_s,
        "preset": res.preset,
        "seed": args.seed,
        "noise_current": args.noise_current,
    }
    if args.plot:
        from .plotting import plot_isolation

        data["plot"] = str(plot_isolation(w, res, args.plot, belief=belief))
        lines.append(f"  plot: {data['plot']}")
    emit(args, data, lines)
    return 0
