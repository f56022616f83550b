"""Ball-cover sampling of the contracted points: the nodes the curve skeleton starts from."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def ball_cover_sampling(points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Farthest point sampling until every point lies within `radius` of a sample.

    Returns (samples (s,) point ids, owner (n,) index into samples of each point's nearest sample). The loop
    runs over samples; a new sample at distance D from the others can only be nearest to points within D of
    it, so only that ball is updated. Starts at the point farthest from the centroid (deterministic).
    """
    tree = cKDTree(points)
    first = int(np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1)))
    nearest = np.linalg.norm(points - points[first], axis=1)
    owner = np.zeros(len(points), dtype=np.int64)
    # Coordinates column by column: the distances of a ball gathered and summed as np.linalg.norm sums them
    # ((x^2 + y^2) + z^2, the same values), without its (m, 3) temporaries.
    xs, ys, zs = (np.ascontiguousarray(column) for column in points.T)
    samples = [first]
    while True:
        far = int(np.argmax(nearest))
        reach = nearest[far]
        if reach <= radius:
            break
        ball = np.asarray(tree.query_ball_point(points[far], reach, return_sorted=False), dtype=np.int64)
        dx, dy, dz = xs[ball] - xs[far], ys[ball] - ys[far], zs[ball] - zs[far]
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        closer = dist < nearest[ball]
        ball, dist = ball[closer], dist[closer]
        nearest[ball] = dist
        owner[ball] = len(samples)
        nearest[far], owner[far] = 0.0, len(samples)
        samples.append(far)
    return np.asarray(samples, dtype=np.int64), owner


def ball_cover_by_piece(points: np.ndarray, radius: float, edges: np.ndarray,
                        pieces: tuple[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """ball_cover_sampling within each connected piece of the graph of `edges` (the original surface): a
    sample never owns points of two pieces, so two rings that pass close to each other after contraction
    (linked rings, a chain) stay apart. `pieces`: connected_components of that graph
    (skelcore.surface.OriginalSurface.pieces). Same returns as ball_cover_sampling."""
    n = len(points)
    count, piece = pieces
    lone = np.ones(n, dtype=bool)
    lone[edges.ravel()] = False
    if lone.any() and not lone.all():  # points on no edge (e.g. absorbed by GLSkeleton) join their nearest piece
        linked = np.flatnonzero(~lone)
        piece = piece.copy()  # `pieces` may be kept for the next skeleton
        piece[lone] = piece[linked[cKDTree(points[linked]).query(points[lone])[1]]]
        labels, piece = np.unique(piece, return_inverse=True)
        count = len(labels)
    if count == 1:
        return ball_cover_sampling(points, radius)
    samples, owner = [], np.zeros(n, dtype=np.int64)
    order = np.argsort(piece, kind="stable")
    bounds = np.searchsorted(piece[order], np.arange(count + 1))
    for label in range(count):
        ids = order[bounds[label]:bounds[label + 1]]
        local_samples, local_owner = ball_cover_sampling(points[ids], radius)
        owner[ids] = local_owner + sum(len(s) for s in samples)
        samples.append(ids[local_samples])
    return np.concatenate(samples), owner

