"""The inspector's session, worker threads, colours and exports, without a browser."""
from __future__ import annotations

import io
import threading
import zipfile

import numpy as np
import pytest

from app import export
from app.scene import colour_values
from app.session import Session
from app.worker import Latest, Worker
from skelcore.errors import InputError, ParameterError
from skelcore.io import load_bytes, validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape
from skelcore.skeleton import SkeletonParams


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
    assert "sl=2.0 from iteration 2" in message
    state = session.step()
    assert state.params.sl == 2.0 and session.history[1].params.sl == 3.0
    assert state.wl == pytest.approx(session.history[0].wl * 2.0)


def test_restart_only_fields_wait_for_restart(session):
    session.step()
    message = session.tune(session.params.replace(k=12, wh0=2.0))
    assert "wh0=2.0 from iteration 2" in message and "k=12 on restart" in message
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
    session.set_skeleton_params(SkeletonParams(sample_radius=0.05))
    coarser = session.skeleton(2)
    assert coarser is not skeleton and coarser.radius > skeleton.radius


def test_bad_upload_leaves_the_session_alone(session):
    before = session.run
    with pytest.raises(InputError, match="garbage.ply"):
        session.load(load_bytes(b"\x00\x01 not a ply", "garbage.ply"))
    assert session.run is before


def test_load_replaces_the_cloud(session):
    capsule = validate(make_shape("capsule", 500).points, name="capsule.xyz")
    session.load(capsule)
    assert session.cloud is capsule and len(session.history[0].points) == 500


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


def test_colour_values_cover_the_range_and_grey_out_nan():
    colours = colour_values(np.array([0.0, 0.5, 1.0, np.nan]), "D_theta")
    assert colours.dtype == np.uint8 and colours.shape == (4, 3)
    assert not np.array_equal(colours[0], colours[2])
    assert tuple(colours[3]) == (150, 150, 150)


def test_png_bytes_flattens_transparency_onto_white():
    import imageio.v3 as iio

    rgba = np.zeros((4, 6, 4), np.uint8)
    rgba[1, 2] = (200, 10, 10, 255)
    image = iio.imread(io.BytesIO(export.png_bytes(rgba)), extension=".png")
    assert image.shape == (4, 6, 3)
    assert tuple(image[0, 0]) == (255, 255, 255) and tuple(image[1, 2]) == (200, 10, 10)


def test_bundle_holds_the_result_files(session):
    session.step()
    data = export.bundle(session, 1, export.png_bytes(np.full((2, 2, 4), 255, np.uint8)))
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        assert set(archive.namelist()) == {"screenshot.png", "skeleton.json", "skeleton.ply", "contracted.ply",
                                           "metrics.json", "params.json", "histograms.html"}
        assert b"plotly" in archive.read("histograms.html").lower()


def test_exports_are_saved_on_the_server_only_when_asked(cloud, tmp_path):
    import viser

    from app.inspector import Inspector

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    inspector = Inspector(server, Session(cloud), save_dir=tmp_path / "exports")
    try:
        assert inspector.wait_idle(120)
        inspector._deliver(None, "view.png", b"png")
        assert not (tmp_path / "exports").exists()
        inspector.save_on_server.value = True
        inspector._deliver(None, "view.png", b"png")
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
        assert len(view._original.points) == len(view._contracted.points) == 300
        assert view._original.points.dtype == np.float32
        assert "300 of 800" in view.notice(len(cloud.points)) and view.notice(300) == ""
        rows = view.subset(len(cloud.points))
        assert np.allclose(view._contracted.points, (cloud.points[rows] * 0.5).astype(np.float32))
    finally:
        server.stop()


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
