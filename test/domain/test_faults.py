"""The fault table: one consistent record per k entry, and what is derived from it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ema_phm.domain import faults
from ema_phm.domain.faults import FAULTS, N_K, NOMINAL, FaultValues, fault, k_with
from ema_phm.domain.health_layout import HEALTH_FIELDS_FIT, HEALTH_RUL_FIELDS
from ema_phm.errors import FaultVectorError


def test_each_record_sits_at_its_index_with_a_unique_name_and_label():
    assert [f.index for f in FAULTS] == list(range(N_K))
    assert len(set(faults.NAMES)) == N_K
    assert faults.LABELS == tuple(f"k{i + 1}" for i in range(N_K))
    assert all(f.name.isidentifier() for f in FAULTS)  # a message field name


def test_records_are_consistent():
    for f in FAULTS:
        assert 0.0 <= f.nominal <= 1.0, f.name
        if f.is_phase:
            assert fault(f.phase_of).index != f.index and not fault(f.phase_of).is_phase
            assert (f.warn, f.error, f.has_rul, f.probes) == (0.0, 0.0, False, ())
        else:
            assert 0.0 < f.warn < f.error <= max(f.nominal, 1.0 - f.nominal), f.name
            assert f.probes and all(0.0 <= p <= 1.0 and p != f.nominal for p in f.probes)
        if f.has_rul:
            assert f.law_prior is not None and math.isclose(sum(f.law_prior.values()), 1.0)
            assert f.severity_scale is not None
        else:
            assert f.no_rul_because


def test_derived_constants_follow_the_table():
    assert NOMINAL.tolist() == [f.nominal for f in FAULTS]
    assert not NOMINAL.flags.writeable
    assert faults.PREDICTED == tuple(f.index for f in FAULTS if f.has_rul)
    assert set(faults.LAW_PRIORS) == {FAULTS[i].name for i in faults.PREDICTED}
    assert HEALTH_FIELDS_FIT[:N_K] == faults.LABELS
    assert len(HEALTH_RUL_FIELDS) == 3 * len(faults.PREDICTED) + 1


def test_named_views_and_builders():
    k = k_with(friction=0.3, gain_drift=0.7)
    assert FaultValues(k).friction == 0.3 and FaultValues(k).gain_drift == 0.7
    assert FaultValues(k).backlash == fault("backlash").nominal
    assert faults.severity(k)[fault("gain_drift").index] == pytest.approx(0.2)
    with pytest.raises(FaultVectorError, match="unknown fault 'frction'"):
        k_with(frction=0.3)
    with pytest.raises(FaultVectorError, match=f"expected {N_K} values"):
        FaultValues(np.zeros(N_K - 1))


def test_a_phase_has_no_severity_and_wraps_in_percent_err():
    ((amount, phase),) = faults.phase_pairs()
    k = k_with(**{FAULTS[amount].name: 0.5, FAULTS[phase].name: 0.99})
    assert faults.severity(k)[phase] == 0.0
    near = k.copy()
    near[phase] = 0.01  # 0.02 turn away across the wrap, not 0.98
    assert faults.percent_err(near, k) == pytest.approx(100.0 * math.sqrt(0.5 * 0.02**2))


def test_an_unknown_name_is_an_attribute_error_so_copy_and_hasattr_work():
    import copy

    values = FaultValues(k_with(friction=0.3))
    assert not hasattr(values, "frction")
    assert copy.copy(values).friction == 0.3
