"""What the inspector tells browsers: notifications in our words, progress notices, and no server paths."""
from __future__ import annotations

import re
import threading
from pathlib import Path

import viser


class Messages:
    def __init__(self, server: viser.ViserServer):
        self.server = server
        self._shown: dict[tuple[int, str], object] = {}  # (client id, title) -> its latest notification
        self._lock = threading.Lock()  # notices come from the worker, the analysis threads and the event loop

    def notify(self, client, title: str, body: str, color: str = "red") -> None:
        """To one browser, or every browser (client None). A notice replaces the one of the same title still up
        in that browser, so repeated clicks do not stack copies over the view."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for target in clients:
            with self._lock:
                earlier = self._shown.pop((target.client_id, title), None)
                if earlier is not None:
                    earlier.remove()
                self._shown[(target.client_id, title)] = target.add_notification(title, body, color=color,
                                                                                 auto_close_seconds=15.0)

    def withdraw(self, title: str) -> None:
        """Take down every browser's notice of this title (what it said no longer holds)."""
        with self._lock:
            for key in [key for key in self._shown if key[1] == title]:
                self._shown.pop(key).remove()

    def progress(self, client, title: str, body: str):
        """A notification with a spinner (app.progress takes it down); None when no browser is there."""
        target = client or next(iter(self.server.get_clients().values()), None)
        if target is None:
            return None
        return target.add_notification(title, body[:1].upper() + body[1:] + "…", loading=True,
                                       with_close_button=False)

    def upload_refused(self, client_id: int, name: str, reason: str) -> None:
        client = self.server.get_clients().get(client_id)
        if client is not None:
            self.notify(client, "Upload refused", f"{Path(name).name}: {reason}")


def without_paths(message: str) -> str:
    """`message` with every absolute path cut to its file name."""
    return re.sub(r"(?<![\w.])/(?:[^\s/:;,'\"()]+/)+([^\s/:;,'\"()]*)", r"\1", message)
