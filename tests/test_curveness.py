"""Curve-likeness of a contracted cloud (skelcore.curveness) and the stop rule that waits for it."""
import numpy as np
import pytest

from skelcore.contraction import goes_on
from skelcore.curveness import curve_share
from skelcore.params import ContractionParams


def test_a_thin_curve_is_curve_like_and_a_sheet_is_not():
    rng = np.random.default_rng(0)
    t = rng.uniform(0, 2 * np.pi, 4000)
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)]) + rng.normal(0, 0.005, (4000, 3))
    sheet = np.column_stack([rng.uniform(-1, 1, (4000, 2)), rng.normal(0, 0.005, 4000)])
    assert curve_share(ring, 0.05) > 0.8
    assert curve_share(sheet, 0.05) < 0.1


def test_a_step_past_the_stall_is_taken_only_towards_curves():
    rng = np.random.default_rng(1)
    sheet = np.column_stack([rng.uniform(-1, 1, 3000), rng.uniform(-0.3, 0.3, 3000), np.zeros(3000)])
    thinner = sheet * np.where(sheet[:, :1] < -0.3, [1, 0.02, 1], [1, 1, 1])  # a third of it now a curve
    params, diagonal = ContractionParams(), 2.0  # the skeleton's scale: radius 0.02 x 2 = 0.04
    assert 0 < curve_share(thinner, 0.04) < params.curve_share
    assert goes_on(sheet, thinner, params, diagonal)  # a sheet narrowing towards its medial curve goes on
    assert not goes_on(thinner, sheet, params, diagonal)  # a step that leaves it less curve-like does not
    assert not goes_on(sheet, thinner, params.replace(curve_share=0), diagonal)  # cloudcontr's rule alone


def _torus(count, major, minor, seed=0):
    """Points on a torus round the z axis."""
    rng = np.random.default_rng(seed)
    u, v = rng.uniform(0, 2 * np.pi, count), rng.uniform(0, 2 * np.pi, count)
    radius = major + minor * np.cos(v)
    return np.column_stack([radius * np.cos(u), radius * np.sin(u), minor * np.sin(v)])


def _thin_tubes(points):
    from skelcore.curveness import thin_tubes
    from skelcore.neighbours import one_rings
    from skelcore.normalise import object_diagonal
    from skelcore.params import default_k

    radius = 0.02 * object_diagonal(points)
    k = default_k(len(points))
    return thin_tubes(points, radius, one_rings(points, k).edges(), k), radius


def test_thin_handles_are_anchored_on_their_axis():
    """A ball's handles one or two points across: their cross-section lies within a skeleton ball and is hollow,
    and they close loops, so their points are anchored, on the handles' axes; no point of the ball is."""
    from skelcore.solids import solid_shape

    points = solid_shape("thin_handled_ball", 10_000).points
    anchors, radius = _thin_tubes(points)
    anchored = np.isfinite(anchors[:, 0])
    on_handles = np.linalg.norm(points, axis=1) > 1.01
    # the arcs that stand free of the ball (their feet, within a skeleton ball of it, contract with it)
    assert anchored[on_handles].mean() > 0.2 and not anchored[~on_handles].any()
    # within the tube (0.04) and the straight axis line's offset from the curved one; at a foot, where the ball
    # enters the cross-section, a centroid may lean towards it, but never past the judging scale (two radii)
    offsets = np.linalg.norm(anchors[anchored] - points[anchored], axis=1)
    assert np.quantile(offsets, 0.99) < 0.08 and (offsets < 2 * radius).all()


def _handle_of(points, handles=3):
    """0 on the ball of solids.handled_ball, else 1 + the handle a point stands on (the solid's directions)."""
    height = 0.8 - 1.2 * np.arange(handles) / (handles - 1)
    azimuth, tilt = 2.39996 * np.arange(handles), np.arccos(height)
    directions = np.column_stack([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), height])
    return np.where(np.linalg.norm(points, axis=1) > 1.01, np.argmax(points @ directions.T, axis=1) + 1, 0)


def test_handles_on_the_sparse_half_of_a_scan_are_anchored():
    """Handles of tube 0.07 (over a sample radius) on a ball with 30% of the points kept on one half: on the
    sparse half a handle is a few points around, its one-rings lie flat over it and a sample radius holds too
    few points to judge it; judged at the reach of its one-ring's neighbourhood every handle is anchored (with a
    fixed radius none was), and no point of the ball is."""
    from skelcore.perturb import thin_half
    from skelcore.solids import solid_shape

    points = thin_half(solid_shape("handled_ball", 10_000).points, 0.3, np.random.default_rng(0))
    anchors, _ = _thin_tubes(points)
    anchored, handle = np.isfinite(anchors[:, 0]), _handle_of(points)
    assert np.bincount(handle)[3] < 0.5 * np.bincount(handle)[2]  # the third handle is on the sparse half
    assert all(anchored[handle == h].mean() > 0.3 for h in (1, 2, 3)) and not anchored[handle == 0].any()


def test_limbs_sheets_and_thick_parts_are_not_anchored():
    """The animal's tail is thin but closes no loop (the hold keeps its end); a thick tube, a sheet and a strip
    narrower than a skeleton ball have no hollow cross-section within one."""
    from skelcore.shapes import make_shape

    rng = np.random.default_rng(2)
    sheet = np.column_stack([rng.uniform(-1, 1, (4000, 2)), rng.normal(0, 0.002, 4000)])
    strip = np.column_stack([rng.uniform(-1, 1, 3000), rng.uniform(-0.01, 0.01, 3000), np.zeros(3000)])
    for cloud in (make_shape("animal", 3000, seed=0).points, _torus(6000, 1.0, 0.3), sheet, strip):
        assert not np.isfinite(_thin_tubes(cloud)[0][:, 0]).any()


def test_noisy_thin_handles_are_anchored_and_the_ball_is_not():
    """Noise of 0.5% of the diagonal scatters a few of a thin handle's points into its cross-section (the tube is
    0.04, the noise 0.018): the wall is still hollow but for those strays, so all three handles are anchored
    (judged by the single nearest point, none was); no point of the ball is. The noise is the draw that showed
    it (default_rng(0), as the noise_0.5 variant once drew); on some draws one handle, its wall
    filled in by the strays, goes unanchored (2 of the draws of seeds 0-3)."""
    from skelcore.perturb import NOISE
    from skelcore.solids import solid_shape

    clean = solid_shape("thin_handled_ball", 10_000).points
    spread = NOISE["noise_0.5"] * np.linalg.norm(np.ptp(clean, axis=0))
    anchors, _ = _thin_tubes(clean + np.random.default_rng(0).normal(0.0, spread, clean.shape))
    anchored, handle = np.isfinite(anchors[:, 0]), _handle_of(clean)
    assert all(anchored[handle == h].mean() > 0.3 for h in (1, 2, 3)) and not anchored[handle == 0].any()


def test_thin_handles_of_a_sparse_cloud_are_anchored_beside_the_body():
    """At 5,000 points a thin handle is about seven points around and the judging scale (the reach of its
    one-ring's neighbourhood) is at its cap of two radii, so the slab across a handle also cuts the ball beside
    much of it, beyond the scale. The cross-section is the piece of the slab the surface joins to the probe, so
    every handle is anchored on every draw (with the whole slab, one handle went unanchored or nearly so on two
    of these four draws); no point of the ball is."""
    from skelcore.solids import solid_shape

    for seed in range(4):
        points = solid_shape("thin_handled_ball", 5_000, seed=seed).points
        anchors, _ = _thin_tubes(points)
        anchored, handle = np.isfinite(anchors[:, 0]), _handle_of(points)
        assert all(anchored[handle == h].mean() > 0.5 for h in (1, 2, 3)) and not anchored[handle == 0].any()


def test_a_handles_ends_are_those_of_its_axis_not_of_a_stray_position():
    """Cleaned, at 5,000 points (the benchmark's clean ball with thin handles, draw 0), a point near a handle's
    root projects onto its probe's axis, tilted into the ball, more than a sample radius from the rest of the
    handle's axis. Swept from that stray position, both of the handle's ends were it, so the handle touched the
    rest at one end only, closed no loop and went unanchored (as did its loop in the run). The ends are now those
    of the axis's largest connected piece, and every handle is anchored."""
    import scipy.sparse as sp

    from skelcore.clean import cleaned
    from skelcore.curveness import _far_ends
    from skelcore.io import validate
    from skelcore.solids import solid_shape

    path = sp.coo_matrix((np.ones(3), ([1, 2, 3], [2, 3, 4])), shape=(5, 5)).tocsr()
    assert sorted(_far_ends(path + path.T)) == [1, 4]  # node 0 stands alone
    points = cleaned(validate(solid_shape("thin_handled_ball", 5_000, seed=0).points, name="handles.xyz")).points
    anchors, _ = _thin_tubes(points)
    anchored, handle = np.isfinite(anchors[:, 0]), _handle_of(points)
    assert all(anchored[handle == h].mean() > 0.5 for h in (1, 2, 3)) and not anchored[handle == 0].any()


def test_a_patch_far_denser_than_the_rest_is_judged_thinned():
    """A scanner that dwelt on one spot: 10,000 more points on a patch of the ball 0.1 across, where every probe
    would see all of them (work and memory as their square: the judgement took 20 s and 3.5 GB, now 0.2 s). The
    patch is judged thinned to the density cap (the ball's points away from it all kept), and the handles are
    anchored as without it; no point of the ball (the patch's included) is."""
    from skelcore import density
    from skelcore.normalise import object_diagonal
    from skelcore.solids import solid_shape

    ball = solid_shape("thin_handled_ball", 10_000).points
    rng = np.random.default_rng(3)
    patch = np.column_stack([rng.normal(0.0, 0.02, (10_000, 2)), -np.ones(10_000)])
    points = np.vstack([ball, patch / np.linalg.norm(patch, axis=1, keepdims=True)])
    cell = 0.02 * object_diagonal(points) / density.CELLS_PER_RADIUS  # thin_tubes': a quarter sample radius
    assert density.capped(ball, cell) is None  # evenly sampled: judged as it is
    kept = density.capped(points, cell)
    assert np.isin(np.flatnonzero(ball[:, 2] > -0.95), kept).all() and len(kept) < len(ball) + 0.1 * len(patch)
    anchors, _ = _thin_tubes(points)
    anchored, handle = np.isfinite(anchors[:, 0]), _handle_of(points)
    assert all(anchored[handle == h].mean() > 0.2 for h in (1, 2, 3)) and not anchored[handle == 0].any()


@pytest.mark.parametrize("far", [1e6, 1e12, 1e17])
def test_points_flung_far_out_neither_overflow_nor_stretch_the_density_cells(far):
    """Two stray points a million to 10^17 extents out: the density cells are packed per point, not numbered on a
    grid from the cloud's lowest corner (whose size overflowed 64 bits: "negative dimensions", an internal error of
    `skelcore run`), nor measured from that corner (float rounding there merged the object's cells). A dense
    cluster beside them is still found, and only its cell thinned."""
    from skelcore import density

    torus = _torus(5000, 1.0, 0.3)
    cloud = np.vstack([torus, [[far, -far, far], [-far, far, -far]]])
    assert density.capped(cloud, 0.01) is None
    dense = np.vstack([cloud, torus[:1] + np.random.default_rng(0).normal(0.0, 1e-4, (2000, 3))])
    kept = density.capped(dense, 0.01)
    assert kept is not None and np.isin(np.arange(1, 5002), kept).all() and len(kept) < 5002 + 200


def test_a_few_points_unevenly_round_a_tube_find_its_axis_not_their_centroid():
    """Ten points of a wire's cross-section, eight of them within 120 degrees of its circle and two across (a few
    points around fall unevenly): their centroid lies nearly half a radius off the axis, near the eight, which
    then read as inside the tube (not hollow); the circle through them has the axis as its centre. The points of
    an open arc (a tube seen from one side: a gap of more than half a turn) and of a line keep their centroid."""
    from skelcore.curveness import _circle_centres

    def on_circle(degrees):
        angles = np.radians(degrees)
        return np.column_stack([0.25 * np.cos(angles) + 3.0, 0.25 * np.sin(angles) - 2.0, np.zeros(len(angles))])

    uneven = on_circle(np.r_[np.linspace(-60, 60, 8), 150, 210])
    arc = on_circle(np.linspace(-75, 75, 10))
    line = np.column_stack([np.zeros(10), np.linspace(-0.2, 0.2, 10), np.zeros(10)])
    sections = [uneven, arc, line]
    centroids = np.array([section.mean(axis=0) for section in sections])
    rows = np.repeat(np.arange(3), 10)
    shift = _circle_centres(np.concatenate(sections) - centroids[rows], rows, np.tile([0.0, 0.0, 1.0], (3, 1)),
                            np.ones(3, dtype=bool))
    assert np.linalg.norm(centroids[0] - [3.0, -2.0, 0.0]) > 0.1
    assert np.allclose(centroids[0] + shift[0], [3.0, -2.0, 0.0]) and np.allclose(shift[1:], 0.0)
