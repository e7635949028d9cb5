"""monitor_node's parameter values -> its HealthMonitor and the settings it fits with.

`health_monitor_from` builds the monitor at start-up; `RunTimeSettings` checks a set of
the dynamic parameters (the node's on-set callback: a refusal with a reason) and applies
an accepted one (from the next window).
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from ..diagnosis.isolation_settings import IsolationSettings
from ..monitor.health_monitor import HealthMonitor
from ..monitor.tracker import PrognosticTracker
from .parameters import ParameterTable


def settings_from(values: Mapping[str, Any]) -> IsolationSettings:
    """The isolation settings the (checked) parameter values describe."""
    return IsolationSettings.from_values(values)


def health_monitor_from(values: Mapping[str, Any]) -> HealthMonitor:
    """The HealthMonitor of monitor_node's (checked) start-up parameter values."""
    return HealthMonitor(
        settings_from(values),
        hardware_id=values["hardware_id"],
        stale_timeout=values["stale_timeout"],
        commission_windows=values["commission_windows"],
        prognostics=PrognosticTracker.from_values(values),
        queue_depth=values["queue_depth"],
    )


class RunTimeSettings:
    """The node's parameter callbacks: check a change whole, then hand the monitor its settings."""

    def __init__(
        self,
        table: ParameterTable,
        current: Callable[[str], Any],
        service: HealthMonitor,
    ) -> None:
        """`current(name)`: the parameter's value now (the node's get_parameter(name).value)."""
        self._table, self._current, self._service = table, current, service

    def _values(self, changes: list[Parameter]) -> dict[str, Any]:
        values = {name: self._current(name) for name in self._table.names}
        values.update(self._table.own(changes))  # use_sim_time & co.: rclpy's
        return values

    def validate(self, params: list[Parameter]) -> SetParametersResult:
        """On-set callback: the values after `params`, checked together (a refusal says why)."""
        try:
            settings_from(self._table.validated(self._values(params)))
        except Exception as exc:  # noqa: BLE001 - any bad value is a refusal, never a crash
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def apply(self, _params: list[Parameter]) -> None:
        """Post-set callback: the monitor fits with the new settings from the next window."""
        self._service.set_settings(settings_from(self._values([])))
