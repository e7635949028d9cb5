"""The estimator: fits one window, by a global search or tracked from a previous result.

`Estimator` is what the monitor's policy (`policy.FitPolicy`) asks for; any object with a
`fit` of this form will do (progpy's spirit: the estimator behind a small interface).
`IsolationEstimator` is the default: `diagnosis.isolation.isolate` with fixed keyword arguments.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Protocol

import numpy as np

from ..diagnosis.isolation import IsolationResult, isolate
from ..domain.window import Window


class Estimator(Protocol):
    """Fits k to one window."""

    def fit(self, window: Window, start: np.ndarray | None = None) -> IsolationResult:
        """Fit `window`: a global search, or tracked from `start` (a previous result's row)."""
        ...


@dataclass(frozen=True)
class IsolationEstimator:
    """`isolate(window, start=start, **options)`; `function` replaces `isolate` (e.g. a test's)."""

    options: Mapping[str, Any] = field(default_factory=dict)
    function: Callable[..., IsolationResult] = isolate

    def fit(self, window: Window, start: np.ndarray | None = None) -> IsolationResult:
        """Fit `window`: a global search, or tracked from `start` (a previous result's row)."""
        return self.function(window, start=start, **self.options)
