"""The clock and the helper threads of one run (skelcore.pipeline)."""
from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable


class StageClock:
    """Seconds per pipeline stage, in order."""

    def __init__(self) -> None:
        self.start = self.last = time.perf_counter()
        self.stages: dict[str, float] = {}

    def mark(self, stage: str) -> None:
        """Close `stage`: the seconds since the previous mark (or the start)."""
        now = time.perf_counter()
        self.stages[stage] = now - self.last
        self.last = now

    def elapsed(self) -> float:
        """Seconds since the clock started."""
        return time.perf_counter() - self.start


class Helpers:
    """A run's two helper threads: one measures the states in order (the paper's metrics, after carrying a reduced
    run's states to every input point), the other judges: it reads the loops the solid has while the contraction
    runs, then the parts of the skeleton evidence that need only the last state. Their numpy, LAPACK, k-d tree and gudhi work releases the GIL, so they use the second core while
    the contraction and the skeleton's graph step (Python) run on the first. An error in a task is raised where
    its result is read, or by `wait`; leaving the block cancels what has not started."""

    def __enter__(self) -> "Helpers":
        self._measure = ThreadPoolExecutor(1, thread_name_prefix="skelcore-metrics")
        self._judge = ThreadPoolExecutor(1, thread_name_prefix="skelcore-evidence")
        self._measuring: list[Future] = []
        return self

    def measuring(self, task: Callable, *args) -> Future:
        """Queue `task(*args)` behind the measuring tasks queued before it."""
        self._measuring.append(self._measure.submit(task, *args))
        return self._measuring[-1]

    def judging(self, task: Callable, *args) -> Future:
        """Run `task(*args)` on the evidence thread."""
        return self._judge.submit(task, *args)

    def wait(self) -> None:
        """Wait until every measuring task is done; the first error of one is raised."""
        for task in self._measuring:
            task.result()

    def __exit__(self, *exc) -> None:
        for pool in (self._measure, self._judge):
            pool.shutdown(wait=True, cancel_futures=True)


def made(task: Future | None):
    """What a task made ahead gave; None when not asked for, or when it failed (then made again where needed)."""
    return None if task is None or task.exception() is not None else task.result()
