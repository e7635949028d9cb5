"""Window: eight channels, a temperature that defaults to unknown, NaN only where unmeasured."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.domain.window import CHANNELS, LEGACY_CHANNELS, Window, telemetry_rows
from ema_phm.errors import WindowError
from ema_phm.telemetry import wire
from ema_phm.telemetry.bags import ROSBAGS_CLASSES

N = 60


def rows(n: int = N, width: int = len(CHANNELS)) -> np.ndarray:
    out = np.random.default_rng(4).normal(size=(n, width))
    out[:, 0] = np.arange(n) / 2000.0
    return out


def test_the_temperature_is_the_eighth_channel_after_the_legacy_seven():
    assert CHANNELS[7] == "temperature" and len(CHANNELS) == 8
    assert LEGACY_CHANNELS == CHANNELS[:7] and LEGACY_CHANNELS[-1] == "i3eq"


def test_a_window_built_without_temperature_has_an_unknown_one():
    a = rows()
    cols = {c: a[:, i] for i, c in enumerate(LEGACY_CHANNELS)}
    w = Window(**cols)
    assert w.temperature.shape == (N,) and np.isnan(w.temperature).all()
    assert w.matrix().shape == (N, 8) and w.validated() is w


def test_matrix_round_trip_keeps_the_temperature():
    a = rows()
    w = Window.from_matrix(a)
    np.testing.assert_array_equal(w.temperature, a[:, 7])
    np.testing.assert_array_equal(w.matrix(), a)


def test_legacy_rows_get_a_nan_temperature_and_other_widths_are_refused():
    a = rows(width=7)
    out = telemetry_rows(a)
    assert out.shape == (N, 8) and np.isnan(out[:, 7]).all()
    np.testing.assert_array_equal(out[:, :7], a)
    for bad in (np.zeros((3, 6)), np.zeros((3, 9)), np.zeros(8)):
        with pytest.raises(WindowError, match=rf"got shape \({bad.shape[0]}"):
            telemetry_rows(bad)


@pytest.mark.parametrize("channel", ["load", "temperature"])
def test_nan_means_unmeasured_in_load_and_temperature_only(channel):
    a = rows()
    a[:, CHANNELS.index(channel)] = np.nan
    Window.from_matrix(a).validated()
    a[5, CHANNELS.index(channel)] = np.inf
    with pytest.raises(WindowError, match=rf"channel '{channel}' has 1 infinite samples"):
        Window.from_matrix(a).validated()


@pytest.mark.parametrize("channel", [c for c in CHANNELS if c not in ("load", "temperature")])
def test_nan_in_a_measured_channel_is_refused(channel):
    a = rows()
    a[7, CHANNELS.index(channel)] = np.nan
    with pytest.raises(WindowError, match=rf"channel '{channel}' has 1 non-finite"):
        Window.from_matrix(a).validated()


def test_legacy_seven_channel_message_decodes_with_unknown_temperature():
    legacy = rows(13, 7)
    msg = wire.to_message(wire.encode_array(legacy, wire.TELEMETRY_LABELS), ROSBAGS_CLASSES)
    out = wire.decode_telemetry(msg)
    assert out.shape == (13, 8) and np.isnan(out[:, 7]).all()
    np.testing.assert_array_equal(out[:, :7], legacy)


def test_eight_channel_message_round_trip_with_nan_load():
    a = rows(13)
    a[:, 2] = np.nan  # an unmeasured load travels as NaN
    parts = wire.encode_telemetry(a)
    assert parts.sizes == (13, 8) and parts.strides == (104, 8)
    out = wire.decode_telemetry(wire.to_message(parts, ROSBAGS_CLASSES))
    np.testing.assert_array_equal(out, a)


def test_encoder_refuses_the_legacy_width():
    with pytest.raises(WindowError, match=r"n x 8 .*got shape \(13, 7\)"):
        wire.encode_telemetry(rows(13, 7))


def test_an_unmeasured_load_is_taken_as_no_load_by_the_monitor():
    from dataclasses import replace

    from ema_phm.diagnosis.fitness import Fitness
    from ema_phm.domain.faults import NOMINAL
    from ema_phm.model.monitor_model import MonitorModel
    from ema_phm.physics.commands import CommandSpec, LoadSpec
    from ema_phm.simulator import real_ema

    hf = real_ema.simulate(NOMINAL, command=CommandSpec(duration=0.2), load=LoadSpec(value=30.0))
    unmeasured = replace(hf.window, load=np.full(hf.window.n, np.nan))
    unloaded = replace(hf.window, load=np.zeros(hf.window.n))
    np.testing.assert_array_equal(
        MonitorModel(unmeasured).simulate(NOMINAL), MonitorModel(unloaded).simulate(NOMINAL)
    )
    assert not np.array_equal(
        MonitorModel(hf.window).simulate(NOMINAL), MonitorModel(unloaded).simulate(NOMINAL)
    )
    assert np.isfinite(Fitness(unmeasured)(NOMINAL))
