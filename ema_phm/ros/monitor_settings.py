"""monitor_node's parameter values -> its HealthMonitor and the settings it fits with.

`health_monitor_from` builds the monitor at start-up; `RunTimeSettings` checks a set of
the dynamic parameters (the node's on-set callback: a refusal with a reason) and applies
an accepted one (from the next window).

The belief: `IsolationSettings.from_values` builds it (`model.belief.belief_for`) from
`actuator_file` and `unit_file`, read at start-up only (a run-time change of another
parameter keeps what they gave); with neither, the packaged belief.  The actuator file is
the user's description, never the simulated actuator.  Without a unit file the monitor
commissions (`commission_windows` > 0, ~/commission) against that belief, the actuator
file's (`monitor.commissioning_guard`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Mapping

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from ..diagnosis.isolation_settings import IsolationSettings
from ..monitor.health_monitor import HealthMonitor
from ..monitor.state import TruthLookup
from ..monitor.tracker import PrognosticTracker
from .parameters import ParameterTable


def health_monitor_from(
    values: Mapping[str, Any], *, truth: TruthLookup | None = None
) -> HealthMonitor:
    """The HealthMonitor of the (checked) start-up values.

    `truth`: the evaluation listener's true-k lookup (`LiveTruth.over`), for %err only.
    """
    return HealthMonitor(
        IsolationSettings.from_values(values),
        hardware_id=values["hardware_id"],
        stale_timeout=values["stale_timeout"],
        commission_windows=values["commission_windows"],
        prognostics=PrognosticTracker.from_values(values),
        queue_depth=values["queue_depth"],
        truth=truth,
    )


#: Read-only parameters naming files read at start-up (never again at run time).
START_UP_FILES = ("actuator_file", "unit_file")


class RunTimeSettings:
    """The node's parameter callbacks: check a change whole, then hand the monitor its settings."""

    def __init__(
        self,
        table: ParameterTable,
        current: Callable[[str], Any],
        service: HealthMonitor,
    ) -> None:
        """`current(name)`: a parameter's value now; `service`: the monitor built at start-up."""
        self._table, self._current, self._service = table, current, service
        # the files were read once, at start-up: a later change of another parameter keeps
        # what they gave, neither reading them again nor failing because they moved
        self._start = service.settings

    def _values(self, changes: list[Parameter]) -> dict[str, Any]:
        """Every parameter after `changes`, but the start-up files."""
        values = {name: self._current(name) for name in self._table.names}
        values.update(self._table.own(changes))  # use_sim_time & co.: rclpy's
        return {k: v for k, v in values.items() if k not in START_UP_FILES}

    def _settings(self, changes: list[Parameter]) -> IsolationSettings:
        fresh = IsolationSettings.from_values(self._table.validated(self._values(changes)))
        start = self._start
        return dataclasses.replace(
            fresh,
            belief=start.belief,
            unit_warnings=start.unit_warnings,
            unit_file=start.unit_file,
        )

    def validate(self, params: list[Parameter]) -> SetParametersResult:
        """On-set callback: the values after `params`, checked together (a refusal says why)."""
        try:
            self._settings(params)
        except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def apply(self, _params: list[Parameter]) -> None:
        """Post-set callback: the monitor fits with the new settings from the next window."""
        self._service.set_settings(self._settings([]))
