"""Fixtures shared by the model tests."""

from __future__ import annotations

import pytest

from ema_phm.domain.faults import NOMINAL
from ema_phm.simulator import real_ema as hf


@pytest.fixture(scope="module")
def nominal():
    return hf.simulate(NOMINAL).window
