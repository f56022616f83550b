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
