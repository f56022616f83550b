"""Progress of slow jobs: the status line says what is being computed at once, and a job still running
after PROGRESS_AFTER seconds puts up a notification with a spinner, taken down when it ends."""
from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Callable

PROGRESS_AFTER = 1.0  # seconds: quicker jobs finish before a notification would be read


class Activity:
    def __init__(self, notify: Callable[[object, str, str], object], on_change: Callable[[], None]):
        """notify(client, title, body) shows a loading notification and returns its handle (or None);
        on_change() redraws the status."""
        self._notify = notify
        self._on_change = on_change
        self._lock = threading.Lock()
        self._doing: dict[str, str] = {}  # thread name -> what it computes

    def text(self) -> str:
        with self._lock:
            return "; ".join(self._doing.values())

    @contextmanager
    def busy(self, client, title: str, body: str, notify: bool = True, after: float = PROGRESS_AFTER):
        """Say `body` in the status while the block runs; after `after` seconds also in a notification."""
        thread = threading.current_thread().name
        with self._lock:
            self._doing[thread] = body
        self._on_change()
        shown, lock = [], threading.Lock()

        def show() -> None:
            with lock:
                if shown is not None:
                    shown.append(self._notify(client, title, body))

        timer = threading.Timer(after, show) if notify else None
        if timer is not None:
            timer.daemon = True
            timer.start()
        try:
            yield
        finally:
            if timer is not None:
                timer.cancel()
            with lock:
                handles, shown = shown, None
            for handle in handles:
                if handle is not None:
                    handle.remove()
            with self._lock:
                self._doing.pop(thread, None)
            self._on_change()
