"""One-ring edges that jump across empty space (not in Cao et al. 2010): found and dropped before the contraction.

A one-ring is the Delaunay fan of a point's k nearest neighbours projected onto their PCA plane. Where the
sampling is coarse beside the shape's detail (a twig one point wide, whose k nearest neighbours reach k/2
spacings along it), the fan joins the point to another part of the shape across empty space in that plane.
The Laplacian then pulls the two parts together and the skeleton gains a loop the shape does not have.

The rule is the sampling's own. Around a sample, the ball of radius r_m (the distance to its m-th nearest
neighbour) holds m samples, whatever the sampling's dimension: a surface, a strand one point wide, a noisy
shell. A surface point has samples round it at that density, so a ball of that radius about it is empty
only where the sampling left a hole: for a random (Poisson) sampling, with probability about e^-m. An edge
whose middle has no input point within r_m (the larger of its two ends', each the median over the point's k
nearest neighbours, which noise and a few strays do not move) runs where nothing was sampled: it is a jump.
Only an edge longer than 2 r_m can be one (its middle lies within half its length of both ends), so only
those are queried: a few per thousand. The middle of a long Delaunay edge lies in an empty circle by
construction, so the test fails on a surface more often than e^-m: on 20,000 uniformly random points in a
square (k = 30), 1 edge in 400 at m = 6, 1 in 8,500 at m = 8, 1 in 60,000 at m = 10 and none of 120,000 at
m = JUMP_SAMPLES = 12. A ball of 12 samples is still small: 2 spacings across on a surface, 6 along a strand
one point wide, whose k = 30 nearest neighbours reach 15 spacings along it (and across to any branch nearer).

Only a jump within the fan's plane counts: the test uses the edge's length projected onto that plane. An
edge along the plane's normal joins two sheets the projection laid onto each other (a thin wall's faces, a
tube's front and back), which a ring spans on any part thinner than itself; that is how LBC contracts thin
parts (their sheets merge). What the fan gets wrong lies in its plane: a gap there reads as surface.

Every side of a fan is tested in the fan's plane, its ring edges and each triangle's far side (j, l). A
ring entry (i, j) is dropped when its edge is a jump, a fan triangle when any of its three sides is one (a
triangle between two surface edges can still span a gap: at a fork, between the two branches).
The rule removes loops and never splits the surface: a jump that is the only link between two pieces of the
fans' triangles left (a gap of the sampling along one strand, or a stray point) stays, the shortest ones
that join them (a minimum spanning forest of the pieces). A jump is dropped only where the surface joins its
ends some other way, where it could only close a false loop.

GLSkeleton's merged rings (skelcore.ring_merge.merge_rings) are not tested again: a merged ring is the union
of two rings already without jumps, so its new edges are backed by two ring edges through the absorbed
point, and its points stand for several input points each, so the input's spacing no longer measures them.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree

from .distinct import distinct_rows

JUMP_SAMPLES = 12  # m: an edge's middle with no input point within r_m of its ends is off the sampled surface


def sampling_reach(distances: np.ndarray, indices: np.ndarray, chunk: int = 1 << 16) -> np.ndarray:
    """(n,) r_m about each point: the median over its k nearest neighbours (the (n, k) kNN `distances` and
    `indices`, the point itself in column 0) of their distance to their m-th nearest neighbour (m =
    JUMP_SAMPLES, at most k - 1)."""
    mth = distances[:, min(JUMP_SAMPLES, distances.shape[1] - 1)]
    reach = np.empty(len(distances))
    for start in range(0, len(distances), chunk):
        reach[start:start + chunk] = np.median(mth[indices[start:start + chunk]], axis=1)
    return reach


def jump_masks(points: np.ndarray, centres: np.ndarray, neighbours: np.ndarray, triangles: np.ndarray,
               normals: np.ndarray, reach: np.ndarray, tree: cKDTree) -> tuple[np.ndarray, np.ndarray]:
    """Which ring entries (centre, neighbour) and which fan triangles (i, j, l) to keep: masks over them
    (module docstring). `normals`: (n, 3) the normal of each point's fan plane; `reach`: sampling_reach of
    `points`; `tree`: a cKDTree over `points`."""
    jumps = find_jumps(points, np.concatenate([centres, triangles[:, 1]]), np.concatenate([neighbours, triangles[:, 2]]),
                       normals[np.concatenate([centres, triangles[:, 0]])], reach, tree)
    if not len(jumps):
        return np.ones(len(centres), dtype=bool), np.ones(len(triangles), dtype=bool)
    while True:
        keep_entry, keep_triangle = _without(jumps, points, centres, neighbours, triangles)
        bridges = _bridges(jumps, points, triangles[keep_triangle])
        if not len(bridges):
            return keep_entry, keep_triangle
        jumps = np.delete(jumps, bridges, axis=0)


def find_jumps(points: np.ndarray, first: np.ndarray, second: np.ndarray, normals: np.ndarray, reach: np.ndarray,
               tree: cKDTree) -> np.ndarray:
    """(j, 2) the pairs (a < b) among the sides (first, second) of fans whose planes have the unit `normals`
    (s, 3) that are jumps: longer within that plane than twice the larger reach of their ends, and with no
    point within that reach of their middle (only the long ones are queried)."""
    limit = np.maximum(reach[first], reach[second])
    offset = points[first] - points[second]
    across = np.einsum("ec,ec->e", offset, normals)
    long = np.einsum("ec,ec->e", offset, offset) - across**2 > (2.0 * limit) ** 2
    if not long.any():
        return np.zeros((0, 2), dtype=np.int64)
    candidates = distinct_rows(np.sort(np.column_stack([first[long], second[long]]), axis=1))
    middle = 0.5 * (points[candidates[:, 0]] + points[candidates[:, 1]])
    limit = np.maximum(reach[candidates[:, 0]], reach[candidates[:, 1]])
    gap = tree.query(middle, k=1, distance_upper_bound=float(limit.max()), workers=-1)[0]
    return candidates[gap > limit]  # inf: nothing within the largest limit


def _without(jumps: np.ndarray, points: np.ndarray, centres: np.ndarray, neighbours: np.ndarray,
             triangles: np.ndarray):
    """Masks of the ring entries and triangles kept when `jumps` are dropped. No ring is emptied: a point all
    of whose ring edges are jumps (a stray in empty space) keeps its nearest, so its ring size stays defined."""
    n = len(points)
    keys = np.sort(jumps[:, 0] * n + jumps[:, 1])
    at_jump = np.zeros(n, dtype=bool)
    at_jump[jumps.ravel()] = True

    def is_jump(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # only pairs with both ends at some jump are looked up
        found = np.zeros(len(a), dtype=bool)
        both = np.flatnonzero(at_jump[a] & at_jump[b])
        if len(keys) and len(both):
            key = np.minimum(a[both], b[both]) * n + np.maximum(a[both], b[both])
            found[both] = keys[np.minimum(np.searchsorted(keys, key), len(keys) - 1)] == key
        return found

    i, j, l = triangles.T
    keep_entry = ~is_jump(centres, neighbours)
    emptied = np.flatnonzero((np.bincount(centres[keep_entry], minlength=n) == 0)[centres])
    if len(emptied):
        length = np.linalg.norm(points[centres[emptied]] - points[neighbours[emptied]], axis=1)
        order = emptied[np.lexsort((length, centres[emptied]))]
        keep_entry[order[np.flatnonzero(np.diff(centres[order], prepend=-1))]] = True  # each one's nearest
    return keep_entry, ~(is_jump(i, j) | is_jump(i, l) | is_jump(j, l))


def _bridges(jumps: np.ndarray, points: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Rows of `jumps` that are the shortest links between the pieces of the `kept` triangles: a minimum
    spanning forest of the pieces over the jumps between them."""
    n = len(points)
    sides = np.concatenate([kept[:, [0, 1]], kept[:, [1, 2]]])
    graph = sp.csr_matrix((np.ones(len(sides), dtype=bool), (sides[:, 0], sides[:, 1])), shape=(n, n))
    count, piece = connected_components(graph, directed=False)
    a, b = piece[jumps[:, 0]], piece[jumps[:, 1]]
    across = np.flatnonzero(a != b)
    if not len(across):
        return across
    length = np.linalg.norm(points[jumps[across, 0]] - points[jumps[across, 1]], axis=1)
    across = across[np.argsort(length, kind="stable")]  # shortest first: its pair of pieces keeps it
    pairs = np.sort(np.column_stack([a[across], b[across]]), axis=1)
    _, first = np.unique(pairs, axis=0, return_index=True)
    across, pairs = across[first], pairs[first]
    length = np.linalg.norm(points[jumps[across, 0]] - points[jumps[across, 1]], axis=1)
    forest = minimum_spanning_tree(sp.csr_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(count, count))).tocoo()
    chosen = np.sort(np.column_stack([forest.row, forest.col]), axis=1) @ [count, 1]
    return across[np.isin(pairs @ [count, 1], chosen)]
