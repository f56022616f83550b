"""Bounded uploads for a viser server.

viser 1.1 offers no hook before it assembles an upload: its GUI API registers two handlers on the
server's websocket interface, one for `FileTransferStartUpload` (it records the announced size and part
count) and one for `FileTransferPart` (it buffers every part, and joins them only when the last one has
arrived; an unfinished transfer is kept until its client disconnects). `UploadGuard` replaces those two
handlers with wrappers that call the originals only for transfers within bounds:

- an announced size above the cap, or more parts than bytes, is refused at the start;
- the bytes received are counted per transfer, and the transfer is dropped as soon as they pass the
  announced size or the cap;
- a client has one transfer in flight (a new one drops its earlier, abandoned one), all clients together
  at most `total_cap` bytes announced, and a transfer that receives nothing for `idle_seconds` is dropped.

Refused and dropped transfers are removed from viser's buffer at once, their parts are ignored when they
keep coming, and the client's own progress display is closed. A client's transfers are freed when its
connection ends, whether or not it ever became a viser client (viser frees them only for clients that
sent their camera first, so a raw websocket client's unfinished upload stayed forever). `on_refused(client_id, filename, reason)`
then tells the person in our words.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import threading
import time
from dataclasses import dataclass
from typing import Callable

import viser
from viser import _messages

IDLE_SECONDS = 30.0
SWEEP_SECONDS = 5.0

Refused = Callable[[int, str, str], None]


@dataclass
class _Transfer:
    client_id: int
    filename: str
    component: str  # the upload button's uuid: the browser's progress display is keyed by it
    announced: int
    received: int = 0
    last: float = 0.0


class UploadGuard:
    def __init__(self, server: viser.ViserServer, cap_bytes: int, on_refused: Refused, *,
                 total_cap: int | None = None, idle_seconds: float = IDLE_SECONDS):
        self.server = server
        self.cap = int(cap_bytes)
        self.total_cap = int(total_cap if total_cap is not None else 2 * cap_bytes)
        self.idle_seconds = idle_seconds
        self.on_refused = on_refused
        self._transfers: dict[str, _Transfer] = {}
        gui = server.gui
        self._viser_states = gui._current_file_upload_states  # viser's buffers, keyed by transfer uuid
        self._interface = server._websock_server
        self._start_original = gui._handle_file_transfer_start
        self._part_original = gui._handle_file_transfer_part
        self._interface.unregister_handler(_messages.FileTransferStartUpload, self._start_original)
        self._interface.unregister_handler(_messages.FileTransferPart, self._part_original)
        self._interface.register_handler(_messages.FileTransferStartUpload, self._start)
        self._interface.register_handler(_messages.FileTransferPart, self._part)
        # every connection's end, also of a client that never became a viser client (viser frees an
        # unfinished upload only for clients that sent a camera first)
        self._interface.on_client_disconnect(lambda connection: self._forget_client(connection.client_id))
        self._closed = threading.Event()
        self._sweeper = threading.Thread(target=self._sweep_loop, name="skel-inspect-upload-sweep", daemon=True)
        self._sweeper.start()

    def in_flight(self) -> int:
        """Bytes announced by the transfers under way (for tests)."""
        return sum(transfer.announced for transfer in self._transfers.values())

    def close(self) -> None:
        self._closed.set()

    # -- handlers (viser's event loop)
    def _start(self, client_id: int, message: _messages.FileTransferStartUpload) -> None:
        name = str(message.filename)[:200]
        size, parts = message.size_bytes, message.part_count
        transfer = _Transfer(client_id, name, str(message.source_component_uuid), size, last=time.monotonic())
        if not isinstance(size, int) or not isinstance(parts, int) or size < 0 or not 0 <= parts <= max(size, 0):
            return self._refuse(message.transfer_uuid, transfer, "the upload was malformed")
        if size > self.cap:
            return self._refuse(message.transfer_uuid, transfer,
                                f"{size / 2**20:.1f} MiB exceeds the cap of {self.cap / 2**20:.0f} MiB")
        for uuid, earlier in list(self._transfers.items()):
            if earlier.client_id == client_id:  # one at a time: an earlier one was abandoned
                self._drop(uuid)
        if self.in_flight() + size > self.total_cap:
            return self._refuse(message.transfer_uuid, transfer,
                                "the server is receiving other uploads; try again in a moment")
        self._transfers[message.transfer_uuid] = transfer
        self._start_original(client_id, message)
        self._settle(message.transfer_uuid)

    def _part(self, client_id: int, message: _messages.FileTransferPart) -> None:
        transfer = self._transfers.get(message.transfer_uuid)
        if transfer is None or transfer.client_id != client_id:
            return  # refused, dropped, finished, or not this client's: its bytes are let go here
        transfer.received += len(message.content) if isinstance(message.content, (bytes, bytearray)) else 0
        transfer.last = time.monotonic()
        if transfer.received > min(transfer.announced, self.cap) or not isinstance(message.content, bytes):
            self._drop(message.transfer_uuid)
            self._refuse(message.transfer_uuid, transfer,
                         f"more bytes arrived than announced or than the cap of {self.cap / 2**20:.0f} MiB")
            return
        self._part_original(client_id, message)
        self._settle(message.transfer_uuid)

    def _settle(self, uuid: str) -> None:
        """Forget a transfer viser has finished (or discarded)."""
        if uuid not in self._viser_states:
            self._transfers.pop(uuid, None)

    def _refuse(self, uuid: str, transfer: _Transfer, reason: str) -> None:
        client = self.server.get_clients().get(transfer.client_id)
        size = transfer.announced
        if client is not None and isinstance(size, int) and size >= 0:
            # The browser's own progress display of this transfer: marked complete, so that the upload
            # button takes files again, then removed, so that it never reads "uploaded successfully".
            connection = client._websock_connection
            connection.queue_message(_messages.FileTransferPartAck(
                source_component_uuid=transfer.component, transfer_uuid=uuid, transferred_bytes=size,
                total_bytes=size))
            connection.queue_message(_messages.RemoveNotificationMessage(uuid=f"upload-{uuid}"))
        self.on_refused(transfer.client_id, transfer.filename, reason)

    def _drop(self, uuid: str) -> None:
        self._transfers.pop(uuid, None)
        if self._viser_states.pop(uuid, None) is not None:
            _return_freed_memory()

    def _forget_client(self, client_id: int) -> None:
        for uuid, transfer in list(self._transfers.items()):
            if transfer.client_id == client_id:
                self._drop(uuid)

    def _sweep(self) -> None:
        now = time.monotonic()
        for uuid, transfer in list(self._transfers.items()):
            if now - transfer.last > self.idle_seconds:
                self._drop(uuid)
                self._refuse(uuid, transfer, f"nothing arrived for {self.idle_seconds:.0f} s; the upload was abandoned")

    def _sweep_loop(self) -> None:
        while not self._closed.wait(min(SWEEP_SECONDS, self.idle_seconds / 2)):
            self._loop_call(self._sweep)

    def _loop_call(self, function, *args) -> None:
        """Run on viser's event loop, where the handlers run: the buffers change on one thread only."""
        loop = self._interface._background_event_loop
        if loop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(function, *args)
            except RuntimeError:  # the loop closed meanwhile
                pass


def _return_freed_memory() -> None:
    """Hand the freed upload buffers back to the system: glibc keeps freed heap memory otherwise."""
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


_LIBC = None
try:
    _name = ctypes.util.find_library("c")
    _LIBC = ctypes.CDLL(_name) if _name else None
    if _LIBC is not None and not hasattr(_LIBC, "malloc_trim"):
        _LIBC = None
except OSError:
    _LIBC = None
