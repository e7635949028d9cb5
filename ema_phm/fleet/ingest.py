"""Ingest: diagnose every window of a fleet not yet in the store, units in parallel on Dask.

`ingest(sources, store)` reads the catalog (`catalog.scan`: recordings not yet complete in
the store), plans each unit (its commissioning, its state after what is stored:
`unit_job.resume_state`, its pending windows in cycle order) and runs the plans.  A unit's
windows are one chain of Dask tasks, each taking the previous one's state, so they run in
time order; units run side by side, at most `UNITS_IN_FLIGHT_PER_WORKER` per worker
submitted at a time (the scheduler holds a bounded graph whatever the fleet's size).  Each
result is stored as it arrives (`store.Store.save_window`), by this process only.

A worker that dies loses nothing: Dask runs its task again on another worker from the same
input state (`diagnose_window` leaves its input untouched), and results already stored stay.
A killed ingest loses only the windows being fitted; run it again and it goes on.  Without
Dask (`workers=0`) the same plans run in this process, one window after another.
"""

from __future__ import annotations

import logging
import os
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from .catalog import Catalog, UnitWork, WindowRef, scan
from .settings import DiagnosisSettings
from .store import Store
from .unit_job import Commissioned, UnitState, commission_unit, diagnose_window, resume_state

#: Units whose chains are submitted at a time, per worker: enough that a worker always has a
#: ready window (each chain has one at a time), few enough to keep the scheduler's graph small.
UNITS_IN_FLIGHT_PER_WORKER = 2
#: Environment of the embedded cluster's worker processes: one fit per core.
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
#: Dask settings of the embedded cluster.  A worker runs its task in a thread beside its event
#: loop, which takes the GIL from it: the statistical profiler (a stack walk every 10 ms)
#: and the 20 ms tick (a fit of 800 evaluations: 1.47-1.84 s in a default worker, 1.31-1.39 s
#: without them, 1.19-1.35 s in a plain process); neither is needed to run fits.  For
#: `dask worker`s of your own: README, "Fleet".
#: What the nannies set in the environment before they start a worker (in the process that
#: starts the cluster: `start_cluster` puts the caller's environment back).
PRE_SPAWN_ENV = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}
WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.gil.enabled": False,
    # Dask's default also sets MALLOC_TRIM_THRESHOLD_=65536, which turns off glibc's
    # adaptive mmap threshold: every large array of a fit is mapped and faulted in anew
    # (measured on one unit's commissioning and 4 windows in a worker: 1.55 M page faults
    # and 5.3 s system time with it, 0.44 M and 1.6 s without; the commissioning 9.0 s -> 6.7 s)
    "distributed.nanny.pre-spawn-environ": PRE_SPAWN_ENV,
}

#: Why a unit whose baselines came after its first windows is not commissioned from them.
LATE_BASELINES = (
    "baselines arrived after its first windows were diagnosed: not used (commission a unit "
    "before its flights are ingested)"
)

Progress = Callable[[int, int], None]


@dataclass
class UnitPlan:
    """What a unit needs this ingest: its starting state or baselines, its pending windows."""

    unit_id: str
    start: UnitState | Commissioned | None  # None: commission from `baselines` first
    baselines: list[WindowRef]
    pending: list[WindowRef]


@dataclass
class IngestReport:
    """What an ingest did."""

    recordings_read: int = 0
    recordings_known: int = 0  # complete in the store before: not read again
    refused: list[str] = field(default_factory=list)
    duplicates: int = 0
    units: int = 0
    windows_stored_before: int = 0  # found again, already in the store
    windows_diagnosed: int = 0
    commissioned: int = 0
    not_commissioned: list[str] = field(default_factory=list)
    #: what spoke against a unit commissioned now (`CommissioningResult.warnings`), one line
    #: each; said in this report only, not kept in the store
    commission_warnings: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)  # one line per unit whose chain failed
    workers: int = 0
    scheduler: str = ""
    wall_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        return asdict(self)

    def lines(self) -> list[str]:
        """The report in a few lines."""
        out = [
            f"recordings: {self.recordings_read} read, {self.recordings_known} already "
            f"complete, {len(self.refused)} refused, {self.duplicates} duplicates",
            f"units: {self.units}; windows: {self.windows_diagnosed} diagnosed now, "
            f"{self.windows_stored_before} stored before; {self.commissioned} units "
            f"commissioned now, {len(self.not_commissioned)} not commissioned",
            f"ran on {self.scheduler} with {self.workers} worker(s) in {self.wall_s:.1f} s",
        ]
        out += [f"refused {r}" for r in self.refused]
        out += [f"not commissioned: {r}" for r in self.not_commissioned]
        out += [f"commissioned despite: {r}" for r in self.commission_warnings]
        out += [f"FAILED {r}" for r in self.failed]
        return out


def plan_units(
    catalog: Catalog, store: Store, settings: DiagnosisSettings
) -> tuple[list[UnitPlan], list[Commissioned]]:
    """Each unit's plan (what the store holds of it, its windows not stored yet); late ones.

    A unit whose baselines arrive after its first windows were diagnosed is not
    commissioned from them (its history began without them): that is stored as its
    commissioning, with `LATE_BASELINES` as the reason.
    """
    late: list[Commissioned] = []
    stored = store.window_keys()
    commissioned = store.commissioning()
    rows = store.unit_rows()
    plans = []
    for unit_id in sorted(catalog.units):
        work: UnitWork = catalog.units[unit_id]
        pending = [r for r in work.windows if r.key not in stored]
        com = commissioned.get(unit_id)
        if not pending and com is not None:
            continue
        start: UnitState | Commissioned | None
        if unit_id in rows:
            if com is None and work.baselines:  # too late: its history has begun without them
                late.append(Commissioned(unit_id, None, LATE_BASELINES))
            values = None if com is None else com.belief_values
            start = resume_state(unit_id, settings, values, rows[unit_id])
        elif com is not None or not work.baselines:
            start = com or Commissioned(unit_id, None, "no baseline recording")
        else:
            start = None
        plans.append(UnitPlan(unit_id, start, work.baselines, pending))
    for com in late:
        store.save_commissioning(com)
    return plans, late


class _Run:
    """One ingest's bookkeeping: store results, count, report progress."""

    def __init__(self, store: Store, report: IngestReport, total: int, progress: Progress | None):
        self.store, self.report, self.total, self.progress = store, report, total, progress
        self.done = 0

    def commissioned(self, com: Commissioned) -> None:
        if self.store.save_commissioning(com):
            self.report.commissioned += com.belief_values is not None
        if com.belief_values is None:
            self.report.not_commissioned.append(f"{com.unit_id}: {com.problem}")
        self.report.commission_warnings += [f"{com.unit_id}: {w}" for w in com.warnings]

    def window(self, result: Any) -> None:
        self.report.windows_diagnosed += self.store.save_window(result)
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total)


def _run_inline(plans: Sequence[UnitPlan], settings: DiagnosisSettings, run: _Run) -> None:
    """The plans in this process, one window after another (no Dask)."""
    for p in plans:
        try:
            state: Any = p.start
            if state is None:
                state = commission_unit(p.unit_id, p.baselines, settings)
                run.commissioned(state)
            for ref in p.pending:
                result, state = diagnose_window(ref, state, settings)
                run.window(result)
        except Exception as exc:  # noqa: BLE001  (one unit's failure must not stop the fleet)
            run.report.failed.append(f"{p.unit_id}: {type(exc).__name__}: {exc}")


def _submit(client: Any, p: UnitPlan, settings: DiagnosisSettings) -> list[tuple[Any, str]]:
    """A unit's chain of tasks: (future, kind) in order; each takes the previous one's state."""
    out: list[tuple[Any, str]] = []
    state: Any = p.start
    if state is None:
        state = client.submit(commission_unit, p.unit_id, p.baselines, settings, pure=False)
        out.append((state, "commission"))
    for ref in p.pending:
        state = client.submit(diagnose_window, ref, state, settings, pure=False)
        out.append((state, "window"))
    return out


def _run_dask(
    client: Any, plans: Sequence[UnitPlan], settings: DiagnosisSettings, run: _Run
) -> None:
    """The plans on a Dask cluster: chains per unit, a bounded number of units in flight."""
    from distributed import as_completed  # noqa: PLC0415

    workers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    waiting = deque(plans)
    what: dict[str, tuple[str, str]] = {}  # future key -> (kind, unit)
    left: dict[str, int] = {}  # unit -> tasks not yet back
    failed: set[str] = set()
    queue = as_completed()

    def launch() -> None:
        while waiting and len(left) < UNITS_IN_FLIGHT_PER_WORKER * workers:
            p = waiting.popleft()
            chain = _submit(client, p, settings)
            if not chain:
                continue
            left[p.unit_id] = len(chain)
            for fut, kind in chain:
                what[fut.key] = (kind, p.unit_id)
                queue.add(fut)

    launch()
    for fut in queue:
        kind, unit = what.pop(fut.key)
        try:
            value = fut.result()
            if unit not in failed:  # after a failure the unit's later results are not stored
                run.commissioned(value) if kind == "commission" else run.window(value[0])
        except Exception as exc:  # noqa: BLE001  (a unit's chain stops; the fleet goes on)
            if unit not in failed:
                failed.add(unit)
                run.report.failed.append(f"{unit}: {type(exc).__name__}: {exc}")
        fut.release()
        left[unit] -= 1
        if not left[unit]:
            del left[unit]
            launch()


def start_cluster(workers: int) -> Any:
    """An embedded Dask cluster on 127.0.0.1: `workers` processes of one thread, no dashboard."""
    import dask  # noqa: PLC0415
    from distributed import LocalCluster  # noqa: PLC0415

    # the nannies set their pre-spawn environment in this process: put the caller's back
    saved = {name: os.environ.get(name) for name in PRE_SPAWN_ENV}
    try:
        with dask.config.set(WORKER_CONFIG):  # the nannies hand it to every worker they start
            return LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                worker_dashboard_address=None,
                silence_logs=logging.ERROR,
                env=dict(WORKER_ENV),
            )
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def ingest(
    sources: Sequence[str | Path],
    store: Store,
    settings: DiagnosisSettings,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Progress | None = None,
) -> IngestReport:
    """Diagnose every window of `sources` not in `store`; the report (see the module docstring).

    `scheduler`: a Dask scheduler's address to run on; else an embedded cluster of `workers`
    processes (None: one per core); `workers` 0: no Dask, this process.  StoreError when the
    store was diagnosed with other settings.
    """
    t0 = time.perf_counter()
    settings.belief()  # a bad actuator file is named here, before the store records it
    store.check_settings(settings)
    catalog = scan(sources, store.complete_recordings())
    report = IngestReport(
        recordings_read=len(catalog.recordings),
        recordings_known=catalog.known,
        refused=list(catalog.refused),
        duplicates=catalog.duplicates,
        units=len(catalog.units),
    )
    plans, late = plan_units(catalog, store, settings)
    report.not_commissioned += [f"{c.unit_id}: {c.problem}" for c in late]
    found = sum(len(w.windows) for w in catalog.units.values())
    report.windows_stored_before = found - sum(len(p.pending) for p in plans)
    run = _Run(store, report, sum(len(p.pending) for p in plans), progress)
    if not plans and scheduler is None:
        report.scheduler = "nothing to do"
    elif scheduler is None and workers == 0:
        report.scheduler, report.workers = "this process (no Dask)", 1
        _run_inline(plans, settings, run)
    else:
        _on_dask(plans, settings, run, scheduler, workers or os.cpu_count() or 1)
    store.note_recordings(catalog.recordings)
    report.wall_s = time.perf_counter() - t0
    return report


def _on_dask(
    plans: Sequence[UnitPlan],
    settings: DiagnosisSettings,
    run: _Run,
    scheduler: str | None,
    workers: int,
) -> None:
    from distributed import Client  # noqa: PLC0415

    cluster = None if scheduler is not None else start_cluster(workers)
    try:
        with _client(Client, scheduler if cluster is None else cluster) as client:
            info = client.scheduler_info(n_workers=-1)
            run.report.scheduler = str(info.get("address", scheduler))
            run.report.workers = len(info.get("workers", {}))
            _run_dask(client, plans, settings, run)
    finally:
        if cluster is not None:
            cluster.close()


#: Seconds to wait for a scheduler to answer and for its first worker.
CONNECT_TIMEOUT_S = 60


def _client(client_class: Any, where: Any) -> Any:
    """A Dask client of `where` (a cluster or an address) with a worker; ConfigError if not."""
    try:
        client = client_class(where, timeout=CONNECT_TIMEOUT_S)
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(f"cannot reach the Dask scheduler {where!r}: {exc}") from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        client.close()
        raise ConfigError(
            f"the Dask scheduler {where!r} has no worker after {CONNECT_TIMEOUT_S} s ({exc})"
        ) from None
    return client
