"""The Parameters and More tabs against the run: the values their boxes show, taken when the engine accepts them,
and a refused value said and put back to the one in force (so the panel never shows what no run uses).

viser sends a number box's value at every key a person types: typing 0.02 sends 0 first, which no run takes.
So the refusal of a value being typed waits until the person has stopped typing (REFUSAL_PAUSE): a value of the
same part (the contraction's parameters, or the skeleton's sample radius) accepted meanwhile drops it, and only a
value left standing is said refused and put back.
"""
from __future__ import annotations

import threading
from typing import Callable

from skelcore.errors import ParameterError
from skelcore.options import RunOptions
from skelcore.params import ContractionParams

from .layout import ParameterWidgets
from .words import METHOD_LABELS, METHODS_BY_LABEL, refused

REFUSAL_PAUSE = 1.0  # seconds without another key before a refused value is said and put back
PARTS = ("parameters", "radius")


class ParameterPanel:
    def __init__(self, widgets: ParameterWidgets, session, notify: Callable[[object, str, str], None]):
        """notify(client, title, body): a notice to one browser."""
        self.widgets, self.session, self._notify = widgets, session, notify
        self.accepted = session.params  # the contraction parameters last accepted
        self.refusing: set[str] = set()  # parts whose refusal waits for the person to stop typing
        self._changes = dict.fromkeys(PARTS, 0)  # a waiting refusal stands while its part has not changed since
        self._lock = threading.Lock()

    def parameters(self, client, typed: bool) -> ContractionParams | None:
        """The contraction parameters the panel shows, on top of the run's (fields the panel lacks stay); None
        when the engine refuses them (see `_take`)."""
        p = self.widgets

        def shown() -> ContractionParams:
            self.accepted = self.session.params.replace(
                method=METHODS_BY_LABEL[p.method.value], k=int(p.k.value) or None, wl0=float(p.wl0.value) or None,
                wh0=float(p.wh0.value), sl=float(p.sl.value), wl_max=float(p.wl_max.value),
                max_iterations=int(p.max_iterations.value), termination=float(p.termination.value),
                hold_curves=bool(p.hold_curves.value))
            return self.accepted
        return self._take("parameters", client, typed, shown)

    def radius(self, client, typed: bool) -> float | None:
        """The skeleton's sample radius the panel shows; None when the engine refuses it (see `_take`)."""
        def shown() -> float:
            radius = float(self.widgets.radius.value)
            RunOptions(sample_radius=radius).skeleton_params()  # refuses a bad radius
            return radius
        return self._take("radius", client, typed, shown)

    def show(self, params: ContractionParams) -> None:
        """Put a run's parameters into the panel (no client: the callbacks ignore it)."""
        self.accepted = params
        p = self.widgets
        p.method.value = METHOD_LABELS[params.method]
        p.wl0.value = params.wl0 or 0.0
        p.wh0.value, p.sl.value, p.wl_max.value = params.wh0, params.sl, params.wl_max
        p.k.value = params.k or 0
        p.max_iterations.value, p.termination.value = params.max_iterations, params.termination
        p.hold_curves.value = params.hold_curves

    def _take(self, part: str, client, typed: bool, shown: Callable[[], object]):
        """shown() when the engine accepts it; else None, the refusal said and the part put back at once, or, for a
        value being typed (`typed`), once the person has stopped typing into that part."""
        with self._lock:
            self._changes[part] += 1
            changes = self._changes[part]
            self.refusing.discard(part)
            try:
                return shown()
            except ParameterError as error:
                message = refused(str(error))
            if typed:
                self.refusing.add(part)
                timer = threading.Timer(REFUSAL_PAUSE, lambda: self._refuse(part, client, message, changes))
                timer.daemon = True
                timer.start()
                return None
        self._refuse(part, client, message, changes)
        return None

    def _refuse(self, part: str, client, message: str, changes: int) -> None:
        with self._lock:
            if changes != self._changes[part]:  # the person typed on
                return
            self.refusing.discard(part)
            self._notify(client, "Parameter refused", f"{message}; put back to the value in force")
            if part == "parameters":
                self.show(self.accepted)
            else:
                self.widgets.radius.value = self.session.sample_radius
