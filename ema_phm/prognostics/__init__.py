"""Prognostics: degradation-trend models, remaining useful life and its metrics.

- `trend.py`   Bayesian regression of one fault's severity on linear and exponential laws
- `rul.py`     per-fault RUL percentiles from a history of k estimates (`prognose`)
- `metrics.py` alpha-lambda, prognostic horizon, relative accuracy, interval coverage
"""
