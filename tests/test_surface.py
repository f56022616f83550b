"""The original surface made once per run (skelcore.surface) gives every state the skeleton made from scratch."""
import numpy as np
import pytest

from skelcore.contraction import run_contraction
from skelcore.errors import InputError
from skelcore.params import ContractionParams
from skelcore.pipeline import original_surface, skeleton_of_state
from skelcore.shapes import make_shape
from skelcore.skeleton import SkeletonParams, extract_skeleton
from skelcore.surface import OriginalSurface


def _same(a, b) -> bool:
    return (np.array_equal(a.nodes_array(), b.nodes_array()) and np.array_equal(a.edges_array(), b.edges_array())
            and np.array_equal(a.correspondence, b.correspondence) and a.radius == b.radius)


@pytest.mark.parametrize("method", ["lbc", "glskeleton"])
def test_kept_surface_gives_the_skeleton_made_from_scratch(method):
    points = make_shape("torus", 2500, seed=3, noise=0.002).points
    states = run_contraction(points, ContractionParams(method=method, max_iterations=4))
    params = SkeletonParams(drop_collinear=method == "glskeleton")
    kept = {}
    for state in [*states, *states[::-1]]:  # forwards, then back: a kept surface serves any state on its rings
        key = id(state.rings)
        if key not in kept:
            kept[key] = original_surface(state, points)
        pieces = kept[key].pieces[1].copy()
        assert _same(skeleton_of_state(state, points, params, surface=kept[key]),
                     skeleton_of_state(state, points, params))
        assert np.array_equal(kept[key].pieces[1], pieces)  # extraction leaves the kept surface as it was
    if method == "glskeleton":
        assert len(states[-1].removed_ids)  # absorbed points: the ball cover's points on no edge were exercised


def test_surface_of_other_points_is_refused():
    points = make_shape("capsule", 500, seed=0).points
    state = run_contraction(points, ContractionParams(max_iterations=1))[-1]
    surface = original_surface(state, points)
    with pytest.raises(InputError, match="differ in number"):
        extract_skeleton(state.points[:-1], points, surface)
    with pytest.raises(InputError, match="point ids"):
        OriginalSurface.of(points, state.rings.triangles + len(points))


def test_the_loop_probe_takes_the_metrics_surface_of_the_same_points(monkeypatch):
    """The false-loop probe's inside test, made from the metrics' inside test of the same cloud (its oriented
    normals, a grid of the probe's own band), is the one it would make itself; the surface of other points is
    not taken."""
    from skelcore.inside import InsideTest
    from skelcore.metrics import MetricsReference

    points = make_shape("two_hole", 3000, seed=0).points
    state = run_contraction(points, ContractionParams(max_iterations=1))[0]
    reference = MetricsReference.from_points(points)
    made = original_surface(state, points).probe.inside()
    other = original_surface(state, points, MetricsReference.from_points(points[::-1].copy()).inside).probe.inside()
    shared = original_surface(state, points, reference.inside)
    monkeypatch.setattr(InsideTest, "of_cloud", None)  # the shared surface's normals are not computed again
    taken = shared.probe.inside()
    assert taken.band == made.band == shared.probe.spacing
    for inside in (taken, other):
        np.testing.assert_array_equal(inside.cells, made.cells)
        np.testing.assert_array_equal(inside.normals, made.normals)
        np.testing.assert_array_equal(inside.samples, points)


def test_a_far_small_piece_does_not_blow_up_the_inside_tests_grid():
    from skelcore.inside import MAX_CELLS, InsideTest

    torus = make_shape("torus", 2000).points
    far = torus[:3] + 50.0  # three points far away: the grid spans both
    test = InsideTest.of_cloud(np.vstack([torus, far]), band=0.03, collapsed=1e-9)
    assert test.cells.size <= MAX_CELLS * 1.25  # and its border; 262^3 = 18M cells before the cap (101 s a run)
    assert test.contains(np.zeros((1, 3))).tolist() == [False]  # the torus's hole is outside
