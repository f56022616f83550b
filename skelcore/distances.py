"""Distances of points from segments and from filled triangles, many at once."""
from __future__ import annotations

import numpy as np


def triangle_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance of each point (m, 3) to its filled triangle (m, 3, 3), corners in rows (a flat one: inf)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, ac = b - a, c - a
    normal = np.cross(ab, ac)
    area2 = np.linalg.norm(normal, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal /= area2[:, None]
    rel = points - a
    height = np.einsum("ij,ij->i", rel, normal)
    foot = rel - height[:, None] * normal
    # barycentric coordinates of the foot
    d00, d01, d11 = (np.einsum("ij,ij->i", *pair) for pair in ((ab, ab), (ab, ac), (ac, ac)))
    d20, d21 = np.einsum("ij,ij->i", foot, ab), np.einsum("ij,ij->i", foot, ac)
    denom = area2 * area2  # = d00 d11 - d01^2 (Lagrange), without its cancellation on a thin sliver
    with np.errstate(invalid="ignore", divide="ignore"):
        v = (d11 * d20 - d01 * d21) / denom
        w = (d00 * d21 - d01 * d20) / denom
    inside = (v >= 0) & (w >= 0) & (v + w <= 1)
    distance = np.abs(height)
    out = ~inside
    if out.any():
        edges = [(a, b), (b, c), (c, a)]
        distance[out] = np.min([segment_distance(points[out], p[out], q[out]) for p, q in edges], axis=0)
    distance[area2 == 0] = np.inf
    return distance


def segment_distance(points: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distances of `points` (m,3) from the segment p-q (a point when p == q): one segment (3,) for all, or one
    per point (m, 3)."""
    d = q - p
    t = np.clip(np.einsum("...j,...j->...", points - p, d) / np.maximum(np.einsum("...j,...j->...", d, d), 1e-300),
                0.0, 1.0)
    return np.linalg.norm(points - (p + t[..., None] * d), axis=-1)
