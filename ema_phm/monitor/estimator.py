"""The estimator: fits one window, by a global search or tracked from a previous result.

`Estimator` is what the monitor's policy (`policy.FitPolicy`) asks for; any object with a
`fit` of this form will do (progpy's spirit: the estimator behind a small interface).
`IsolationEstimator` is the default: `diagnosis.isolation.isolate` with fixed keyword arguments.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Protocol

import numpy as np

from ..diagnosis import isolation
from ..diagnosis.isolation import IsolationResult
from ..domain.window import Window


class Estimator(Protocol):
    """Fits k to one window."""

    def fit(self, window: Window, start: np.ndarray | None = None) -> IsolationResult:
        """Fit `window`: a global search, or tracked from `start` (a previous result's row)."""
        ...


@dataclass(frozen=True)
class IsolationEstimator:
    """`isolate(window, start=start, **options)`; `function` replaces `isolate` (e.g. a test's).

    Without `function`, `isolation.isolate` is looked up at each fit.
    """

    options: Mapping[str, Any] = field(default_factory=dict)
    function: Callable[..., IsolationResult] | None = None

    def fit(self, window: Window, start: np.ndarray | None = None) -> IsolationResult:
        """Fit `window`: a global search, or tracked from `start` (a previous result's row)."""
        fit = isolation.isolate if self.function is None else self.function
        return fit(window, start=start, **self.options)
