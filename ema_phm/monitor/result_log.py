"""What the monitor keeps for its callers: results, failures, skipped windows and faults."""

from __future__ import annotations

import threading
from collections import deque
from typing import Any

#: Results, failures, skipped windows and faults kept for callers (newest last).
HISTORY = 1000
#: Reasons of discarded windows kept.
DISCARDS = 100


class ResultLog:
    """The newest `HISTORY` of each (newest last); callers may wait for them (`wait`).

    Changed under the owner's lock (`lock`, also the condition's), then `notify`.
    """

    def __init__(self, lock: threading.RLock) -> None:
        """Wait on `lock`, the owner's."""
        self.results: deque[dict[str, Any]] = deque(maxlen=HISTORY)  # health dicts
        self.failures: deque[str] = deque(maxlen=HISTORY)  # reasons of failed isolations
        self.not_excited: deque[str] = deque(maxlen=HISTORY)  # reasons of windows not assessed
        self.faults: deque[str] = deque(maxlen=HISTORY)  # callback errors, rejected inputs
        self.discard_reasons: deque[str] = deque(maxlen=DISCARDS)
        self._changed = threading.Condition(lock)

    def notify(self) -> None:
        """Wake the waiters (call with the lock held)."""
        self._changed.notify_all()

    def wait(
        self,
        n: int = 1,
        timeout: float | None = None,
        *,
        failures: int | None = None,
        not_excited: int | None = None,
    ) -> list[dict[str, Any]]:
        """Block until at least n results exist; return the results so far.

        Also returns once `failures` isolations failed, `not_excited` windows were not
        assessed, or `timeout` s passed.
        """

        def done() -> bool:
            return (
                len(self.results) >= n
                or (failures is not None and len(self.failures) >= failures)
                or (not_excited is not None and len(self.not_excited) >= not_excited)
            )

        with self._changed:
            self._changed.wait_for(done, timeout)
            return list(self.results)
