"""bench/bench_import.py: every form imports, and the scores count what they say."""

from __future__ import annotations

import numpy as np
import pytest

from bench import bench_import as bi
from ema_phm.domain.faults import NAMES, NOMINAL


@pytest.fixture(scope="module")
def unit_windows():
    return bi.windows_of(1, 0)  # healthy, then backlash 0.6 (FAULTS[1])


def test_a_unit_has_a_healthy_and_a_faulty_window(unit_windows):
    (h, kh, _, _), (f, kf, _, fast) = unit_windows
    assert h == "healthy" and np.array_equal(kh, NOMINAL)
    assert f == "backlash" and kf[NAMES.index("backlash")] == pytest.approx(0.6)
    window, phases = fast
    assert window.dt == pytest.approx(1 / bi.PHASE_RATE) and phases.shape == (window.n, 3)


@pytest.mark.parametrize("form", list(bi.VARIANTS))
def test_every_form_imports_back_to_one_window(form, unit_windows):
    _, k, w, fast = unit_windows[1]
    kind, cmap = bi.VARIANTS[form]
    got, cost = bi.imported(kind, cmap, w, fast)
    assert got.n == w.n and np.array_equal(got.k_true, k)
    assert cost["bytes"] > 0 and cost["import_s"] > 0
    if form in ("bag", "csv", "parquet", "no_temperature"):
        assert np.allclose(got.i3eq, w.i3eq) and np.allclose(got.omega_m, w.omega_m)
    if form == "no_temperature":
        assert np.isnan(got.temperature).all()
    if form == "no_encoder":
        assert got.meta["channels"]["theta_m"].startswith("derived")
    if form == "phases_20khz":  # the fast run's own I_3eq, within the phases' noise and ripple
        acquired = fast[0].i3eq[:: round(bi.PHASE_RATE / 2000.0)]
        rms = float(np.sqrt(np.mean(acquired**2)))
        assert float(np.sqrt(np.mean((got.i3eq - acquired) ** 2))) < 0.1 * rms
    if form == "iq_1khz":  # every other sample interpolated
        assert np.allclose(got.i3eq[::2], w.i3eq[::2])
        assert not np.allclose(got.i3eq[1::2], w.i3eq[1::2])


def _row(index, window, form, seed, k, **kw):
    base = {"explained": True, "level": 0, "dominant": 0, "unseen": [], "percent_err": 1.0}
    kt = NOMINAL.copy()
    return {
        "index": index,
        "window": window,
        "form": form,
        "seed": seed,
        "k": list(k),
        "k_true": list(kt),
        **base,
        **kw,
    }


def test_the_scores_count_what_they_say():
    k0 = NOMINAL.copy()
    k1 = k0.copy()
    k1[0] = 0.02
    rows = [
        _row(0, "healthy", "native", 0, k0),
        _row(0, "healthy", "native", 1, k1),
        _row(0, "healthy", "bag", 0, k1),
        _row(0, "healthy", "no_encoder", 0, k0, level=1, dominant=1, unseen=[1]),
        _row(0, "backlash", "no_encoder", 0, k0, level=1, dominant=0, unseen=[1]),
    ]
    eq = bi.equivalence(rows)
    assert eq["import"] == [pytest.approx(0.02)] and eq["seed"] == [pytest.approx(0.02)]
    forms = bi.per_form(rows)
    assert forms["no_encoder"]["false_alarms"] == (1, 1)
    assert forms["no_encoder"]["unseen_claims"] == 1
    assert forms["no_encoder"]["named"] == (0, 1)  # friction named, the truth is backlash
    text = bi.report({"rows": rows, "command": "x", "units": 1, "seed": 0})
    assert "| no_encoder | 2 |" in text
