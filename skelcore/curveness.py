"""How curve-like a contracted cloud is, at the scale the skeleton samples it.

A point is curve-like when its neighbourhood within the skeleton's sample radius is a segment, not a
patch of sheet or a blob: the PCA spread across the curve (sqrt of the middle eigenvalue) is at most
CURVE_RATIO times the spread along it (sqrt of the largest). At that ratio a ball of the sample radius
sees a cross-section under about a quarter of its diameter, thin enough that one skeleton sample covers
it. The share of curve-like points tells whether a contraction has reached curves (share near 1) or
stopped at a sheet.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

CURVE_RATIO = 0.25  # spread across / spread along, at most, for a curve-like neighbourhood
PROBES = 2000  # points whose neighbourhoods are measured (a fixed random subset; all when fewer)
NEIGHBOURS = 32  # nearest probes within the radius that make a neighbourhood


def curve_likeness(points: np.ndarray, radius: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(probe ids, spread ratio across/along of each probe's neighbourhood; NaN where it has fewer than
    4 probes within `radius`)."""
    rng = np.random.default_rng(seed)
    probes = np.sort(rng.choice(len(points), PROBES, replace=False)) if len(points) > PROBES \
        else np.arange(len(points))
    sample = points[probes]
    k = min(NEIGHBOURS, len(sample))
    distance, index = cKDTree(sample).query(sample, k=k, distance_upper_bound=radius)
    distance, index = distance.reshape(len(sample), k), index.reshape(len(sample), k)
    valid = np.isfinite(distance)
    local = np.where(valid[..., None], sample[np.minimum(index, len(sample) - 1)], 0.0)
    counts = valid.sum(axis=1)
    mean = local.sum(axis=1) / np.maximum(counts, 1)[:, None]
    centred = np.where(valid[..., None], local - mean[:, None, :], 0.0)
    covariance = np.einsum("nki,nkj->nij", centred, centred) / np.maximum(counts, 1)[:, None, None]
    eigen = np.linalg.eigvalsh(covariance)  # ascending
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt(np.maximum(eigen[:, 1], 0) / eigen[:, 2])
    ratio[(counts < 4) | ~(eigen[:, 2] > 0)] = np.nan
    return probes, ratio


def curve_share(points: np.ndarray, radius: float, seed: int = 0) -> float:
    """The share of measured points whose neighbourhood is curve-like (see the module)."""
    _, ratio = curve_likeness(points, radius, seed)
    measured = ratio[np.isfinite(ratio)]
    return float((measured <= CURVE_RATIO).mean()) if len(measured) else 0.0
