"""What the status and the panel say about the run, without a browser: a warning on a skeleton of a barely
contracted cloud, the run playing exactly while the Play button says Pause, and the parameter changes waiting
for a step said below the tabs, not above the box being typed into."""
from __future__ import annotations

import threading
import types

import pytest

from app.analysis import Analyses
from app.session import Session
from app.status import run_state, status_markdown
from skelcore.io import validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape


@pytest.fixture(scope="module")
def torus():
    return validate(make_shape("torus", 1500).points, name="torus.xyz")


def _status_at_the_end(cloud, params: ContractionParams) -> str:
    session = Session(cloud, params, look_ahead=False)
    while session.step() is not None:
        pass
    last = len(session.history) - 1
    readiness = Analyses(session).readiness(session.run, last)
    return status_markdown(session, last, run=run_state(session.history, "", False), readiness=readiness,
                           skeleton="", following=True)


def test_a_run_that_ends_barely_contracted_warns_that_its_skeleton_may_not_follow_the_shape(torus):
    """Stopped after one step (max iterations 1), the torus is still a surface: its skeleton is drawn as the run's
    result, and the status says how little the cloud was contracted, with the engine's figures."""
    status = _status_at_the_end(torus, ContractionParams(max_iterations=1))
    assert "**Barely contracted:** stopped after 1 step with 0% of points curve-like (50% aimed at)" in status
    assert "the skeleton may not follow the shape" in status
    assert "Barely contracted" not in _status_at_the_end(torus, ContractionParams())  # a full run: no warning


def test_the_status_says_the_run_plays_exactly_while_the_button_says_pause():
    """The status reads whether the run plays from the same place as the Play button (app.playback), so Play says
    Pause only while the status says playing, whatever is being computed."""
    history = [types.SimpleNamespace(iteration=i, termination=None) for i in (0, 1)]
    assert run_state(history, "", True) == "playing"
    assert run_state(history, "computing iteration 2", True) == "playing: computing iteration 2…"
    assert run_state(history, "computing iteration 2", False) == "busy: computing iteration 2…"
    assert run_state(history, "", False).startswith("paused")


def test_parameter_changes_are_said_below_the_tabs_not_in_the_status(torus):
    """The status sits above the boxes: a line it gained as a person typed pushed the box down, and the browser
    scrolled the panel after the caret, taking the run controls off its top."""
    from app.status import pending_markdown

    session = Session(torus, look_ahead=False)
    session.tune(session.params.replace(wh0=2.0))
    status = status_markdown(session, 0, run="ready", readiness=None, skeleton="", following=True)
    assert "Pending" not in status and "W_H0 2" not in status
    assert pending_markdown(session) == "**Pending:** W_H0 2 from iteration 1"
    session.step()
    assert pending_markdown(session) == ""


def _panel(monkeypatch):
    """A ParameterPanel on plain boxes, its pauses ended by hand; (panel, boxes, pauses, notices, taken)."""
    from app import panel as panel_module
    from app.panel import ParameterPanel

    pauses = []

    class Pause:  # the wait for the person to stop typing
        def __init__(self, seconds, then):
            pauses.append(then)

        def start(self):
            pass

    monkeypatch.setattr(panel_module, "threading", types.SimpleNamespace(Timer=Pause, Lock=threading.Lock))
    box = types.SimpleNamespace
    boxes = box(method=box(value="LBC"), k=box(value=0), wl0=box(value=0.0), wh0=box(value=1.0), sl=box(value=3.0),
                wl_max=box(value=2048.0), max_iterations=box(value=20), termination=box(value=0.01),
                hold_curves=box(value=True), radius=box(value=0.02))
    notices, taken = [], []
    panel = ParameterPanel(boxes, types.SimpleNamespace(params=ContractionParams(), sample_radius=0.02),
                           lambda client, title, body: notices.append(body),
                           {part: lambda value, client, part=part: taken.append((part, value))
                            for part in ("parameters", "radius")})
    return panel, boxes, pauses, notices, taken


def test_a_value_being_typed_is_taken_once_the_person_stops_or_clicks(monkeypatch):
    """viser sends a box's value at every key: typing 30 into max iterations sends 3 first. Taken at once, a step
    meanwhile (Play's) would end the run at 3 iterations; a value is taken once the person stops typing, and a
    click on Step or Play takes at once the value typed last."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    for typed in (3, 30):
        boxes.max_iterations.value = typed
        panel.changed("parameters", None, typing=True)
    assert taken == [] and panel.typing == {"parameters": None}
    panel.flush()  # a click
    assert [(part, value.max_iterations) for part, value in taken] == [("parameters", 30)] and not panel.typing
    pauses[0]()
    pauses[1]()  # the pauses after the keys end: the value was taken already
    assert len(taken) == 1
    boxes.radius.value = 0.03
    panel.changed("radius", None, typing=True)
    pauses[2]()  # the person stopped typing
    assert taken[1:] == [("radius", 0.03)] and notices == []
    boxes.method.value = "GLSkeleton"
    panel.changed("parameters", None, typing=False)  # chosen from a list: at once
    assert taken[-1][1].method == "glskeleton" and len(pauses) == 3


def test_a_refused_value_waits_for_the_person_to_stop_typing_and_a_value_typed_on_drops_it(monkeypatch):
    """viser sends a box's value at every key (0.02 arrives as 0, 0.0, 0.02): a refusal of a typed value is said and
    put back only if it still stands once the person stops typing into its part (the contraction's parameters, or
    the sample radius); a Restart's refusal is said at once."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    boxes.termination.value = 0.0
    panel.changed("parameters", None, typing=True)
    boxes.radius.value = 0.0
    panel.changed("radius", None, typing=True)
    boxes.termination.value = 0.02
    panel.changed("parameters", None, typing=True)
    assert taken == [] and set(panel.typing) == {"parameters", "radius"}
    pauses[0]()  # the person typed on: 0 is neither refused nor taken
    assert notices == [] and taken == [] and boxes.termination.value == 0.02
    pauses[2]()
    assert [(part, value.termination) for part, value in taken] == [("parameters", 0.02)]
    pauses[1]()  # the radius was left at 0
    assert notices == ["Sample radius = 0.0: must be a positive finite number; put back to the value in force"]
    assert boxes.radius.value == 0.02 and not panel.typing and len(taken) == 1
    boxes.wh0.value = 0.0
    assert panel.parameters(None) is None  # Restart: said at once
    assert notices[-1].startswith("W_H0 = 0.0: must be") and boxes.wh0.value == 1.0 and len(pauses) == 3
