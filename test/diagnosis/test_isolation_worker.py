"""IsolationWorker: jobs one at a time, survives a raising job, close() joins its thread."""

from __future__ import annotations

import threading

from ema_phm.diagnosis.isolation_worker import IsolationWorker


def test_jobs_run_in_order_and_a_raising_one_does_not_stop_the_worker(capsys):
    done: list[int] = []
    finished = threading.Event()

    def handle(job: int) -> None:
        if job == 1:
            raise RuntimeError("job one failed")
        done.append(job)
        if job == 3:
            finished.set()

    worker = IsolationWorker(handle, name="test-worker")
    for job in (1, 2, 3):
        worker.submit(job)
    assert finished.wait(5.0)
    worker.close()
    assert done == [2, 3] and not worker.is_alive() and worker.cancel.is_set()
    assert "job one failed" in capsys.readouterr().err
