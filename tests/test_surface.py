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


def _torus(count, major, minor, rng):
    """`count` points spread evenly over a torus round the z axis (its tube angle drawn by area)."""
    points = np.zeros((0, 3))
    while len(points) < count:
        u, v = rng.uniform(0, 2 * np.pi, (2, 4 * count))
        keep = rng.random(4 * count) < (major + minor * np.cos(v)) / (major + minor)
        ring = major + minor * np.cos(v[keep])
        points = np.vstack([points, np.column_stack([ring * np.cos(u[keep]), ring * np.sin(u[keep]),
                                                     minor * np.sin(v[keep])])])
    return points[:count]


def test_a_small_object_beside_a_large_one_has_its_loops_judged_at_its_own_spacing():
    """A torus 7/100 the size of another in the same cloud, 2,000 points against 8,000: sampled four times as
    finely, its hole is about two of the cloud's spacings across, and the cloud's probe, which reads open space
    within one spacing of the surface as solid, found 5-6% of its disk open, near the 2% a loop needs (a torus a
    tenth the size in another cloud read 0%, where the grid fell badly, and lost its loop). Its own probe, over its
    points at its spacing, finds 40%; the large torus keeps the cloud's probe."""
    from skelcore.neighbours import one_rings
    from skelcore.params import default_k
    from skelcore.surface import FINER

    rng = np.random.default_rng(0)
    cloud = np.vstack([_torus(8000, 1.0, 0.3, rng), _torus(2000, 0.07, 0.021, rng) + [2.0, 0.0, 0.0]])
    surface = OriginalSurface.of(cloud, one_rings(cloud, default_k(len(cloud))).triangles)
    count, piece = surface.pieces
    assert count == 2 and surface.probe_of_piece(int(piece[0])) is surface.probe
    own = surface.probe_of_piece(int(piece[-1]))
    assert own is not surface.probe and FINER * own.spacing < surface.spacing and len(own.points) == 2000
    turn = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    corners = np.column_stack([2.0 + 0.07 * np.cos(turn), 0.07 * np.sin(turn), np.zeros(8)])
    assert surface.probe.open_share(corners) < 0.1 < 0.3 < own.open_share(corners)


def test_a_separate_piece_a_few_balls_across_is_said_to_be_resolved_little():
    """The sample radius is a fraction of the whole cloud's diagonal: a torus 1/20 the size of the other in its
    cloud is 2.2 radii across and loses its loop; one 1/10 the size, 4.3 across, keeps it and is not named; nor is
    a cloud of one piece."""
    from skelcore.neighbours import one_rings
    from skelcore.params import default_k
    from skelcore.skeleton import SkeletonParams

    def notes(scale):
        rng = np.random.default_rng(0)
        cloud = np.vstack([_torus(8000, 1.0, 0.3, rng), _torus(2000, scale, 0.3 * scale, rng) + [2.0, 0.0, 0.0]])
        surface = OriginalSurface.of(cloud, one_rings(cloud, default_k(len(cloud))).triangles)
        return surface.scale_notes(SkeletonParams.sample_radius)

    [said] = notes(0.05)
    assert said.startswith("a separate piece is 2.") and "less than 4" in said and "skeletonise it alone" in said
    assert notes(0.1) == []
    one = _torus(5000, 1.0, 0.3, np.random.default_rng(1))
    assert OriginalSurface.of(one, one_rings(one, default_k(5000)).triangles).scale_notes(0.02) == []
