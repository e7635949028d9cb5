"""Excitation check: windows that cannot identify k are refused before the fit, with a reason."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.diagnosis import excitation
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.domain.window import CHANNELS, Window
from ema_phm.errors import ConfigError, ExcitationError
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema as hf

NOISE = 0.01 * 22.5  # 1 % of the current full scale
#: Accepted windows must clear the threshold by this factor, so that another machine's
#: rounding (or a small model change) cannot flip the verdict.
MARGIN = 3.0
FRICTION = np.array([0.5, 0, 0, 0, 0, 0, 0.5, 0.5])


def chirp_window(amplitude: float, *, k: np.ndarray = NOMINAL, noise: float = 0.0) -> Window:
    return hf.simulate(
        k, command=CommandSpec(amplitude=amplitude), seed=3, noise_current=noise
    ).window


def zero_window(n: int = 4001) -> Window:
    t = np.arange(n) / 2000.0
    return Window.from_matrix(np.column_stack([t] + [np.zeros(n)] * (len(CHANNELS) - 1)))


@pytest.fixture(scope="module")
def zero_amplitude():
    return chirp_window(0.0)


@pytest.mark.parametrize(
    "make",
    [
        lambda: chirp_window(0.0),
        zero_window,
        lambda: chirp_window(1e-4),
        lambda: chirp_window(1e-4, noise=NOISE),
        lambda: chirp_window(1e-4, k=FRICTION),
    ],
    ids=["amplitude-0", "all-zero-telemetry", "1e-4-rad", "1e-4-rad-noisy", "1e-4-rad-friction"],
)
def test_unexciting_window_is_refused_before_the_fit(make):
    window = make()
    seen = []
    with pytest.raises(ExcitationError):
        isolate(window, seed=0, on_progress=seen.append)
    assert seen == []  # refused before any generation ran
    assert not excitation.measure(window).ok


def test_a_1e_4_rad_chirp_is_below_the_threshold_by_a_margin():
    assert excitation.measure(chirp_window(1e-4)).separation < excitation.THRESHOLD / MARGIN


@pytest.mark.parametrize(
    "k,noise",
    [
        (NOMINAL, 0.0),
        (NOMINAL, NOISE),
        (FRICTION, 0.0),
        (FRICTION, NOISE),
        (np.array([0, 0, 0, 0.4, 0, 0, 0.5, 0.5]), NOISE),
    ],
    ids=["healthy", "healthy-noisy", "friction", "friction-noisy", "short-b-noisy"],
)
def test_default_window_is_accepted_with_margin(k, noise):
    window = hf.simulate(k, seed=1, noise_current=noise).window  # the default 2 s, 0.03 rad chirp
    ex = excitation.measure(window)
    assert ex.ok
    assert ex.separation > MARGIN * ex.threshold
    assert ex.reason.startswith("excitation ok")


def test_short_test_windows_are_accepted_with_margin():
    for duration in (0.3, 1.0):  # the windows test_cli and test_isolation fit
        ex = excitation.measure(
            hf.simulate(NOMINAL, command=CommandSpec(duration=duration)).window
        )
        assert ex.separation > MARGIN * ex.threshold, duration


def test_error_is_one_line_naming_the_measured_value_and_the_threshold(zero_amplitude):
    with pytest.raises(ExcitationError) as info:
        isolate(zero_amplitude)
    msg = str(info.value)
    assert "\n" not in msg
    assert "not enough excitation" in msg
    assert "probe separation 0 (all 8 probes score the same;" in msg
    assert f"threshold {excitation.THRESHOLD:g}" in msg
    assert "command RMS 0 rad" in msg


def test_error_names_the_weakest_probe_when_one_is_weakest():
    ex = excitation.measure(chirp_window(1e-4))
    assert not ex.ok and ex.weakest in excitation.PROBES
    assert f"(weakest probe: {ex.weakest};" in ex.reason and "below the threshold" in ex.reason


def test_check_excitation_false_bypasses_the_check(zero_amplitude):
    res = isolate(zero_amplitude, preset="de", seed=0, max_evaluations=80, check_excitation=False)
    assert res.k.shape == (N_K,)


def test_threshold_is_bounded_and_zero_accepts_everything(zero_amplitude):
    assert excitation.measure(zero_amplitude, threshold=0.0).ok
    for bad in (-1.0, float("nan"), "x"):
        with pytest.raises(ConfigError, match="excitation_threshold"):
            excitation.measure(zero_amplitude, threshold=bad)


def test_separation_is_zero_for_the_reference_and_not_counted_as_evaluations():
    fit = Fitness(hf.simulate(FRICTION, command=CommandSpec(duration=0.3)).window)
    sep = fit.separation(np.vstack([NOMINAL, FRICTION]), NOMINAL)
    assert sep[0] == 0.0 and sep[1] > 0.0
    assert fit.evaluations == 0


def test_every_fault_family_has_a_probe():
    ks = np.vstack(list(excitation.PROBES.values()))
    moved = np.any(ks != NOMINAL, axis=0)
    assert list(np.flatnonzero(moved)) == [0, 1, 2, 3, 4, 5, 7]  # k7 (phase) needs eccentricity
