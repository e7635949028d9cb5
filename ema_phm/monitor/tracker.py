"""Live prognostics: a monitor's per-window history, and the prognosis after each window.

`PrognosticTracker.observe(assessment)` hands a fitted window to its `policy.FitPolicy`,
which counts it or not, adds it to the history and runs the predictor (`rul.prognose`);
`PrognosticSummary` says what the monitor reports from the result: the dominant prognosis,
its level contribution (WARN), the /diagnostics key/values, the typed `RemainingLife`
entries and the JSON.  No rclpy.

Which windows count: `window_rule.WindowRule` decides (through the policy), the same rule as
the offline replay (`ema-phm prognose`): a fit the model does not explain (adequacy not ok),
a duplicated cycle or a step back within a run is not counted, with its reason
(`PrognosticSummary.last_skipped`, on /diagnostics as ``prognosis_last_skipped``); nothing is
cleared.  A new run (the stream's
``hardware_id`` / ``run_id`` in its run_info, `note_run_info`) starts a new history.  Windows
not assessed (not excited, failed) never reach the tracker.

Cycle of a window: each window is one operating cycle, numbered round(t0 / (t1 - t0)),
its start time over its duration (as `cycle_bags.read_cycle_windows` numbers a monitor's
recording), or the cycle its stream gave it (windows cut by excitation are numbered in
order: `span_assembler`).  Windows skipped while busy or not counted so leave gaps instead
of shifting the later ones.

Alarm: a fault is "imminent" (the level WARN) once its RUL 5th percentile has been below
the horizon in `alarm_windows` consecutive prognoses (default 2).  A single window's
excursion on a fault that does not grow can make a short steep trend whose p5 dips below
the horizon once; on the 96 non-growing faults of the prognostics benchmark's degrading
trajectories, 7 had a p5 below the horizon in some single prognosis, 2 in two consecutive
ones (docs/benchmarks_prognostics.md); on its first 15 trajectories a growing fault's first
WARN came one window later with 2 than with 1.

Memory: the newest `max_windows` entries (default `MAX_WINDOWS`); older ones are dropped,
so the trend is fitted on that stretch only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

from ..domain.faults import NAMES
from ..domain.health_layout import HEALTH_RUL_FIELDS
from ..errors import ConfigError
from ..limits import Limit, check
from ..prognostics.learn import load_growth_priors
from ..prognostics.rul import FaultPrognosis, Prognosis, failure_thresholds
from ..prognostics.rul import growth_priors as rul_growth_priors
from ..telemetry.typed import RemainingLife
from .policy import FitPolicy
from .predictor import RulPredictor
from .window_rule import run_identity

#: History entries kept (a prognosis of 500 entries: 40 ms median of 7 on an idle 2-core EPYC).
MAX_WINDOWS = 500
#: Allowed history caps: a trend needs two entries.
MAX_WINDOWS_LIMIT = Limit(2, math.inf, integer=True)
#: Level contributions (the diagnostic_msgs levels, as `health`).
OK, WARN = 0, 1


def window_cycle(fitted: Any) -> int:
    """A fitted window's operating cycle: the one its stream gave, else `cycle_of` its times."""
    given = getattr(fitted, "cycle", None)
    return int(given) if given is not None else cycle_of(fitted.window_t0, fitted.window_t1)


def cycle_of(t0: float, t1: float) -> int:
    """The operating cycle of a window from t0 to t1 [s]: round(t0 / (t1 - t0))."""
    duration = float(t1) - float(t0)
    if not (math.isfinite(duration) and duration > 0 and math.isfinite(float(t0))):
        raise ConfigError(f"window t = {t0!r}..{t1!r} s has no cycle: its span must be > 0")
    return int(round(float(t0) / duration))


def _number_text(v: float) -> Any:
    """A value, infinity as the text 'inf' (health's formatter shows non-finite floats as nan)."""
    return "inf" if v == math.inf else v


@dataclass(frozen=True)
class PrognosticSummary:
    """What the monitor reports from one prognosis (None: no window counted yet)."""

    prognosis: Prognosis | None
    windows: int  # entries in the history
    not_counted: int  # fitted windows left out (`window_rule`: not explained, out of order)
    horizon_cycles: int
    cycle_hours: float
    persisting: frozenset[str] = frozenset()  # faults below the horizon long enough to warn
    last_skipped: str = ""  # why the last window not counted was left out

    @property
    def degrading(self) -> tuple[FaultPrognosis, ...]:
        """The faults with a RUL."""
        return () if self.prognosis is None else self.prognosis.degrading

    @property
    def dominant(self) -> FaultPrognosis | None:
        """The degrading fault with the smallest median RUL; None when none degrades."""
        faults = self.degrading
        return min(faults, key=lambda f: f.rul[0].p50) if faults else None

    @property
    def no_degradation_detected(self) -> bool:
        """True when a prognosis with enough data found no fault degrading."""
        if self.prognosis is None or self.degrading:
            return False
        return any(f.status == "no_degradation" for f in self.prognosis.faults)

    @property
    def imminent(self) -> tuple[FaultPrognosis, ...]:
        """Degrading faults whose RUL 5th percentile has stayed below the horizon (alarm)."""
        return tuple(
            f
            for f in self.degrading
            if f.rul[0].p5 < self.horizon_cycles and f.name in self.persisting
        )

    @property
    def level(self) -> int:
        """WARN when a fault is imminent (`imminent`), else OK."""
        return WARN if self.imminent else OK

    @property
    def headline(self) -> str:
        """The dominant prognosis in one line."""
        f = self.dominant
        if f is not None:
            c, h = f.rul
            return (
                f"{f.name} degrading: RUL {c.p50:g} cycles [{c.p5:g}, {c.p95:g}] "
                f"({h.p50:.4g} h [{h.p5:.4g}, {h.p95:.4g}])"
            )
        if self.prognosis is None:
            return "no prognosis yet: no explained window"
        if self.no_degradation_detected:
            return "no degradation detected"
        short = next((f for f in self.prognosis.faults if f.status == "insufficient_data"), None)
        if short is None:  # every fault with a RUL is one the recordings cannot show
            return "no prognosis: the recordings show no fault that has a RUL"
        return f"no prognosis yet: {short.message}"

    @property
    def warning(self) -> str:
        """Why the level is WARN ('' when it is OK)."""
        soon = self.imminent
        if not soon:
            return ""
        return "; ".join(
            f"{f.name} RUL p5 {f.rul[0].p5:g} cycles < horizon {self.horizon_cycles} "
            f"cycles (p50 {f.rul[0].p50:g}, P(within horizon) {f.p_within_horizon:.2f})"
            for f in soon
        )

    def diagnostic_values(self) -> dict[str, Any]:
        """/diagnostics key/values: the dominant prognosis, statuses, each degrading RUL."""
        dominant = self.dominant
        out: dict[str, Any] = {
            "prognosis": self.headline,
            "prognosis_dominant_fault": "" if dominant is None else dominant.name,
            "prognosis_windows": self.windows,
            "prognosis_not_counted": self.not_counted,
            "prognosis_last_skipped": self.last_skipped,
            "prognosis_cycle": math.nan if self.prognosis is None else self.prognosis.cycle,
            "rul_horizon_cycles": self.horizon_cycles,
            "cycle_hours": self.cycle_hours,
        }
        if self.prognosis is None:
            return out
        for f in self.prognosis.faults:
            out[f"prognosis_status_{f.name}"] = f.status
        for f in self.degrading:
            for unit, pct in zip(("cycles", "hours"), f.rul, strict=True):
                for p, v in (("p5", pct.p5), ("p50", pct.p50), ("p95", pct.p95)):
                    out[f"rul_{f.name}_{unit}_{p}"] = _number_text(v)
            out[f"rul_{f.name}_p_within_horizon"] = f.p_within_horizon
        return out

    def remaining_life(self) -> tuple[RemainingLife, ...]:
        """One `RemainingLife` per k entry: filled for degrading faults, NaN otherwise.

        A percentile beyond every sampled crossing stays inf (never reached).
        """
        out = [RemainingLife()] * len(NAMES)
        horizon_hours = self.horizon_cycles * self.cycle_hours
        for f in self.degrading:
            c, h = f.rul
            out[f.index] = RemainingLife(
                c.p5, c.p50, c.p95, h.p5, h.p50, h.p95, horizon_hours, f.p_within_horizon
            )
        return tuple(out)

    def health_fields(self) -> dict[str, float]:
        """The `/ema/health` prognosis values (`wire.HEALTH_RUL_FIELDS`).

        RUL percentiles in cycles of each degrading fault (inf: never reached), NaN for the
        others; ``rul_dominant`` the 1-based k entry of `dominant`, 0 when none.
        """
        out = dict.fromkeys(HEALTH_RUL_FIELDS, math.nan)
        for f in self.degrading:
            c = f.rul[0]
            for name, v in zip(("p5", "p50", "p95"), (c.p5, c.p50, c.p95), strict=True):
                out[f"rul_k{f.index + 1}_{name}"] = float(v)
        dominant = self.dominant
        out["rul_dominant"] = 0.0 if dominant is None else float(dominant.index + 1)
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values: the headline, the level contribution and the prognosis."""
        dominant = self.dominant
        return {
            "headline": self.headline,
            "level": "WARN" if self.level == WARN else "OK",
            "warning": self.warning,
            "dominant_fault": None if dominant is None else dominant.name,
            "no_degradation_detected": self.no_degradation_detected,
            "windows": self.windows,
            "not_counted": self.not_counted,
            "last_skipped": self.last_skipped,
            "horizon_cycles": self.horizon_cycles,
            "prognosis": None if self.prognosis is None else self.prognosis.as_dict(),
        }


class PrognosticTracker:
    """The history of a monitor's counted windows and the prognosis after each one."""

    def __init__(
        self,
        *,
        thresholds: Sequence[float] | None = None,
        cycle_hours: float | None = 1.0,
        horizon_cycles: int = 10,
        alarm_windows: int = 2,
        max_windows: int = MAX_WINDOWS,
        growth_priors: Mapping[str, Any] | None = None,
    ) -> None:
        """ConfigError naming a bad threshold, cycle_hours, horizon, cap or growth prior.

        `cycle_hours` None: the stream's (`note_stream_cycle_hours`), 1 until it tells.
        `growth_priors`: `rul.prognose`'s (None: the fault table's; {}: none).
        """
        self.growth_priors = growth_priors
        if growth_priors is not None:
            rul_growth_priors(growth_priors)  # checked here, not at the first prognosis
        self.thresholds = failure_thresholds(thresholds)
        self.follows_stream = cycle_hours is None
        self.cycle_hours = 1.0 if cycle_hours is None else float(check("cycle_hours", cycle_hours))
        self.horizon_cycles = int(check("rul_horizon_cycles", horizon_cycles))
        self.alarm_windows = int(check("rul_alarm_windows", alarm_windows))
        self._streak: dict[str, int] = {}  # consecutive prognoses with p5 below the horizon
        self.max_windows = int(check("max_windows", max_windows, limit=MAX_WINDOWS_LIMIT))
        #: which windows count, their estimates and the predictor (the policy's count half)
        self.policy = FitPolicy(self._predictor(), max_windows=self.max_windows)
        self.not_counted = 0
        self.run: tuple[str, ...] | None = None  # the stream's identity (`note_run_info`)
        self.summary = PrognosticSummary(None, 0, 0, self.horizon_cycles, self.cycle_hours)

    def _predictor(self) -> RulPredictor:
        return RulPredictor(
            self.thresholds,
            self.cycle_hours,
            float(self.horizon_cycles),
            growth_priors=self.growth_priors,
        )

    def fresh(self) -> PrognosticTracker:
        """A tracker with these settings and no history (e.g. after maintenance)."""
        new = PrognosticTracker(
            thresholds=list(self.thresholds),
            cycle_hours=None if self.follows_stream else self.cycle_hours,
            horizon_cycles=self.horizon_cycles,
            alarm_windows=self.alarm_windows,
            max_windows=self.max_windows,
            growth_priors=self.growth_priors,
        )
        if self.follows_stream:
            new.note_stream_cycle_hours(self.cycle_hours)
        return new

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> PrognosticTracker | None:
        """From monitor_node parameter values; None when `prognostics` is false."""
        if not values["prognostics"]:
            return None
        return cls(
            thresholds=list(values["failure_thresholds"]),
            cycle_hours=values["cycle_hours"] or None,  # 0: the stream's
            horizon_cycles=values["rul_horizon_cycles"],
            alarm_windows=values["rul_alarm_windows"],
            growth_priors=load_growth_priors(values.get("growth_priors_file", "")),
        )

    def note_stream_cycle_hours(self, value: Any) -> None:
        """The stream's hours per cycle (run_info), used when constructed with None.

        ConfigError naming a bad value; ignored when the tracker has its own.
        """
        if self.follows_stream and value is not None:
            self.cycle_hours = float(check("cycle_hours", value))
            self.policy.predictor = self._predictor()
            self.summary = replace(self.summary, cycle_hours=self.cycle_hours)

    def note_run_info(self, info: Mapping[str, Any]) -> None:
        """A run_info object: its cycle_hours (`note_stream_cycle_hours`) and its run identity.

        A window of another run than the last fitted one starts a new history.
        """
        self.run = run_identity(info)
        self.note_stream_cycle_hours(info.get("cycle_hours"))

    @property
    def streak(self) -> dict[str, int]:
        """Per fault, consecutive prognoses with its RUL p5 below the horizon (the alarm's)."""
        return dict(self._streak)

    def resume(
        self,
        observed: Sequence[tuple[tuple[str, ...] | None, Any]],
        streak: Mapping[str, int],
        *,
        seed: int = 0,
    ) -> PrognosticSummary:
        """Rebuild the state `observe` left after windows observed before; the summary.

        `observed`: (run identity, fitted window) of every window `observe` was given, in
        order (a fleet store's rows); `streak`: `streak` as it was after the last of them.
        The windows are counted without a prognosis each; the one prognosis is made from the
        history the last counted window left, with `seed`, as `observe` made it (the
        prognosis depends only on the history and the seed).
        """
        summary = PrognosticSummary(None, 0, 0, self.horizon_cycles, self.cycle_hours)
        for run, fitted in observed:
            self.run = run
            cycle = float(window_cycle(fitted))
            counted = self.policy.count(cycle, fitted, run, prognose=False)
            if counted.verdict.new_run:  # as `observe`: a new life's summary starts empty
                summary = replace(summary, last_skipped="")
            if not counted.verdict.counts:
                self.not_counted += 1
                summary = replace(summary, last_skipped=counted.verdict.reason)
        self._streak = {str(k): int(v) for k, v in streak.items()}
        prognosis = None
        if self.windows:
            prognosis = self.policy.predictor.predict(self.policy.estimates.history(), seed=seed)
        self.summary = self._summary_of(prognosis, summary.last_skipped)
        return self.summary

    def _summary_of(self, prognosis: Prognosis | None, last_skipped: str) -> PrognosticSummary:
        """The summary after `prognosis` (None: none yet), the alarm from the streak."""
        persisting = frozenset(n for n, c in self._streak.items() if c >= self.alarm_windows)
        return PrognosticSummary(
            prognosis,
            self.windows,
            self.not_counted,
            self.horizon_cycles,
            self.cycle_hours,
            persisting if prognosis is not None else frozenset(),
            last_skipped,
        )

    @property
    def windows(self) -> int:
        """Entries in the history."""
        return len(self.policy.estimates)

    def observe(self, assessment: Any, *, seed: int = 0) -> PrognosticSummary:
        """Add a fitted window (a `health.Assessment`) if it counts; prognose; the summary.

        A window that does not count leaves the prognosis as it was (see the module
        docstring); `seed` seeds `rul.prognose`.
        """
        cycle = float(window_cycle(assessment))
        counted = self.policy.count(cycle, assessment, self.run, seed=int(seed))
        if counted.verdict.new_run:  # another run of the stream: a new life
            self._streak.clear()
            self.summary = PrognosticSummary(
                None, 0, self.not_counted, self.horizon_cycles, self.cycle_hours
            )
        if not counted.verdict.counts or counted.prognosis is None:
            self.not_counted += 1
            self.summary = replace(
                self.summary, not_counted=self.not_counted, last_skipped=counted.verdict.reason
            )
            return self.summary
        prognosis = counted.prognosis
        for f in prognosis.faults:
            below = f.status == "degrading" and f.rul[0].p5 < self.horizon_cycles
            self._streak[f.name] = self._streak.get(f.name, 0) + 1 if below else 0
        self.summary = self._summary_of(prognosis, self.summary.last_skipped)
        return self.summary
