"""One background thread that handles jobs one at a time, and stops promptly when closed."""

from __future__ import annotations

import queue
import sys
import threading
from typing import Callable, Generic, TypeVar

J = TypeVar("J")


class IsolationWorker(Generic[J]):
    """Runs `handle(job)` for each submitted job in its own thread; `cancel` is set by `close()`.

    Whatever `handle` raises is printed on stderr and the next job is handled: the
    worker outlives any job.
    """

    def __init__(self, handle: Callable[[J], None], *, name: str) -> None:
        self.cancel = threading.Event()
        self._handle = handle
        self._name = name
        self._jobs: queue.Queue[J | None] = queue.Queue()
        self._thread = threading.Thread(target=self._work, name=name, daemon=True)
        self._thread.start()

    def submit(self, job: J) -> None:
        """Queue `job` for the worker thread."""
        self._jobs.put(job)

    def is_alive(self) -> bool:
        """True while the worker thread runs."""
        return self._thread.is_alive()

    def close(self, timeout: float = 30.0) -> None:
        """Cancel the running job, stop the thread and join it (also from the thread itself)."""
        self.cancel.set()
        self._jobs.put(None)
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=timeout)

    def _work(self) -> None:
        while not self.cancel.is_set():
            job = self._jobs.get()
            if job is None:
                return
            try:
                self._handle(job)
            except Exception as exc:  # noqa: BLE001 - the last line of defence: keep working
                print(
                    f"[ERROR] [{self._name}]: a job raised {type(exc).__name__}: {exc}",
                    file=sys.stderr,
                )
