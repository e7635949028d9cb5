"""Actuator health from an isolation result: thresholds -> level, message, severity.

The decision logic behind the monitor's `/ema/health` output and its verdicts: an
`Assessment` (level, dominant fault, message, severities) of a fit, free of rclpy so it
is testable without spinning a node.  What the monitor says about it on /diagnostics is
`ema_phm.monitor.status_texts`; the node copies `Assessment.vector()` into a
`std_msgs/Float64MultiArray`.

Severity and thresholds are the fault table's (`domain.faults`): a fault's distance
from its healthy value; a phase has none and its thresholds are ignored.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..domain.faults import (
    DEFAULT_ERROR,
    DEFAULT_WARN,
    LABELS,
    N_K,
    NAMES,
    NOMINAL,
    SEVERITY_INDICES,
    per_fault,
    percent_err,
    severity,
    validate,
)
from ..domain.health_layout import (  # noqa: F401  (the /ema/health layout)
    HEALTH_FIELDS,
    HEALTH_FIELDS_FIT,
    HEALTH_LABEL,
    HEALTH_RUL_FIELDS,
)
from ..errors import ConfigError

# DiagnosticStatus levels (diagnostic_msgs/msg/DiagnosticStatus).
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES: dict[int, str] = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}

#: When a fault with an interval is claimed (`assess`); the default chosen by
#: bench/bench_robust.py (docs/benchmarks_robust.md): the same healthy WARN rate, more faults
#: found than the lower-bound rule, whose intervals are wide where the model is biased.
DECISION_RULES: tuple[str, ...] = ("significant", "lower_bound")
DEFAULT_DECISION = "significant"


def severity_lower_bound(interval: np.ndarray) -> np.ndarray:
    """The smallest severity inside each entry's interval (0 when it holds the nominal).

    `interval` is (N_K, 2) [low, high]; an entry without severity (a phase) is 0.
    """
    iv = np.asarray(interval, dtype=np.float64)
    lo = np.maximum(0.0, np.maximum(iv[:, 0] - NOMINAL, NOMINAL - iv[:, 1]))
    lo[[i for i in range(N_K) if i not in SEVERITY_INDICES]] = 0.0
    return lo


def _warn_ratio(sev: np.ndarray, th: "Thresholds") -> np.ndarray:
    """Each fault's severity over its WARN threshold; -1 for an entry without severity."""
    ratio = np.full(N_K, -1.0)
    for i in SEVERITY_INDICES:
        ratio[i] = sev[i] / th.warn[i]
    return ratio


@dataclass(frozen=True)
class Thresholds:
    """Per-fault severity thresholds: WARN at >= warn[i], ERROR at >= error[i]."""

    warn: tuple[float, ...] = DEFAULT_WARN
    error: tuple[float, ...] = DEFAULT_ERROR

    def __post_init__(self) -> None:
        for name in ("warn", "error"):
            object.__setattr__(self, name, per_fault(f"{name}_threshold", getattr(self, name)))
        for i in SEVERITY_INDICES:
            w, e = self.warn[i], self.error[i]
            if not (math.isfinite(w) and math.isfinite(e)):
                raise ConfigError(
                    f"thresholds of {LABELS[i]} ({NAMES[i]}) must be finite, "
                    f"got warn {w}, error {e}"
                )
            if not 0.0 < w <= e:
                raise ConfigError(
                    f"thresholds of {LABELS[i]} ({NAMES[i]}) must satisfy 0 < warn <= error, "
                    f"got warn {w:g}, error {e:g}"
                )

    def level_of(self, sev: np.ndarray) -> np.ndarray:
        """Level (OK/WARN/ERROR) of each entry of a severity vector (a phase always OK)."""
        out = np.full(N_K, OK, dtype=int)
        for i in SEVERITY_INDICES:
            if sev[i] >= self.error[i]:
                out[i] = ERROR
            elif sev[i] >= self.warn[i]:
                out[i] = WARN
        return out


def format_value(v: Any) -> str:
    """A value as diagnostic KeyValue text ('nan' for missing numbers)."""
    if v is None:
        return "nan"
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return "nan" if not math.isfinite(float(v)) else f"{float(v):.6g}"
    return str(v)


@dataclass(frozen=True)
class Assessment:
    """One fitted window judged against the thresholds."""

    k: np.ndarray
    severity: np.ndarray
    levels: np.ndarray  # per entry, OK/WARN/ERROR
    level: int
    dominant: int  # index of the fault with the largest severity / warn threshold
    message: str
    percent_err: float  # NaN without ground truth
    fitness: float
    evaluations: int
    elapsed_s: float
    window_t0: float
    window_t1: float
    k_true: np.ndarray | None = None
    #: (N_K, 2) 90 % intervals; None when the fit gave none (levels then use k itself)
    k_interval: np.ndarray | None = None
    #: per entry (identifiable, reason)
    identifiable: tuple[tuple[bool, str], ...] | None = None
    #: {statistic, threshold, ok}; None when not measured
    adequacy: Mapping[str, Any] | None = None
    #: nuisance name -> value (nuisance.REPORTED_UNITS)
    nuisance: Mapping[str, float] = field(default_factory=dict)
    #: severity the decisions used: the interval's lower bound, or `severity`
    decision_severity: np.ndarray | None = None
    #: whether the belief was commissioned on this unit (None: not said, a bare `assess`)
    commissioned: bool | None = None
    #: entries the window's recording could not show, held healthy by the fit: index -> why
    unseen: Mapping[int, str] = field(default_factory=dict)
    #: the window's operating cycle when its stream numbers them (None: by its time)
    cycle: int | None = None

    def vector(self, prognosis: Mapping[str, float] | None = None) -> np.ndarray:
        """The `/ema/health` numbers in `HEALTH_FIELDS` order.

        `prognosis`: values of `domain.health_layout.HEALTH_RUL_FIELDS` (the tracker's
        `health_fields`); the RUL fields not given are NaN (``rul_dominant`` 0: none).
        """
        fields = {
            **dict.fromkeys(HEALTH_RUL_FIELDS, math.nan),
            "rul_dominant": 0.0,
            **(prognosis or {}),
            **{label: float(v) for label, v in zip(LABELS, self.k, strict=True)},
            "percent_err": self.percent_err,
            "fitness": self.fitness,
            "evaluations": float(self.evaluations),
            "elapsed_s": self.elapsed_s,
            "window_t0": self.window_t0,
            "window_t1": self.window_t1,
            "level": float(self.level),
        }
        return np.array([fields[name] for name in HEALTH_FIELDS], dtype=np.float64)

    def as_dict(self) -> dict[str, Any]:
        """The assessment as JSON-ready values (a non-finite percent_err as None)."""
        pe = None if not math.isfinite(self.percent_err) else float(self.percent_err)
        return {
            "level": LEVEL_NAMES[self.level],
            "message": self.message,
            "k": [float(v) for v in self.k],
            "k_true": None if self.k_true is None else [float(v) for v in self.k_true],
            "percent_err": pe,
            "severity": {NAMES[i]: float(self.severity[i]) for i in SEVERITY_INDICES},
            "dominant_fault": NAMES[self.dominant],
            "fitness": float(self.fitness),
            "evaluations": int(self.evaluations),
            "elapsed_s": float(self.elapsed_s),
            "window_t0": float(self.window_t0),
            "window_t1": float(self.window_t1),
            "cycle": self.cycle,
            "k_interval": None
            if self.k_interval is None
            else [[float(a), float(b)] for a, b in self.k_interval],
            "identifiable": None
            if self.identifiable is None
            else [
                {"name": NAMES[i], "ok": bool(ok), "reason": why}
                for i, (ok, why) in enumerate(self.identifiable)
            ],
            "adequacy": None if self.adequacy is None else dict(self.adequacy),
            "nuisance": {n: float(v) for n, v in self.nuisance.items()},
            "commissioned": self.commissioned,
            "unseen": {NAMES[i]: why for i, why in sorted(self.unseen.items())},
        }


def assess(
    k: Sequence[float] | np.ndarray,
    thresholds: Thresholds | None = None,
    *,
    k_true: Sequence[float] | np.ndarray | None = None,
    fitness: float = math.nan,
    evaluations: int = 0,
    elapsed_s: float = math.nan,
    window_t0: float = math.nan,
    window_t1: float = math.nan,
    k_interval: np.ndarray | None = None,
    identifiable: tuple[tuple[bool, str], ...] | None = None,
    adequacy: Mapping[str, Any] | None = None,
    nuisance: Mapping[str, float] | None = None,
    decision: str = DEFAULT_DECISION,
) -> Assessment:
    """Judge an isolated k: the worst per-fault level wins; the message names the worst fault.

    With `k_interval`, `decision` says when a fault is claimed: "significant" (default)
    when its estimate passes the threshold and its 90 % interval excludes the healthy
    value; "lower_bound" only when the whole interval is past the threshold
    (`severity_lower_bound`).  docs/benchmarks_robust.md measures both on healthy and
    faulty realistic windows.  With an `adequacy`
    that is not ok the window gets WARN "model does not explain this window" and no fault
    is claimed: a fit that does not explain the data isolates nothing.
    """
    th = thresholds or Thresholds()
    kk = validate(k)
    kt = None if k_true is None else validate(k_true)
    sev = severity(kk)
    interval = None if k_interval is None else np.asarray(k_interval, dtype=np.float64)
    dsev = _decision_severity(sev, interval, decision)
    ratio = _warn_ratio(dsev, th)
    if not ratio.max() > 0:  # nothing claimed: name the largest estimate
        ratio = _warn_ratio(sev, th)
    dom = int(np.argmax(ratio))
    judged = _Judged(kk, sev, dsev, th.level_of(dsev), dom, interval, decision)
    levels, level, message = _verdict(judged, th, adequacy)
    return Assessment(
        k=kk,
        severity=sev,
        levels=levels,
        level=level,
        dominant=dom,
        message=message,
        percent_err=math.nan if kt is None else percent_err(kk, kt),
        fitness=float(fitness),
        evaluations=int(evaluations),
        elapsed_s=float(elapsed_s),
        window_t0=float(window_t0),
        window_t1=float(window_t1),
        k_true=kt,
        k_interval=interval,
        identifiable=identifiable,
        adequacy=None if adequacy is None else dict(adequacy),
        nuisance=dict(nuisance or {}),
        decision_severity=dsev,
    )


def _verdict(
    j: _Judged, th: Thresholds, adequacy: Mapping[str, Any] | None
) -> tuple[np.ndarray, int, str]:
    """(levels, level, message): WARN and no fault claimed when the model does not fit."""
    if adequacy is not None and not adequacy.get("ok", True):
        message = (
            f"WARN: model does not explain this window (adequacy statistic "
            f"{float(adequacy['statistic']):.3g} > {float(adequacy['threshold']):.3g}); "
            f"no fault isolated"
        )
        if adequacy.get("stand_in_level"):
            message += (
                " (judged against the packaged actuator's healthy level: the actuator "
                "description gives none; commissioning measures the unit's)"
            )
        return np.full(N_K, OK, dtype=int), WARN, message
    level = int(j.levels.max())
    return j.levels, level, _message(j, level, th)


def _decision_severity(sev: np.ndarray, interval: np.ndarray | None, decision: str) -> np.ndarray:
    """The severity the levels are decided on under rule `decision` (`DECISION_RULES`)."""
    if decision not in DECISION_RULES:
        raise ConfigError(f"unknown decision rule {decision!r}; choose from {DECISION_RULES}")
    if interval is None:
        return sev
    if decision == "lower_bound":
        return severity_lower_bound(interval)
    # significant: the estimate decides, if its interval excludes the healthy value
    return np.where(severity_lower_bound(interval) > 0.0, sev, 0.0)


@dataclass(frozen=True)
class _Judged:
    """What `assess` decided, for the words of its message."""

    k: np.ndarray
    severity: np.ndarray
    decision_severity: np.ndarray
    levels: np.ndarray
    dominant: int
    interval: np.ndarray | None
    decision: str


def _message(j: _Judged, level: int, th: Thresholds) -> str:
    """The assessment's message: the level and the worst fault, then the others claimed."""
    dom, interval, dsev = j.dominant, j.interval, j.decision_severity
    name = NAMES[dom]
    bound_word = (
        ""
        if interval is None
        else " (90 % lower bound)"
        if j.decision == "lower_bound"
        else " (interval excludes healthy)"
    )
    if level == OK and interval is not None and j.decision == "significant":
        return (
            f"OK: no fault claimed: none has its estimate at or above its warn threshold with "
            f"its 90 % interval off healthy (largest: {name} severity {j.severity[dom]:.3f}, "
            f"interval [{interval[dom, 0]:.3f}, {interval[dom, 1]:.3f}], warn {th.warn[dom]:g})"
        )
    if level == OK:
        return (
            f"OK: no fault at or above its warn threshold{bound_word} (largest: {name} "
            f"severity {dsev[dom]:.3f} < {th.warn[dom]:g})"
        )
    levels = j.levels
    bound = th.error[dom] if levels[dom] == ERROR else th.warn[dom]
    which = "error" if levels[dom] == ERROR else "warn"
    shown = "" if interval is None else f" in [{interval[dom, 0]:.3f}, {interval[dom, 1]:.3f}]"
    message = (
        f"{LEVEL_NAMES[level]}: {name} ({LABELS[dom]} = {j.k[dom]:.3f}{shown}, severity "
        f"{dsev[dom]:.3f}{bound_word} >= {which} threshold {bound:g})"
    )
    others = [i for i in SEVERITY_INDICES if i != dom and levels[i] > OK]
    if others:
        message += "; also " + ", ".join(
            f"{NAMES[i]} ({LEVEL_NAMES[int(levels[i])]})" for i in others
        )
    return message


def assess_isolation(
    result: Any,
    thresholds: Thresholds | None = None,
    *,
    window_t0: float = math.nan,
    window_t1: float = math.nan,
) -> Assessment:
    """`assess` of an isolation.IsolationResult, with its intervals, flags and adequacy.

    An uncommissioned fit's message says so (`UNCOMMISSIONED`).
    """
    adequacy = None if result.adequacy is None else result.adequacy.as_dict()
    out = assess(
        result.k,
        thresholds,
        k_true=result.k_true,
        fitness=result.fitness,
        evaluations=result.evaluations,
        elapsed_s=result.wall_s,
        window_t0=window_t0,
        window_t1=window_t1,
        k_interval=result.k_interval,
        identifiable=result.identifiable,
        adequacy=adequacy,
        nuisance=result.nuisance,
    )
    commissioned = bool(getattr(result, "commissioned", True))
    message = out.message if commissioned else out.message + UNCOMMISSIONED
    unseen = dict(getattr(result, "unseen", None) or {})
    return dataclasses.replace(out, commissioned=commissioned, message=message, unseen=unseen)


def isolation_report(result: Any, verdict: Assessment) -> dict[str, Any]:
    """The fit and its verdict as `ema-phm isolate --json` prints them (and ~/run_test answers)."""
    out = dict(result.as_dict())
    out["level"] = LEVEL_NAMES[verdict.level]
    out["message"] = verdict.message
    return out


#: What an uncommissioned verdict adds to its message.
UNCOMMISSIONED = (
    "; uncommissioned: the belief is the actuator description, not this unit, and the "
    "intervals hold its unit-to-unit spread (config/unit_tolerances.yaml); commission it "
    "from healthy recordings (`ema-phm calibrate --baseline`) for a sharper answer"
)
