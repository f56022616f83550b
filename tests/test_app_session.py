"""The inspector's session, worker threads, colours and exports, without a browser."""
from __future__ import annotations

import dataclasses
import io
import threading
import zipfile

import numpy as np
import pytest

from app import export
from app.colours import colour_values
from app.session import Session
from app.worker import Latest, Worker
from skelcore.errors import InputError, ParameterError
from skelcore.io import load_bytes, validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape


@pytest.fixture(scope="module")
def cloud():
    return validate(make_shape("torus", 800).points, name="torus.xyz")


@pytest.fixture
def session(cloud):
    return Session(cloud, ContractionParams())


def test_steps_to_the_end_then_refuses(session):
    while session.step() is not None:
        pass
    iterations = [state.iteration for state in session.history]
    assert iterations == list(range(len(iterations)))
    assert session.finished and session.latest.termination
    assert session.step() is None
    assert any(line.startswith("ended at iteration") for line in session.log)


def test_weight_change_applies_from_the_next_step(session):
    session.step()
    message = session.tune(session.params.replace(sl=2.0))
    assert "s_L 2 from iteration 2" in message
    state = session.step()
    assert state.params.sl == 2.0 and session.history[1].params.sl == 3.0
    assert state.wl == pytest.approx(session.history[0].wl * 2.0)


def test_the_curve_hold_can_be_switched_off_and_on_during_a_run(session):
    assert session.params.hold_curves  # the default
    session.step()
    message = session.tune(session.params.replace(hold_curves=False))
    assert "Hold curves off from iteration 2" in message
    assert not session.step().params.hold_curves
    message = session.tune(session.params.replace(hold_curves=True))
    assert "Hold curves on from iteration 3" in message
    assert session.step().params.hold_curves


def test_tuning_after_the_end_waits_for_restart(session):
    while session.step() is not None:
        pass
    message = session.tune(session.params.replace(sl=2.0))
    assert message == "s_L 2 at restart (the run has ended)" and session.pending == message
    assert "from iteration" not in message


def test_pending_change_is_told_until_used(session):
    session.tune(session.params.replace(wh0=2.0))
    assert session.pending == "W_H0 2 from iteration 1"
    session.step()
    assert session.pending == ""


def test_restart_only_fields_wait_for_restart(session):
    session.step()
    message = session.tune(session.params.replace(k=12, wh0=2.0))
    assert "W_H0 2 from iteration 2" in message and "k 12 at restart" in message
    assert session.step().params.k is None  # the running generator never sees k
    session.restart(session.params.replace(k=12))
    assert len(session.history) == 1 and session.start_params.k == 12


def test_restart_starts_a_new_run_with_its_own_caches(session):
    session.step()
    first_run = session.run
    session.metrics(1)
    session.restart()
    assert session.run is not first_run and len(session.history) == 1
    assert first_run.metrics is not None and session.run.metrics is None


def test_metrics_and_skeletons_are_computed_once(session):
    session.step()
    session.step()
    metrics = session.metrics_upto(2)
    assert [m.iteration for m in metrics] == [0, 1, 2]
    assert session.metrics(1) is metrics[1]
    assert session.verdict(2)["label"] in ("stable", "not yet converged", "unstable")
    assert session.verdict(0)["label"] is None  # nothing has happened at iteration 0
    judged = session.verdict(2, with_skeleton=True)
    assert judged["iteration"] == 2 and "skeleton loops" in {c["name"] for c in judged["criteria"]}
    assert "skeleton loops" not in {c["name"] for c in session.verdict(2)["criteria"]}
    skeleton = session.skeleton(2)
    assert session.skeleton(2) is skeleton
    session.set_sample_radius(0.05)
    coarser = session.skeleton(2)
    assert coarser is not skeleton and coarser.radius > skeleton.radius


def test_the_inputs_topology_is_computed_once_per_run(session, monkeypatch):
    """The verdict's skeleton checks read the input's pieces: the same at every iteration."""
    import app.session as session_module
    from skelcore.evidence import skeleton_evidence

    inputs = []
    real = session_module.input_evidence
    monkeypatch.setattr(session_module, "input_evidence",
                        lambda points, gap: inputs.append(points) or real(points, gap))
    for _ in range(3):
        session.step()
    verdicts = [session.verdict(index, with_skeleton=True) for index in (1, 2, 3)]
    assert len(inputs) == 1 and inputs[0] is session.cloud.points
    skeleton = session.skeleton(3)
    fresh = skeleton_evidence(skeleton, session.history[3], session.cloud.points)
    assert session.run.evidence[(3, session.skeleton_params)] == fresh
    assert verdicts[-1] == session.verdict(3, with_skeleton=True)


def test_the_compare_tab_names_the_verdict_the_histograms_tab_shows(monkeypatch):
    """The Histograms tab's verdict holds the skeleton's checks; the Compare tab's note named the verdict of the
    metrics alone, so a run failed by its skeleton read "unstable" above the histograms and "stable" or "not yet
    converged" beside the pinned run."""
    import app.session as session_module
    from app.compare import comparison, comparison_note, pin

    real = session_module.skeleton_evidence
    split = lambda *args, **kwargs: {**real(*args, **kwargs), "components": 5}  # more pieces than the clouds hold
    monkeypatch.setattr(session_module, "skeleton_evidence", split)
    session = Session(validate(make_shape("torus", 1500).points, name="torus.xyz"), ContractionParams())
    for _ in range(2):  # iteration 2 of this torus is stable by its metrics
        session.step()
    index, state = len(session.history) - 1, session.latest
    plain = session.verdict(index)
    # a skeleton not yet drawn (provisional, not asked for): the tab shows the metrics' verdict, and so does the pin
    assert plain["label"] != "unstable" and pin(session).summary["verdict"] == plain
    judged = session.verdict(index, with_skeleton=True)  # as the presenter does once it draws the skeleton
    assert judged["label"] == "unstable"
    pinned = pin(session)
    assert pinned.summary["verdict"] == judged
    note = comparison(pinned, state, session.metrics_upto(index), judged)[0]
    assert note.count("verdict unstable") == 2, note
    assert comparison_note(pinned, state, judged) == note  # the note alone, as the presenter sends it with the checks
    session.tune(session.params.replace(sl=2.0))
    session.step()  # the current run, retuned on its third step, says so as the pinned one would
    assert "current: LBC, W_H0 1, s_L 2, iteration 3, retuned at iteration 3**" in comparison_note(
        pinned, session.latest, judged, session.history)
    # a current run restarted to its input has no verdict yet, and the note says so rather than "verdict None"
    session.restart()
    start = comparison_note(pinned, session.latest, session.verdict(0), session.history)
    assert "iteration 0** (red, no verdict yet)" in start and "None" not in start, start
    # a run pinned before its skeleton was final has none drawn in green, and the note does not say it has
    drawn = dataclasses.replace(pinned, skeleton=(np.zeros((2, 3)), np.array([[0, 1]])))
    assert comparison_note(drawn, session.latest, judged).endswith("the pinned skeleton is drawn in green.")
    assert comparison_note(dataclasses.replace(pinned, skeleton=None), session.latest, judged).endswith(
        "no pinned skeleton is drawn: the run was pinned before its skeleton was final.")


def test_the_skeletons_loop_probe_takes_the_metrics_surface(monkeypatch):
    """A skeleton drawn after its metrics judges its loops on the metrics' inside test of the same points: the
    oriented normals of the cloud are computed once for both, and the result is the one the probe's own gives."""
    from skelcore.inside import InsideTest

    session = Session(validate(make_shape("torus", 3000).points, name="torus.xyz"))
    while session.step() is not None:
        pass
    last = len(session.history) - 1
    own = session.skeleton(last)
    session.restart()
    while session.step() is not None:
        pass
    session.metrics_upto(last)
    made = []
    real = InsideTest.of_cloud
    monkeypatch.setattr(InsideTest, "of_cloud", lambda *args, **kwargs: made.append(args) or real(*args, **kwargs))
    shared = session.skeleton(last)
    assert not made and shared.topology() == own.topology() and own.topology()["cycles"] == 1  # a loop was judged
    np.testing.assert_array_equal(shared.nodes_array(), own.nodes_array())


def test_bad_upload_leaves_the_session_alone(session):
    before = session.run
    with pytest.raises(InputError, match="garbage.ply"):
        session.load(load_bytes(b"\x00\x01 not a ply", "garbage.ply"))
    assert session.run is before


def test_load_replaces_the_cloud(session):
    capsule = validate(make_shape("capsule", 500).points, name="capsule.xyz")
    session.load(capsule)
    # cleaned as `skelcore run` cleans it: a clean synthetic capsule keeps every point, denoised
    assert session.cloud.name == "capsule.xyz" and len(session.history[0].points) == 500
    assert session.cloud.cleaning is not None and np.abs(session.cloud.points - capsule.points).max() < 0.05


def test_load_uses_the_parameters_waiting_for_a_restart(session):
    while session.step() is not None:
        pass
    session.tune(session.params.replace(sl=2.0, method="glskeleton"))  # the run has ended: both wait for a restart
    kept = session.load(validate(make_shape("capsule", 500).points, name="capsule.xyz"))
    assert session.params.sl == 2.0 and session.params.method == "glskeleton" and session.pending == ""
    assert "s_L 2" in session.log[-2] and "Method GLSkeleton" in session.log[-2]  # the run's start
    # a new object runs with them: said, as the panel alone does not tell tuned values from defaults
    assert kept == "parameters Method GLSkeleton, s_L 2 kept from before (defaults: Method LBC, s_L 3)"
    assert session.log[-1] == kept


def test_a_load_with_the_default_parameters_says_nothing_of_them(session):
    assert session.load(validate(make_shape("capsule", 500).points, name="capsule.xyz")) == ""
    assert session.log[-1].startswith("start: capsule.xyz")


def test_what_loading_did_is_kept_in_the_log(session):
    """It was said only in a notification, which goes away after a few seconds."""
    points = make_shape("capsule", 500).points
    session.load(validate(np.concatenate([points, points[:7]]), name="/somewhere/capsule.xyz"))
    assert any(line.startswith("capsule.xyz: ") and "7" in line for line in session.log)


def test_bad_parameter_is_refused(session):
    with pytest.raises(ParameterError):
        session.tune(ContractionParams(sl=0.5))


def test_worker_plays_until_paused_and_survives_errors():
    errors, ticks, released = [], [], threading.Event()
    worker = Worker(lambda message, client: errors.append(message))

    def tick() -> bool:
        ticks.append(1)
        if len(ticks) == 3:
            released.set()
        return True

    worker.play(tick, interval=0.01)
    assert released.wait(60)
    worker.pause()
    assert worker.wait_idle(60)
    count = len(ticks)
    worker.submit(lambda: None)
    assert worker.wait_idle(60) and len(ticks) == count
    worker.submit(lambda: (_ for _ in ()).throw(ParameterError("parameter x=1: bad")))
    worker.submit(lambda: ticks.append(2))
    assert worker.wait_idle(60)
    assert errors == ["parameter x=1: bad"] and ticks[-1] == 2
    worker.close()


def test_latest_runs_only_the_newest_request():
    seen, gate = [], threading.Event()

    def handle(item) -> None:
        gate.wait(60)
        seen.append(item)

    latest = Latest(handle, lambda message, client: None)
    latest.request(1)
    for item in (2, 3, 4):  # arrive while 1 is being handled
        latest.request(item)
    gate.set()
    assert latest.wait_idle(60)
    assert seen[-1] == 4 and 2 not in seen and 3 not in seen
    latest.close()


def test_latest_keeps_the_newest_request_of_each_key():
    """One request per browser: a browser's newer request replaces its own older one, not another's."""
    seen, gate = [], threading.Event()

    def handle(item) -> None:
        gate.wait(60)
        seen.append(item)

    latest = Latest(handle, lambda message, client: None)
    latest.request("a0", key="a")
    for item, key in (("a1", "a"), ("b1", "b"), ("a2", "a"), ("b2", "b")):  # arrive while a0 is being handled
        latest.request(item, key=key)
    gate.set()
    assert latest.wait_idle(60)
    assert sorted(seen[-2:]) == ["a2", "b2"] and "b1" not in seen  # b1 waited, and b2 replaced it
    latest.close()


@pytest.mark.parametrize("quantity, target", [("D_theta", 0.5), ("delta_kappa", 0.0)])
def test_colour_map_target_stands_out_on_the_white_background(quantity, target):
    from app.colours import COLOUR_RANGES, LAYER_COLOURS

    low, high = COLOUR_RANGES[quantity]
    colours = colour_values(np.array([low, target, high, np.nan]), quantity)
    assert colours.dtype == np.uint8 and colours.shape == (4, 3)
    assert not np.array_equal(colours[0], colours[2])
    assert tuple(colours[3]) == LAYER_COLOURS["original"]  # no value: the original's grey
    for colour in colours[:3]:  # every value, the target above all, is far from white
        assert 255 * 3 - int(colour.astype(int).sum()) > 150
    assert colours[1].astype(int).sum() < 200  # the target is dark


def test_png_bytes_flattens_transparency_onto_white_or_keeps_it():
    import imageio.v3 as iio

    rgba = np.zeros((4, 6, 4), np.uint8)
    rgba[1, 2] = (200, 10, 10, 255)
    image = iio.imread(io.BytesIO(export.png_bytes(rgba)), extension=".png")
    assert image.shape == (4, 6, 3)
    assert tuple(image[0, 0]) == (255, 255, 255) and tuple(image[1, 2]) == (200, 10, 10)
    clear = iio.imread(io.BytesIO(export.png_bytes(rgba, transparent=True)), extension=".png")
    assert clear.shape == (4, 6, 4) and clear[0, 0, 3] == 0 and clear[1, 2, 3] == 255


def test_labels_are_burned_in():
    plain = export.compose(np.zeros((200, 400, 4), np.uint8))
    labelled = export.compose(np.zeros((200, 400, 4), np.uint8), ["iteration 3 · lbc", "verdict: stable"])
    assert (plain == 255).all() and (labelled < 100).any()


def test_animation_has_one_frame_per_iteration():
    import imageio.v3 as iio

    frames = [np.full((64, 96, 3), 40 * i, np.uint8) for i in range(4)]
    files = export.animation_files(frames)
    assert iio.imread(files["gif"], index=None, extension=".gif").shape[0] == 4
    assert files["mp4"][4:8] == b"ftyp"
    assert _mp4_frames(files["mp4"]) == 4


def _mp4_frames(data: bytes) -> int:
    import tempfile

    import imageio

    with tempfile.NamedTemporaryFile(suffix=".mp4") as handle:
        handle.write(data)
        handle.flush()
        reader = imageio.get_reader(handle.name, format="FFMPEG")
        try:
            return reader.count_frames()
        finally:
            reader.close()


def test_bundle_holds_the_result_files(session):
    import json

    session.step()
    data = export.bundle(session, 1, export.png_bytes(np.full((2, 2, 4), 255, np.uint8)))
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        assert set(archive.namelist()) == {"screenshot.png", "skeleton.json", "skeleton.ply", "contracted.ply",
                                           "metrics.json", "params.json", "histograms.html", "convergence.html",
                                           "plotly.min.js", "log.txt"}
        assert archive.read("log.txt").decode().splitlines() == session.log  # all of it, oldest first
        for page in ("histograms.html", "convergence.html"):
            text = archive.read(page).decode()
            # offline, as the inspector is: the pages load the copy of plotly.js beside them (from its CDN they
            # were blank), and it is there once, not inlined in each (4.8 MB)
            assert "Plotly.newPlot" in text and "src='plotly.min.js'" in text and "cdn.plot.ly" not in text
            assert len(text) < 200_000 and '"showSendToCloud": false' in text  # no upload to Plotly's cloud
        assert "Plotly" in archive.read("plotly.min.js").decode()[:5000]
        assert json.loads(archive.read("params.json"))["input"] == "torus.xyz"
    assert len(data) < 2_500_000


def test_bundle_skeleton_is_the_one_skelcore_run_builds(tmp_path):
    """One owner of the skeleton parameters: a GLSkeleton bundle's skeleton.json matches its params.json
    and what `skelcore run` writes for the same input and parameters."""
    import json

    from skelcore.export import write_points_ply
    from skelcore.options import RunOptions
    from skelcore.pipeline import run_pipeline

    cloud = validate(make_shape("y_branch", 1500).points, name=str(tmp_path / "server" / "y_branch.xyz"))
    params = ContractionParams(method="glskeleton")
    session = Session(cloud, params)
    while session.step() is not None:
        pass
    last = len(session.history) - 1
    with zipfile.ZipFile(io.BytesIO(export.bundle(session, last, b"png"))) as archive:
        bundled = {name: json.loads(archive.read(name)) for name in ("params.json", "skeleton.json")}
    assert bundled["params.json"]["skeleton"]["drop_collinear"] is True
    assert bundled["params.json"]["input"] == "y_branch.xyz"  # the file name, never the server's path
    source = write_points_ply(tmp_path / "y_branch.ply", cloud.points)
    result = run_pipeline(source, tmp_path / "cli", RunOptions(params=params))
    cli = json.loads((tmp_path / "cli" / "skeleton.json").read_text())
    assert bundled["params.json"]["skeleton"] == json.loads((tmp_path / "cli" / "params.json").read_text())["skeleton"]
    assert len(bundled["skeleton.json"]["nodes"]) == len(cli["nodes"]) == result.skeleton.graph.number_of_nodes()
    assert np.allclose(bundled["skeleton.json"]["nodes"], cli["nodes"])


def test_exports_are_saved_on_the_server_only_when_asked(cloud, tmp_path):
    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud), save_dir=tmp_path / "exports")
    try:
        assert inspector.wait_idle(120)
        inspector.delivery.deliver(None, "view.png", b"png")
        assert not (tmp_path / "exports").exists()
        inspector.ui.files.save_on_server.value = True
        inspector.delivery.deliver(None, "view.png", b"png")
        assert (tmp_path / "exports" / "view.png").read_bytes() == b"png"
    finally:
        inspector.close()
        server.stop()


def test_large_clouds_are_drawn_from_a_fixed_subset(cloud):
    import viser

    from app.scene import SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = SceneView(server.scene, display_cap=300)
        view.load(cloud.points)
        view.show_points("state", cloud.points * 0.5)
        assert len(view.drawn_points("original")) == len(view.drawn_points("contracted")) == 300
        assert view.drawn_points("original").dtype == np.float32
        assert "300 of 800" in view.notice(len(cloud.points)) and view.notice(300) == ""
        rows = view.rows(len(cloud.points))
        assert np.allclose(view.drawn_points("contracted"), (cloud.points[rows] * 0.5).astype(np.float32))
        view.set_opacity("original", 0.25)  # a quarter of the points, the same ones whatever the opacity
        assert len(view.drawn_points("original")) == 200
        assert set(map(tuple, view.drawn_points("original"))) <= set(map(tuple, cloud.points.astype(np.float32)))
        colours = np.zeros((800, 3), np.uint8)
        view.set_colours("state", colours, "D_theta")
        assert len(view.drawn_colours("contracted")) == 300 and view.coloured
    finally:
        server.stop()



def test_skeleton_edges_keep_their_width_through_a_size_change_and_the_pinned_ones_stay_wider(cloud):
    """Edges are EDGE_THICKNESS node radii wide when drawn and after Skeleton size changes (it used to halve
    them); the pinned run's edges follow the size too and stay wider than the current ones."""
    import viser

    from app.scene import EDGE_THICKNESS, GHOST_THICKNESS, SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = SceneView(server.scene)
        view.load(cloud.points)
        nodes, edges = cloud.points[:3], np.array([[0, 1], [1, 2]])
        view.show_skeleton(nodes, edges, np.array([1, 2, 1]))
        view.show_ghost(nodes, edges)
        radius = view._node_radius()
        assert view._edges.thickness == pytest.approx(EDGE_THICKNESS * radius)
        assert view._ghost.thickness == pytest.approx(GHOST_THICKNESS * radius)
        assert view._ghost.thickness > view._edges.thickness
        view.set_size("skeleton", 2.0)
        assert view._edges.thickness == pytest.approx(EDGE_THICKNESS * 2 * radius)
        assert view._ghost.thickness == pytest.approx(GHOST_THICKNESS * 2 * radius)
    finally:
        server.stop()


def test_the_nodes_are_hidden_while_the_points_are_coloured_and_the_legend_says_so(cloud):
    """Coloured points (a quantity or labels) hide the skeleton's node balls, which covered the contracted points
    along the skeleton and whose blue, dark and orange read as the colour bar's; the edges stay, and the Legend
    says the nodes are hidden instead of naming their kinds. Plain colours bring them back, unless the skeleton
    layer itself is hidden. The pinned run's rods are thinner meanwhile, a little wider than the current edges."""
    import viser

    from app.colours import legend_html
    from app.scene import EDGE_THICKNESS, GHOST_THICKNESS, GHOST_THICKNESS_COLOURED, SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = SceneView(server.scene)
        view.load(cloud.points)
        view.show_points("state", cloud.points * 0.5)
        view.show_skeleton(cloud.points[:4], np.array([[0, 1], [1, 2], [1, 3]]), np.array([1, 3, 1, 1]))
        assert view._nodes.visible and view._edges.visible
        view.show_ghost(cloud.points[:4], np.array([[0, 1], [1, 2]]))
        radius = view._node_radius()
        assert view._ghost.thickness == pytest.approx(GHOST_THICKNESS * radius)
        view.set_colours("state", np.zeros((len(cloud.points), 3), np.uint8), "D_theta")
        assert not view._nodes.visible and view._edges.visible
        assert view._ghost.thickness == pytest.approx(GHOST_THICKNESS_COLOURED * radius)
        assert view._ghost.thickness > view._edges.thickness == pytest.approx(EDGE_THICKNESS * radius)
        view.show_skeleton(cloud.points[:2], np.array([[0, 1]]), np.array([1, 1]))  # the next skeleton, still coloured
        assert not view._nodes.visible
        view.set_colours("state", None)
        assert view._nodes.visible and view._ghost.thickness == pytest.approx(GHOST_THICKNESS * radius)
        view.set_visible("skeleton", False)
        view.set_colours("state", np.zeros((len(cloud.points), 3), np.uint8), "label")
        view.set_colours("state", None)
        assert not view._nodes.visible and not view._edges.visible
        view.set_visible("skeleton", True)
        assert view._nodes.visible and view._edges.visible
    finally:
        server.stop()
    coloured = legend_html("D_theta", points_coloured=True)
    assert "junction" not in coloured and "nodes are hidden while the points are coloured" in coloured
    assert "junction" in legend_html(None)


def test_the_legend_names_the_node_kinds_only_while_the_skeleton_is_shown():
    from app.colours import legend_html

    assert "junction" in legend_html(None) and "junction" not in legend_html(None, skeleton=False)
    assert "pinned run's skeleton" in legend_html(None, pinned=True, skeleton=False)


def test_the_legend_names_only_the_layers_drawn(session):
    from app.status import legend

    state = session.latest  # an LBC run: no input point is absorbed
    shown = {"original": False, "contracted": True, "skeleton": True, "removed": True}
    text = legend("D_theta", state, None, note="", visible=shown, original_coloured=True, provisional_wanted=False,
                  pinned=False, labels_html="")
    assert "removed" not in text and "original" in text  # hidden, but coloured: the colour bar says so
    assert "contracted and original coloured by" in text
    shown["original"] = True
    text = legend("plain", state, None, note="", visible=shown, original_coloured=False, provisional_wanted=False,
                  pinned=False, labels_html="")
    assert "original" in text and "contracted" in text and "removed" not in text

def test_a_pause_between_stages_resumes_the_same_step(cloud):
    """Session.step stops between two stages of a step when asked, and the next call finishes that step:
    the run is the same as one stepped straight through."""
    straight, paused = Session(cloud), Session(cloud)
    for _ in range(3):
        straight.step()
    stops = 0
    while len(paused.history) < 4:
        if paused.step(paused=lambda: True) is None:
            stops += 1
            assert not paused.finished
    assert stops >= 3  # at least one stop within every step
    for a, b in zip(straight.history, paused.history):
        assert a.iteration == b.iteration and np.array_equal(a.points, b.points)


def test_dense_clouds_start_thinned():
    from app.scene import auto_opacity

    assert auto_opacity(5_000) == 1.0
    assert auto_opacity(50_000) == pytest.approx(0.4)
    assert auto_opacity(2_000_000) == pytest.approx(0.05)


def projected_box_share(points, camera, fov, width, height):
    """Share of the shorter image side spanned by the projected bounding box of the points."""
    local = (points - camera.position) @ camera.rotation
    focal = height / 2 / np.tan(fov / 2)
    return float(max(np.ptp(local[:, 0] / local[:, 2] * focal), np.ptp(local[:, 1] / local[:, 2] * focal))
                 / min(width, height))


def test_framing_camera_fills_the_shorter_side():
    from skelcore.display import framing_camera

    points = make_shape("torus", 800).points * 3.0 + 10.0
    for direction, (width, height) in (((1, -1, 0.5), (1280, 720)), ((0, 0, -1), (800, 600)),
                                       ((0.2, 1, 0), (720, 1280))):
        camera = framing_camera(points, direction, fov=np.radians(50), aspect=width / height, fill=0.8)
        share = projected_box_share(points, camera, np.radians(50), width, height)
        assert 0.5 <= share <= 1.0 / min(width, height) * max(width, height)
        local = (points - camera.position) @ camera.rotation
        assert (local[:, 2] > 0).all()  # everything in front of the camera


def test_a_framed_view_keeps_the_legends_share_of_the_image_free():
    """At 1280x720 the Legend covered the foot of a tall object."""
    from skelcore.display import framing_camera

    fov = np.radians(50)
    tall = make_shape("capsule", 800).points * [1, 1, 4]
    for bottom in (0.0, 0.18):
        camera = framing_camera(tall, (1, -1, -0.3), fov=fov, aspect=0.75, fill=0.8, bottom=bottom)
        local = (tall - camera.position) @ camera.rotation
        v = local[:, 1] / local[:, 2] / np.tan(fov / 2)  # image height from -1 (top) to 1 (foot)
        assert v.max() <= 1 - 2 * bottom - 0.05  # clear of the panel, with room
        assert v.max() - v.min() == pytest.approx(0.8 * 2 * (1 - bottom), rel=0.05)  # the free part, filled


def test_a_view_direction_turns_with_the_scenes_up():
    from skelcore.display import UP_AXES, turned_up

    aside = np.array([-0.7, 0.7, -0.5])  # from above and aside when +Z is up
    for up in UP_AXES.values():
        turned = turned_up(aside, up)
        assert turned @ np.asarray(up) == pytest.approx(-0.5)  # still from above, as far
        assert np.linalg.norm(turned) == pytest.approx(np.linalg.norm(aside))
    np.testing.assert_allclose(turned_up(aside, UP_AXES["+Z"]), aside)


def test_every_point_gets_a_value_when_metrics_are_sampled():
    from skelcore.display import values_for_all_points
    from skelcore.metrics import MetricsReference

    points = make_shape("torus", 3000).points
    reference = MetricsReference.from_points(points, k=20, max_points=500)
    contracted = points * 0.9
    metrics = reference.evaluate(contracted)
    result = values_for_all_points(metrics, contracted, "d_theta")
    assert result.measured <= 500 and result.carried >= 2500
    assert np.isfinite(result.values).all()
    own = metrics.per_point("d_theta")
    measured = np.isfinite(own)
    assert np.array_equal(result.values[measured], own[measured])


def test_a_cloud_above_the_point_budget_contracts_reduced_and_shows_every_point(tmp_path):
    """As `skelcore run` does: the voxel-reduced cloud is contracted, every input point is carried along, the
    skeleton is made from the reduced states with every input point's node, and the export names the reduction."""
    import json

    from app.status import run_notes

    cloud = validate(make_shape("torus", 3000, seed=0).points, name="torus.xyz")
    session = Session(cloud, point_budget=1500)
    reduction = session.run.reduction
    assert reduction is not None and len(reduction.points) <= 1500
    assert any(line.startswith("multi-resolution: 3,000 points") for line in session.log)
    # the centroids it contracts are those `skelcore run` contracts (denoised at their own spacing)
    from skelcore.options import RunOptions
    from skelcore.pipeline import compute

    np.testing.assert_array_equal(reduction.points, compute(cloud, RunOptions(point_budget=1500)).reduction.points)
    while session.step() is not None:
        pass
    history, reduced = session.history, session.run.reduced
    assert len(history) == len(reduced) > 2
    assert all(state.n_points == 3000 and state.points.shape == (3000, 3) for state in history)
    assert [s.iteration for s in history] == [s.iteration for s in reduced]
    last = len(history) - 1
    skeleton = session.skeleton(last)
    assert skeleton.correspondence.shape == (3000,)
    assert skeleton.topology()["cycles"] == 1 and skeleton.topology()["components"] == 1
    assert f"{len(reduction.points):,} voxel centroids" in run_notes(session.run, history[last], notice="")
    session.write_results(last, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["multiresolution"]["input_points"] == 3000
    assert Session(cloud, point_budget=None).run.reduction is None  # --full-resolution


def test_a_state_computed_ahead_is_the_step_and_is_shown_at_once(cloud):
    """look_ahead computes the next state, its metrics and its skeleton; Step then takes that very state, and
    the run is the same as one stepped without looking ahead."""
    plain, ahead = Session(cloud), Session(cloud)
    plain.step()
    ahead.step()
    assert ahead.look_ahead(skeleton=True, provisional=True)
    computed = ahead.run.ahead
    assert len(ahead.history) == 2 and computed.iteration == 2  # not part of the run yet
    assert ahead.step() is computed
    assert np.array_equal(computed.points, plain.step().points)
    assert (2, ahead.skeleton_params) in ahead.run.skeletons  # made ahead, under the index the state took
    np.testing.assert_array_equal(ahead.metrics(2).d_theta, plain.metrics(2).d_theta)
    assert ahead.skeleton(2).graph.number_of_nodes() == plain.skeleton(2).graph.number_of_nodes()


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_a_change_after_the_look_ahead_computes_the_step_again(cloud, method):
    """A parameter changed after the next state was computed ahead applies to that state, as the note says;
    its metrics and skeleton are those of the state computed again."""
    params = ContractionParams(method=method)
    plain, ahead = Session(cloud, params), Session(cloud, params)
    plain.step()
    ahead.step()
    assert ahead.look_ahead(skeleton=True, provisional=True)
    stale = ahead.run.ahead
    assert "s_L 2 from iteration 2" in ahead.tune(ahead.params.replace(sl=2.0))
    plain.tune(plain.params.replace(sl=2.0))
    assert ahead.look_ahead(skeleton=True, provisional=True)  # the idle worker computes it again at once
    state = ahead.step()
    assert state is not stale and state.params.sl == 2.0 and ahead.pending == ""
    assert np.array_equal(state.points, plain.step().points)
    np.testing.assert_array_equal(ahead.metrics(2).d_theta, plain.metrics(2).d_theta)
    assert np.allclose(ahead.skeleton(2).nodes_array(), plain.skeleton(2).nodes_array())
    assert ahead.tune(ahead.params.replace(sl=3.0)) and ahead.look_ahead()
    assert ahead.tune(ahead.params.replace(sl=2.0)) == ""  # back to the shown parameters: nothing pending
    assert np.array_equal(ahead.step().points, plain.step().points)  # ...yet the state ahead was redone


def test_a_look_ahead_stops_between_stages_and_step_finishes_it(cloud):
    straight, ahead = Session(cloud), Session(cloud)
    straight.step()
    ahead.step()
    assert not ahead.look_ahead(paused=lambda: True)  # stopped within the step
    assert ahead.run.ahead is None and len(ahead.history) == 2
    assert np.array_equal(ahead.step().points, straight.step().points)


def test_the_idle_worker_looks_ahead_and_yields_to_jobs():
    order, interrupted = [], []

    def idle():
        order.append("idle")
        interrupted.append(worker.interrupted())
        return True

    worker = Worker(lambda message, client: order.append(message), on_idle=idle)
    try:
        worker.submit(lambda: order.append("a"))
        assert worker.wait_idle(10)
        assert order == ["a", "idle"] and interrupted == [False]
        assert worker.wait_idle(10) and order == ["a", "idle"]  # idle again only after a job ran
        release = threading.Event()
        worker.submit(release.wait)
        worker.submit(lambda: order.append("b"))
        worker.submit(lambda: order.append("c"))
        release.set()
        assert worker.wait_idle(10)
        assert order == ["a", "idle", "b", "c", "idle"]  # not between queued jobs
    finally:
        worker.close()


def test_an_interrupted_idle_task_is_taken_up_again():
    calls = []

    def idle():
        calls.append(worker.interrupted())
        return not worker.interrupted() and len(calls) > 1  # the first call pretends a job interrupted it

    worker = Worker(lambda message, client: None, on_idle=idle)
    try:
        worker.submit(lambda: None)
        assert worker.wait_idle(10)
        assert len(calls) == 2  # taken up again by the next turn of the queue, wait_idle's marker included
    finally:
        worker.close()


def test_a_reduced_run_looks_ahead_at_its_own_resolution(cloud):
    """Above the point budget the state ahead is the reduced cloud's, carried to every input point; its skeleton
    is made from the reduced state, as Step would."""
    plain, ahead = Session(cloud, point_budget=400), Session(cloud, point_budget=400)
    assert ahead.run.reduction is not None
    assert ahead.look_ahead(skeleton=True, provisional=True)
    state = ahead.step()
    assert len(state.points) == len(cloud.points) and len(ahead.run.reduced[-1].points) < len(cloud.points)
    assert np.array_equal(state.points, plain.step().points)
    assert np.allclose(ahead.skeleton(1).nodes_array(), plain.skeleton(1).nodes_array())


@pytest.mark.parametrize("look_ahead", [False, True])
def test_a_step_says_what_it_computes_unless_it_was_computed_ahead(cloud, look_ahead):
    import types

    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud, look_ahead=look_ahead))
    said, step = [], inspector.session.step
    inspector.session.step = lambda *args, **kwargs: said.append(inspector.activity.text()) or step(*args, **kwargs)
    try:
        assert inspector.wait_idle(120)
        assert (inspector.session.run.ahead is not None) == look_ahead
        inspector._on_step(types.SimpleNamespace(client=None))
        assert inspector.wait_idle(120) and len(inspector.session.history) == 2
        assert said == [""] if look_ahead else "computing iteration 1" in said[0]
    finally:
        inspector.close()
        server.stop()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_looking_ahead_never_changes_the_run(cloud, seed):
    """Random Steps, weight changes and look-aheads (some stopped within the step) give the same run as the same
    Steps and changes without looking ahead."""
    rng = np.random.default_rng(seed)
    method = ["lbc", "glskeleton"][seed % 2]
    plain = Session(cloud, ContractionParams(method=method, max_iterations=8), look_ahead=False)
    ahead = Session(cloud, ContractionParams(method=method, max_iterations=8))
    for _ in range(25):
        action = rng.choice(["step", "tune", "look", "stop"])
        if action == "step":
            assert (plain.step() is None) == (ahead.step() is None)
        elif action == "tune":
            change = {"sl": float(rng.choice([2.0, 2.5, 3.0])), "wh0": float(rng.choice([1.0, 2.0]))}
            assert plain.tune(plain.params.replace(**change)) == ahead.tune(ahead.params.replace(**change))
        else:
            stages = iter(range(int(rng.integers(1, 3)) if action == "stop" else 10**6))
            ahead.look_ahead(lambda: next(stages, None) is None, skeleton=True, provisional=True)
        assert len(plain.history) == len(ahead.history) and plain.pending == ahead.pending
        assert np.array_equal(plain.latest.points, ahead.latest.points) and plain.latest.params == ahead.latest.params
    assert [m.iteration for m in plain.metrics_upto(len(plain.history) - 1)] == \
        [m.iteration for m in ahead.metrics_upto(len(ahead.history) - 1)]
    last = len(plain.history) - 1
    np.testing.assert_array_equal(plain.metrics(last).d_theta, ahead.metrics(last).d_theta)
    assert np.allclose(plain.skeleton(last).nodes_array(), ahead.skeleton(last).nodes_array())


def test_the_status_says_what_was_computed_ahead():
    import types

    from app.status import run_state

    history = [types.SimpleNamespace(iteration=i, termination=None) for i in (0, 1)]
    assert run_state(history, "", False) == "ready" and run_state(history, "", False, paused=True) == "paused"
    assert "iteration 2 computed ahead" in run_state(history, "", False, types.SimpleNamespace(iteration=2))
    assert "ends the run" in run_state(history, "", False, types.SimpleNamespace(iteration=1))
    assert run_state(history, "computing iteration 2", False, None) == "busy: computing iteration 2…"
    failing = types.SimpleNamespace(iteration=1, termination="solver_failure", message="")
    weights = np.array([1.0, 4.0, 1e9])
    assert run_state(history, "", False, failing, weights=weights) == (
        "ready; the next step, computed ahead, ends the run (per-point weights 1 to 1e+09 in force)")
    assert run_state([*history[:1], failing], "", False, weights=weights) == (
        "ended: the next step was discarded, as the sparse solver failed (per-point weights 1 to 1e+09 in force)")
    assert run_state([*history[:1], failing], "", False, weights=np.ones(3)).endswith("solver failed")


def test_the_status_counts_the_points_held_on_thin_handles():
    """A ball with handles one or two points across: the points on the handles are held in place and drawn on
    their axis (skelcore.step.anchored); the status says how many, the notes on the run what that means. A torus
    has none, and neither says anything."""
    from app.status import run_notes, status_markdown
    from skelcore.solids import solid_shape

    def status_after_a_step(points, name):
        session = Session(validate(points, name=name))
        session.step()
        return (session, status_markdown(session, 1, run="paused", readiness=None, skeleton="", following=True),
                run_notes(session.run, session.history[1], notice=""))

    session, status, notes = status_after_a_step(solid_shape("thin_handled_ball", 10000).points, "handles.xyz")
    held = session.history[1].anchored
    assert held > 0 and f"10,000 points, {held:,} held on thin handles" in status
    assert f"{held:,} points on thin handles are held in place and drawn on their axis (More: Hold curves)." in notes
    _, status, notes = status_after_a_step(make_shape("torus", 3000, seed=0).points, "torus.xyz")
    assert "thin handles" not in status + notes


def test_a_run_that_ends_a_step_back_drops_that_step_and_what_came_of_it(monkeypatch):
    """Step 3 pushes 2% of the points just past the input's box (within the margin of the fling check, so it is
    kept), step 4 blows the box up: the run ends on iteration 2 (skelcore.step.rejected). The session drops
    iteration 3 with its metrics and skeletons, computed ahead or shown, and the status is iteration 2's."""
    from app.status import run_state
    from skelcore import solver
    from skelcore.skeleton import SkeletonParams
    from skelcore.step import start_run

    points = make_shape("capsule", 800, seed=0).points
    run = start_run(points, ContractionParams())
    axis = int(np.argmax(np.ptp(run.unit, axis=0)))  # along the capsule, past its end
    past = run.unit.max(axis=0)[axis] + 0.25 * SkeletonParams.sample_radius * run.diagonal
    solve, calls = solver.CholeskySolver.solve, {"n": 0}

    def spoiled(self, system, rhs):
        calls["n"] += 1
        result = solve(self, system, rhs)
        if calls["n"] == 3:
            result = result.copy()
            result[np.argsort(result[:, axis])[-len(result) // 50:], axis] = past  # the end's 2%
        return result * 3.0 if calls["n"] == 4 else result

    monkeypatch.setattr(solver.CholeskySolver, "solve", spoiled)
    session = Session(validate(points, name="capsule.xyz"), ContractionParams(termination=1e-9))
    while not session.finished:
        session.look_ahead(skeleton=True, provisional=True)
        session.skeleton(len(session.history) - 1)
        session.metrics(len(session.history) - 1)
        session.step()
    iterations = [state.iteration for state in session.history]
    assert iterations == list(range(3)) and session.latest.termination == "bbox_growth"
    assert "iteration 3 is dropped too" in session.latest.message
    run = session.run
    assert all(index < len(session.history) for index, _ in [*run.skeletons, *run.evidence])
    assert len(session.metrics_upto(2, run)) == 3
    assert run_state(session.history, "", False) == ("ended: the next step was discarded, as it grew the bounding "
                                                     "box past its limit")


def test_the_panels_words_name_every_method_and_a_refused_value():
    from app.words import METHOD_LABELS, refused
    from skelcore.params import METHODS

    assert set(METHOD_LABELS) == set(METHODS)
    with pytest.raises(ParameterError) as error:
        ContractionParams(sl=0.5).validated()
    assert refused(str(error.value)).startswith("s_L = 0.5: must be")
    # the W_L0 and k boxes take 0 for automatic: the refusal of a negative value says so, as their labels do
    for changes, said in ((dict(wl0=-5.0), "W_L0 = -5.0: must be 0 (auto) or a number in (0, 1e+100]"),
                          (dict(k=2), "k = 2: must be 0 (auto) or ")):
        with pytest.raises(ParameterError) as error:
            ContractionParams(**changes).validated()
        assert refused(str(error.value)).startswith(said)


def test_compared_runs_are_named_by_every_parameter_set_away_from_its_default():
    from types import SimpleNamespace

    from app.compare import describe

    default = SimpleNamespace(params=ContractionParams(), iteration=4)
    assert describe(default, "pinned") == "pinned: LBC, W_H0 1, s_L 3, iteration 4"
    changed = SimpleNamespace(params=ContractionParams(method="glskeleton", termination=0.001, hold_curves=False),
                              iteration=2)
    assert describe(changed, "current") == "current: GLSkeleton, W_H0 1, s_L 3, Termination 0.001, Hold curves off, " \
                                           "iteration 2"
    steps = [SimpleNamespace(params=ContractionParams(sl=sl), iteration=i) for i, sl in enumerate([1.5] * 5 + [2.0] * 2)]
    assert describe(steps[-1], "pinned", steps) == "pinned: LBC, W_H0 1, s_L 2, iteration 6, retuned at iteration 5"


def test_a_repeated_notice_replaces_the_one_still_up():
    from app.messages import Messages

    class Notice:
        def __init__(self, shown, text):
            self.shown, self.text = shown, text
            shown.append(text)

        def remove(self):
            self.shown.remove(self.text)

    class Client:
        client_id, shown = 7, []

        def add_notification(self, title, body, **_):
            return Notice(self.shown, f"{title}: {body}")

    client = Client()
    server = type("Server", (), {"get_clients": lambda self: {7: client}})()
    messages = Messages(server)
    for _ in range(3):
        messages.notify(client, "Run has ended", "the one-ring size ratio stopped falling")
    messages.notify(None, "Parameter refused", "s_L = 0.5: must be at least 1")
    assert client.shown == ["Run has ended: the one-ring size ratio stopped falling",
                            "Parameter refused: s_L = 0.5: must be at least 1"]
    messages.withdraw("Run has ended")
    assert client.shown == ["Parameter refused: s_L = 0.5: must be at least 1"]


def test_a_dense_patch_is_thinned_for_the_contraction_and_about_says_so():
    """As `skelcore run`: a patch a hundred times denser than the surface around it is thinned for the
    contraction, every point carried along and shown; --full-resolution contracts every point."""
    from app.status import run_notes
    from skelcore.solids import solid_shape

    ball = solid_shape("handled_ball", 3000).points
    patch = np.column_stack([np.random.default_rng(3).normal(0.0, 0.03, (3000, 2)), -np.ones(3000)])
    cloud = validate(np.vstack([ball, patch / np.linalg.norm(patch, axis=1, keepdims=True)]), name="ball.xyz")
    session = Session(cloud)
    reduction = session.run.reduction
    assert reduction is not None and reduction.thinned and len(reduction.points) < 3200
    assert any(line.startswith("dense parts: ") for line in session.log)
    session.step()
    assert session.history[-1].points.shape == (len(session.run.cloud.points), 3) == (reduction.n_input, 3)
    assert "Dense parts thinned for the contraction" in run_notes(session.run, session.history[-1], notice="")
    assert Session(cloud, point_budget=None).run.reduction is None


def test_a_start_names_the_holds_only_where_they_differ_from_their_defaults():
    session = Session(validate(make_shape("torus", 800).points, name="torus.xyz"))
    assert "Hold" not in session.log[-1]
    session.restart(ContractionParams(hold_inside=True, hold_curves=False))
    assert session.log[-1].endswith("Hold curves off, Hold inside on")


def test_a_cloud_on_scan_lines_is_contracted_one_line_spacing_apart_and_about_says_so():
    """As `skelcore run`: a pretzel cut into a profile scanner's lines is contracted as voxel centroids one line
    spacing apart, every point carried along and shown; --full-resolution contracts every point."""
    from app.status import run_notes
    from skelcore.perturb import scan_lines
    from skelcore.solids import benchmark_shapes

    pretzel = benchmark_shapes(seed=0, names=["pretzel"])[0]
    cloud = validate(scan_lines(*pretzel.mesh, seed=0), name="pretzel.xyz")
    session = Session(cloud)
    reduction = session.run.reduction
    assert reduction is not None and reduction.scan_lines > 2.5 and len(reduction.points) < len(cloud.points) / 3
    assert any(line.startswith("scan lines: ") for line in session.log)
    session.step()
    assert session.history[-1].points.shape == (len(session.run.cloud.points), 3) == (reduction.n_input, 3)
    assert "one line spacing apart: the points lie on scan lines" in run_notes(session.run, session.history[-1],
                                                                                  notice="")
    assert Session(cloud, point_budget=None).run.reduction is None


def test_a_single_view_is_said_once_in_the_notes_and_in_the_files_the_inspector_writes(tmp_path):
    """The door pull's single view: once the metrics' inside test has read it as a view, the notes below the tabs
    say so, once, and so does metrics.json of the results the inspector writes (`skelcore run` says it the same)."""
    import json

    from app.status import run_notes
    from skelcore import single_view
    from skelcore.perturb import perturb
    from skelcore.solids import benchmark_shapes

    shape = benchmark_shapes(names=["door_pull"])[0]
    view = perturb(shape.points, "partial", seed=0, normals=shape.normals, loops=True)
    session = Session(validate(view, name="door_pull_view.xyz"))
    session.step()
    session.metrics_upto(1)
    said = single_view.NOTE[:1].upper() + single_view.NOTE[1:]
    assert run_notes(session.run, session.history[1], notice="").count(said) == 1
    session.write_results(1, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["notes"].count(single_view.NOTE) == 1
    plain = Session(validate(shape.points, name="door_pull.xyz"))
    plain.step()
    plain.metrics_upto(1)
    assert "single view" not in run_notes(plain.run, plain.history[1], notice="")
