"""Prognostic metrics against a hand-worked example (ema_phm/prognostics/metrics.py).

The example: true end of life t_EoL = 100, predictions at t = 20, 40, 60, 80 (true RUL
80, 60, 40, 20), each given as four RUL samples; alpha = 0.2, beta = 0.5, lambda = 0.5.

t   r*  samples              alpha-lambda bounds (1 +/- 0.2) r*   PH bounds r* +/- 0.2*100
20  80  30, 40, 50, 110      [64, 96]: none      -> 0.00          [60, 100]: none -> 0.00
40  60  45, 55, 62, 70       [48, 72]: 55,62,70  -> 0.75          [40, 80]: all   -> 1.00
60  40  30, 38, 41, 60       [32, 48]: 38,41     -> 0.50          [20, 60]: all   -> 1.00
80  20  10, 12, 14, 30       [16, 24]: none      -> 0.00          [0, 40]:  all   -> 1.00

- t_lambda = 20 + 0.5 * (100 - 20) = 60: alpha-lambda at 60 holds (0.50 >= 0.5);
  from lambda = 0.5 on it does not (t = 80 fails).
- PH: first met at t = 40 -> PH = 100 - 40 = 60.
- RA (median): t=20: 1 - |80 - 45|/80 = 0.5625; t=40: 1 - |60 - 58.5|/60 = 0.975;
  t=60: 1 - |40 - 39.5|/40 = 0.9875; t=80: 1 - |20 - 13|/20 = 0.65; CRA = 0.79375.
- Coverage of the intervals [35, 105], [46, 69], [31, 58], [10.5, 18]: the last misses
  r* = 20 -> 3/4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ema_phm.errors import ConfigError
from ema_phm.prognostics import metrics

T = [20.0, 40.0, 60.0, 80.0]
S = [[30, 40, 50, 110], [45, 55, 62, 70], [30, 38, 41, 60], [10, 12, 14, 30]]
EOL = 100.0


def test_alpha_lambda_hand_worked():
    assert metrics.alpha_lambda(T, S, EOL, alpha=0.2, lam=0.5, beta=0.5) is True
    assert metrics.alpha_lambda(T, S, EOL, alpha=0.2, lam=0.5, beta=0.6) is False
    assert metrics.alpha_lambda(T, S, EOL, alpha=0.2, lam=0.25, beta=0.5) is True  # t = 40
    assert metrics.alpha_lambda(T, S, EOL, alpha=0.2, lam=0.0, beta=0.5) is False  # t = 20
    assert metrics.alpha_lambda_from(T, S, EOL, alpha=0.2, lam=0.5, beta=0.5) is False
    assert metrics.alpha_lambda_from(T[:3], S[:3], EOL, alpha=0.2, lam=0.5) is True
    # no prediction in [t_lambda, t_EoL)
    assert metrics.alpha_lambda([20.0], [S[0]], EOL, lam=0.5) is None


def test_prognostic_horizon_hand_worked():
    assert metrics.prognostic_horizon(T, S, EOL, alpha=0.2, beta=0.5) == 60.0
    # a tighter alpha (bounds +/- 5): t = 40 holds 55, 62 -> 0.5; PH stays 60
    assert metrics.prognostic_horizon(T, S, EOL, alpha=0.05, beta=0.5) == 60.0
    # asking for all the mass within +/- 5: t=40 no (45, 70 out), t=60 no, t=80 no
    assert metrics.prognostic_horizon(T, S, EOL, alpha=0.05, beta=1.0) == 0.0


def test_relative_accuracy_hand_worked():
    assert metrics.relative_accuracy(S[2], 60.0, EOL) == pytest.approx(0.9875)
    assert metrics.relative_accuracy(S[0], 20.0, EOL) == pytest.approx(0.5625)
    assert metrics.cumulative_relative_accuracy(T, S, EOL) == pytest.approx(0.79375)
    assert metrics.relative_accuracy([np.inf], 20.0, EOL) == -math.inf


def test_interval_coverage_hand_worked():
    low, high = [35, 46, 31, 10.5], [105, 69, 58, 18]
    assert metrics.interval_coverage(T, low, high, EOL) == pytest.approx(0.75)
    # predictions at or after the end of life are not scored
    assert math.isnan(metrics.interval_coverage([100.0, 120.0], [0, 0], [1, 1], EOL))


def test_no_prediction_as_inf_meets_no_bound():
    s = [[np.inf]] * 4
    assert metrics.prognostic_horizon(T, s, EOL) == 0.0
    assert metrics.alpha_lambda(T, s, EOL) is False


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: metrics.alpha_lambda(T, S[:3], EOL), "4 prediction times but 3"),
        (lambda: metrics.alpha_lambda([40, 20, 60, 80], S, EOL), "increasing"),
        (lambda: metrics.alpha_lambda(T, S, EOL, alpha=0.0), r"alpha must be .* got 0\.0"),
        (lambda: metrics.alpha_lambda(T, S, EOL, lam=1.5), r"lambda must be .* got 1\.5"),
        (lambda: metrics.prognostic_horizon(T, S, math.nan), "end of life"),
        (lambda: metrics.interval_coverage(T, [1, 2, 3, 4], [0, 9, 9, 9], EOL), "low 1 > high 0"),
        (lambda: metrics.relative_accuracy(S[0], 100.0, EOL), "t < t_EoL"),
    ],
)
def test_bad_input_names_the_problem(call, match):
    with pytest.raises(ConfigError, match=match):
        call()
