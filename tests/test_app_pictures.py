"""The pictures the Files tab exports, without a browser: framed on the whole cloud through a narrow lens, their
burned-in words sized to the picture, and no 3-D label of fixed on-screen size in them."""
from __future__ import annotations

import contextlib
import types

import numpy as np
import pytest

from app import export
from skelcore.shapes import make_shape


def _project(points: np.ndarray, position, rotation: np.ndarray, fov: float, width: int, height: int) -> np.ndarray:
    """Pixel coordinates (u right, v down, from the image's top left) of points seen by a pinhole camera."""
    local = (points - position) @ rotation
    assert (local[:, 2] > 0).all()  # everything in front of the camera
    focal = height / 2 / np.tan(fov / 2)
    return np.column_stack([width / 2 + local[:, 0] / local[:, 2] * focal,
                            height / 2 + local[:, 1] / local[:, 2] * focal])


@pytest.mark.parametrize("width, height", [(800, 600), (1600, 1000)])
def test_pictures_take_the_whole_cloud_through_a_narrow_lens_whatever_the_browsers(width, height):
    """The browser's camera gives the direction only: viser's 75 degree lens, close enough to fill the picture with
    the object's box, made near points loom and cut nothing off only by luck."""
    import viser.transforms as tf

    from skelcore.display import display_origin

    points = make_shape("y_branch", 3000).points * 4.0 + 20.0
    for position in ((30.0, 10.0, 25.0), (20.0, 20.0, 40.0), (5.0, 21.0, 20.5)):
        browser = types.SimpleNamespace(position=np.array(position), look_at=np.array([20.0, 20.0, 20.0]),
                                        fov=np.radians(75), up_direction=np.array([0.0, 0.0, 1.0]))
        origin = display_origin(points)  # the scene's coordinates: from the cloud's centre, 20 away here
        camera = export.framed_camera(points, browser, width, height)
        assert camera["fov"] <= np.radians(35)
        rotation = tf.SO3(np.asarray(camera["wxyz"])).as_matrix()
        pixels = _project(points - origin, camera["position"], rotation, camera["fov"], width, height)
        margin = 0.04 * min(width, height)
        assert (pixels.min(axis=0) >= margin).all() and (pixels.max(axis=0) <= (width - margin, height - margin)).all()
        assert pixels[:, 1].min() >= 3 * export.LABEL_SIZE * min(width, height)  # under three burned-in lines
        assert np.ptp(pixels, axis=0).max() >= 0.5 * min(width, height)  # not lost in the middle either


def test_contracted_points_a_step_carried_beyond_the_original_are_framed_under_the_burned_in_lines():
    """A GLSkeleton step took a horse's ear tip (and its skeleton's end node) 1.9 sample radii above the original's
    box, into the burned-in lines of a picture framed on the original alone: pictures frame what they draw."""
    import viser.transforms as tf

    from skelcore.display import display_origin

    points = make_shape("y_branch", 3000).points  # in the plane z = 0, 0.4 thick
    tip = points.copy()
    tip[:30, 2] = 0.8  # a few points carried up, twice the shape's thickness above it
    state = types.SimpleNamespace(points=tip)
    browser = types.SimpleNamespace(position=np.array([3.0, -3.0, 1.0]), look_at=np.zeros(3), fov=np.radians(75),
                                    up_direction=np.array([0.0, 0.0, 1.0]))
    width, height = 1280, 720
    for states, framed in (((), False), ((state,), True)):
        camera = export.framed_camera(points, browser, width, height, states)
        rotation = tf.SO3(np.asarray(camera["wxyz"])).as_matrix()
        pixels = _project(state.points - display_origin(points), camera["position"], rotation, camera["fov"], width,
                          height)
        under_words = pixels[:, 1].min() >= 3 * export.LABEL_SIZE * min(width, height)
        assert under_words == framed


@pytest.mark.parametrize("width, height", [(800, 600), (1280, 720), (1600, 1000), (2560, 1440)])
def test_burned_in_words_are_sized_to_the_picture(width, height):
    """At least 1/32 of the shorter side high (19 px at 800x600: the 18 px font of before drew 17 px glyphs), and
    no larger in a large picture than in a small one, relative to it."""
    image = export.compose(np.zeros((height, width, 4), np.uint8), ["torus.ply · LBC · iteration 3"])
    rows = np.flatnonzero((image < 100).any(axis=(1, 2)))
    share = (rows.max() - rows.min() + 1) / min(width, height)
    assert 1 / 32 <= share <= 1 / 20


def test_a_picture_says_why_its_skeleton_is_provisional_instead_of_drawing_the_3d_label(cloud_points):
    """The 3-D label is drawn 12 px high whatever the picture's size; a picture leaves it out and burns the words in
    at its own scale. The view shows the label again afterwards."""
    import viser

    from app.scene import SceneView

    state = types.SimpleNamespace(params=types.SimpleNamespace(method="lbc"), iteration=2)
    lines = export.caption("torus.ply", state, "not yet converged", ["skeleton provisional: 3% of points curve-like"])
    assert lines[-1] == "skeleton provisional: 3% of points curve-like"
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = SceneView(server.scene)
        view.load(cloud_points)
        view.show_skeleton(cloud_points[:3], np.array([[0, 1], [1, 2]]), np.array([1, 2, 1]), provisional=True)
        assert view._label.visible
        with view.picture():
            assert not view._label.visible
        assert view._label.visible
    finally:
        server.stop()


def test_pictures_draw_points_as_large_as_the_view_does_layers_drawn_anew_too(cloud_points):
    """viser's get_render draws points at the size the live view's lens and canvas give them; a picture, through a
    narrower lens and at its own height, scales them by export.point_scale while it is taken (a layer drawn anew
    meanwhile too) and gives them back their size afterwards."""
    import viser

    from app.scene import SceneView

    camera = types.SimpleNamespace(fov=np.radians(75), image_height=1000)
    assert export.point_scale(camera, 720) == pytest.approx(np.tan(np.radians(37.5)) / np.tan(np.radians(15)) * 0.72)
    assert export.point_scale(types.SimpleNamespace(fov=np.radians(75), image_height=None), 720) == 1.0
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view = SceneView(server.scene)
        view.load(cloud_points)
        view.show_points("state", cloud_points * 0.5)
        sizes = {layer: view._handles[layer].point_size for layer in ("original", "contracted")}
        with view.picture(2.5):
            assert all(view._handles[layer].point_size == pytest.approx(2.5 * size) for layer, size in sizes.items())
            view.show_points("next", cloud_points[:100] * 0.5)  # fewer points: a new handle
            assert view._handles["contracted"].point_size == pytest.approx(2.5 * sizes["contracted"])
        assert all(view._handles[layer].point_size == pytest.approx(size) for layer, size in sizes.items())
    finally:
        server.stop()


def test_a_picture_of_coloured_points_carries_the_colour_bar_with_its_words():
    """Points coloured by a quantity: the burned-in words come with the view's colour bar at the bottom left (a
    picture without it showed colours no one could read); plain colours, or no burned-in words, have none."""
    from app.colours import COLOUR_RANGES, colour_values

    blank = np.full((600, 800, 4), 255, np.uint8)
    with_bar = export.compose(blank, ["torus.ply"], colour_by="D_theta")
    size = round(export.LABEL_SIZE * 600)
    low, high = COLOUR_RANGES["D_theta"]
    ends = colour_values(np.array([low, high]), "D_theta").astype(int)
    bar = with_bar[:, size // 2: size // 2 + 12 * size]
    rows = np.flatnonzero((np.abs(bar[:, 0].astype(int) - ends[0]).sum(axis=1) < 10)
                          & (np.abs(bar[:, -1].astype(int) - ends[1]).sum(axis=1) < 10))
    assert len(rows) and rows.min() > 0.8 * 600  # the bar, both its ends, at the foot of the picture
    for plain in (export.compose(blank, ["torus.ply"]), export.compose(blank, [], colour_by="D_theta")):
        assert (plain[int(0.8 * 600):] == 255).all()


@pytest.fixture(scope="module")
def cloud_points():
    return make_shape("torus", 800).points


def test_a_picture_names_the_verdict_the_panel_shows(monkeypatch):
    """Once the skeleton's checks are made the panel's verdict includes them, and so does the picture's: one step
    of a torus is "not yet converged" by the contraction's figures, "unstable" by its skeleton's (it said the
    former while the panel said the latter)."""
    from app.delivery import Delivery
    from app.session import Session
    from skelcore.io import validate
    from skelcore.params import ContractionParams

    session = Session(validate(make_shape("torus", 1500).points, name="torus.xyz"), ContractionParams(max_iterations=1),
                      look_ahead=False)
    session.step()
    panel = session.verdict(1, with_skeleton=True)["label"]  # what the skeleton thread shows once it has drawn
    assert panel != session.verdict(1)["label"]
    captions = []
    caption = export.caption
    monkeypatch.setattr(export, "caption", lambda *args: captions.append(args) or caption(*args))
    setting = types.SimpleNamespace
    files = setting(resolution=setting(value="800x600"), labels=setting(value=True), transparent=setting(value=False))
    camera = setting(position=np.array([3.0, 3.0, 2.0]), look_at=np.zeros(3), fov=np.radians(75),
                     up_direction=np.array([0.0, 0.0, 1.0]), image_height=720)
    client = setting(camera=camera, get_render=lambda height, width, **_: np.zeros((height, width, 4), np.uint8))
    viewer = setting(client=client, view=setting(picture=contextlib.nullcontext, colour_quantity=None))
    Delivery(session, files, None, None, None, None, lambda *_: [])._render(viewer, 1)
    assert captions[-1][2] == panel


def test_an_animation_of_a_few_large_frames_is_written_without_ffmpeg_chatter(capfd):
    """ffmpeg warns that five frames give no rate estimate: harmless, but it read as an error in the server's log."""
    frames = [np.full((720, 1280, 3), shade, dtype=np.uint8) for shade in range(0, 250, 50)]
    files = export.animation_files(frames)
    assert files["mp4"] and files["gif"]
    assert "probesize" not in capfd.readouterr().err


def _sphere(n: int, seed: int = 0) -> np.ndarray:
    points = np.random.default_rng(seed).normal(size=(n, 3))
    return points / np.linalg.norm(points, axis=1, keepdims=True)


def test_an_original_is_drawn_small_enough_for_its_surface_not_to_hide_the_inside():
    """A densely sampled closed surface starts with points about SEE_THROUGH of their spacing across (at the default
    size they overlapped into a wall that hid the skeleton inside a bunny scan); a sparse one keeps the default, and
    thinning (fewer points drawn) lets the points grow again."""
    from scipy.spatial import cKDTree

    from skelcore.display import SEE_THROUGH, SMALLEST_SIZE, see_through_size

    default = 0.005
    dense = _sphere(3_000)
    spacing = float(np.median(cKDTree(dense).query(dense, k=2)[0][:, 1]))
    diagonal = float(np.linalg.norm(np.ptp(dense, axis=0)))
    factor = see_through_size(dense, 1.0, default)
    assert SMALLEST_SIZE < factor < 1
    assert abs(factor * default * diagonal - SEE_THROUGH * spacing) <= 0.05 * default * diagonal  # to the slider's 0.1
    assert see_through_size(_sphere(300), 1.0, default) == 1.0  # points far apart: nothing to see through
    assert see_through_size(dense, 0.5, default) > factor  # half of them drawn: 1.4 times the spacing
    assert see_through_size(_sphere(12_000), 1.0, default) == SMALLEST_SIZE  # smaller would vanish
    # a large cloud's spacing is measured on a sample and scaled: 0.75% of 400,000 drawn ~ 3,000 points
    assert see_through_size(_sphere(400_000), 0.0075, default) == factor
    assert see_through_size(np.zeros((5, 3)), 1.0, default) == 1.0


def test_a_cloud_far_from_the_origin_or_in_millimetres_is_drawn_from_near_it_and_within_the_cameras_planes():
    """float32 positions step by a ten-millionth of their magnitude: a trunk 0.6 m across at map coordinates (5e6 m)
    was drawn as a few lines of points, and at 1e18 the camera's position equalled the point it looked at; a scan
    in millimetres 2.8 m long lay past the browser camera's far plane (1000) and the view stayed blank."""
    from skelcore.display import CLIPPING, clipping_planes, display_origin, framing_camera

    trunk = _sphere(2000) * [0.3, 0.3, 2.0] + [512345.0, 5412345.0, 120.0]
    origin = display_origin(trunk)
    np.testing.assert_allclose(origin, [512345.0, 5412345.0, 120.0], atol=0.5)
    local = (trunk - origin).astype(np.float32)
    assert np.abs(local.astype(np.float64) + origin - trunk).max() < 1e-6  # float32 keeps the micrometres
    assert not display_origin(_sphere(300) + [0.5, 0, 0]).any()  # near 0: drawn as it is
    millimetres = _sphere(2000) * 1400.0
    framing = framing_camera(millimetres, (-0.7, 0.7, -0.5), 1.2, 0.75, 0.8)
    near, far = clipping_planes(millimetres)
    distance = np.linalg.norm(framing.position - framing.look_at)
    assert near * 100 < distance < far / 100
    assert far / near == CLIPPING ** 2
    huge = _sphere(2000) * 1e6 + 1e18
    assert np.isfinite(clipping_planes(huge)).all()
    framing = framing_camera(huge - display_origin(huge), (-0.7, 0.7, -0.5), 1.2, 0.75, 0.8)
    assert np.linalg.norm(framing.position - framing.look_at) > 1e6


def test_a_picture_names_the_pinned_run_whose_skeleton_it_shows_in_green():
    """A run pinned for comparison has its skeleton drawn in green in every picture and frame of the current run:
    the caption names that run (a walk-through's screenshot read "GLSkeleton" above the pinned LBC ring)."""
    from app import compare
    from app.presenter import Presenter
    from skelcore.params import ContractionParams

    state = types.SimpleNamespace(params=ContractionParams(sl=2.0), iteration=6)
    readiness = types.SimpleNamespace(provisional=False)
    presenter = types.SimpleNamespace(analyses=types.SimpleNamespace(readiness=lambda run, index: readiness),
                                      pinned=None, _skeleton_wanted=lambda viewer, ready: True)
    run = types.SimpleNamespace(history=[state])
    assert Presenter.picture_notes(presenter, None, run, 0) == []
    presenter.pinned = types.SimpleNamespace(name=compare.describe(state, "pinned"), skeleton=(np.zeros((2, 3)),
                                                                                               np.array([[0, 1]])))
    assert Presenter.picture_notes(presenter, None, run, 0) == ["in green, pinned: LBC, W_H0 1, s_L 2, iteration 6"]
    presenter.pinned.skeleton = None  # pinned before its cloud had contracted: nothing drawn, nothing said
    assert Presenter.picture_notes(presenter, None, run, 0) == []
