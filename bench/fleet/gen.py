"""The fleet benchmark's --generate phase: the simulated fleet, timed (kept when it exists)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from bench.fleet.common import Run, check_fleet, folder_bytes, sizes
from ema_phm.fleet.generate import generate_fleet
from ema_phm.simulator import envelope


def run_generate(run: Run, fleet_dir: Path, before: dict | None) -> dict[str, Any]:
    """Generate the fleet into `fleet_dir` unless it exists; what was done, and how fast.

    An existing folder must hold the fleet this run expects (`check_fleet`); its earlier
    timing (`before`, the JSON's entry for the same folder) is kept.
    """
    quick, seed = run.quick, run.seed
    n = sizes(quick)
    cmd = run.command("--generate", str(fleet_dir))
    if fleet_dir.exists():
        check_fleet(fleet_dir, quick, seed)
        if before and before.get("dir") == str(fleet_dir) and before.get("seconds"):
            print(f"[generate] {fleet_dir} exists: kept, with its timing")
            return before
        print(f"[generate] {fleet_dir} exists: kept (not timed here)")
        return {"dir": str(fleet_dir), "reused": True, "seconds": None, "command": cmd}
    done = []
    t0 = time.perf_counter()

    def on_unit(d: Any) -> None:
        done.append(d)
        dt = time.perf_counter() - t0
        print(f"[generate] {len(done)}/{n['units']} units ({d.unit_id}), {dt:.0f} s", flush=True)

    drawn = generate_fleet(
        fleet_dir, units=n["units"], windows=n["windows"], seed=seed, on_unit=on_unit
    )
    seconds = time.perf_counter() - t0
    recordings = len(drawn) * (n["windows"] + envelope.BASELINES)
    return {
        "dir": str(fleet_dir),
        "reused": False,
        "units": len(drawn),
        "windows": n["windows"],
        "baselines": envelope.BASELINES,
        "seed": seed,
        "degrading": sum(d.fault is not None for d in drawn),
        "recordings": recordings,
        "seconds": seconds,
        "s_per_recording": seconds / recordings,
        "bytes": folder_bytes(fleet_dir),
        "command": cmd,
    }
