"""Pacer: waits until wall time reaches the simulated time, re-anchors when far behind."""

from __future__ import annotations

import pytest

from ema_phm.simulator.pacing import MAX_LAG_S, Pacer


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_waits_for_the_last_sample_time_scaled_by_the_factor():
    clock = Clock()
    pacer = Pacer(2.0, clock=clock)
    assert pacer.delay(0.0, 1.0) == pytest.approx(0.5)
    clock.now += 0.5
    assert pacer.delay(1.0, 2.0) == pytest.approx(0.5)


def test_zero_factor_never_waits():
    assert Pacer(0.0).delay(0.0, 100.0) == 0.0


def test_far_behind_reanchors_and_reports_the_lag_once():
    clock = Clock()
    pacer = Pacer(1.0, clock=clock)
    pacer.delay(0.0, 0.0)
    clock.now += 1.0 + MAX_LAG_S + 0.5
    assert pacer.delay(0.0, 1.0) == 0.0
    assert pacer.first_lag() == pytest.approx(MAX_LAG_S + 0.5) and pacer.first_lag() is None
    assert pacer.delay(1.0, 2.0) == pytest.approx(1.0)  # paced from the new anchor
