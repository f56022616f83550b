"""Clouds sampled on scan lines: dense along lines that lie far apart, as a profile scanner, a line laser or a
spinning LiDAR's rings leave them.

The one-rings need a point's nearest neighbours to spread over the surface around it. On scan lines they lie on
its own line and its nearest neighbours across, so the fans are strips of long thin triangles, and a contraction
of them tears: the benchmark's 23 meshed shapes cut by parallel planes every 1.5% of their diagonal, points every
0.3% along each cut (skelcore.perturb.scan_lines: lines five to six times farther apart than the points on them),
kept their topology in 10 (LBC) and 11 (GLSkeleton) of 23 runs, and in 21 of 23 with each method once contracted
as voxel centroids one line spacing apart (skelcore.multires.even_scan_lines, every input point carried along).

`line_spacing` reads it from a fixed sample of the points: for each, the nearest neighbour in a direction over 60
degrees from that of its nearest one (its line's), against that nearest one's distance. An evenly sampled surface
has the two about equal (the median ratio of every benchmark cloud, lattices included, is under 1.6; of CGAL's 24
point sets, scans among them, under 2.3); cut every 0.6% (a ratio of 2), six of those shapes kept their topology
point by point, every 0.9% (3) the chair gained four loops. A cloud whose points have no such neighbour within reach
is made of curves, not lines over a surface, and is read as it is.
"""
from __future__ import annotations

import numpy as np

LINE_RATIO = 2.5  # lines this many times farther apart than the points along them are scan lines
SAMPLE = 4000  # points whose neighbourhoods are read (a fixed, evenly spread choice)
NEIGHBOURS = 24  # nearest neighbours searched for one across the line
ACROSS = 0.5  # cosine of the angle to the line's direction below which a neighbour lies across it (60 degrees)


def line_spacing(points: np.ndarray) -> tuple[float, float] | None:
    """(the spacing across the lines, its ratio to the spacing along them) when the cloud lies on scan lines,
    medians over a sample of its points; None for a cloud sampled evenly, or made of curves."""
    from scipy.spatial import cKDTree

    n = len(points)
    if n <= NEIGHBOURS:
        return None
    rows = np.unique(np.linspace(0, n - 1, min(n, SAMPLE)).astype(np.int64))
    distance, index = cKDTree(points).query(points[rows], k=NEIGHBOURS, workers=-1)
    offsets = points[index[:, 1:]] - points[rows][:, None]
    along = offsets[:, 0] / np.maximum(distance[:, 1:2], 1e-300)  # the line's direction: to the nearest point
    cosine = np.abs(np.einsum("ijk,ik->ij", offsets, along)) / np.maximum(distance[:, 1:], 1e-300)
    across = np.where(cosine < ACROSS, distance[:, 1:], np.inf).min(axis=1)
    ratio = float(np.median(across / np.maximum(distance[:, 1], 1e-300)))
    if not LINE_RATIO < ratio < np.inf:
        return None
    return float(np.median(across[np.isfinite(across)])), ratio
