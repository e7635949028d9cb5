"""monitor_node: the prognostics node.  Telemetry in, fault isolation, health out.

Subscribes
  /ema/telemetry     std_msgs/Float64MultiArray  (telemetry layout, see ema_node); with
                     telemetry_input:=batch /ema/telemetry_batch ema_phm_msgs/TelemetryBatch
  /ema/run_info      std_msgs/String             JSON: sample_rate, samples_per_window, k history
  /ema/ground_truth  std_msgs/Float64MultiArray  true k, for percent_err only: kept by an
                     evaluation listener beside the monitor (`evaluation.live_truth`)
  or, with channel_map_file, the rig's topics its channel map names instead of the first two
                     (`mapped_inputs`; docs/your_recordings.md)
Publishes
  /ema/window        std_msgs/Float64MultiArray  exactly the window being fitted (telemetry layout)
  /ema/health        std_msgs/Float64MultiArray  one dim labelled wire.HEALTH_LABEL
                     (`domain.health_layout`, from the fault table): every k entry,
                     percent_err, fitness, evaluations, elapsed_s, window_t0, window_t1,
                     level, then the prognosis after the window: RUL percentiles 5/50/95
                     [cycles] of every fault with a RUL, and rul_dominant
  /diagnostics       diagnostic_msgs/DiagnosticArray  status "<node's full name>: actuator"
                     without the leading slash, as diagnostic_updater names it
                     (`status_name`: "monitor_node: actuator", "left/monitor_node: actuator"),
                     after every result and every `heartbeat_period` s
  /ema/window_batch  ema_phm_msgs/TelemetryBatch  the fitted window, typed (with /ema/window)
  /ema/actuator_health  ema_phm_msgs/ActuatorHealth  with every /diagnostics status: level,
                     message and the named k entries of the last fit (`assessed` true on
                     the message of the fit itself), each with its remaining life (`rul`)
                     and `no_degradation_detected` from the latest prognosis
Services (std_srvs/Trigger, `ema_phm.ros.services`)
  ~/commission, ~/reset_prognosis, ~/fit_next_now
Action
  ~/run_test         ema_phm_msgs/action/RunTest  command a test excitation on
                     run_test_command_topic (only with run_test_enabled), record, fit, answer
                     the verdict (`run_test_action`; docs/ros.md)
The /ema/... names are relative to the node's namespace (`common.RelativeTopics`): under
`-r __ns:=/left` they are /left/ema/...; /diagnostics stays absolute.  A recording names
them as above whatever the namespace.

`actuator_file` (read-only) names the actuator watched: the belief is built from that file
(`model.belief.belief_for`, at start-up only); '' = the packaged belief.

A shell over `ema_phm.monitor.health_monitor.HealthMonitor`, which decides
everything (windows, skipping while busy, statuses, counters, staleness, prognoses); this
node decodes the messages, forwards them, and publishes and logs what it returns
(`monitor_outputs.MonitorOutputs`); `monitor_settings` builds the HealthMonitor from the
parameters and checks their changes, `monitor_recording.NodeRecording` writes the bag.

With `warm_up` (default) the worker thread first runs the fit once on a synthetic window
(`ema_phm.diagnosis.warm_up`; /diagnostics says "warming up", OK and never STALE) and
only then are the inputs subscribed to, so an ema_node with `wait_for_subscribers` holds
its telemetry until the monitor is ready.  With `prognostics` (default) every explained fit feeds a
`monitor.tracker.PrognosticTracker`: /diagnostics carries the RUL key/values
(``prognosis``, ``rul_<fault>_cycles_p50``, ...) and is at least WARN once a degrading
fault's RUL 5th percentile has been below `rul_horizon_cycles` in `rul_alarm_windows`
consecutive prognoses (default 2).
Windows are fitted by an `IsolationWorker` thread so the executor keeps spinning;
shutdown (destroy_node; SIGINT/SIGTERM through `common.spin_main`) cancels a
running isolation.  Whatever a callback raises is reported as ERROR on
/diagnostics (`callback_errors`) and the node keeps serving; a failed write to
the recording is only logged (reporting it would be recorded again).

With `record_bag`, everything received (raw telemetry, run_info, ground truth) and
published (window, window_batch, health, diagnostics, actuator_health) goes to a rosbag2
MCAP bag, closed on shutdown; raw subscriptions, so the bag holds the bytes that were on the wire.
"""

from __future__ import annotations

import sys
from typing import Any

from rclpy.node import Node

from .common import RelativeTopics, spin_main
from .monitor_core import NODE_NAME, MonitorCore, WarmUp
from .monitor_outputs import STATUS_TASK, diagnostic_array, status_name
from .monitor_recording import RECORD_TOPICS
from .parameters import declare_all

__all__ = [
    "NODE_NAME",
    "RECORD_TOPICS",
    "STATUS_TASK",
    "MonitorNode",
    "WarmUp",
    "diagnostic_array",
    "main",
    "status_name",
]


class MonitorNode(RelativeTopics, MonitorCore, Node):
    """monitor_node: built, started and subscribed in its constructor (`ros2 run`)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        try:
            values = declare_all(self, self.PARAMETERS)
            self._build(values)
            self._start(warm_up=values["warm_up"])
        except BaseException:  # a bad parameter, or a stop signal during start-up
            self._abandon()
            raise

    def _abandon(self) -> None:
        """Undo a build cut short: stop the worker, finish an opened bag, destroy the node."""
        self.close()
        Node.destroy_node(self)

    def destroy_node(self) -> None:
        """Close (see `close`), then destroy the node."""
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """The `monitor_node` executable."""
    return spin_main(MonitorNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
