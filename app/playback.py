"""Play, Run to end and Pause of the shared run, and the Play button that always says what a click does."""
from __future__ import annotations

from typing import Callable

from .layout import RunControls
from .worker import Worker


class Playback:
    def __init__(self, worker: Worker, controls: RunControls):
        self.worker = worker
        self.controls = controls

    def toggle(self, tick: Callable[[], bool], client, after_pause: Callable[[], None]) -> None:
        """Play (tick once per iteration until it returns False), or Pause then `after_pause` on the worker."""
        if self.worker.playing:
            self.pause()
            self.worker.submit(after_pause)
        else:
            self.start(tick, client, full=True)

    def start(self, tick: Callable[[], bool], client, full: bool) -> None:
        """full: Play, paced by the interval slider; otherwise Run to end, as fast as it goes."""
        if self.worker.playing:
            return
        self.controls.play.label = "Pause"
        self.worker.play(tick, client, float(self.controls.interval.value) if full else 0.0)

    def pause(self) -> None:
        """Every stop of Play goes through here, so the button always tells what a click will do."""
        self.worker.pause()
        self.controls.play.label = "Play"

    def ended(self) -> None:
        """The run stopped by itself."""
        self.controls.play.label = "Play"
