"""Contracted points flung out of the shape (skelcore.flung) and the skeleton drawn after they are put back."""
import numpy as np

from skelcore.flung import flung_points, put_back
from skelcore.skeleton import SkeletonParams, extract_skeleton
from skelcore.surface import OriginalSurface
from test_skeleton import ring_triangles, topology, torus


def sphere(n=3000, upper_only=False, seed=0):
    """Points on the unit sphere (only its upper half: a single-view scan of a ball, open below)."""
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(n, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    if upper_only:
        points[:, 2] = np.abs(points[:, 2])
    return points


def flung_torus(n=3000):
    """A torus contracted onto its centre circle, but for the points round its outermost tip, flung straight out
    of it as a degenerate ring throws them: from 0.3 to 0.6 beyond the surface."""
    contracted, original = torus(n=n, jitter=0.005)
    tip = np.argsort(np.linalg.norm(original - [1.25, 0.0, 0.0], axis=1))[:20]
    contracted[tip] = [1.55, 0.0, 0.0] + np.linspace(0.0, 0.3, len(tip))[:, None] * [1.0, 0.0, 0.0]
    return contracted, original, tip


def test_points_flung_out_of_a_torus_go_back_to_its_circle_and_no_other_point_moves():
    contracted, original, tip = flung_torus()
    surface = OriginalSurface.of(original, ring_triangles(original))
    assert set(np.flatnonzero(flung_points(contracted, surface))) == set(tip)
    put = put_back(contracted, surface)
    assert np.abs(np.linalg.norm(put[tip, :2], axis=1) - 1.0).max() < 0.05  # the circle, where their ring went
    others = np.setdiff1d(np.arange(len(put)), tip)
    assert np.array_equal(put[others], contracted[others])


def test_a_flung_spur_is_no_part_of_the_skeleton():
    contracted, original, _ = flung_torus()
    triangles = ring_triangles(original)
    drawn = extract_skeleton(contracted, original, triangles, SkeletonParams(put_back_flung=False))
    assert topology(drawn)["ends"] >= 1  # the spur the flung points drew out of the torus
    skeleton = extract_skeleton(contracted, original, triangles)
    assert topology(skeleton) == {"components": 1, "cycles": 1, "junctions": 0, "ends": 0}
    assert np.linalg.norm(skeleton.nodes_array()[:, :2], axis=1).max() < 1.1


def test_a_point_on_the_surface_or_in_the_hole_is_not_flung():
    """Within a point spacing of the surface a point is on it; in the torus's hole it is outside the solid, but
    within the hull, where a skeleton can run (the axis of a cup, of a pipe)."""
    contracted, original = torus(n=3000, jitter=0.005)
    surface = OriginalSurface.of(original, ring_triangles(original))
    contracted[0] = original[np.argmax(original[:, 0])] + [0.5 * surface.probe.spacing, 0.0, 0.0]
    contracted[1] = [0.0, 0.0, 0.0]
    assert not flung_points(contracted, surface).any()
    assert put_back(contracted, surface) is contracted


def test_nothing_is_flung_beyond_an_open_scan():
    """A point far out above a ball is flung. A scan of its upper half only is open: the space inside joins the
    region round it, the object goes on beyond what was seen, and nothing is flung, not even that point."""
    centre = np.random.default_rng(1).normal(0.0, 0.05, (3000, 3))
    for original, closed in ((sphere(), True), (sphere(upper_only=True), False)):
        surface = OriginalSurface.of(original, ring_triangles(original))
        contracted = centre.copy()
        assert not flung_points(contracted, surface).any()
        contracted[0] = [0.0, 0.0, 1.8]
        assert flung_points(contracted, surface).tolist() == [closed] + [False] * (len(centre) - 1)
