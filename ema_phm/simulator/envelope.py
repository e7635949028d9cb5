"""The realistic operating envelope of a drawn unit: temperatures, unmeasured loads, noise.

The ranges every realistic scenario draws from, uniformly: the benchmarks
(bench/harness/scenarios.py) and the fleet generator (`ema_phm.fleet.generate`) read them
here.  In flight, a unit sees the whole range; in the hangar, where it is commissioned, a
mild part of it.
"""

from __future__ import annotations

from typing import Mapping

#: Operating temperature range [degC] of the windings and magnets: a cold-soaked actuator at
#: a cold-day dispatch to a warm motor after sustained duty.
TEMPERATURE_C = (-20.0, 70.0)
#: Unmeasured constant hinge moment at the user shaft [N*m]: up to about 6 % of the 845 N*m
#: the motor holds through the gear (a trimmed surface's residual hinge moment); the
#: issue-9 audit used 25 N*m.
LOAD_NM = (-50.0, 50.0)
#: Unmeasured hinge spring [N*m/rad]: up to 60 N*m at the 0.03 rad chirp amplitude, an
#: aerodynamic hinge moment growing with deflection.
SPRING_NM_PER_RAD = (0.0, 2000.0)
#: White-noise RMS on every channel, and why:
NOISE: Mapping[str, float] = {
    # 1 % of the 22.5 A current range, the level bench_isolation.py already uses (a
    # Hall-effect / shunt acquisition after the 2nd-order filter)
    "noise_current": 0.01 * 22.5,
    # 5e-5 rad: about 3 LSB of the 1.5e-5 rad user position resolution, 0.17 % of the
    # 0.03 rad chirp amplitude (an RVDT / LVDT read by a 16-bit converter)
    "noise_position": 5.0e-5,
    # 0.5 rad/s: about 2.5 resolver LSB (9.6e-5 rad) differentiated over a 0.5 ms sample,
    # 0.12 % of the chirp's 420 rad/s motor speed peak
    "noise_speed": 0.5,
}
#: Healthy ground windows a unit is commissioned from.
BASELINES = 2
#: The hangar, where a unit is commissioned: temperature [degC], small unmeasured loads.
HANGAR_C = (10.0, 30.0)
HANGAR_LOAD_NM = (-10.0, 10.0)
HANGAR_SPRING = (0.0, 300.0)
