"""How curve-like a contracted cloud is, at the scale the skeleton samples it.

A point is curve-like when its neighbourhood within the skeleton's sample radius is a segment, not a
patch of sheet or a blob: the PCA spread across the curve (sqrt of the middle eigenvalue) is at most
CURVE_RATIO times the spread along it (sqrt of the largest). At that ratio a ball of the sample radius
sees a cross-section under about a quarter of its diameter, thin enough that one skeleton sample covers
it. The share of curve-like points tells whether a contraction has reached curves (share near 1) or
stopped at a sheet.

`skeleton_scale_share` is the one curve-likeness every figure reports (metrics.json, the verdict, the
inspector): the share at the skeleton's default sample radius, a fraction of the INPUT cloud's diagonal.

`thin_parts` finds the points a first contraction step has already brought to the axis of a thin part (a handle,
a limb): the points whose W_L the contraction may hold (skelcore.step.hold_curves).
"""
from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .skeleton import SkeletonParams

CURVE_RATIO = 0.25  # spread across / spread along, at most, for a curve-like neighbourhood
PROBES = 2000  # points whose neighbourhoods are measured (a fixed random subset; all when fewer)
MIN_NEIGHBOURS = 8  # probes within the radius needed to judge; fewer: spread too thin to be a curve there
NEAREST_INPUT = 30  # input points that judge whether a contracted point is surrounded (cloudcontr's k)
SURROUNDED = 0.5  # length of the mean unit direction to them, below which they lie on all sides
MIN_CURVE_RADII = 2.0  # a thin part spans at least this many sample radii: two skeleton edges


def curve_likeness(points: np.ndarray, radius: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(probe ids, spread ratio across/along of each probe's neighbourhood, the probes within `radius`;
    NaN where it has fewer than MIN_NEIGHBOURS)."""
    rng = np.random.default_rng(seed)
    probes = np.sort(rng.choice(len(points), PROBES, replace=False)) if len(points) > PROBES \
        else np.arange(len(points))
    sample = points[probes]
    tree = cKDTree(sample)
    pairs = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    rows = np.concatenate([pairs.row, np.arange(len(sample))])  # each probe with every probe within radius
    cols = np.concatenate([pairs.col, np.arange(len(sample))])
    counts = np.bincount(rows, minlength=len(sample)).astype(float)
    mean = np.stack([np.bincount(rows, sample[cols, axis], len(sample)) for axis in range(3)], 1) / counts[:, None]
    offset = sample[cols] - mean[rows]
    covariance = np.stack([np.bincount(rows, offset[:, i] * offset[:, j], len(sample))
                           for i in range(3) for j in range(3)], 1).reshape(-1, 3, 3) / counts[:, None, None]
    eigen = np.linalg.eigvalsh(covariance)  # ascending
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(np.maximum(eigen[:, 1], 0) / eigen[:, 2])
    ratio[(counts < MIN_NEIGHBOURS) | ~(eigen[:, 2] > 0)] = np.nan
    return probes, ratio


def curve_like_points(points: np.ndarray, radius: float, seed: int = 0) -> np.ndarray:
    """(n,) whether each point is curve-like: the judgement of its nearest probe (the probes are an even
    random subset, so a point's nearest probe lies within a probe spacing and sees the same neighbourhood)."""
    probes, ratio = curve_likeness(points, radius, seed)
    curve = ratio <= CURVE_RATIO
    if len(probes) == len(points):
        return curve
    _, nearest = cKDTree(points[probes]).query(points, workers=-1)
    return curve[nearest]


def curve_share(points: np.ndarray, radius: float, seed: int = 0) -> float:
    """The share of measured points whose neighbourhood is curve-like (see the module); a point too isolated
    to be judged counts as not curve-like."""
    _, ratio = curve_likeness(points, radius, seed)
    return float((ratio <= CURVE_RATIO).mean()) if len(ratio) else 0.0


def skeleton_scale_share(points: np.ndarray, diagonal: float, seed: int = 0) -> float:
    """curve_share of `points` at the skeleton's default sample radius, taken as that fraction of `diagonal`,
    the input cloud's object diagonal (skelcore.normalise.object_diagonal): the scale at which the skeleton
    samples the contracted cloud."""
    return curve_share(points, SkeletonParams.sample_radius * diagonal, seed)


def thin_parts(contracted: np.ndarray, original: np.ndarray, radius: float) -> np.ndarray:
    """(n,) whether each contracted point lies on the axis of a thin part of the input, judged after the first
    contraction step. Such a point is
    - curve-like at `radius` (one step made it so: the part's cross-section is a few ring spacings),
    - surrounded by the input: the unit directions from it to its NEAREST_INPUT nearest input points average to
      a vector shorter than SURROUNDED, as around a tube's axis, and not one-sided, as on the rim of an open
      scan or the edge of a sheet, which also contract to curves first,
    - in a piece of such points (within `radius` of each other) spanning at least MIN_CURVE_RADII radii: shorter
      pieces are bumps the skeleton could not draw as a curve anyway."""
    thin = np.zeros(len(contracted), dtype=bool)
    candidates = np.flatnonzero(curve_like_points(contracted, radius))
    if len(candidates) == 0:
        return thin
    _, nearest = cKDTree(original).query(contracted[candidates], min(NEAREST_INPUT, len(original)), workers=-1)
    directions = original[nearest.reshape(len(candidates), -1)] - contracted[candidates, None]
    directions /= np.maximum(np.linalg.norm(directions, axis=2, keepdims=True), 1e-300)
    candidates = candidates[np.linalg.norm(directions.mean(axis=1), axis=1) < SURROUNDED]
    if len(candidates) == 0:
        return thin
    axis_points = contracted[candidates]
    tree = cKDTree(axis_points)
    count, piece = connected_components(tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix"),
                                        directed=False)
    low, high = np.full((count, 3), np.inf), np.full((count, 3), -np.inf)
    np.minimum.at(low, piece, axis_points)
    np.maximum.at(high, piece, axis_points)
    thin[candidates[(high - low).max(axis=1)[piece] >= MIN_CURVE_RADII * radius]] = True
    return thin
