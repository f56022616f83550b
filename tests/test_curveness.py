"""Curve-likeness of a contracted cloud (skelcore.curveness) and the stop rule that waits for it."""
import numpy as np

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


def test_thin_tubes_are_the_parts_one_skeleton_ball_spans():
    """A ring tube whose cross-section fits within the radius is thin, and each point is anchored on its axis;
    a thick tube, a sheet and a strip narrower than the radius are not."""
    from skelcore.curveness import thin_tubes

    radius = 0.1
    thin = thin_tubes(_torus(3000, 1.0, 0.4 * radius), radius)
    assert np.isfinite(thin[:, 0]).mean() > 0.9
    anchored = thin[np.isfinite(thin[:, 0])]
    assert np.abs(np.hypot(anchored[:, 0], anchored[:, 1]) - 1.0).max() < 0.3 * radius  # on the ring's axis
    assert np.abs(anchored[:, 2]).max() < 0.3 * radius
    rng = np.random.default_rng(2)
    sheet = np.column_stack([rng.uniform(-1, 1, (4000, 2)), rng.normal(0, 0.002, 4000)])
    strip = np.column_stack([rng.uniform(-1, 1, 3000), rng.uniform(-0.4 * radius, 0.4 * radius, 3000), np.zeros(3000)])
    for cloud in (_torus(6000, 1.0, 3 * radius), sheet, strip):
        assert np.isfinite(thin_tubes(cloud, radius)[:, 0]).mean() < 0.02
