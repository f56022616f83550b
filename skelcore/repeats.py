"""Repeated points: a cloud keeps each point once, and a mesh its vertices once (an STL file repeats each vertex
for every face it has), found by sorting a hash of each point's bytes. A mesh whose faces close no solid that way
is welded: some exporters write one vertex a rounding apart in each face that has it."""
from __future__ import annotations

import numpy as np

from .mesh_topology import closed_solid

# Vertices closer than this share of the mesh's median edge are one vertex written twice: float32 text keeps six
# or seven digits, a rounding of 5e-7 of a coordinate, which is 5e-4 of an edge only on a mesh a thousand edges
# from the origin; no face of a sound mesh has an edge that short.
WELD_SHARE = 1e-3
EDGE_SAMPLE = 30_000  # faces the median edge is read from (of a 1M-vertex mesh's 2M: a second saved)


def without_repeats(points: np.ndarray, faces: np.ndarray | None, labels: np.ndarray | None,
                    rows: np.ndarray | None, notes: list[str]
                    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """The points without repeats (each point's first occurrence, in the input's order; said in `notes`), the faces
    renumbered over them without those whose corners repeat (None when none is left), the labels and the input
    `rows` that follow."""
    kept = first_occurrences(points)
    if kept is not None:
        first, row = kept
        notes.append(f"removed {len(points) - len(first)} duplicate points")
        points = points[first]
        labels, rows = (None if values is None else values[first] for values in (labels, rows))
        faces = None if faces is None else row[faces]
    if faces is not None:
        faces = _with_three_corners(faces)
        faces = faces if len(faces) else None
    return points, faces, labels, rows


def welded(points: np.ndarray, faces: np.ndarray, labels: np.ndarray | None, rows: np.ndarray | None,
           notes: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None, int, int] | None:
    """A mesh whose faces close no solid with its vertices closer than WELD_SHARE of its median edge merged (each
    group into its first vertex; said in `notes`), with the loops through the solid it then bounds and its pieces;
    None when that closes none (the mesh stays as it came)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    some = faces[::max(1, len(faces) // EDGE_SAMPLE)]
    edge = float(np.median(np.linalg.norm(points[some] - points[np.roll(some, 1, axis=1)], axis=2)))
    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)  # built for one query: the quick build
    pairs = tree.query_pairs(WELD_SHARE * edge, output_type="ndarray") if edge > 0 else ()
    if not len(pairs):
        return None
    ones = np.ones(len(pairs), dtype=np.int8)
    _, group = connected_components(coo_matrix((ones, pairs.T), shape=(len(points),) * 2), directed=False)
    first = np.full(group.max() + 1, len(points))
    np.minimum.at(first, group, np.arange(len(points)))
    kept = np.sort(first)
    rank = np.empty(len(points), dtype=np.int64)
    rank[kept] = np.arange(len(kept))
    merged = _with_three_corners(rank[first[group]][faces])
    loops, pieces, _ = closed_solid(merged, len(kept))
    if loops is None:
        return None
    notes.append(f"merged {len(points) - len(kept)} mesh vertices within {WELD_SHARE * edge:.3g} of another (the "
                 f"file writes them apart by rounding), so the faces close a solid")
    return (points[kept], merged, *(None if values is None else values[kept] for values in (labels, rows)), loops,
            pieces)


def _with_three_corners(faces: np.ndarray) -> np.ndarray:
    """The faces whose three corners are three vertices."""
    return faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]


def first_occurrences(points: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """None when no two points are equal; else (the ids of each distinct point's first occurrence, ascending; for
    every point, the position of its distinct point among those). Points are sorted by a hash of their bytes, where
    equal points lie next to each other (6M rows of an STL: 3.4 s, np.unique over rows 10.9 s; without repeats the
    sort of the hashes alone decides); a hash shared by unequal points sorts the rows themselves."""
    bits = np.ascontiguousarray(points, dtype=np.float64).view(np.uint64)
    bits = np.where(points == 0.0, np.uint64(0), bits)  # -0.0 and 0.0 are the same coordinate
    hashes = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15) ^ bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F) ^ bits[:, 2]
    order = np.argsort(hashes, kind="stable")
    same_hash = hashes[order[1:]] == hashes[order[:-1]]
    if not same_hash.any():
        return None
    same = np.all(points[order[1:]] == points[order[:-1]], axis=1)
    if (same_hash & ~same).any():  # two points share a hash
        order = np.lexsort(points.T[::-1])
        same = np.all(points[order[1:]] == points[order[:-1]], axis=1)
    starts = np.flatnonzero(np.r_[True, ~same])
    if len(starts) == len(points):  # only hashes were shared
        return None
    first = np.minimum.reduceat(order, starts)  # each distinct point's first occurrence
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    row = np.empty(len(points), dtype=np.int64)
    row[order] = rank[np.cumsum(np.r_[True, ~same]) - 1]
    return np.sort(first), row
