"""viser's message wake-ups set on its event loop only.

viser 1.1 wakes a client's sender by `asyncio.Event.set()` on the buffer a message went into, from whichever thread
pushed it, and then schedules the same set() on its event loop (`call_soon_threadsafe`). asyncio's Event is not
thread-safe: a set() from the inspector's worker thread walks the event's waiters while the loop adds or removes one,
and raises "deque mutated during iteration" out of an ordinary status update (seen once in the browser tests under
load, reported as an internal error). `install` makes set() off the loop thread do nothing; the set() viser
schedules on the loop right after (or at the end of an atomic block) wakes the sender, as it always did.
"""
from __future__ import annotations

import asyncio

import viser
from viser.infra import _async_message_buffer


class _LoopOnlyEvent(asyncio.Event):
    def set(self) -> None:
        running = asyncio._get_running_loop()
        bound = getattr(self, "_loop", None)  # the loop it was first awaited on
        if running is not None and (bound is None or running is bound):
            super().set()


def _on_loop_only(event: asyncio.Event) -> None:
    # The same object becomes the subclass: a sender already waiting on it is woken by the loop's set() as before.
    if type(event) is asyncio.Event:
        event.__class__ = _LoopOnlyEvent


_created = _async_message_buffer.AsyncMessageBuffer.__init__


def _init(self, *args, **kwargs) -> None:
    _created(self, *args, **kwargs)
    _on_loop_only(self.message_event)


def install(server: viser.ViserServer) -> None:
    """Every message buffer made from now on, and `server`'s broadcast one (made with the server), set on the loop."""
    if _async_message_buffer.AsyncMessageBuffer.__init__ is not _init:
        _async_message_buffer.AsyncMessageBuffer.__init__ = _init
    _on_loop_only(server._websock_server._broadcast_buffer.message_event)
