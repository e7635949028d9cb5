"""monitor_lifecycle_node: monitor_node as a managed (lifecycle) node.

The same monitor, topics, services and parameters as `monitor_node`, brought up by a lifecycle
manager through the standard lifecycle services (``~/change_state``, ``~/get_state``, ...):

- **configure** checks every parameter, reads the actuator, unit and growth-prior files, builds
  the belief and the monitor, its publishers, worker, services and recording.  A failure (a bad
  file, a bad value, an existing bag) leaves the node unconfigured; the reason is logged as an
  error and kept in `configure_error`.
- **activate** says the first status and subscribes to the inputs (after the warm-up, as
  monitor_node does).
- **deactivate** unsubscribes the inputs: nothing new is fitted; a fit already running or
  queued still ends and is published; the history and the prognosis are kept.
- **cleanup** stops the worker, finishes the bag and destroys what configure made; configure
  can then run again with changed parameters.
- **shutdown** does what cleanup does, from any state.

Parameters are declared when the node is made (so `ros2 param` reaches it unconfigured) and
checked at configure.  `ros2 run ema_phm monitor_lifecycle_node`; the plain `monitor_node`
stays for `ros2 run` without a manager.
"""

from __future__ import annotations

import sys
from typing import Any

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from ..errors import EmaPhmError
from .common import PARAMETER_ERRORS, RelativeTopics, spin_main
from .monitor_core import NODE_NAME, MonitorCore
from .parameters import declare_all

#: What a failed configure is (reported, the node stays unconfigured): a bad parameter value,
#: a file that cannot be read or is not what it should be, a bag that cannot be opened.
CONFIGURE_ERRORS: tuple[type[BaseException], ...] = (*PARAMETER_ERRORS, EmaPhmError, OSError)


class MonitorLifecycleNode(RelativeTopics, MonitorCore, LifecycleNode):
    """monitor_node as a managed node: built at configure, subscribed at activate."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        declare_all(self, self.PARAMETERS, check=False)
        self.configure_error = ""  # why the last configure failed ('' = it did not)
        self._built = False

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Check the parameters and build the monitor; FAILURE (unconfigured) with the reason."""
        try:
            values = self.PARAMETERS.validated(
                {spec.name: self.get_parameter(spec.name).value for spec in self.PARAMETERS}
            )
            self._build(values)
        except CONFIGURE_ERRORS as exc:
            self.configure_error = " ".join(str(exc).split()) or type(exc).__name__
            self.get_logger().error(f"configure failed: {self.configure_error}")
            self._teardown()  # whatever of the build was made
            return TransitionCallbackReturn.FAILURE
        self._warm_up = bool(values["warm_up"])
        self._built, self.configure_error = True, ""
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Say the first status and subscribe to the inputs (after the warm-up)."""
        self._start(warm_up=self._warm_up)
        self._warm_up = False  # warmed up once: a re-activation subscribes at once
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Unsubscribe the inputs; the history, the prognosis and a fit under way are kept."""
        self._unsubscribe_inputs()
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Stop the worker, finish the bag, destroy what configure made."""
        self._tear_down_if_built()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """As cleanup, from whatever state the node is in."""
        self._tear_down_if_built()
        return TransitionCallbackReturn.SUCCESS

    def _tear_down_if_built(self) -> None:
        if self._built:
            self._built = False
            self._teardown()

    def destroy_node(self) -> None:
        """Tear down (see `on_cleanup`), then destroy the node."""
        self._tear_down_if_built()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """The `monitor_lifecycle_node` executable."""
    return spin_main(MonitorLifecycleNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
