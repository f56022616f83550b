"""What the status and the panel say about the run, without a browser: a warning on a skeleton of a barely
contracted cloud, the run playing exactly while the Play button says Pause, each fact of the status said once in
few words with the figures of the run's end and the explanations in the notes below the tabs, and the parameter
changes waiting for a step said below the tabs, not above the box being typed into."""
from __future__ import annotations

import threading
import types

import pytest

from app import words
from app.analysis import Analyses
from app.session import Session
from app.status import legend, run_notes, run_state, skeleton_note, status_markdown
from skelcore.io import validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape


@pytest.fixture(scope="module")
def torus():
    return validate(make_shape("torus", 1500).points, name="torus.xyz")


def _status_and_legend_at_the_end(cloud, params: ContractionParams) -> tuple[str, str]:
    session = Session(cloud, params, look_ahead=False)
    while session.step() is not None:
        pass
    last = len(session.history) - 1
    readiness = Analyses(session).readiness(session.run, last)
    status = status_markdown(session, last, run=run_state(session.history, "", False), readiness=readiness,
                             skeleton="", following=True)
    return status, _legend(session.history[last], readiness)


def _legend(state, readiness) -> str:
    """The legend of a browser that shows the skeleton, provisional ones not asked for."""
    visible = {"original": True, "contracted": True, "skeleton": True, "removed": False}
    return legend("plain", state, readiness, note="", visible=visible, original_coloured=False,
                  provisional_wanted=False, pinned=False, labels_html="")


def test_a_run_that_ends_barely_contracted_warns_that_its_skeleton_may_not_follow_the_shape(torus):
    """Stopped after one step (max iterations 1), the torus is still a surface: its skeleton is drawn as the run's
    result; the status says how little the cloud was contracted, with the engine's figures, and the legend, beside
    the skeleton, what that means for it."""
    status, key = _status_and_legend_at_the_end(torus, ContractionParams(max_iterations=1))
    assert "⚠ **Barely contracted:** stopped after 1 step with 0% of points curve-like (50% aimed at)" in status
    assert "barely contracted: the skeleton may not follow the shape" in key
    status, key = _status_and_legend_at_the_end(torus, ContractionParams())  # a full run: no warning
    assert "Barely contracted" not in status and "barely contracted" not in key


def test_the_legend_names_the_node_kinds_only_of_a_state_whose_skeleton_is_drawn(torus):
    """Iteration 0 has no skeleton (nothing contracted, provisional ones not asked for): no end, junction or path
    node in its legend, nor before its state is measured; a finished run's skeleton has them."""
    session = Session(torus, ContractionParams(), look_ahead=False)
    readiness = Analyses(session).readiness(session.run, 0)
    assert readiness.provisional
    for key in (_legend(session.latest, readiness), _legend(session.latest, None)):
        assert "junction" not in key and "path node" not in key
    said = "no skeleton yet: iteration 0 is the input itself, drawn as the contracted points"
    assert said in _legend(session.latest, readiness)
    visible = {"original": True, "contracted": True, "skeleton": True, "removed": False}
    provisional = legend("plain", session.latest, readiness, note="", visible=visible, original_coloured=False,
                         provisional_wanted=True, pinned=False, labels_html="")
    assert "junction" in provisional and "skeleton provisional" in provisional
    while session.step() is not None:
        pass
    assert "junction" in _legend(session.latest, Analyses(session).readiness(session.run, len(session.history) - 1))


@pytest.fixture(scope="module")
def held_and_barely():
    """The longest status: a cloud with thin handles held in place, contracted at reduced resolution, its run ended
    at a low iteration limit barely contracted, with a parameter retuned on the last step (a figure in its end)."""
    from skelcore.solids import solid_shape

    cloud = validate(solid_shape("thin_handled_ball", 10_000).points, name="handles.xyz")
    session = Session(cloud, ContractionParams(max_iterations=3), point_budget=5_000, look_ahead=False)
    session.step()
    session.step()
    session.tune(session.params.replace(termination=0.001))
    session.step()
    return session, Analyses(session)


def test_the_longest_status_says_each_fact_once_and_leaves_figures_and_explanations_to_the_notes(held_and_barely):
    """The status sits above the tabs: each line pushes the boxes towards the window's edge. Its facts come in at
    most four short paragraphs, the run's end in its words only; the figures the run ended on and what holding
    handles means are in the notes below the tabs, why no skeleton is drawn in the legend."""
    session, analyses = held_and_barely
    run, last = session.run, len(session.history) - 1
    latest = session.latest
    assert run.reduction is not None and latest.anchored > 0 and latest.termination == "max_iterations"
    assert latest.message == "the maximum number of iterations was reached; retuned termination=0.001"
    ended = run_state(session.history, "", False)
    assert ended == "ended: the maximum number of iterations was reached"
    readiness = analyses.readiness(run, last)
    status = status_markdown(session, last, run=ended, readiness=readiness, skeleton="", following=True)
    paragraphs = status.split("\n\n")
    assert paragraphs[0] == ("**Iteration 3** of 3 computed &middot; run ended: the maximum number of iterations was "
                             "reached")
    assert paragraphs[1].startswith(f"10,000 points, {latest.anchored:,} held on thin handles &middot; "
                                    "<span style='white-space:nowrap'>W_L = ")
    assert paragraphs[2].startswith("⚠ **Barely contracted:** stopped at the iteration limit after 3 steps")
    assert len(paragraphs) == 3 and "retuned" not in status and "drawn on their axis" not in status
    notes = run_notes(run, latest, notice="")
    assert f"{latest.anchored:,} points on thin handles are held in place and drawn on their axis" in notes
    assert f"Run ended at iteration 3: {latest.message}." in notes
    # an earlier iteration, looked back at: where the browser is, and that no skeleton is drawn yet, in few words
    earlier = analyses.readiness(run, 2)
    assert earlier.provisional and not earlier.barely_contracted
    note = skeleton_note(earlier, skeleton_shown=True, provisional_wanted=False)
    assert note == "no skeleton yet (View: Show provisional)"
    status = status_markdown(session, 2, run=ended, readiness=earlier, skeleton=note, following=False)
    assert status.split("\n\n")[0] == ("**Iteration 2** of 3 computed &middot; _not following the newest (key L)_ "
                                       "&middot; run ended: the maximum number of iterations was reached")
    assert status.endswith("\n\n_no skeleton yet (View: Show provisional)_") and status.count("\n\n") == 2
    assert f"{earlier.share:.0%} of points curve-like, 50% needed" in _legend(session.history[2], earlier)
    assert skeleton_note(earlier, skeleton_shown=True, provisional_wanted=True) == "skeleton drawn provisionally"
    assert skeleton_note(earlier, skeleton_shown=False, provisional_wanted=False) == ""


def test_the_status_says_the_run_plays_exactly_while_the_button_says_pause():
    """The status reads whether the run plays from the same place as the Play button (app.playback), so Play says
    Pause only while the status says playing, whatever is being computed."""
    history = [types.SimpleNamespace(iteration=i, termination=None) for i in (0, 1)]
    assert run_state(history, "", True) == "playing"
    assert run_state(history, "computing iteration 2", True) == "playing: computing iteration 2…"
    assert run_state(history, "computing iteration 2", False) == "busy: computing iteration 2…"
    assert run_state(history, "", False, paused=True).startswith("paused")
    assert run_state(history, "", False).startswith("ready")  # between Steps: no Pause was made
    ended = [*history[:1], types.SimpleNamespace(iteration=1, termination="ring_ratio", message="")]
    assert run_state(ended, "", True) == "replaying"  # Play on an ended run replays it


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


def test_before_the_first_step_the_status_says_the_input_is_shown_not_iteration_0_of_0(torus):
    session = Session(torus, look_ahead=False)
    first = status_markdown(session, 0, run="ready", readiness=None, skeleton="", following=True)
    assert "**Iteration 0** (the input) &middot; no step taken yet" in first and "of 0" not in first
    session.step()
    assert "**Iteration 1** of 1 computed" in status_markdown(session, 1, run="ready", readiness=None, skeleton="",
                                                             following=True)


def _panel(monkeypatch):
    """A ParameterPanel on plain boxes, its pauses ended by hand; (panel, boxes, pauses, notices, taken)."""
    from app import panel as panel_module
    from app.layout import ParameterWidgets
    from app.panel import ParameterPanel

    pauses = []

    class Pause:  # the wait for the person to stop typing
        def __init__(self, seconds, then):
            pauses.append(then)

        def start(self):
            pass

    monkeypatch.setattr(panel_module, "threading", types.SimpleNamespace(Timer=Pause, Lock=threading.Lock))
    box = types.SimpleNamespace
    boxes = ParameterWidgets(method=box(value="LBC"), k=box(value="0"), wl0=box(value="0"), wh0=box(value="1"),
                             sl=box(value="3"), wl_max=box(value="2048"), max_iterations=box(value="20"),
                             termination=box(value="0.01"), hold_curves=box(value=True), hold_inside=box(value=False),
                             radius=box(value="0.02"), restart=None)
    notices, taken = [], []
    panel = ParameterPanel(boxes, types.SimpleNamespace(params=ContractionParams(), sample_radius=0.02),
                           lambda client, title, body: notices.append(body),
                           {part: lambda value, client, part=part: taken.append((part, value))
                            for part in ("parameters", "radius")}, lambda title: None)
    return panel, boxes, pauses, notices, taken


def test_a_value_being_typed_is_taken_once_the_person_stops_or_clicks(monkeypatch):
    """viser sends a box's value at every key: typing 30 into max iterations sends 3 first. Taken at once, a step
    meanwhile (Play's) would end the run at 3 iterations; a value is taken once the person stops typing, and a
    click on Step or Play takes at once the value typed last."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    for typed in ("3", "30"):
        boxes.max_iterations.value = typed
        panel.changed("parameters", None, typing=True)
    assert taken == [] and panel.typing == {"parameters": None}
    panel.flush()  # a click
    assert [(part, value.max_iterations) for part, value in taken] == [("parameters", 30)] and not panel.typing
    pauses[0]()
    pauses[1]()  # the pauses after the keys end: the value was taken already
    assert len(taken) == 1
    boxes.radius.value = "0.03"
    panel.changed("radius", None, typing=True)
    pauses[2]()  # the person stopped typing
    assert taken[1:] == [("radius", 0.03)] and notices == []
    boxes.method.value = "GLSkeleton"
    panel.changed("parameters", None, typing=False)  # chosen from a list: at once
    assert taken[-1][1].method == "glskeleton" and len(pauses) == 3


def test_the_play_interval_is_typed_as_the_parameters_are(monkeypatch):
    """It was a slider, whose box sends a typed 2e-1 as -21 (viser drops the "e"), which the slider then set to 0
    without a word: a text box now, taken once the person stops typing, a refusal said (quoting what was typed and
    the value put back) and put back; a value taken later takes the refusal's notice down."""
    from app import playback

    panel, _, pauses, notices, _ = _panel(monkeypatch)
    panel._withdraw = lambda title: notices.append(f"withdrawn {title}")
    controls = types.SimpleNamespace(interval=types.SimpleNamespace(value="0.25"))
    play = playback.Playback(types.SimpleNamespace(playing=False), controls, changed=lambda: None)
    panel.add_part("interval", play.interval_part())
    assert play.interval == 0.25
    controls.interval.value = "2e-1"
    panel.changed("interval", None, typing=True)
    pauses[-1]()
    assert play.interval == 0.2 and notices == ["withdrawn Parameter refused"]
    for typed in ("30", "-1", "soon", "0,5"):
        controls.interval.value = typed
        panel.changed("interval", None, typing=True)
        pauses[-1]()
        assert play.interval == 0.2 and controls.interval.value == "0.2"
    assert notices[1:] == [
        "Play interval (s) = '30': must be from 0 to 10 seconds; put back to '0.2'",
        "Play interval (s) = '-1': must be from 0 to 10 seconds; put back to '0.2'",
        "Play interval (s) = 'soon': must be a finite number (like 0.5 or 1e-3); put back to '0.2'",
        "Play interval (s) = '0,5': must be a finite number (like 0.5 or 1e-3) (a point marks decimals: 0.5, not "
        "0,5); put back to '0.2'"]
    controls.interval.value = "1"
    panel.changed("interval", None, typing=True)
    pauses[-1]()  # a value taken: the last refusal no longer holds
    assert play.interval == 1.0 and notices[-1] == "withdrawn Parameter refused"


def test_a_refused_value_waits_for_the_person_to_stop_typing_and_a_value_typed_on_drops_it(monkeypatch):
    """viser sends a box's value at every key (0.02 arrives as 0, 0.0, 0.02): a refusal of a typed value is said and
    put back only if it still stands once the person stops typing into its part (the contraction's parameters, or
    the sample radius); a Restart's refusal is said at once."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    boxes.termination.value = "0"
    panel.changed("parameters", None, typing=True)
    boxes.radius.value = "0"
    panel.changed("radius", None, typing=True)
    boxes.termination.value = "0.02"
    panel.changed("parameters", None, typing=True)
    assert taken == [] and set(panel.typing) == {"parameters", "radius"}
    pauses[0]()  # the person typed on: 0 is neither refused nor taken
    assert notices == [] and taken == [] and boxes.termination.value == "0.02"
    pauses[2]()
    assert [(part, value.termination) for part, value in taken] == [("parameters", 0.02)]
    pauses[1]()  # the radius was left at 0
    assert notices == ["Sample radius = '0': must be a positive finite number; put back to '0.02'"]
    assert boxes.radius.value == "0.02" and not panel.typing and len(taken) == 1
    boxes.wh0.value = "0"
    assert panel.parameters(None) is None  # Restart: said at once
    assert notices[-1].startswith("W_H0 = '0': must be") and notices[-1].endswith("put back to '1'")
    assert boxes.wh0.value == "1" and len(pauses) == 3


def test_the_real_parameters_are_read_as_typed_with_an_exponent_and_words_are_refused(monkeypatch):
    """viser's number box drops the "e" as it is typed (1e9 arrived as 19, 1e-3 as -13): the real parameters are
    text boxes read as the person wrote them, and a box holding no number is refused in the panel's words and
    put back, showing the value in force as it reads back."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    boxes.termination.value, boxes.wl_max.value, boxes.sl.value = " 1e-3 ", "2e3", "2.5"
    params = panel.parameters(None)
    assert (params.termination, params.wl_max, params.sl) == (0.001, 2000.0, 2.5) and notices == []
    boxes.wh0.value = "abc"
    assert panel.parameters(None) is None
    assert notices[-1] == "W_H0 = 'abc': must be a finite number (like 0.5 or 1e-3); put back to '1'"
    for typed, shown in (("", "(empty)"), ("1e400", "'1e400'")):
        boxes.sl.value = typed
        assert panel.parameters(None) is None and notices[-1].startswith(f"s_L = {shown}: must be a finite number")
    assert (boxes.wh0.value, boxes.termination.value, boxes.wl_max.value) == ("1", "0.001", "2000")
    assert words.number_text(0.1 + 0.2) == "0.30000000000000004" and words.number_text(2048.0) == "2048"


def test_the_whole_number_parameters_are_read_as_typed_and_fractions_and_words_are_refused(monkeypatch):
    """k and Max iterations are text boxes too: viser's number box sent 13 for 1e3 and nothing at all for letters,
    which left the box blank and a Restart on the old value without a word."""
    panel, boxes, pauses, notices, taken = _panel(monkeypatch)
    boxes.k.value, boxes.max_iterations.value = " 12 ", "1e3"
    params = panel.parameters(None)
    assert (params.k, params.max_iterations) == (12, 1000) and notices == []
    boxes.k.value = "0"
    assert panel.parameters(None).k is None  # 0 = auto
    for typed in ("twelve", "12.5", "nan"):
        boxes.k.value = typed
        assert panel.parameters(None) is None and boxes.k.value == "0"
        assert notices[-1] == f"k = '{typed}': must be 0 (auto) or a whole number (like 12 or 1e3); put back to '0'"
    boxes.max_iterations.value = "-3"
    assert panel.parameters(None) is None and notices[-1].startswith("Max iterations = '-3'")
    assert boxes.max_iterations.value == "1000"


def test_a_double_click_on_pause_pauses(monkeypatch):
    """The reviewer double-clicked Pause: the run paused and, the second click landing before the button said Play,
    played on. A Play from the same browser within a double click's time of its Pause is dropped; another
    browser's is not, nor one after it, and a Pause never is."""
    from app import playback

    clock = [100.0]
    monkeypatch.setattr(playback.time, "monotonic", lambda: clock[0])
    worker = types.SimpleNamespace(playing=False)
    worker.play = lambda tick, client, interval: setattr(worker, "playing", True)
    worker.pause = lambda: setattr(worker, "playing", False)
    controls = types.SimpleNamespace(interval=types.SimpleNamespace(value=0.5))
    play = playback.Playback(worker, controls, changed=lambda: None)
    me, other = types.SimpleNamespace(client_id=1), types.SimpleNamespace(client_id=2)
    play.toggle(lambda: lambda: True, me)
    clock[0] += 0.1
    play.toggle(lambda: lambda: True, me)  # Pause at once: never dropped
    assert not worker.playing
    clock[0] += 0.2
    play.toggle(lambda: lambda: True, me)  # the double click's second half
    assert not worker.playing
    play.toggle(lambda: lambda: True, other)  # another browser's Play is its own
    assert worker.playing
    play.toggle(lambda: lambda: True, other)
    clock[0] += playback.DOUBLE_CLICK
    play.toggle(lambda: lambda: True, me)
    assert worker.playing


def test_the_run_reads_paused_only_after_a_pause():
    """A person's Pause of a playing run makes the status say "paused"; a Step, a Play and Run to end take it back
    (the status said "paused" after a single Step, which two walk-throughs read as a Pause they had not made)."""
    from app import playback

    worker = types.SimpleNamespace(playing=False)
    worker.play = lambda tick, client, interval: setattr(worker, "playing", True)
    worker.pause = lambda: setattr(worker, "playing", False)
    play = playback.Playback(worker, types.SimpleNamespace(interval=types.SimpleNamespace(value=0.5)),
                             changed=lambda: None)
    history = [types.SimpleNamespace(iteration=i, termination=None) for i in (0, 1)]
    play.stepped()
    assert not play.paused and run_state(history, "", worker.playing, paused=play.paused) == "ready"
    play.toggle(lambda: lambda: True, None)
    play.toggle(lambda: lambda: True, None)  # Pause
    assert play.paused and run_state(history, "", worker.playing, paused=play.paused) == "paused"
    play.stepped()
    assert not play.paused
    play.paused = True
    play.start(lambda: True, None, full=False)  # Run to end
    assert not play.paused
    play.pause()  # the run's own end
    assert not play.paused


def _criterion(name: str, passed: bool) -> dict:
    return {"name": name, "value": "1", "threshold": "t", "passed": passed, "severity": "unstable", "text": name}


def _headline(line) -> str:
    """The markdown of the headline above the histograms, out of its clamping <div> (app.viewer.HEADLINE_STYLE)."""
    return line.content.split("\n\n")[1]


def _verdict_viewer():
    line, table = types.SimpleNamespace(content=""), types.SimpleNamespace(content="")
    return types.SimpleNamespace(ui=types.SimpleNamespace(plots=types.SimpleNamespace(verdict=table,
                                                                                       verdict_line=line)))


def test_the_verdict_line_above_the_histograms_names_the_failed_criteria():
    """The headline says why, not only "unstable": the first two failed criteria by name, the rest counted."""
    from app.viewer import Viewer

    viewer = _verdict_viewer()
    line, table = viewer.ui.plots.verdict_line, viewer.ui.plots.verdict
    names = ["D_theta peaks", "delta_kappa peaks", "points inside the original", "skeleton loops"]
    for failing, said in (([], ""), (names[1:2], " · failed: delta_kappa peaks"),
                          (names[1:], " · failed: delta_kappa peaks, points inside the original and 1 more")):
        criteria = [_criterion(name, name not in failing) for name in names]
        label = "unstable" if failing else "stable"
        Viewer.show_verdict(viewer, {"label": label, "iteration": 4, "criteria": criteria})
        assert _headline(line) == f"**Iteration 4: {label}**{said} _(see Verdict tab)_"
        assert all(f"| {name} |" in table.content for name in names)  # the tab keeps every criterion


def test_a_long_verdict_headline_keeps_to_two_lines_and_the_verdict_tab_keeps_it_all():
    """At 1280x720 a third line of the headline gave the plots panel a scrollbar: with long criteria failed and a
    hint, 150 characters. The headline names fewer criteria, then counts them, to stay within two lines; the
    panel clamps it there whatever the font; its hover and the Verdict tab say everything."""
    from app.status import HEADLINE_CHARS
    from app.viewer import HEADLINE_STYLE, Viewer

    viewer = _verdict_viewer()
    line, table = viewer.ui.plots.verdict_line, viewer.ui.plots.verdict
    names = ["curve-like share of the cloud", "spread against the original", "points inside the original",
             "contraction steps taken", "skeleton loops"]
    hint = "1 of the mesh's 2 loops kept: try More > Hold inside"
    for label, iteration, given, said in (
            ("not yet converged", 123, "", "failed: curve-like share of the cloud and 4 more"),
            ("unstable", 12, hint, "5 criteria failed")):
        verdict = {"label": label, "iteration": iteration, "criteria": [_criterion(name, False) for name in names]}
        Viewer.show_verdict(viewer, verdict, given)
        headline = _headline(line)
        assert said in headline and len(headline.replace("**", "").replace("_(", "(").replace(")_", ")")) \
            <= HEADLINE_CHARS
        assert line.content.startswith(HEADLINE_STYLE) and "-webkit-line-clamp: 2" in HEADLINE_STYLE
        assert all(name in line.content.split('title="')[1].split('"')[0] for name in names)  # on hover: all
        assert all(f"| {name} |" in table.content for name in names) and given in table.content


def test_the_headline_says_to_hold_inside_when_the_skeleton_keeps_fewer_loops_than_the_solid():
    """A tall pipe's bore pulled onto its axis: the headline names what to try, unless the run held its points inside
    already, no solid is known (neither a closed mesh's genus nor a closed cloud's read), or the skeleton keeps
    every loop."""
    from app.status import hold_inside_hint
    from app.viewer import Viewer

    lost = {"label": "unstable", "iteration": 5, "criteria": [{**_criterion("skeleton loops", False), "value": "0"}]}
    plain, held = (types.SimpleNamespace(params=ContractionParams(hold_inside=on)) for on in (False, True))
    hint = hold_inside_hint(lost, plain, lambda: 1)
    assert hint == "0 of the mesh's 1 loop kept: try More > Hold inside"
    assert hold_inside_hint(lost, held, lambda: 1) == hold_inside_hint(lost, plain, lambda: None) \
        == hold_inside_hint(lost, plain, lambda: 0) == ""
    kept = {**lost, "criteria": [{**_criterion("skeleton loops", True), "value": "1"}]}
    assert hold_inside_hint(kept, plain, lambda: 1) == ""
    # the solid is read (a few tenths of a second for a cloud) only where the hint could be given
    unread = lambda: 1 / 0  # noqa: E731
    assert hold_inside_hint(lost, held, unread) == hold_inside_hint({"criteria": []}, plain, unread) == ""
    # the hint reads the skeleton's loop count whether the criterion passed or failed
    agreed = {**lost, "criteria": [{**_criterion("skeleton loops", True), "value": "0"}]}
    assert hold_inside_hint(agreed, plain, lambda: 2, mesh=False) \
        == "0 of the solid's 2 loops kept: try More > Hold inside"
    viewer = _verdict_viewer()
    line, table = viewer.ui.plots.verdict_line, viewer.ui.plots.verdict
    Viewer.show_verdict(viewer, lost, hint)
    assert _headline(line) == ("**Iteration 5: unstable** · failed: skeleton loops · **0 of the mesh's 1 loop kept: "
                               "try More > Hold inside** _(see Verdict tab)_")
    assert "**Iteration 5: unstable**\n\n**0 of the mesh's 1 loop kept: try More > Hold inside**\n" in table.content


def test_about_this_run_says_what_loading_and_cleaning_did_to_the_input():
    """A mesh drawn over instead of its vertices was said only in the terminal or a passing notification; the notes
    below the tabs keep it, beside what cleaning removed."""
    import numpy as np

    from skelcore.solids import solid_mesh

    vertices, faces = solid_mesh("block_2_holes")
    session = Session(validate(vertices, faces, name="block.stl"), look_ahead=False)
    notes = run_notes(session.run, session.history[0], notice="")
    assert notes.startswith(f"Mesh: its {len(vertices):,} vertices leave ") and "points are drawn evenly over it" in notes
    drawn = len(session.run.cloud.points)
    assert drawn > 5000 and f"The histograms judge a fixed random sample of 5,000 of the {drawn:,} points" in notes
    points = np.vstack([make_shape("torus", 3000, seed=0).points, [[9.0, 9.0, 9.0], [-9.0, 9.0, 9.0]]])
    session = Session(validate(points, name="torus.xyz"), look_ahead=False)
    notes = run_notes(session.run, session.history[0], notice="")
    assert "Cleaning removed 2 outliers (3,002 -> 3,000 points)." in notes
    assert "The histograms judge" not in notes  # every point judged
    merging = Session(validate(points, name="torus.xyz"), ContractionParams(method="glskeleton"), look_ahead=False)
    assert ("The histograms judge the 3,000 points, those of them GLSkeleton has not merged into others; their n "
            "counts those with a value") in run_notes(merging.run, merging.history[0], notice="")


def test_about_this_run_says_a_cloud_is_sparser_than_the_skeletons_balls():
    """As `skelcore run` says it; known once a skeleton of the run has read the surface."""
    sparse = Session(validate(make_shape("torus", 400, seed=0).points, name="sparse.xyz"), look_ahead=False)
    dense = Session(validate(make_shape("torus", 3000, seed=0).points, name="dense.xyz"), look_ahead=False)
    for session in (sparse, dense):
        session.step()
        session.skeleton(1)
    [note] = sparse.run.surface[2].scale_notes(sparse.sample_radius)
    assert note.startswith("a sparse cloud: its points lie ")
    assert f"A{note[1:]}." in run_notes(sparse.run, sparse.history[1], notice="", skeleton=[note])
    assert dense.run.surface[2].scale_notes(dense.sample_radius) == []


def test_a_refused_label_weight_is_worded_as_the_panel_names_it_with_what_was_typed():
    """The Labels tab's boxes: a refusal names the label (negative labels too) and quotes the text typed."""
    from skelcore.errors import ParameterError

    for label_value, typed in ((3, "0"), (-3, "x"), (7, "0,5")):
        with pytest.raises(ParameterError) as refusal:
            words.typed_weight(label_value, typed)
        message = str(refusal.value)
        assert words.refused_field(message) == words.weight_name(label_value)
        worded = words.refused(message, {words.weight_name(label_value): typed})
        assert worded.startswith(f"the weight of label {label_value} = '{typed}': must be a positive number")
        assert worded.endswith("(a point marks decimals: 0.5, not 0,5)") == ("," in typed)
    assert words.typed_weight(1, " 1e-2 ") == 0.01


def test_a_sparse_clouds_spacing_is_told_apart_from_the_sample_radius_it_exceeds():
    """"its points lie 2.0% of the diagonal apart, more than the skeleton's sample radius (2.0%)" (a walk-through):
    where one decimal does not tell the spacing from the radius, it gets two."""
    from types import SimpleNamespace

    from skelcore.surface import OriginalSurface

    def note(spacing):
        surface = SimpleNamespace(spacing=spacing, diagonal=1.0, pieces=(1, None),
                                  gap_unit=lambda radius: max(radius, spacing))
        return OriginalSurface.scale_notes(surface, 0.02)[0]

    assert note(0.0204).startswith("a sparse cloud: its points lie 2.04% of the diagonal apart, more than the "
                                   "skeleton's sample radius (2.0%)")
    assert note(0.039).startswith("a sparse cloud: its points lie 3.9% of the diagonal apart")
