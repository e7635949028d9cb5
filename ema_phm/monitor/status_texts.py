"""What the monitor says on /diagnostics: every status, its message and key/values.

`HealthStatus` (level, message, values, as a `diagnostic_msgs/DiagnosticStatus` carries
them) for each thing the monitor can be doing: waiting, warming up, commissioning, a result
(`result_status` of a `diagnosis.health.Assessment`), a failure, busy, not excited, a fault,
stale.  `StatusContext` is what every status shows besides its cause (counters, settings,
prognosis, stream).  Free of rclpy, like a diagnostic_updater task function.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ..diagnosis.health import ERROR, LEVEL_NAMES, OK, STALE, Assessment, format_value
from ..domain.faults import (
    LABELS,
    NAMES,
    SEVERITY_INDICES,
)
from ..domain.health_layout import (  # noqa: F401  (the /ema/health layout)
    HEALTH_FIELDS,
    HEALTH_FIELDS_FIT,
    HEALTH_LABEL,
    HEALTH_RUL_FIELDS,
)

#: DiagnosticStatus.name of the actuator status the monitor publishes.
STATUS_NAME = "ema_phm: actuator"
#: Counters the monitor reports in every status.
COUNTERS: tuple[str, ...] = (
    "windows_done",
    "windows_skipped_busy",
    "windows_discarded",
    "isolation_failures",
    "windows_not_excited",
    "callback_errors",
    "tracking_restarts",
    "stream_changes",
    "telemetry_other_unit",
)
#: Default of the monitor's `stale_timeout` [s]: no telemetry for this long -> STALE.
DEFAULT_STALE_TIMEOUT = 5.0
#: Windows that may wait behind the running fit.  The first fit is a global search (~4 s on
#: 2 cores alone; 4.2-12.0 s measured beside ema_node at real time in one process, cause
#: not isolated) over 2 s windows; tracked fits (~0.65 s) then drain the queue.  Five
#: absorb a first fit of up to ~12 s without skipping a window (three skipped one at 8 s).
DEFAULT_QUEUE_DEPTH = 5


@dataclass(frozen=True)
class HealthStatus:
    """What goes into one `diagnostic_msgs/DiagnosticStatus` (level, message, key/values)."""

    level: int
    message: str
    values: tuple[tuple[str, str], ...]
    name: str = STATUS_NAME
    hardware_id: str = ""

    def value(self, key: str) -> str:
        """The value of `key` (KeyError if absent)."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)

    def as_dict(self) -> dict[str, Any]:
        """The status as a dict (level by name)."""
        return {
            "name": self.name,
            "hardware_id": self.hardware_id,
            "level": LEVEL_NAMES[self.level],
            "message": self.message,
            "values": dict(self.values),
        }


@dataclass
class StatusContext:
    """Everything besides the fit that a status reports (counters, settings)."""

    hardware_id: str = ""
    counters: Mapping[str, int] = field(default_factory=dict)
    settings: Mapping[str, Any] = field(
        default_factory=dict
    )  # preset, seed, fitness, max_evaluations
    #: the latest monitor.tracker.PrognosticSummary; None: prognostics off
    prognostics: Any | None = None
    #: identity of the telemetry stream being assembled ("" before any, "anonymous")
    stream: str = ""


def _values(
    a: Assessment | None, ctx: StatusContext, extra: Mapping[str, Any] | None = None
) -> tuple[tuple[str, str], ...]:
    nan = math.nan
    vals: list[tuple[str, str]] = []
    for i, label in enumerate(LABELS):
        vals.append((label, format_value(a.k[i] if a is not None else nan)))
    vals.append(("percent_err", format_value(a.percent_err if a is not None else nan)))
    if a is not None:
        vals.append(("dominant_fault", NAMES[a.dominant]))
        for i in SEVERITY_INDICES:
            vals.append((f"severity_{NAMES[i]}", format_value(a.severity[i])))
        vals += _uncertainty_values(a)
    vals += [
        ("fitness", format_value(a.fitness if a is not None else nan)),
        ("evaluations", format_value(a.evaluations if a is not None else 0)),
        ("elapsed_s", format_value(a.elapsed_s if a is not None else nan)),
        ("window_t0", format_value(a.window_t0 if a is not None else nan)),
        ("window_t1", format_value(a.window_t1 if a is not None else nan)),
    ]
    for c in COUNTERS:
        vals.append((c, format_value(int(ctx.counters.get(c, 0)))))
    if ctx.stream:
        vals.append(("stream", ctx.stream))
    for key, v in ctx.settings.items():
        vals.append((key, format_value(v)))
    if ctx.prognostics is not None:
        for key, v in ctx.prognostics.diagnostic_values().items():
            vals.append((key, format_value(v)))
    for key, v in (extra or {}).items():
        vals.append((key, format_value(v)))
    return tuple(vals)


def _uncertainty_values(a: Assessment) -> list[tuple[str, str]]:
    """Intervals, identifiability, adequacy and nuisances as KeyValues (absent: nothing)."""
    vals: list[tuple[str, str]] = []
    if a.k_interval is not None:
        for i, label in enumerate(LABELS):
            vals.append((f"{label}_low", format_value(a.k_interval[i, 0])))
            vals.append((f"{label}_high", format_value(a.k_interval[i, 1])))
    if a.identifiable is not None:
        for label, (ok, why) in zip(LABELS, a.identifiable, strict=True):
            vals.append((f"identifiable_{label}", "true" if ok else f"false: {why}"))
    if a.adequacy is not None:
        for key in ("statistic", "threshold", "ok"):
            vals.append((f"adequacy_{key}", format_value(a.adequacy[key])))
    for name, v in a.nuisance.items():
        vals.append((f"nuisance_{name}", format_value(v)))
    if a.commissioned is not None:  # false: judged against the actuator description
        vals.append(("commissioned", "true" if a.commissioned else "false"))
    return vals


def with_prognosis(status: HealthStatus, prognostics: Any | None) -> HealthStatus:
    """`status` at the larger of its level and the prognosis's (`PrognosticSummary.level`).

    When the prognosis raises it (a fault's RUL 5th percentile below the horizon), the
    message starts with the reason; otherwise the status is returned as it is.
    """
    if prognostics is None or prognostics.level <= status.level:
        return status
    level = prognostics.level
    message = f"{LEVEL_NAMES[level]}: prognosis: {prognostics.warning}; {status.message}"
    return dataclasses.replace(status, level=level, message=message)


def result_status(a: Assessment, ctx: StatusContext) -> HealthStatus:
    """Status after a successful isolation."""
    return HealthStatus(a.level, a.message, _values(a, ctx), hardware_id=ctx.hardware_id)


def failure_status(
    reason: str,
    ctx: StatusContext,
    last: Assessment | None = None,
    window_t0: float = math.nan,
    window_t1: float = math.nan,
) -> HealthStatus:
    """ERROR: the isolation of a window failed; the last good fit's values are kept."""
    one_line = " ".join(str(reason).split())
    msg = f"ERROR: isolation failed on window t = {window_t0:g}..{window_t1:g} s: {one_line}"
    return HealthStatus(
        ERROR, msg, _values(last, ctx, {"last_error": reason}), hardware_id=ctx.hardware_id
    )


def commissioning_status(detail: str, ctx: StatusContext, *, level: int = OK) -> HealthStatus:
    """OK while the monitor commissions itself from its first windows (assumed healthy).

    WARN (`level`) when it refused to commission from them (they look faulty, disagree, do
    not excite the actuator, or the commissioned fit does not explain the unit) or
    commissioned with a warning (a factor that ran to a search bound).
    """
    return HealthStatus(
        level,
        f"commissioning: {detail}",
        _values(None, ctx, {"commissioning": detail}),
        hardware_id=ctx.hardware_id,
    )


def waiting_status(ctx: StatusContext, detail: str = "no window fitted yet") -> HealthStatus:
    """OK (nothing known against the actuator yet): before the first complete window."""
    return HealthStatus(
        OK, f"waiting for telemetry: {detail}", _values(None, ctx), hardware_id=ctx.hardware_id
    )


def warming_up_status(ctx: StatusContext) -> HealthStatus:
    """OK while the monitor runs its fit paths once before it subscribes to telemetry."""
    return HealthStatus(
        OK,
        "warming up: compiling the monitor's fit on a synthetic window; telemetry is "
        "subscribed to after it",
        _values(None, ctx, {"warming_up": True}),
        hardware_id=ctx.hardware_id,
    )


def busy_status(
    last: HealthStatus | None,
    last_assessment: Assessment | None,
    ctx: StatusContext,
    *,
    window_t0: float,
    window_t1: float,
    evaluations: int,
) -> HealthStatus:
    """Heartbeat while a window is being isolated: the previous level, message 'isolating…'."""
    level = last.level if last is not None else OK
    msg = f"isolating… window t = {window_t0:g}..{window_t1:g} s, {evaluations} evaluations so far"
    if last is not None and last_assessment is not None:
        msg += f" (last result: {last.message})"
    return HealthStatus(
        level, msg, _values(last_assessment, ctx, {"isolating": True}), hardware_id=ctx.hardware_id
    )


def not_excited_status(
    reason: str, ctx: StatusContext, window_t0: float, window_t1: float
) -> HealthStatus:
    """OK, not assessed: the window did not excite the actuator enough to identify k.

    No k and no fault are claimed (the actuator is not accused of anything); the
    values carry `assessed: false` and the reason.
    """
    msg = (
        f"not enough excitation on window t = {window_t0:g}..{window_t1:g} s, not assessed: "
        f"{' '.join(str(reason).split())}"
    )
    window = {"window_t0": format_value(window_t0), "window_t1": format_value(window_t1)}
    vals = tuple(
        (k, window.get(k, v))
        for k, v in _values(None, ctx, {"assessed": False, "excitation": reason})
    )
    return HealthStatus(OK, msg, vals, hardware_id=ctx.hardware_id)


def fault_status(
    where: str, reason: str, ctx: StatusContext, last: Assessment | None = None
) -> HealthStatus:
    """ERROR: the monitor itself hit a problem (bad input, a callback that raised).

    The last good fit's values are kept, the reason is in `last_error`.
    """
    msg = f"ERROR: {where}: {' '.join(str(reason).split())}"
    return HealthStatus(
        ERROR, msg, _values(last, ctx, {"last_error": reason}), hardware_id=ctx.hardware_id
    )


def is_stale(telemetry_age_s: float, stale_timeout_s: float) -> bool:
    """True when the last telemetry is older than the timeout (a NaN age, unknown, is stale)."""
    return not telemetry_age_s <= stale_timeout_s


def stale_status(
    telemetry_age_s: float,
    stale_timeout_s: float,
    ctx: StatusContext,
    last: Assessment | None = None,
) -> HealthStatus:
    """STALE: no telemetry for longer than `stale_timeout_s`; the last fit's values are kept."""
    msg = f"STALE: no telemetry for {telemetry_age_s:.1f} s (stale_timeout {stale_timeout_s:g} s)"
    extra = {"stale": True, "telemetry_age_s": telemetry_age_s}
    return HealthStatus(STALE, msg, _values(last, ctx, extra), hardware_id=ctx.hardware_id)


def current_status(
    status: HealthStatus,
    *,
    telemetry_age_s: float,
    stale_timeout_s: float,
    ctx: StatusContext,
    last: Assessment | None = None,
) -> HealthStatus:
    """What a heartbeat reports: `status`, or STALE once the telemetry is older than the timeout.

    Fresh telemetry brings `status` (the last result) back unchanged.
    """
    if is_stale(telemetry_age_s, stale_timeout_s):
        return stale_status(telemetry_age_s, stale_timeout_s, ctx, last)
    return status


def parse_values(values: Mapping[str, str] | Sequence[tuple[str, str]]) -> dict[str, Any]:
    """KeyValue strings back to numbers where they are numbers (for readers of /diagnostics)."""
    items = values.items() if isinstance(values, Mapping) else values
    out: dict[str, Any] = {}
    for key, v in items:
        try:
            f = float(v)
        except ValueError:
            out[key] = v
            continue
        out[key] = (
            int(f) if key in COUNTERS or key in ("evaluations", "seed", "max_evaluations") else f
        )
    return out
