"""Play, Run to end and Pause of the shared run. Whether the run plays is the worker's alone: every start and stop
calls `changed`, which redraws the Play button and every status from it at once (Presenter.update_statuses), so
the button and the status never disagree."""
from __future__ import annotations

from typing import Callable

from .layout import RunControls
from .worker import Worker


class Playback:
    def __init__(self, worker: Worker, controls: RunControls, changed: Callable[[], None]):
        self.worker = worker
        self.controls = controls
        self.changed = changed

    def toggle(self, tick: Callable[[], bool], client) -> None:
        """Play (tick once per iteration until it returns False), or Pause."""
        if self.worker.playing:
            self.pause()
        else:
            self.start(tick, client, full=True)

    def start(self, tick: Callable[[], bool], client, full: bool) -> None:
        """full: Play, paced by the interval slider; otherwise Run to end, as fast as it goes."""
        if self.worker.playing:
            return
        self.worker.play(tick, client, float(self.controls.interval.value) if full else 0.0)
        self.changed()

    def pause(self) -> None:
        """Every stop of Play goes through here, the run's own end too."""
        self.worker.pause()
        self.changed()
