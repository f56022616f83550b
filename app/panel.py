"""The Parameters and More tabs against the run: the values their boxes show, taken when the engine accepts them,
and a refused value said and put back to the one in force (so the panel never shows what no run uses).

viser sends a box's value at every key a person types: typing 30 sends 3 first, typing 0.02 sends 0. So a value
being typed is taken only once the person has stopped typing into its part (TYPING_PAUSE; the parts: the
contraction's parameters and the skeleton's sample radius, and those others add with `add_part`: Play's interval,
a labelled cloud's weights): a step meanwhile, Play's too, runs with the values in force, and a refused value is
said and put back only then. A click on Step, Play, Run to end or Reset takes what is being typed first (`flush`),
so a step uses the value typed last and nothing typed is taken after a Reset; Restart reads the panel as it
stands (`parameters`).
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Callable

from skelcore.errors import ParameterError
from skelcore.options import RunOptions
from skelcore.params import AUTOMATIC, INTEGERS, ContractionParams

from .layout import ParameterWidgets
from .words import (METHOD_LABELS, METHODS_BY_LABEL, number_text, refused, refused_field, typed_number,
                    typed_whole_number)

TYPING_PAUSE = 1.0  # seconds without another key before a value being typed is taken (or refused)
REFUSED = "Parameter refused"  # the title of a refusal's notice


@dataclass(frozen=True)
class Part:
    """What the panel does with one part: `shown()` its value as the boxes show it (ParameterError: refused),
    `take(value, client)` use a value the engine accepted, `put_back()` show the value last taken again;
    `boxes()` its text boxes by the field a refusal names (a refusal quotes the box's text and the value put back)."""
    shown: Callable[[], object]
    take: Callable[[object, object], None]
    put_back: Callable[[], None]
    boxes: Callable[[], dict]


class ParameterPanel:
    def __init__(self, widgets: ParameterWidgets, session, notify: Callable[[object, str, str], None],
                 take: dict[str, Callable[[object, object], None]], withdraw: Callable[[str], None]):
        """notify(client, title, body): a notice to one browser; take[part](value, client): use a value of `part`
        the engine accepted; withdraw(title): take down every browser's notice of that title."""
        self.widgets, self.session, self._notify, self._withdraw = widgets, session, notify, withdraw
        self.accepted = session.params  # the contraction parameters last accepted
        self.typing: dict[str, object] = {}  # part -> the client typing into it, until its value is taken
        self._changes: dict[str, int] = {}  # a wait for the person stands while its part has not changed since
        self._lock = threading.Lock()
        self._parts: dict[str, Part] = {}
        self.add_part("parameters", Part(self._parameters_shown, take["parameters"], lambda: self.show(self.accepted),
                                         widgets.number_boxes))
        self.add_part("radius", Part(self._radius_shown, take["radius"], self._radius_put_back,
                                     lambda: {"sample_radius": widgets.radius}))

    def add_part(self, name: str, part: Part) -> None:
        """Boxes of another part (a new part, or one replacing the part of that name), taken as the others are."""
        with self._lock:
            self._parts[name] = part
            self._changes.setdefault(name, 0)
            self.typing.pop(name, None)

    def changed(self, part: str, client, typing: bool) -> None:
        """A box of `part` changed: its value is taken once the person has stopped typing, or at once when it was
        not typed (a choice from a list, a switch)."""
        with self._lock:
            self._changes[part] += 1
            self.typing[part] = client
            if not typing:
                self._settle(part)
                return
            changes = self._changes[part]
        timer = threading.Timer(TYPING_PAUSE, lambda: self._stopped(part, changes))
        timer.daemon = True
        timer.start()

    def flush(self) -> None:
        """Take what is being typed at once: a click that acts on the values uses the values typed last."""
        with self._lock:
            for part in list(self.typing):
                self._settle(part)

    def parameters(self, client) -> ContractionParams | None:
        """The contraction parameters the panel shows, now (Restart: what is being typed into them no longer waits);
        None when the engine refuses them, said and put back at once."""
        with self._lock:
            self.typing.pop("parameters", None)
            return self._value("parameters", client)

    def show(self, params: ContractionParams) -> None:
        """Put a run's parameters into the panel (no client: the callbacks ignore it)."""
        self.accepted = params
        p = self.widgets
        p.method.value = METHOD_LABELS[params.method]
        for field, box in p.number_boxes().items():
            box.value = number_text(getattr(params, field) or 0)
        p.hold_curves.value, p.hold_inside.value = params.hold_curves, params.hold_inside

    def _parameters_shown(self) -> ContractionParams:
        """The panel's values on top of the run's parameters (fields the panel lacks stay); refused: ParameterError."""
        p = self.widgets
        typed = {field: (typed_whole_number if field in INTEGERS else typed_number)(field, box.value)
                 for field, box in p.number_boxes().items()}
        typed.update({field: typed[field] or None for field in AUTOMATIC})  # a 0 in their box: the engine chooses
        self.accepted = self.session.params.replace(
            method=METHODS_BY_LABEL[p.method.value], hold_curves=bool(p.hold_curves.value),
            hold_inside=bool(p.hold_inside.value), **typed)
        return self.accepted

    def _radius_shown(self) -> float:
        radius = typed_number("sample_radius", self.widgets.radius.value)
        RunOptions(sample_radius=radius).skeleton_params()  # refuses a bad radius
        return radius

    def _radius_put_back(self) -> None:
        self.widgets.radius.value = number_text(self.session.sample_radius)

    def _stopped(self, part: str, changes: int) -> None:
        """The pause after a key: the person stopped typing, unless the part changed since (or was taken)."""
        with self._lock:
            if changes == self._changes[part] and part in self.typing:
                self._settle(part)

    def _settle(self, part: str) -> None:
        """Take the part's value, or say it is refused and put it back (under the lock)."""
        client = self.typing.pop(part)
        value = self._value(part, client)
        if value is not None:
            self._parts[part].take(value, client)

    def _value(self, part: str, client):
        """The part's value as shown; None when the engine refuses it, said and put back to the last value taken.
        A value taken takes down the notice of an earlier refusal, which no longer holds."""
        handler = self._parts[part]
        try:
            value = handler.shown()
        except ParameterError as error:
            boxes, field = handler.boxes(), refused_field(str(error))
            message = refused(str(error), {name: box.value for name, box in boxes.items()})
            handler.put_back()
            back = repr(str(boxes[field].value)) if field in boxes else "the last value taken"
            self._notify(client, REFUSED, f"{message}; put back to {back}")
            return None
        self._withdraw(REFUSED)
        return value
