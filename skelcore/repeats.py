"""Repeated points: a cloud keeps each point once, and a mesh its vertices once (an STL file repeats each vertex
for every face it has), found by sorting a hash of each point's bytes."""
from __future__ import annotations

import numpy as np


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
        faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
        faces = faces if len(faces) else None
    return points, faces, labels, rows


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
