"""Both nodes in one process for one window: the main job on bundled defaults.

`run_demo()` starts monitor_node and ema_node on a private in-process graph
(realtime_factor 0, max_windows 1; the EMA waits for the monitor to subscribe, so
the one window it publishes is complete), waits for the first health result,
shuts everything down and returns the result as a dict.
"""

from __future__ import annotations

from typing import Any, Sequence

from ..domain.faults import k_with, validate
from ..errors import EmaPhmError, ExcitationError
from .ema_node import EmaNode
from .monitor_node import MonitorNode
from .runtime import InProcessGraph

#: True k of run_demo's EMA when none is given (`ema-phm demo` passes its own, tools.demo.DEMO_K).
DEMO_K: tuple[float, ...] = tuple(
    float(v) for v in k_with(friction=0.5, short_circuit_a=0.3, eccentricity=0.4)
)


class DemoTimeout(EmaPhmError, TimeoutError):
    """No health result arrived in time."""


def run_demo(
    k: Sequence[float] = DEMO_K,
    seed: int = 0,
    timeout_s: float = 120.0,
    *,
    preset: str = "",
    max_evaluations: int = 0,
    fitness: str = "default",
    record_bag: str = "",
    domain_id: int | None = None,
    ema_params: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Run ema_node and monitor_node for one window; return the monitor's first health result.

    `seed` is the noise seed of ema_node (true k) and the isolation seed of monitor_node.

    The dict has: level, message, k, k_true, percent_err, severity, dominant_fault, fitness,
    evaluations, elapsed_s, window_t0, window_t1, preset, seed, fitness_weighting,
    max_evaluations, latency_s, counters, diagnostics (the DiagnosticStatus as a dict),
    domain_id.  Raises FaultVectorError for a bad k, DemoTimeout if no result within
    `timeout_s`, ExcitationError if the window did not excite the actuator enough to be
    assessed.
    """
    kk = validate(k)

    with InProcessGraph(domain_id) as graph:
        monitor = graph.add(
            MonitorNode,
            preset=preset,
            seed=seed,
            fitness=fitness,
            max_evaluations=max_evaluations,
            record_bag=record_bag,
        )
        params = dict(
            k=kk.tolist(), seed=seed, realtime_factor=0.0, max_windows=1, wait_for_subscribers=1
        )
        params.update(ema_params or {})
        graph.add(EmaNode, **params)
        results = monitor.wait_for_results(1, timeout=timeout_s, failures=1, not_excited=1)
        if not results and monitor.failures:
            raise EmaPhmError(f"isolation failed: {monitor.failures[0]}")
        if not results and monitor.not_excited:
            raise ExcitationError(f"the window was not assessed: {monitor.not_excited[0]}")
        if not results:
            raise DemoTimeout(
                f"no health result within {timeout_s:g} s "
                f"(windows discarded: {monitor.counters['windows_discarded']}, "
                f"isolation failures: {monitor.counters['isolation_failures']})"
            )
        out = dict(results[0])
        status = monitor.last_status
        out["diagnostics"] = None if status is None else status.as_dict()
        out["domain_id"] = graph.domain_id
    return out
