"""Recentring of the curve skeleton's degree-2 nodes on the cross-section of the ORIGINAL points."""
from __future__ import annotations

import numpy as np

Adjacency = dict[int, set[int]]


def recentre(adj: Adjacency, xyz: list, node_of_point: np.ndarray, original: np.ndarray) -> None:
    """Move every degree-2 node, across the curve only, onto the centre of the cross-section of the ORIGINAL
    points mapped to it and to its two neighbours (three consecutive slabs make a balanced piece; one slab is
    often lopsided). The centre is a least-squares circle (Kasa fit) in the plane normal to the curve: exact
    for a tube however its points are spread, where a centroid follows the sampling density and, on a bent
    tube, the larger area of the outer side (by r^2 / 2R). Cross-sections that are not round, or whose points
    cover only one side, fall back to the centroid. Ends and junctions stay: the centroid of a tip is pulled
    towards its cap, that of a junction towards its heaviest branch."""
    middle = np.array([x for x in adj if len(adj[x]) == 2], dtype=np.int64)
    if len(middle) == 0:
        return
    pos = np.asarray(xyz, dtype=float)
    a, b = np.array([sorted(adj[x]) for x in middle]).T
    tangent = pos[b] - pos[a]
    norm = np.linalg.norm(tangent, axis=1, keepdims=True)
    tangent = np.divide(tangent, norm, out=np.zeros_like(tangent), where=norm > 0)
    u = np.cross(tangent, np.eye(3)[np.argmin(np.abs(tangent), axis=1)])
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    v = np.cross(tangent, u)

    # Every point of the three slabs of each middle node, as (middle row, point) pairs.
    order = np.argsort(node_of_point, kind="stable")
    starts = np.searchsorted(node_of_point[order], np.arange(len(xyz) + 1))
    slabs = np.concatenate([middle, a, b])
    counts = starts[slabs + 1] - starts[slabs]
    row = np.tile(np.arange(len(middle)), 3).repeat(counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    point = order[np.repeat(starts[slabs], counts) + offset]
    local = original[point] - pos[middle][row]
    x, y = (local * u[row]).sum(axis=1), (local * v[row]).sum(axis=1)

    def total(values):
        return np.bincount(row, weights=values, minlength=len(middle))

    n = np.bincount(row, minlength=len(middle)).astype(float)
    # In units of each section's RMS distance: the fit's normal matrix mixes lengths^2, lengths and counts, so
    # its solvability test below compares like with like only at a size of about 1 (at 2^-20 of the size it
    # judged every section unsolvable and fell back to the centroid).
    unit = np.sqrt(total(x * x + y * y) / np.maximum(n, 1))
    unit = np.where(unit > 0, unit, 1.0)
    x, y = x / unit[row], y / unit[row]
    z = x * x + y * y
    sx, sy, sxx, sxy, syy = total(x), total(y), total(x * x), total(x * y), total(y * y)
    # Kasa: x^2 + y^2 = 2 cx x + 2 cy y + c in the least-squares sense, one 3x3 system per node.
    normal = np.stack([np.stack([sxx, sxy, sx], -1), np.stack([sxy, syy, sy], -1), np.stack([sx, sy, n], -1)], -2)
    rhs = np.stack([total(x * z), total(y * z), total(z)], -1)
    solvable = np.abs(np.linalg.det(normal)) > 1e-12 * np.maximum(np.abs(normal).max(axis=(1, 2)), 1e-300) ** 3
    solution = np.zeros((len(middle), 3))
    solution[solvable] = np.linalg.solve(normal[solvable], rhs[solvable][..., None])[..., 0]
    cx, cy = solution[:, 0] / 2, solution[:, 1] / 2
    radius = np.sqrt(np.maximum(solution[:, 2] + cx * cx + cy * cy, 0))
    dx, dy = x - cx[row], y - cy[row]
    distance = np.hypot(dx, dy)
    rms = np.sqrt(total((distance - radius[row]) ** 2) / np.maximum(n, 1))
    spread = np.divide(rms, radius, out=np.full(len(middle), np.inf), where=radius > 0)  # a floor would overflow
    around = np.hypot(total(dx / np.maximum(distance, 1e-300)), total(dy / np.maximum(distance, 1e-300))) / np.maximum(n, 1)
    round_section = solvable & (n >= 6) & (radius > 0) & (spread < 0.2) & (around < 0.5)
    cx, cy = np.where(round_section, cx, sx / np.maximum(n, 1)), np.where(round_section, cy, sy / np.maximum(n, 1))
    cx, cy = cx * unit, cy * unit
    moved = pos[middle] + cx[:, None] * u + cy[:, None] * v
    for x_, p in zip(middle.tolist(), moved.tolist()):
        xyz[x_] = tuple(p)
