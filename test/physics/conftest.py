"""Fixtures shared by the physics tests."""

from __future__ import annotations

import pytest

from ema_phm.physics import real_ema as hf
from ema_phm.physics.fault_vector import NOMINAL


@pytest.fixture(scope="module")
def nominal():
    return hf.simulate(NOMINAL).window
