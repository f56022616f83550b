"""The inspector without a browser: a viser server, and a stand-in for a browser where a test needs one."""
from __future__ import annotations

import contextlib

import numpy as np
import pytest

from app.session import Session
from skelcore.io import validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape


@pytest.fixture(scope="module")
def cloud():
    return validate(make_shape("torus", 800).points, name="torus.xyz")


class _Broadcast:
    """A browser stand-in: the server's own GUI and scene, which every browser shares; its notices are kept."""
    client_id = 1

    def __init__(self, server):
        self.gui, self.scene, self.atomic, self.flush = server.gui, server.scene, server.atomic, server.flush
        self.notices: list[tuple[str, str]] = []

    def add_notification(self, title, body, **_):
        import types

        self.notices.append((title, body))
        return types.SimpleNamespace(remove=lambda: None)


def test_while_playing_the_plots_follow_the_points_when_each_computation_outlasts_an_iteration(cloud):
    """Each analysis ends only once the points have moved past its state, as when the metrics and figures take longer
    than an iteration: the plots of a state already passed are still drawn, the newest ready, so they trail the
    points by one computation, never by many; once the run ends they show its last state."""
    import time

    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, ContractionParams(wl0=1.0, sl=1.0, max_iterations=12),
                                          look_ahead=False))
    presenter, drawn = inspector.presenter, []
    try:
        inspector._connect(_Broadcast(server))
        assert inspector.wait_idle(120)
        viewer = presenter.all()[0]
        plots, mark = presenter.analyses.plots, presenter.mark

        def outlasting(run, index):
            while inspector.worker.playing and viewer.drawn["points"][1] <= index:
                time.sleep(0.01)
            return plots(run, index)

        def recording(stage, each, run, index):
            drawn.append((stage, index, inspector.worker.playing, viewer.drawn["points"][1]))
            mark(stage, each, run, index)

        presenter.analyses.plots, presenter.mark = outlasting, recording
        inspector.playback.start(lambda: inspector._tick(True), None, full=True)
        assert inspector.wait_idle(120) and inspector.session.finished
    finally:
        inspector.close()
        server.stop()
    while_playing = [(index, shown) for stage, index, playing, shown in drawn if stage == "plots" and playing]
    assert len(while_playing) >= 2, drawn
    assert all(index < shown for index, shown in while_playing)  # of a state passed, never of one to come
    assert [index for stage, index, *_ in drawn if stage == "plots"][-1] == len(inspector.session.history) - 1


def test_the_asset_list_selects_the_cloud_loaded_or_none(assets_dir):
    """Files' list of bundled assets shows the loaded cloud when it is one of them, an entry selecting none for
    another file (an upload named like an asset included), never the list's first asset."""
    import types

    import viser

    from app.inspector import Inspector
    from app.layout import NO_ASSET
    from app.main import bundled_assets
    from skelcore.io import load

    assets = bundled_assets(assets_dir)
    assert next(iter(assets)) != "torus.ply"
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(load(assets["torus.ply"]), look_ahead=False), assets=assets)
    listed = inspector.ui.files.asset
    try:
        assert inspector.wait_idle(120) and listed.value == "torus.ply" and listed.options == tuple(assets)
        inspector.open(validate(make_shape("capsule", 800).points, name="capsule.ply"))
        assert inspector.wait_idle(120) and inspector.session.cloud.name == "capsule.ply"
        assert listed.value == NO_ASSET and listed.options == (NO_ASSET, *assets)
        inspector.loader.on_load_asset(types.SimpleNamespace(client=None))
        assert inspector.wait_idle(120) and inspector.session.cloud.name == "capsule.ply"  # the entry loads nothing
        listed.value = "y_branch.ply"
        inspector.loader.on_load_asset(types.SimpleNamespace(client=None))
        assert inspector.wait_idle(120) and inspector.session.cloud.name.endswith("y_branch.ply")
        assert listed.value == "y_branch.ply" and listed.options == tuple(assets)
    finally:
        inspector.close()
        server.stop()


def test_an_upload_with_nan_rows_is_offered_without_them_only_when_the_rest_can_be_loaded(cloud):
    """A file whose finite rows are too few to load is refused at once, in one line saying so, not after the person
    agreed to drop the others; with enough of them the drop is offered, as a question alone."""
    import dataclasses
    import types

    import viser
    from viser._gui_handles import UploadedFile

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, look_ahead=False))
    loader, said = inspector.loader, {}
    try:
        assert inspector.wait_idle(120)
        for finite in (4, 40):
            points = np.vstack([make_shape("capsule", 40, seed=0).points[:finite], [[np.nan, 1, 1], [2, 2, np.inf]]])
            data = "\n".join(" ".join(f"{value:.6f}" for value in row) for row in points).encode()
            loader.files = dataclasses.replace(loader.files, upload=types.SimpleNamespace(
                value=UploadedFile("holes.xyz", data)))  # what viser holds once a browser uploaded the file
            client = _Broadcast(server)
            loader.on_upload(types.SimpleNamespace(client=client))
            assert inspector.wait_idle(120)
            said[finite] = [notice for notice in client.notices if not notice[0].startswith("Reading")]  # no progress
        offers = [handle.label for handle in server.gui._gui_input_handle_from_uuid.values()
                  if getattr(handle, "label", "").startswith("Drop ")]
    finally:
        inspector.close()
        server.stop()
    assert said[4] == [("Error", "holes.xyz: only 4 distinct points remain after dropping the 2 with NaN or Inf "
                                 "coordinates, at least 20 are needed")]
    assert said[40] == [] and offers == ["Drop 2 points and load"]  # a question, not an error as well
    assert inspector.session.cloud.name == cloud.name  # nothing loaded without the person's yes


def test_colour_by_label_is_offered_only_for_a_cloud_with_labels(cloud):
    """An unlabelled cloud has nothing to colour by label: the entry is left out, and a view coloured by the labels
    of the cloud before turns plain."""
    import viser

    from app.inspector import Inspector

    labelled = validate(cloud.points, name="labelled.xyz", labels=(cloud.points[:, 0] > 0).astype(np.int64))
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, look_ahead=False))
    colouring = inspector.ui.view.colouring
    try:
        assert inspector.wait_idle(120) and "label" not in colouring.options
        inspector.open(labelled)
        assert inspector.wait_idle(120) and colouring.options[-1] == "label"
        colouring.value = "label"
        inspector.presenter.set_colouring()
        inspector.open(cloud)
        assert inspector.wait_idle(120) and "label" not in colouring.options
        assert colouring.value == "plain" and inspector.presenter.colour_by == "plain"
    finally:
        inspector.close()
        server.stop()


def test_the_iteration_slider_marks_no_end_before_the_first_step():
    """With iteration 0 alone the slider spans 0..1 (viser needs an end past its start): only the 0 is marked, not
    an end that reads "1"; from the first step both ends are."""
    import viser

    from app.viewer import Viewer

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        viewer = Viewer(_Broadcast(server), order=0.0, notes_order=1.0)
        timeline = viewer.ui.timeline
        viewer.set_timeline(1, 0)
        assert [(mark.value, mark.label) for mark in timeline._marks] == [(0, "0")] and timeline.disabled
        viewer.set_timeline(3, 2)
        assert timeline._marks is None and timeline.max == 2 and timeline.value == 2 and not timeline.disabled
        viewer.set_timeline(1, 0)  # a Reset
        assert [mark.label for mark in timeline._marks] == ["0"]
    finally:
        server.stop()


@contextlib.contextmanager
def served(cloud):
    """An idle inspector on `cloud` (no look-ahead) with its own viser server, closed afterwards."""
    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, look_ahead=False))
    try:
        assert inspector.wait_idle(120)
        yield inspector
    finally:
        inspector.close()
        server.stop()


def test_a_gltf_opens_with_y_up_and_a_chosen_up_stays_for_formats_that_fix_none(cloud):
    """Every cloud opened with +Z up, so a glTF (whose format fixes +Y up) lay on its side."""
    from skelcore.display import UP_AXES

    with served(cloud) as inspector:
        up = inspector.ui.view.up
        assert up.value == "+Z" and np.allclose(inspector.server.initial_camera.up, UP_AXES["+Z"])
        inspector.open(validate(cloud.points, name="scan.glb"))
        assert inspector.wait_idle(120)
        assert up.value == "+Y" and np.allclose(inspector.server.initial_camera.up, UP_AXES["+Y"])
        # the first view still looks down on the object from aside, about the new up
        camera = inspector.server.initial_camera
        assert (camera.look_at - camera.position) @ UP_AXES["+Y"] < 0
        inspector.presenter.turn_up("-X", chosen=True)  # a person's choice, from the View tab
        inspector.open(validate(cloud.points, name="scan.ply"))
        assert inspector.wait_idle(120)
        assert up.value == "-X" and np.allclose(inspector.server.initial_camera.up, UP_AXES["-X"])
        inspector.open(validate(cloud.points, name="scan.gltf"))
        assert inspector.wait_idle(120)
        assert up.value == "+Y"
    with served(validate(cloud.points, name="opened.glb")) as inspector:  # given at the start, not loaded later
        assert inspector.ui.view.up.value == "+Y"


def test_the_log_tab_shows_the_newest_line_first(cloud):
    """At 1280x720 the Log tab holds a few lines before the control panel scrolls: the newest go on top."""
    from app.presenter import LOG_LINES

    with served(cloud) as inspector:
        inspector.open(validate(cloud.points[::2], name="half.xyz"))
        assert inspector.wait_idle(120)
        inspector.presenter.update_statuses()
        lines = inspector.ui.log.content.split("\n")
        assert lines == [f"- {line}" for line in inspector.session.log[::-1][:LOG_LINES]] and len(lines) >= 2


def test_fit_view_frames_the_contracted_points_of_the_iteration_shown_too(cloud, monkeypatch):
    """A step can fling contracted points out of the original's box: Fit view keeps them in the picture."""
    import types

    import app.scene as scene_module

    framed = []
    real = scene_module.framing_camera
    monkeypatch.setattr(scene_module, "framing_camera",
                        lambda points, *args, **kwargs: framed.append(points) or real(points, *args, **kwargs))
    with served(cloud) as inspector:
        for _ in range(2):
            inspector.session.step()
        camera = types.SimpleNamespace(look_at=np.zeros(3), position=np.array([0.0, -5.0, 0.0]), fov=0.9, aspect=1.5,
                                       image_height=720, up_direction=np.array([0.0, 0.0, 1.0]))
        client = types.SimpleNamespace(client_id=-1, camera=camera)
        inspector.presenter.viewers[-1] = types.SimpleNamespace(shown=2)
        try:
            inspector.presenter.fit(client)
            contracted = inspector.session.run.state(2).points
            assert np.array_equal(framed[-1], np.concatenate([inspector.session.cloud.points, contracted]))
            inspector.presenter.viewers[-1].shown = 0  # the input alone
            inspector.presenter.fit(client)
            assert np.array_equal(framed[-1], inspector.session.cloud.points)
        finally:
            inspector.presenter.viewers.pop(-1)


def test_scrubbed_back_the_convergence_shows_the_whole_run_with_the_iteration_marked(cloud):
    """The histograms are of the iteration shown; the convergence goes on to the newest, the shown one marked."""
    with served(cloud) as inspector:
        for _ in range(3):
            inspector.session.step()
        run = inspector.session.run
        theta, _, convergence = inspector.presenter.analyses.plots(run, 1).figures
        assert theta.layout.title.text.endswith("iteration 1")
        assert list(convergence.data[0].x) == [state.iteration for state in run.history]
        assert [(shape.x0, shape.type) for shape in convergence.layout.shapes if shape.yref.endswith("domain")] == [
            (1, "line"), (1, "line")]
        newest = inspector.presenter.analyses.plots(run, len(run.history) - 1).figures[2]
        assert not [shape for shape in newest.layout.shapes if shape.yref.endswith("domain")]


def test_play_on_an_ended_run_replays_its_iterations_in_the_browser_that_asked(cloud):
    """Once the run has ended Play has nothing to compute: it shows the run's iterations again, from the first
    when the browser shows the last, from the next one after an iteration scrubbed to, and stops at the last
    with the Play button back (before, a click did nothing that could be seen)."""
    import types

    shown: list[int] = []
    with _playing(Session(cloud, ContractionParams(wl0=1.0, sl=3.0), look_ahead=False)) as (inspector, browser):
        inspector.playback.start(lambda: inspector._tick(False), None, full=False)  # Run to end
        assert inspector.wait_idle(120) and inspector.session.finished
        newest = len(inspector.session.history) - 1
        assert newest >= 2
        viewer = inspector.presenter.all()[0]
        assert viewer.shown == newest
        show = inspector.presenter.show
        inspector.presenter.show = lambda v, index, full=True: (shown.append(index), show(v, index, full))
        click = types.SimpleNamespace(client=browser)
        inspector._on_play(click)
        assert inspector.wait_idle(120) and not inspector.worker.playing
        assert shown == list(range(newest + 1)) and viewer.shown == newest and viewer.following
        assert inspector.ui.run.play.label == "Replay"
        shown.clear()
        inspector._view_iteration(viewer, 1)
        assert inspector.wait_idle(120)
        inspector._on_play(click)
        assert inspector.wait_idle(120)
        assert shown == list(range(1, newest + 1))  # the scrub, then on from the iteration after it


@contextlib.contextmanager
def _playing(session: Session):
    """An inspector of `session` on a local server, one browser connected and Play's interval 0; closed after."""
    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, session)
    inspector.playback.set_interval(0.0)
    browser = _Broadcast(server)
    try:
        inspector._connect(browser)
        assert inspector.wait_idle(120)
        yield inspector, browser
    finally:
        inspector.close()
        server.stop()


def test_play_clicked_while_the_step_that_ends_the_run_waits_replays_the_run(cloud):
    """Play chose between stepping and replaying when clicked, before the Step queued ahead of it had run: a Step
    that ended the run left Play stepping past the end, which showed nothing, the button flashing Pause. It chooses
    as it starts, after that Step; and once the run has ended the button says Replay, what a click then does."""
    import threading
    import types

    params = ContractionParams(wl0=1.0, sl=3.0)
    counting, steps = Session(cloud, params, look_ahead=False), 0
    while not counting.finished:
        counting.step()
        steps += 1
    shown: list[int] = []
    with _playing(Session(cloud, params, look_ahead=False)) as (inspector, browser):
        click = types.SimpleNamespace(client=browser)
        for _ in range(steps - 1):  # up to the Step that ends the run
            inspector._on_step(click)
            assert inspector.wait_idle(120)
        assert not inspector.session.finished and inspector.ui.run.play.label == "Play"
        show = inspector.presenter.show
        inspector.presenter.show = lambda v, index, full=True: (shown.append(index), show(v, index, full))
        busy = threading.Event()
        inspector.worker.submit(busy.wait)  # the worker is still at work when both clicks arrive
        inspector._on_step(click)
        inspector._on_play(click)
        busy.set()
        assert inspector.wait_idle(120) and inspector.session.finished
        newest = len(inspector.session.history) - 1
        assert shown == [newest, *range(newest + 1)]  # the Step's end, then the run from its first iteration
        assert inspector.ui.run.play.label == "Replay"


def test_a_dense_closed_cloud_opens_with_original_points_small_enough_to_see_through():
    """The View tab's original size starts where skelcore.display.see_through_size puts it for the cloud loaded, so
    the person sees the setting and can undo it; a sparse cloud starts at 1."""
    import viser

    from app.inspector import Inspector
    from app.scene import POINT_SIZES
    from skelcore.display import see_through_size

    points = np.random.default_rng(0).normal(size=(12_000, 3))
    dense = validate(points / np.linalg.norm(points, axis=1, keepdims=True), name="ball.xyz")
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(dense, ContractionParams(), look_ahead=False))
    try:
        inspector._connect(_Broadcast(server))
        assert inspector.wait_idle(120)
        size = float(inspector.ui.view.size["original"].value)
        assert size == see_through_size(dense.points, 1.0, POINT_SIZES["original"]) and size < 1
    finally:
        inspector.close()
        server.stop()


def test_a_message_pushed_from_a_worker_thread_wakes_the_sender_from_the_loop_only():
    """viser sets a buffer's wake-up event from the pushing thread and again on its loop; asyncio's Event is not
    thread-safe (a set() off the loop walked the waiters while the loop changed them: "deque mutated during
    iteration" out of a status update). After app.loop_events.install the off-loop set() leaves the waiters alone
    and the loop's set() wakes them; every message buffer made afterwards, and the server's broadcast one, are so."""
    import asyncio
    import threading

    import viser
    from viser.infra._async_message_buffer import AsyncMessageBuffer

    from app import loop_events

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        loop_events.install(server)
        assert isinstance(server._websock_server._broadcast_buffer.message_event, loop_events._LoopOnlyEvent)
        loop = asyncio.new_event_loop()
        buffer = AsyncMessageBuffer(loop, persistent_messages=False)
        event = buffer.message_event
        assert isinstance(event, loop_events._LoopOnlyEvent)

        async def woken() -> bool:
            waiter = asyncio.ensure_future(event.wait())
            await asyncio.sleep(0)  # the waiter is queued on the event
            off_loop = threading.Thread(target=event.set)
            off_loop.start()
            off_loop.join()
            still_waiting = not waiter.done() and not event.is_set()
            loop.call_soon(event.set)  # what viser schedules after every push
            await asyncio.wait_for(waiter, 5)
            return still_waiting

        assert loop.run_until_complete(woken())
        loop.close()
    finally:
        server.stop()


def test_view_sizes_and_opacities_typed_past_their_sliders_are_put_back_within_them(cloud):
    """The box beside a slider takes any number: a contracted size of 1000 froze every browser drawing it, -1 hid a
    layer, an opacity of -1 drew one black dot. Values are kept within the slider's range, and the box shows it."""
    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, ContractionParams(), look_ahead=False))
    try:
        inspector._connect(_Broadcast(server))
        assert inspector.wait_idle(120)
        size, opacity = inspector.ui.view.size, inspector.ui.view.opacity
        size["contracted"].value, size["original"].value, opacity["original"].value = 1000.0, -1.0, float("nan")
        inspector.presenter.apply_view()
        assert (size["contracted"].value, size["original"].value, opacity["original"].value) == (
            size["contracted"].max, size["original"].min, 1.0)
        view = inspector.presenter.all()[0].view
        assert view.sizes["contracted"] == size["contracted"].max and view.opacity["original"] == 1.0
    finally:
        inspector.close()
        server.stop()


def test_a_cloud_in_map_coordinates_is_drawn_from_its_own_centre():
    """The scene's positions are float32 from the cloud's display origin (a trunk at 5e6 m was drawn as a few
    lines of points), read back in the cloud's coordinates, and the first camera clips around the cloud's size."""
    import viser

    from app.inspector import Inspector
    from skelcore.display import clipping_planes

    rng = np.random.default_rng(0)
    angle, height = rng.random(3000) * 2 * np.pi, rng.random(3000) * 4.0
    trunk = np.column_stack([0.3 * np.cos(angle), 0.3 * np.sin(angle), height]) + [512345.0, 5412345.0, 120.0]
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(validate(trunk, name="trunk.xyz"), ContractionParams(), look_ahead=False))
    try:
        inspector._connect(_Broadcast(server))
        assert inspector.wait_idle(120)
        view = inspector.presenter.all()[0].view
        drawn = view._handles["original"].points
        assert np.abs(drawn).max() < 3  # from the trunk's centre, not 5e6 away
        points = inspector.session.cloud.points
        rows = view.rows(len(points), "original")
        np.testing.assert_allclose(view.drawn_points("original"), points if rows is None else points[rows], atol=1e-5)
        camera = server.initial_camera
        assert (camera.near, camera.far) == clipping_planes(inspector.session.cloud.points)
    finally:
        inspector.close()
        server.stop()


def test_every_box_of_a_fractional_parameter_keeps_what_is_typed():
    """The browser rounds a number box to its step's decimals (the W_L cap's step of 1 turned a typed 2.5 into 2)
    and drops the "e" of 1e-3 as it is typed: every real parameter is a text box, read as typed."""
    import dataclasses

    import viser

    from app.layout import build_parameters
    from app.words import typed_number

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        params = ContractionParams()
        widgets = build_parameters(server.gui, server.gui.add_tab_group(), params, 0.02)
        fractional = [f.name for f in dataclasses.fields(params) if f.type in ("float", "float | None")]
        boxes = {name: getattr(widgets, name) for name in fractional if hasattr(widgets, name)}
        assert {"wl0", "wh0", "sl", "wl_max", "termination"} <= set(boxes)
        assert all(isinstance(box, viser.GuiTextHandle) for box in boxes.values())
        assert [typed_number(name, text) for name, text in (("wl_max", "2.5"), ("termination", "1e-3"))] == [2.5, 0.001]
    finally:
        server.stop()


def test_a_starting_weight_typed_above_its_cap_is_said_to_start_at_the_cap(cloud):
    """W_L never exceeds the W_L cap: a W_L0 typed above it started the run at the cap without a word, and one
    step pulled a hand to a dot while the box still showed 1e+12."""
    with served(cloud) as inspector:
        client = _Broadcast(inspector.server)
        inspector.worker.submit(lambda: inspector._tune(inspector.session.params.replace(wl0=1e12), client), client)
        assert inspector.wait_idle(60)
        assert client.notices == [("Capped", "W_L0 = 1e+12 is above its cap (W_L cap = 2048): the run starts at the "
                                              "cap, where a larger W_L0 changes nothing")]
        inspector.worker.submit(lambda: inspector._tune(inspector.session.params.replace(wl0=2.0), client), client)
        assert inspector.wait_idle(60) and len(client.notices) == 1


def test_the_first_view_fits_the_cloud_between_the_panels_of_a_1280x720_window():
    """A browser tells its canvas only once connected: the first view frames the cloud for the narrowest canvas,
    between the panels of a 1280x720 window, with the framing's margin (framed for a 1600x1000 one, the animal's head
    reached the controls' edge)."""
    import viser

    from app.inspector import Inspector
    from app.layout import NARROWEST_CANVAS
    from app.scene import FRAME_FILL
    from skelcore.display import display_origin
    from skelcore.shapes import make_shape

    points = make_shape("y_branch", 2000).points * [3.0, 1.0, 1.0]  # wider than tall
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(validate(points, name="wide.xyz"), ContractionParams(), look_ahead=False))
    try:
        assert inspector.wait_idle(120)
        camera = server.initial_camera
        forward = np.asarray(camera.look_at) - np.asarray(camera.position)
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, camera.up)
        right /= np.linalg.norm(right)
        local = points - display_origin(points) - np.asarray(camera.position)
        across = np.abs(local @ right) / (local @ forward)  # tan of each point's angle off the view's axis
        half_width = np.tan(camera.fov / 2) * NARROWEST_CANVAS[0] / NARROWEST_CANVAS[1]
        # the framing aims with a sample of the points: those left out may reach a little further
        assert 0.9 < across.max() / (FRAME_FILL * half_width) < 1.05
    finally:
        inspector.close()
        server.stop()
