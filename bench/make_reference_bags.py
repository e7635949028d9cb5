#!/usr/bin/env python3
"""Make the reference recordings in bags/ with the two nodes, in-process.

For each case: monitor_node (default preset, seed 0, recording) and ema_node
(true k, seed 0, realtime_factor 0, max_windows 1, waiting for the monitor) run on
a private in-process graph.  The EMA publishes exactly one window (samples 0..N,
N = duration * 2000 Hz); the monitor fits it, publishes /ema/window, /ema/health
and /diagnostics, and the bag is closed once those are recorded.  So each bag's
/ema/telemetry is exactly the fitted window, and

    ema-phm isolate bags/<name> --seed 0     (default preset)

gives the k of the bag's /ema/health.  Rewrites bags/README.md.

    .venv/bin/python -m bench.make_reference_bags [--out bags] [--force] [NAME ...]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from ema_phm.diagnosis import health  # noqa: E402
from ema_phm.domain.faults import NAMES, NOMINAL, k_with  # noqa: E402
from ema_phm.physics.commands import default_specs  # noqa: E402
from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402
from ema_phm.telemetry.wire import HEALTH_TOPIC  # noqa: E402
from ema_phm.tools.benchmark import K_FAULT  # noqa: E402

NOM = NOMINAL.tolist()


def _k(**levels: float) -> list[float]:
    """The healthy k with the named faults set, as ema_node's `k` parameter."""
    return k_with(**levels).tolist()


#: name -> (true k, what it is)
CASES: dict[str, tuple[list[float], str]] = {
    "nominal": (NOM, "healthy actuator"),
    "friction": (_k(friction=0.5), "dry friction x2 (k1 = 0.5)"),
    "backlash": (_k(backlash=0.5), "backlash x50.5 (k2 = 0.5)"),
    "short_circuit": (_k(short_circuit_a=0.3), "30 % of phase A's turns shorted (k3 = 0.3)"),
    "eccentricity": (
        _k(eccentricity=0.5, eccentricity_phase=0.25),
        "static eccentricity zeta = 0.5 at electrical phase -pi/2 (k6 = 0.5, k7 = 0.25)",
    ),
    "gain_drift": (_k(gain_drift=0.75), "position-loop gain +25 % (k8 = 0.75)"),
    "multi_fault": (
        K_FAULT.tolist(),
        "friction, backlash, short circuit A, eccentricity and gain drift at once",
    ),
    "realistic_unit": (
        _k(friction=0.5),
        "dry friction x2 (k1 = 0.5) on a drawn unit (`unit_seed` 3) at 55 degC, noise on every "
        "channel, unmeasured load 30 N*m + 1500 N*m/rad (parameters in REALISTIC)",
    ),
}
#: Bags of the second packaged actuator (a PI current loop in dq, issue 20): both nodes
#: are given its actuator file (ema_node simulates it, monitor_node believes it).
SMALL_PI = "config/actuators/small_pi_ema.yaml"
ACTUATOR: dict[str, str] = {
    "small_pi_nominal": SMALL_PI,
    "small_pi_friction": SMALL_PI,
    "small_pi_gain_drift": SMALL_PI,
}
CASES.update(
    {
        "small_pi_nominal": (NOM, "healthy small PI-drive actuator (small_pi_ema.yaml)"),
        "small_pi_friction": (_k(friction=0.5), "dry friction x2 (k1 = 0.5), small PI drive"),
        "small_pi_gain_drift": (_k(gain_drift=0.75), "position gain +25 % (k8 = 0.75), small PI"),
    }
)
#: ema_node parameters of the realistic bag beyond k and seed: a manufactured unit at a hot
#: temperature, the noise levels of bench/harness/scenarios.py, a hinge load the telemetry
#: does not carry (the monitor assumes none).
REALISTIC: dict[str, dict] = {
    "realistic_unit": dict(
        unit_seed=3,
        temperature=55.0,
        noise_current=0.225,
        noise_position=5.0e-5,
        noise_speed=0.5,
        load=30.0,
        load_spring=1500.0,
        load_unmeasured=True,
    ),
}
#: Seed of ema_node's noise (no noise by default, so it does not matter).
EMA_SEED = 0
#: The monitor's stale_timeout [s]: the EMA stops after its one window, so a slow isolation
#: (a loaded machine) would otherwise record STALE heartbeats, an artefact of the set-up.
STALE_TIMEOUT = 600.0
#: Seed of the monitor's isolation (reproducible for every seed, 0 too: isolation shifts
#: it before pymoo hands it to `cma`), so a replay gives the recorded k.
ISOLATION_SEED = 0


def make(name: str, out: Path, *, force: bool) -> dict:
    k, _ = CASES[name]
    path = out / name
    if path.exists():
        if not force:
            raise SystemExit(f"{path} exists (use --force to remake it)")
        shutil.rmtree(path)
    t0 = time.monotonic()
    with InProcessGraph() as g:
        actuator = {"actuator_file": str(ROOT / ACTUATOR[name])} if name in ACTUATOR else {}
        monitor = g.add(
            MonitorNode,
            **actuator,
            record_bag=str(path),
            seed=ISOLATION_SEED,
            heartbeat_period=1.0,
            stale_timeout=STALE_TIMEOUT,
        )
        ema = g.add(
            EmaNode,
            k=k,
            seed=EMA_SEED,
            realtime_factor=0.0,
            max_windows=1,
            wait_for_subscribers=1,
            **actuator,
            **REALISTIC.get(name, {}),
        )
        results = monitor.wait_for_results(1, timeout=600.0, failures=1)
        if not results:
            raise SystemExit(f"{name}: no health result ({list(monitor.failures)})")
        end = time.monotonic() + 10.0
        while monitor.recorded.get(HEALTH_TOPIC, 0) < 1 and time.monotonic() < end:
            time.sleep(0.02)
        time.sleep(0.3)  # let the result's /diagnostics reach the recorder too
        samples = ema.samples_published
    r = dict(results[0])
    r.update(
        name=name,
        path=path,
        samples=samples,
        wall_s=time.monotonic() - t0,
        size=sum(f.stat().st_size for f in path.iterdir()),
    )
    print(
        f"{name:>14}: k1..k8 = {[round(v, 3) for v in r['k']]}  %err {r['percent_err']:.3f}  "
        f"{r['level']}  "
        f"({r['evaluations']} evaluations, {r['elapsed_s']:.1f} s, bag {r['size'] / 1e3:.0f} kB)",
        flush=True,
    )
    return r


def readme(rows: list[dict], out: Path) -> None:
    cmd, load = default_specs()
    first = rows[0]
    lines = [
        "# Reference recordings",
        "",
        "Small rosbag2 bags (`metadata.yaml` + one `.mcap`, CDR) recorded by `monitor_node` while",
        "`ema_node` played the actuator: one window each, fitted live.  Made by",
        "`.venv/bin/python -m bench.make_reference_bags --force` (both nodes in one process,",
        "private domain, localhost only); see that script for the exact parameters.",
        "",
        "How each was made:",
        "",
        f"- `ema_node`: the true k below, `seed` {EMA_SEED}, no measurement noise (the node's "
        "defaults; `realistic_unit` excepted, see below),",
        f"  command {cmd.kind} {cmd.amplitude:g} rad, {cmd.f0:g} -> {cmd.f1:g} Hz over "
        f"{cmd.duration:g} s, "
        f"constant load {load.value:g} N*m,",
        "  `realtime_factor` 0, `max_windows` 1, `wait_for_subscribers` 1: it publishes samples",
        f"  0..N of the stream (N = {first['samples'] - 1}, 2000 Hz) in messages of 100 "
        "samples and stops.",
        f"- `monitor_node`: preset `{first['preset']}` (the library default), `seed` "
        f"{first['seed']}, fitness "
        f"`{first['fitness_weighting']}`,",
        "  full evaluation budget, default thresholds, `stale_timeout` "
        f"{STALE_TIMEOUT:g} s (the EMA stops after one",
        "  window: no STALE heartbeat while a slow isolation runs), `record_bag` = the bag.",
        "",
        "All but `realistic_unit` are ideal: the datasheet unit at 20 degC, ideal sensors, no "
        "load, so the",
        "monitor's parameters equal the actuator's.  `realistic_unit` is the actuator as a "
        "monitor meets it:",
        "ema_node parameters "
        + ", ".join(
            f"`{key}` {v!r}".replace("True", "true")
            for key, v in REALISTIC["realistic_unit"].items()
        )
        + " (the same noise as bench/bench_realistic.py; the load channel is NaN).",
        "",
        "The `small_pi_*` bags are of the second packaged actuator, "
        f"`{SMALL_PI}` (a PI current loop",
        "in dq with PWM): both nodes were given it as `actuator_file`, so replay them with",
        f"`ema-phm isolate bags/<name> --actuator {SMALL_PI}`.",
        "",
        "Every bag holds: `/ema/run_info` (JSON, 1), `/ema/ground_truth` (true k, 1),",
        "`/ema/telemetry` (the window: N + 1 samples, as received), `/ema/window` (the same",
        "window in one message: exactly what was fitted), `/ema/health` (1 result),",
        "`/diagnostics` (heartbeats and the result; `values` hold k1..k8, percent_err and the",
        "isolation settings).  Log times are the monitor's receive times (wall clock).",
        "",
        "Because `/ema/telemetry` is exactly the fitted window,",
        f"`ema-phm isolate bags/<name> --seed {ISOLATION_SEED}` (default preset) reproduces "
        "the recorded",
        "health k exactly (test/telemetry/test_replay.py checks it; the recorded seed is in "
        "`/diagnostics`).",
        "",
        "| bag | true k (k1..k8) | what | isolated k (recorded /ema/health) | %err | level | "
        "size |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        k_true = ", ".join(f"{v:g}" for v in r["k_true"])
        k = ", ".join(f"{v:.3f}" for v in r["k"])
        lines.append(
            f"| `{r['name']}` | {k_true} | {CASES[r['name']][1]} | {k} | {r['percent_err']:.2f} | "
            f"{r['level']} | {r['size'] / 1e3:.0f} kB |"
        )
    lines += [
        "",
        "k entries: " + ", ".join(f"k{i + 1} {n}" for i, n in enumerate(NAMES)) + ".",
        f"Levels use the monitor's default thresholds (warn {list(health.DEFAULT_WARN)}, "
        f"error {list(health.DEFAULT_ERROR)}; k7 ignored).",
        "",
    ]
    (out / "README.md").write_text("\n".join(lines), encoding="utf-8")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "names", nargs="*", choices=[[], *CASES], help="bags to make (default: all)", default=[]
    )
    ap.add_argument("--out", default=str(ROOT / "bags"))
    ap.add_argument("--force", action="store_true", help="remake bags that exist")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = args.names or list(CASES)
    rows = [make(n, out, force=args.force) for n in names]
    if set(names) == set(CASES):
        readme(rows, out)
        print(f"wrote {out / 'README.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
