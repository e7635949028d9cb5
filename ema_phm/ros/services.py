"""monitor_node's services (std_srvs/Trigger), each a request to its HealthMonitor.

  ~/commission       commission again from the next N windows fitted, assumed healthy
                     (N = the commission_windows parameter, or COMMISSION_WINDOWS when it
                     is 0); drops the current commissioning, the tracked fit and the
                     prognosis.  Refused with a unit_file (it is the baseline); with an
                     actuator_file it commissions against that file's belief.
  ~/reset_prognosis  forget the prognostic history (after maintenance, a new unit): the
                     next explained window starts a new life.  Refused when prognostics is off.
  ~/fit_next_now     drop the windows queued behind the running fit, so the next window to
                     complete is fitted as soon as the running fit ends (catching up with the
                     stream); the dropped ones count in windows_skipped_busy.

`~` is the node's name: /monitor_node/commission, /left/monitor_node/commission under a
namespace.  The response's `success` says whether the request was taken, `message` what
it did or why not; the status it changes goes out on /diagnostics as usual.
"""

from __future__ import annotations

from typing import Any, Callable

from std_srvs.srv import Trigger

from ..errors import EmaPhmError
from ..monitor.health_monitor import Outputs

#: Windows `~/commission` uses when the commission_windows parameter is 0.
COMMISSION_WINDOWS = 3
#: The services' names (relative to the node: ~/NAME).
SERVICES: tuple[str, ...] = ("commission", "reset_prognosis", "fit_next_now")


def commission_windows(node: Any) -> int:
    """How many windows `~/commission` keeps: the parameter, or COMMISSION_WINDOWS."""
    return int(node.get_parameter("commission_windows").value) or COMMISSION_WINDOWS


def recommission(node: Any) -> Outputs:
    """`~/commission`: the monitor's recommission from `commission_windows(node)` windows."""
    return node.service.recommission(commission_windows(node))


def add_services(node: Any) -> list[Any]:
    """Create the three services on a MonitorNode (its `service` and `_emit`)."""
    monitor = node.service
    requests: dict[str, Callable[[], Outputs]] = {
        "commission": lambda: recommission(node),
        "reset_prognosis": monitor.reset_prognosis,
        "fit_next_now": monitor.fit_next_now,
    }
    return [
        node.create_service(Trigger, f"~/{name}", _trigger(node, name, requests[name]))
        for name in SERVICES
    ]


def _trigger(
    node: Any, request_name: str, request: Callable[[], Outputs]
) -> Callable[[Any, Any], Any]:
    def serve(_request: Any, response: Any) -> Any:
        try:
            out = request()
        except EmaPhmError as exc:  # refused: said in the response, nothing changed
            response.success, response.message = False, str(exc)
            return response
        except Exception as exc:  # noqa: BLE001 - a node never dies from a callback
            reason = f"{type(exc).__name__}: {exc}"
            node._emit(node.service.fault(f"service {request_name}", reason))
            response.success, response.message = False, reason
            return response
        node._emit(out)  # the status and the log line, as any input's
        response.success = True
        response.message = out.logs[-1].text if out.logs else "done"
        return response

    return serve
