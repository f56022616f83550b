"""Background threads, so that GUI callbacks return at once.

`Worker` runs every engine call, in submission order. Play is a job that re-submits itself after
each iteration (after a wait, when Play is paced), so a pause, a parameter change or a timeline move
queued meanwhile runs between two iterations. When a job leaves nothing queued and nothing plays, the
worker runs its idle task (the inspector computes the next iteration ahead), which yields to the next job
as soon as one is queued (`interrupted`) and is taken up again once the worker is idle anew. `Latest` runs the slow per-iteration analysis (metrics,
skeleton) for the newest request of each key (each browser) only: requests made while it is busy replace
the waiting one of their key, so the engine never waits for it.
"""
from __future__ import annotations

import queue
import threading
import time
import traceback
from typing import Callable

from skelcore.errors import SkelError

ErrorHandler = Callable[[str, object], None]  # (one-line message, client that asked or None)


def _guarded(job: Callable[[], object], client, on_error: ErrorHandler) -> bool:
    """Run a job; report a failure (SkelError: its one line; a bug: the traceback goes to the log)."""
    try:
        job()
        return True
    except SkelError as error:
        on_error(str(error), client)
    except Exception as error:
        traceback.print_exc()
        on_error(_in_our_words(error), client)
    return False


def _in_our_words(error: Exception) -> str:
    """An unforeseen failure as one line for a browser: no exception text, which may hold server paths."""
    if isinstance(error, MemoryError) or "bad_alloc" in str(error):
        return "the server ran out of memory; load a smaller or voxel-downsampled cloud"
    if isinstance(error, OSError):
        return f"the server cannot read or write a file ({error.strerror or 'input/output error'})"
    return f"internal error ({type(error).__name__}); the server's log has the details"


class Worker:
    def __init__(self, on_error: ErrorHandler, on_idle: Callable[[], bool] | None = None):
        """on_idle: the idle task; it returns False when it stopped because `interrupted()` turned true."""
        self._on_error = on_error
        self._on_idle = on_idle
        self._jobs: queue.Queue = queue.Queue()
        self._waiting = 0  # jobs queued, not counting wait_idle's markers
        self._counting = threading.Lock()
        self._idle_due = False  # a job ran (or the idle task was interrupted) since the idle task last finished
        self._playing = threading.Event()
        self._closed = False
        self._thread = threading.Thread(target=self._loop, name="skel-inspect-engine", daemon=True)
        self._thread.start()

    @property
    def playing(self) -> bool:
        return self._playing.is_set()

    def submit(self, job: Callable[[], object], client=None, *, marker: bool = False) -> None:
        if not self._closed:
            if not marker:
                with self._counting:
                    self._waiting += 1
            self._jobs.put((job, client, marker))

    def interrupted(self) -> bool:
        """True when the idle task should stop: a job is queued, Play runs, or the worker closes."""
        return self._waiting > 0 or self._playing.is_set() or self._closed

    def play(self, tick: Callable[[], bool], client=None, interval: float = 0.0) -> None:
        """Run tick() once per queue turn, at most once per `interval` seconds, until it returns False
        or pause() is called. Waiting happens off the queue, so other jobs run meanwhile."""
        if self._playing.is_set():
            return
        self._playing.set()
        self.submit(lambda: self._tick(tick, client, interval), client)

    def pause(self) -> None:
        self._playing.clear()

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until the jobs submitted so far have run, nothing plays and the idle task has finished."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            done = threading.Event()
            self.submit(done.set, marker=True)  # runs after the idle task the jobs before it set off
            if not done.wait(None if deadline is None else max(0.0, deadline - time.monotonic())):
                return False
            if not self._playing.is_set() and not self._idle_due:
                return True

    def close(self) -> None:
        self._playing.clear()
        self._closed = True
        self._jobs.put(None)
        self._thread.join(timeout=30)

    def _tick(self, tick: Callable[[], bool], client, interval: float) -> None:
        if not self._playing.is_set():
            return
        started = time.monotonic()
        if not (tick() and self._playing.is_set()):
            self._playing.clear()
            return
        again = lambda: self.submit(lambda: self._tick(tick, client, interval), client)  # noqa: E731
        wait = interval - (time.monotonic() - started)
        if wait > 0:
            timer = threading.Timer(wait, again)
            timer.daemon = True
            timer.start()
        else:
            again()

    def _loop(self) -> None:
        while (item := self._jobs.get()) is not None:
            job, client, marker = item
            if not marker:
                with self._counting:
                    self._waiting -= 1
                self._idle_due = self._on_idle is not None
            if not _guarded(job, client, self._on_error):
                self._playing.clear()
            if self._idle_due and not self.interrupted():
                self._idle()

    def _idle(self) -> None:
        finished = []
        _guarded(lambda: finished.append(self._on_idle()), None, self._on_error)
        self._idle_due = finished == [False]  # interrupted: taken up again after the jobs that interrupted it


class Latest:
    def __init__(self, handle: Callable[[object], None], on_error: ErrorHandler):
        self._handle = handle
        self._on_error = on_error
        self._pending: dict = {}  # key -> (item, client), oldest first
        self._busy = False
        self._closed = False
        self._changed = threading.Condition()
        self._thread = threading.Thread(target=self._loop, name="skel-inspect-analysis", daemon=True)
        self._thread.start()

    def request(self, item, client=None, key=None) -> None:
        """Handle `item` once the thread is free, instead of an earlier request of the same `key` not handled yet."""
        with self._changed:
            self._pending.pop(key, None)
            self._pending[key] = (item, client)
            self._changed.notify_all()

    def wait_idle(self, timeout: float | None = None) -> bool:
        with self._changed:
            return self._changed.wait_for(lambda: not self._pending and not self._busy, timeout)

    def close(self) -> None:
        with self._changed:
            self._closed = True
            self._changed.notify_all()
        self._thread.join(timeout=30)

    def _loop(self) -> None:
        while True:
            with self._changed:
                self._changed.wait_for(lambda: self._pending or self._closed)
                if self._closed:
                    return
                item, client = self._pending.pop(next(iter(self._pending)))
                self._busy = True
            _guarded(lambda: self._handle(item), client, self._on_error)
            with self._changed:
                self._busy = False
                self._changed.notify_all()
