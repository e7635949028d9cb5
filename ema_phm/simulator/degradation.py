"""Faults that grow: the true fault vector k as a function of the operating cycle.

A degradation description says, per entry of k, how that fault evolves over the
actuator's life.  Each telemetry window is one operating cycle (for example one
pre-flight built-in test) with k held constant inside it; cycle c runs with
``Degradation.k(c)``.  ``cycle_hours`` maps cycles to operating hours.

Laws (c = cycle, c0 = ``onset``, v0 = ``initial``, r = ``rate``); before the onset
the entry keeps its healthy value (`domain.faults.NOMINAL`):

``linear``       k(c) = v0 + r (c - c0)              for c >= c0 (r in 1/cycle, r >= 0)
``exponential``  k(c) = v0 exp(r (c - c0))           for c >= c0 (v0 > 0, r in 1/cycle, r > 0)
``step``         k(c) = v0                           for c >= c0 (abrupt; no rate)

Which law fits which fault, with the thesis (chapter 4) in mind: dry friction and
backlash grow with wear (linear or exponential), a coil-coil short circuit
propagates (exponential), the static eccentricity grows with bearing wear (linear or
exponential).  The gain fault (k8) is abrupt, section 4.6: it may only be ``step``.
The eccentricity phase (k7) is a direction, not an amount of damage: also ``step``
only (it sets where the smallest air gap is).

``cap: true`` clamps a growing entry at 1 (the end of k's range); without it, a
cycle at which the law leaves [0, 1] is an error naming the fault, the cycle and
the value (`Degradation.check_cycles` checks a whole run before it is simulated).

YAML layout (`config/degradation_example.yaml`)::

    cycle_hours: 2.0          # optional: operating hours per cycle (window)
    faults:
      friction: {law: linear, onset: 10, initial: 0.0, rate: 0.01, cap: true}
      short_circuit_b: {law: exponential, onset: 5, initial: 0.02, rate: 0.05}

Fault names are those of `domain.faults.NAMES`.  Everything is deterministic.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Sequence

import numpy as np
import yaml

from ..domain.cycles import DEFAULT_CYCLE_HOURS, check_cycle_hours
from ..domain.faults import N_K, NAMES, NOMINAL, validate
from ..errors import ConfigError, FaultVectorError
from ..limits import FINITE, Limit, check

if TYPE_CHECKING:  # the HF (numba) is imported only when a run is simulated
    from ..physics.commands import CommandSpec, LoadSpec
    from ..physics.parameters import ActuatorParameters
    from .sensors import SensorSpec

#: Growth laws, in the order the docs list them.
LAWS: tuple[str, ...] = ("linear", "exponential", "step")
#: Entries that may only change abruptly: the eccentricity phase and the gain (sec. 4.6).
STEP_ONLY: tuple[str, ...] = ("eccentricity_phase", "gain_drift")
#: Keys a fault entry may hold.
FAULT_KEYS: tuple[str, ...] = ("law", "onset", "initial", "rate", "cap")
#: Keys the top level of a degradation file may hold.
TOP_KEYS: tuple[str, ...] = ("cycle_hours", "faults")
#: Largest onset cycle accepted (a billion cycles is far past any actuator's life).
MAX_ONSET = 1_000_000_000
#: Largest rate accepted [1/cycle]: linear 1/cycle crosses k's range in one cycle;
#: exponential 10/cycle multiplies k by e^10 per cycle.
MAX_RATE = {"linear": 1.0, "exponential": 10.0}
#: Range of a growing law's rate (a step has none).
RATE_LIMITS = {
    "linear": Limit(0.0, MAX_RATE["linear"], "per cycle"),
    "exponential": Limit(0.0, MAX_RATE["exponential"], "per cycle", low_open=True),
}
#: Range of an onset cycle, of a cycle number, of a run's number of windows.
ONSET_LIMIT = Limit(0, MAX_ONSET, integer=True)
CYCLE_LIMIT = Limit(0, math.inf, integer=True)
WINDOWS_LIMIT = Limit(1, math.inf, integer=True)


@dataclass(frozen=True)
class FaultGrowth:
    """How one entry of k evolves over cycles (see the module docstring for the laws)."""

    name: str  # one of domain.faults.NAMES
    law: str  # linear | exponential | step
    onset: int  # first cycle at which the fault is present [cycle]
    initial: float  # k at the onset cycle [normalized k]
    rate: float = 0.0  # growth rate [1/cycle]: k per cycle (linear) or e-folding rate (exp.)
    cap: bool = False  # clamp at 1 instead of refusing a k above 1

    def __post_init__(self) -> None:
        where = f"degradation of {self.name!r}"
        if self.name not in NAMES:
            raise ConfigError(
                f"degradation: unknown fault {self.name!r}; choose from {', '.join(NAMES)}"
            )
        if self.law not in LAWS:
            raise ConfigError(f"{where}: law must be one of {', '.join(LAWS)}, got {self.law!r}")
        if self.name in STEP_ONLY and self.law != "step":
            why = (
                "the gain fault is abrupt (thesis sec. 4.6)"
                if self.name == "gain_drift"
                else "the eccentricity phase is a direction, not an amount of damage"
            )
            raise ConfigError(f"{where}: law must be 'step' ({why}), got {self.law!r}")
        onset = check("onset", self.onset, limit=ONSET_LIMIT, label=f"{where}: onset")
        object.__setattr__(self, "onset", int(onset))
        initial = float(
            check("initial", self.initial, limit=Limit(0.0, 1.0), label=f"{where}: initial")
        )
        object.__setattr__(self, "initial", initial)
        object.__setattr__(self, "rate", self._checked_rate(where, initial))
        if not isinstance(self.cap, bool):
            raise ConfigError(f"{where}: cap must be true or false, got {self.cap!r}")

    def _checked_rate(self, where: str, initial: float) -> float:
        """The rate as a float within its law's range; ConfigError naming it if not."""
        if self.law == "step":
            rate = float(check("rate", self.rate, limit=FINITE, label=f"{where}: rate"))
            if rate != 0.0:
                raise ConfigError(
                    f"{where}: a step has no rate (it is abrupt), got rate {self.rate!r}"
                )
            return rate
        rate = float(
            check(
                "rate", self.rate, limit=RATE_LIMITS[self.law], label=f"{where}: {self.law} rate"
            )
        )
        if self.law == "exponential" and initial <= 0.0:
            raise ConfigError(
                f"{where}: exponential growth needs initial > 0 (0 stays 0), got {self.initial!r}"
            )
        return rate

    @property
    def index(self) -> int:
        """Position of this fault in k (0-based)."""
        return NAMES.index(self.name)

    def value(self, cycle: int) -> float:
        """The k of this entry at `cycle` (capped at 1 with `cap`; otherwise possibly above 1)."""
        c = _cycle(cycle)
        if c < self.onset:
            return float(NOMINAL[self.index])
        if self.law == "step":
            v = self.initial
        elif self.law == "linear":
            v = self.initial + self.rate * (c - self.onset)
        else:
            e = self.rate * (c - self.onset)
            v = math.inf if e > 700.0 else self.initial * math.exp(e)
        return min(v, 1.0) if self.cap else v

    def as_dict(self) -> dict[str, Any]:
        """The entry as its YAML mapping."""
        out: dict[str, Any] = {"law": self.law, "onset": self.onset, "initial": self.initial}
        if self.law != "step":
            out["rate"] = self.rate
        out["cap"] = self.cap
        return out


def _cycle(cycle: Any) -> int:
    """A cycle number (whole, >= 0) or ConfigError naming it."""
    return int(check("cycle", cycle, limit=CYCLE_LIMIT))


@dataclass(frozen=True)
class Degradation:
    """The faults that grow, one `FaultGrowth` per entry of k at most; the rest stay healthy."""

    faults: tuple[FaultGrowth, ...] = ()
    cycle_hours: float | None = None  # operating hours per cycle; None: not given
    source: str = ""  # where it was read from (for messages)

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for f in self.faults:
            if f.name in seen:
                raise ConfigError(f"degradation: fault {f.name!r} is described twice")
            seen.add(f.name)
        if self.cycle_hours is not None:
            object.__setattr__(
                self, "cycle_hours", check_cycle_hours(self.cycle_hours, label="cycle_hours")
            )

    def k(self, cycle: int) -> np.ndarray:
        """The true k of `cycle` (N_K entries); FaultVectorError naming fault, cycle and value.

        Raised when an uncapped law has left [0, 1] by then.
        """
        c = _cycle(cycle)
        k = NOMINAL.copy()
        for f in self.faults:
            v = f.value(c)
            if not 0.0 <= v <= 1.0:
                raise FaultVectorError(
                    f"degradation{' ' + self.source if self.source else ''}: "
                    f"{f.name} ({f.law}) reaches k{f.index + 1} = {v:.6g} at cycle {c}, outside "
                    f"[0, 1]; set cap: true or a smaller rate"
                )
            k[f.index] = v
        return validate(k)

    def trajectory(self, cycles: Sequence[int] | np.ndarray) -> np.ndarray:
        """The k of every cycle in `cycles`, shape (len(cycles), N_K)."""
        return np.array([self.k(int(c)) for c in cycles], dtype=np.float64).reshape(-1, N_K)

    def check_cycles(self, n: int) -> np.ndarray:
        """The k of cycles 0 .. n-1, shape (n, N_K): a whole run checked before it starts."""
        return self.trajectory(range(n))

    def hours_per_cycle(self, given: float | None = None) -> float:
        """`given` when not None, else this description's cycle_hours, else DEFAULT_CYCLE_HOURS.

        ConfigError when `given` is outside `limits.LIMITS["cycle_hours"]`.
        """
        if given is not None:
            return check_cycle_hours(given, label="cycle_hours")
        return self.cycle_hours if self.cycle_hours is not None else DEFAULT_CYCLE_HOURS

    def growth(self, name: str) -> FaultGrowth | None:
        """The description of fault `name`, None when it stays healthy."""
        if name not in NAMES:
            raise ConfigError(f"unknown fault {name!r}; choose from {', '.join(NAMES)}")
        return next((f for f in self.faults if f.name == name), None)

    def first_cycle_at(self, name: str, threshold: float, *, last: int = MAX_ONSET) -> int | None:
        """First cycle at which fault `name`'s severity |k - nominal| >= `threshold`.

        The true end of life of that fault for a failure threshold; None when it does not
        happen up to cycle `last` (a healthy entry, one capped or stepped below the threshold,
        the eccentricity phase).  Solved for linear and exponential laws, then checked
        against `value` cycle by cycle around the solution.
        """
        f = self.growth(name)
        if f is None or name == "eccentricity_phase":  # a direction has no severity
            return None
        nominal = float(NOMINAL[f.index])

        def sev(c: int) -> float:
            return abs(f.value(c) - nominal)

        if sev(f.onset) >= threshold:
            return f.onset if f.onset <= last else None
        if f.law == "step" or f.rate == 0.0:
            return None
        # smallest c >= onset with the law >= nominal + threshold (all growing laws increase)
        target = nominal + threshold
        if f.law == "linear":
            c = f.onset + math.ceil((target - f.initial) / f.rate - 1e-12)
        else:
            c = f.onset + math.ceil(math.log(target / f.initial) / f.rate - 1e-12)
        while c > f.onset and sev(c - 1) >= threshold:  # guard the ceil against rounding
            c -= 1
        while sev(c) < threshold:
            if c > last or (f.cap and f.value(c) >= 1.0):
                return None
            c += 1
        return c if c <= last else None

    def as_dict(self) -> dict[str, Any]:
        """The description as its YAML mapping."""
        out: dict[str, Any] = {}
        if self.cycle_hours is not None:
            out["cycle_hours"] = self.cycle_hours
        out["faults"] = {f.name: f.as_dict() for f in self.faults}
        return out

    @classmethod
    def from_mapping(cls, data: Any, *, source: str = "") -> Degradation:
        """Build from the YAML mapping; ConfigError naming the key and the value otherwise."""
        where = f"degradation {source}".strip()
        if not isinstance(data, Mapping):
            raise ConfigError(f"{where} must be a mapping, got {type(data).__name__}")
        unknown = sorted(set(map(str, data)) - set(TOP_KEYS))
        if unknown:
            raise ConfigError(
                f"{where}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(TOP_KEYS)}"
            )
        faults = data.get("faults", {})
        if faults is None:
            faults = {}
        if not isinstance(faults, Mapping):
            raise ConfigError(
                f"{where}: faults must be a mapping of fault name to its growth, "
                f"got {type(faults).__name__}"
            )
        entries = []
        for name, spec in faults.items():
            if not isinstance(spec, Mapping):
                raise ConfigError(
                    f"{where}: faults.{name} must be a mapping with keys "
                    f"{', '.join(FAULT_KEYS)}, got {spec!r}"
                )
            bad = sorted(set(map(str, spec)) - set(FAULT_KEYS))
            if bad:
                raise ConfigError(
                    f"{where}: faults.{name}: unknown key(s) {', '.join(bad)}; "
                    f"allowed: {', '.join(FAULT_KEYS)}"
                )
            for key in ("law", "onset", "initial"):
                if key not in spec:
                    raise ConfigError(f"{where}: faults.{name} has no {key!r}")
            if spec["law"] in ("linear", "exponential") and "rate" not in spec:
                raise ConfigError(f"{where}: faults.{name} ({spec['law']}) has no 'rate'")
            entries.append(
                FaultGrowth(
                    name=str(name),
                    law=spec["law"],
                    onset=spec["onset"],
                    initial=spec["initial"],
                    rate=spec.get("rate", 0.0),
                    cap=spec.get("cap", False),
                )
            )
        return cls(faults=tuple(entries), cycle_hours=data.get("cycle_hours"), source=str(source))

    @classmethod
    def load(cls, path: str | Path) -> Degradation:
        """Read a degradation YAML file (duplicate keys refused); ConfigError naming the file."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ConfigError(f"degradation file not found: {path}") from None
        except OSError as exc:
            raise ConfigError(f"cannot read degradation file {path}: {exc.strerror}") from None
        try:
            data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 (a SafeLoader)
        except yaml.YAMLError as exc:
            msg = " ".join(str(exc).split())
            raise ConfigError(f"degradation file {path} is not valid YAML: {msg}") from None
        return cls.from_mapping(data, source=str(path))


def simulate_cycles(
    degradation: Degradation,
    windows: int,
    *,
    actuator: ActuatorParameters | None = None,
    command: CommandSpec | None = None,
    load: LoadSpec | None = None,
    sensors: SensorSpec | None = None,
    seed: int = 0,
    temperature_c: float | None = None,
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Run the HF (`real_ema.HFStream`) for `windows` cycles; yield (cycle, k, new rows).

    Cycle c runs with ``degradation.k(c)``, held constant inside its window; every cycle's
    k is checked before the first sample is simulated.  The windows follow each other as
    ema_node streams them (sample j at t = j / sample_rate, N samples per window, the
    physical state carried over): window c holds samples cN .. (c+1)N, so consecutive
    windows share their boundary sample.  Cycle 0 yields samples 0 .. N (N + 1 rows in
    `domain.window.CHANNELS` order), cycle c >= 1 the N new samples cN+1 .. (c+1)N; the
    shared sample cN was simulated with the previous cycle's k (k changes at the boundary,
    as ema_node applies a new k).  Options as `real_ema.simulate`'s; the noise is drawn
    from one generator seeded with `seed`.
    """
    # the HF (numba) is imported only when cycles are simulated: reading a degradation file
    # stays light for the nodes' and the CLI's parameter checks
    from .real_ema import HFStream  # noqa: PLC0415

    windows = int(check("windows", windows, limit=WINDOWS_LIMIT))
    ks = degradation.check_cycles(windows)
    stream = HFStream(
        ks[0],
        actuator=actuator,
        command=command,
        load=load,
        sensors=sensors,
        seed=seed,
        temperature_c=temperature_c,
    )
    n = stream.samples_per_window
    for c in range(int(windows)):
        if c == 0:
            rows = stream.advance(n + 1)
        else:
            stream.set_k(ks[c])
            rows = stream.advance(n)
        yield c, ks[c].copy(), rows


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a mapping with a repeated key (PyYAML keeps the last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


# YAML 1.1 (PyYAML) reads `1e-3` (no dot) as the string "1e-3"; YAML 1.2 and every
# reader of this file mean the number.  "abc" stays a string and is refused with its key.
_UniqueKeyLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)
