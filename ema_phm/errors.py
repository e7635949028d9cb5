"""The one place ema_phm's exceptions live.

Every error a user can cause (bad fault vector, bad window, bad bag, bad
config) is raised as one of these with a message naming the problem and the
offending value, so the CLI can print one line and exit 2 and the nodes can
report it on their health output.
"""

from __future__ import annotations


class EmaPhmError(Exception):
    """Base class of every error ema_phm raises on purpose."""


class FaultVectorError(EmaPhmError, ValueError):
    """A fault vector k is malformed (length, NaN, out of [0, 1])."""


class ConfigError(EmaPhmError, ValueError):
    """A parameter file or a model parameter is missing or out of range."""


class WindowError(EmaPhmError, ValueError):
    """A telemetry window is unusable (too short, NaN, uneven time base)."""


class BagError(EmaPhmError):
    """A bag is missing, truncated, foreign or lacks a needed topic."""


class RecordingStopped(BagError):
    """A recording stopped for good: writing its file failed (e.g. the disk is full)."""


class IsolationCancelled(EmaPhmError):
    """An isolation was stopped from another thread before it finished."""


class ExcitationError(WindowError):
    """A window does not excite the actuator enough for k to be identified from it."""


class StoreError(EmaPhmError):
    """A fleet's results store cannot be used (its schema, its settings, its URL)."""
