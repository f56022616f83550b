"""Uploads speak in our words only.

viser's upload button shows its own notification: a progress bar while the bytes arrive (useful: a
300k-point file takes seconds), then "File uploaded successfully" (misleading beside our error when the
file turns out to be unreadable). The browser names that notification "upload-<transfer id>". This
follows each transfer's parts as they arrive and, as the last one comes in, takes that notification
down in the same stream of messages as viser's last acknowledgement, so the browser never shows the
success line; the inspector then says what happens to the file. A file of one part can finish before the
browser has put its notification up, so the notice is taken down again a moment later, and then the transfer's
messages leave the buffer viser replays to browsers that connect later. Uses viser's message hooks and that buffer,
which its public API does not expose (checked with viser 1.1).
"""
from __future__ import annotations

import threading

import viser
from viser import _messages


AGAIN_AFTER = (0.2, 1.0)  # seconds


class UploadNotices:
    def __init__(self, server: viser.ViserServer):
        self._server = server
        self._parts: dict[str, list[int]] = {}  # transfer id -> [parts received, parts expected]
        self._lock = threading.Lock()
        hooks = server._websock_server
        hooks.register_handler(_messages.FileTransferStartUpload, self._started)
        hooks.register_handler(_messages.FileTransferPart, self._part)

    def _started(self, client_id, message: _messages.FileTransferStartUpload) -> None:
        if message.part_count == 0:  # an empty file: viser finishes it at once
            self._dismiss(message.transfer_uuid)
            return
        with self._lock:
            self._parts[message.transfer_uuid] = [0, message.part_count]

    def _part(self, client_id, message: _messages.FileTransferPart) -> None:
        with self._lock:
            parts = self._parts.get(message.transfer_uuid)
            if parts is None:
                return
            parts[0] += 1
            if parts[0] < parts[1]:
                return
            del self._parts[message.transfer_uuid]
        self._dismiss(message.transfer_uuid)

    def _dismiss(self, transfer: str) -> None:
        def remove() -> None:  # broadcast, like viser's acknowledgements, so it arrives after the last one
            self._server._websock_server.queue_message(_messages.RemoveNotificationMessage(f"upload-{transfer}"))

        def forget() -> None:  # the acknowledgements stay in viser's replay buffer: a browser that opens later
            # would replay them as "Uploading undefined ... File uploaded successfully" in its Files tab
            remove()
            self._server._websock_server._broadcast_buffer.remove_from_buffer(
                lambda message: getattr(message, "transfer_uuid", None) == transfer
                or getattr(message, "uuid", None) == f"upload-{transfer}")

        remove()
        for delay in AGAIN_AFTER:
            timer = threading.Timer(delay, forget if delay == AGAIN_AFTER[-1] else remove)
            timer.daemon = True
            timer.start()
