"""Play, Run to end and Pause of the shared run. Whether the run plays is the worker's alone: every start and stop
calls `changed`, which redraws the Play button and every status from it at once (Presenter.update_statuses), so
the button and the status never disagree. The Play interval is a text box taken as the parameters are
(`interval_part`, app.panel)."""
from __future__ import annotations

import time
from typing import Callable

from skelcore.errors import ParameterError

from .layout import RunControls
from .panel import Part
from .words import number_text, typed_number
from .worker import Worker

# A Play from one browser within this many seconds of its Pause is a double click on Pause: the button's new label
# reaches the browser a round trip after the first click, so the second still aimed at Pause. (A Pause is never
# dropped: stopping is what a person can always ask for.)
DOUBLE_CLICK = 0.4
INTERVAL_MAX = 10.0  # seconds between two iterations during Play: longer than anyone watches one


class Playback:
    def __init__(self, worker: Worker, controls: RunControls, changed: Callable[[], None]):
        self.worker = worker
        self.controls = controls
        self.changed = changed
        self.interval = typed_number("play_interval", controls.interval.value)  # the interval last taken
        self._paused_by: dict[object, float] = {}  # browser -> when it last paused with the button
        # a person paused the playing run: the status says "paused" until a Step, Play or Run to end ("ready"
        # after a Step: walk-throughs read "paused" there as a Pause they had not made)
        self.paused = False

    def toggle(self, choose: Callable[[], Callable[[], bool]], client) -> None:
        """Play, or Pause; a double click on Pause pauses. Play runs the tick `choose()` returns once per iteration
        until it returns False; `choose` is called on the worker as Play starts, after the jobs queued before the
        click: a Step clicked just before may end the run meanwhile, and Play on an ended run does something else
        (it replays it) than Play on a run going on."""
        who, now = getattr(client, "client_id", None), time.monotonic()
        if self.worker.playing:
            self._paused_by[who] = now
            self.paused = True
            self.pause()
        elif now - self._paused_by.get(who, -DOUBLE_CLICK) >= DOUBLE_CLICK:
            self.start(_chosen_on_first_tick(choose), client, full=True)

    def start(self, tick: Callable[[], bool], client, full: bool) -> None:
        """full: Play, paced by the interval taken; otherwise Run to end, as fast as it goes."""
        if self.worker.playing:
            return
        self.paused = False
        self.worker.play(tick, client, self.interval if full else 0.0)
        self.changed()

    def interval_shown(self) -> float:
        """The Play interval its box shows; ParameterError unless 0 to INTERVAL_MAX seconds."""
        seconds = typed_number("play_interval", self.controls.interval.value)
        if not 0 <= seconds <= INTERVAL_MAX:
            raise ParameterError(f"parameter play_interval={seconds!r}: must be from 0 to {INTERVAL_MAX:g} seconds")
        return seconds

    def set_interval(self, seconds: float, client=None) -> None:
        """Pace Play by `seconds` from its next start (a Play going on keeps its pace)."""
        self.interval = seconds

    def show_interval(self) -> None:
        self.controls.interval.value = number_text(self.interval)

    def interval_part(self) -> Part:
        """The Play interval as a part of app.panel's: taken as the parameters are."""
        return Part(self.interval_shown, self.set_interval, self.show_interval,
                    lambda: {"play_interval": self.controls.interval})

    def pause(self) -> None:
        """Every stop of Play goes through here, the run's own end too."""
        self.worker.pause()
        self.changed()

    def stepped(self) -> None:
        """A Step: Play stops, and the run is no longer where a Pause left it."""
        self.paused = False
        self.pause()


def _chosen_on_first_tick(choose: Callable[[], Callable[[], bool]]) -> Callable[[], bool]:
    """A tick that runs the one `choose()` returns when it first runs."""
    chosen: list[Callable[[], bool]] = []

    def tick() -> bool:
        if not chosen:
            chosen.append(choose())
        return chosen[0]()
    return tick
