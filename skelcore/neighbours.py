"""Neighbourhoods: kNN, PCA frames and the one-ring of every point (Cao et al. 2010, section 3).

The one-ring of a point is its fan of triangles in the 2-D Delaunay triangulation of its k nearest
neighbours projected onto their PCA plane. The Delaunay neighbours of a point c are exactly the vertices
of the convex hull of its neighbours inverted about c (p -> p/|p|^2), together with c itself: inversion
maps circles through c to lines, so an empty circumcircle through c becomes a supporting line. That
hull is computed for all points at once on a fixed (n, k-1) array, angularly sorted, by removing every
vertex that lies inside the triangle (c, previous, next) until none does: no Python loop over points.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .distinct import distinct
from .ring_jumps import jump_masks, sampling_reach


@dataclass(frozen=True)
class OneRings:
    """The one-ring of every point: neighbours in fan order (CSR) and the ring triangles (i, j, l)."""
    indptr: np.ndarray  # (n+1,) CSR offsets into `indices`
    indices: np.ndarray  # fan neighbours of each point, in angular order
    triangles: np.ndarray  # (m,3) fan triangles (i, j, l), i the centre, j then l counter-clockwise

    @property
    def n_points(self) -> int:
        """The number of points the rings are over."""
        return len(self.indptr) - 1

    def centres(self) -> np.ndarray:
        """The centre of each entry of `indices`."""
        return np.repeat(np.arange(self.n_points), np.diff(self.indptr))

    def edges(self) -> np.ndarray:
        """(e,2) unique undirected centre-neighbour pairs, a < b, in lexicographic order."""
        centres, n = self.centres(), self.n_points
        # one integer key per pair: distinct values instead of rows, 4x faster, same order
        keys = distinct(np.minimum(centres, self.indices) * n + np.maximum(centres, self.indices))
        return np.column_stack([keys // n, keys % n])

    def sizes(self, points: np.ndarray, reduce=np.minimum) -> np.ndarray:
        """Per point, the smallest (or, with np.add, the summed) distance to its ring neighbours."""
        lengths = np.linalg.norm(points[self.indices] - points[self.centres()], axis=1)
        return reduce.reduceat(lengths, self.indptr[:-1]) if len(lengths) else np.zeros(self.n_points)

    def mean_edge_length(self, points: np.ndarray, among: np.ndarray | None = None) -> float:
        """Mean over points (those of the mask `among`; None: all) of the mean distance to the ring (cloudcontr's
        one_ring_size, type 2)."""
        means = self.sizes(points, np.add) / np.maximum(np.diff(self.indptr), 1)
        return float(np.mean(means if among is None else means[among]))


def knn(points: np.ndarray, k: int, tree: cKDTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distances and indices of the k nearest neighbours, the point itself in column 0. `tree`: a cKDTree
    over `points` when one is at hand."""
    k = min(k, len(points))
    tree = cKDTree(points) if tree is None else tree
    # Queried in the tree's leaf order, neighbouring queries walk the same nodes: on an unordered file of 1M
    # points this takes 0.4 of the CPU time of querying in file order, with the same answer.
    order = tree.indices if tree.n == len(points) else np.arange(len(points))
    dist, idx = tree.query(points[order], k=k, workers=-1)
    distances, indices = np.empty((len(points), k)), np.empty((len(points), k), dtype=np.int64)
    distances[order], indices[order] = dist.reshape(len(points), k), idx.reshape(len(points), k)
    return distances, indices


def leaf_knn(tree: cKDTree, k: int) -> tuple[np.ndarray, np.ndarray]:
    """knn of every point of `tree` with rows and neighbour ids both in the tree's leaf order (`tree.indices`:
    row j is point tree.indices[j]), where neighbouring rows and their neighbours lie near in memory."""
    k = min(k, tree.n)
    distances, indices = tree.query(tree.data[tree.indices], k=k, workers=-1)
    leaf = np.empty(tree.n, dtype=np.int64)
    leaf[tree.indices] = np.arange(tree.n)
    return distances.reshape(tree.n, k), leaf[indices.reshape(tree.n, k)]


def stray_pieces(distance: np.ndarray, index: np.ndarray, spacing: np.ndarray, keep: np.ndarray, piece_gap: float,
                 min_piece_share: float) -> np.ndarray:
    """(n,) which of the `keep` points lie in pieces holding less than `min_piece_share` of them, the pieces being
    those points joined by chains of nearest-neighbour steps of at most `piece_gap` times their median spacing:
    skelcore.clean's stray rule. distance, index: (n, k) each point's nearest neighbours, itself first; spacing:
    (n,) each point's mean distance to the others, which the caller has already."""
    piece = joined_pieces(distance, index, keep, piece_gap * np.median(spacing[keep]))
    sizes = np.bincount(piece[keep], minlength=piece.max() + 1)
    return keep & (sizes[piece] < min_piece_share * keep.sum())


def joined_pieces(distance: np.ndarray, index: np.ndarray, members: np.ndarray, gap: float) -> np.ndarray:
    """(n,) the piece of each point: `members` joined by chains of nearest-neighbour steps of at most `gap`
    (distance, index: (n, k) each point's nearest neighbours, itself first); every other point a piece alone."""
    n = len(distance)
    near = (distance[:, 1:] <= gap) & members[index[:, 1:]] & members[:, None]
    # built as CSR, row by row as the kNN gives them: a COO graph's conversion sorts every edge (3x slower);
    # float64 weights and 32-bit ids are what connected_components works on, so it copies nothing first
    ids = np.int32 if n < np.iinfo(np.int32).max else np.int64
    indptr = np.concatenate([[0], np.cumsum(near.sum(axis=1))]).astype(ids)
    graph = csr_matrix((np.ones(indptr[-1]), index[:, 1:][near].astype(ids), indptr), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def pca_frames(points: np.ndarray, neighbours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors (columns) of each neighbourhood's covariance."""
    values, vectors, _ = local_frames(points[neighbours])
    return values, vectors


def local_frames(local: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """pca_frames of neighbourhoods already gathered, `local` (n, k, 3), and their means (n, 1, 3): callers that
    need the coordinates or the means too gather them once. weights: (n, k) weights of the points (None: equal)."""
    if weights is None:
        mean = local.mean(axis=1, keepdims=True)
        centred = local - mean
        covariance = np.matmul(centred.transpose(0, 2, 1), centred) / local.shape[1]
    else:
        share = (weights / weights.sum(axis=1, keepdims=True))[..., None]
        mean = (share * local).sum(axis=1, keepdims=True)
        centred = local - mean
        covariance = np.matmul((share * centred).transpose(0, 2, 1), centred)
    values, vectors = np.linalg.eigh(covariance)
    return values, vectors, mean


# Most fans lie among the nearest neighbours; a check finds the rows that need all k. 16 scans fewer columns
# in all than 12 (which leaves 45% of the rows of a noisy torus to rescan, 16 a fifth) or 20.
NEAREST_FIRST = 16


CHUNK = 16_384  # points per block: the (block, k, 3) temporaries stay small and cache-friendly
# Two neighbours' directions from the centre this close are one ray (behind_nearer): rounding leaves equal angles
# about 1e-15 apart, and a fan triangle this thin has cotangents of 1e9, far past the Laplacian's COT_LIMIT.
RAY_TIE = 1e-9


def one_rings(points: np.ndarray, k: int, drop_jumps: bool = False) -> OneRings:
    """The Delaunay fan of every point among its k nearest neighbours (itself included in k). `drop_jumps`:
    without the edges that cross empty space, and the fan triangles they bound (skelcore.ring_jumps)."""
    n = len(points)
    tree = cKDTree(points)
    distances, idx = knn(points, k, tree)
    rings, triangles, normals = [], [], []
    for start in range(0, n, CHUNK):
        block = idx[start:start + CHUNK]
        local = points[block]
        _, frames, _ = local_frames(local)
        normals.append(frames[:, :, 0])
        neighbours = block[:, 1:]  # nearest first
        # Coordinates in the plane of the two largest principal components.
        planar = np.matmul(local[:, 1:] - local[:, :1], frames[:, :, [2, 1]])
        ring_row, ring_slot, centre, j_slot, l_slot = _fans_nearest_first(planar)
        rings.append((ring_row + start, neighbours[ring_row, ring_slot]))
        triangles.append(np.column_stack([centre + start, neighbours[centre, j_slot], neighbours[centre, l_slot]]))
    ring_rows, ring_ids = np.concatenate([rows for rows, _ in rings]), np.concatenate([ids for _, ids in rings])
    triangles = np.concatenate(triangles)
    if drop_jumps:
        keep_entry, keep_triangle = jump_masks(points, ring_rows, ring_ids, triangles, np.concatenate(normals),
                                               sampling_reach(distances, idx), tree)
        ring_rows, ring_ids, triangles = ring_rows[keep_entry], ring_ids[keep_entry], triangles[keep_triangle]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(ring_rows, minlength=n))])
    return OneRings(indptr=indptr, indices=ring_ids, triangles=triangles)


def _fans_nearest_first(planar: np.ndarray):
    """delaunay_fans of rows sorted nearest first, scanning only the nearest few where that is exact.

    Inversion puts every farther neighbour inside the disc of radius 1/d, d the smallest planar distance of
    those left out; where the closed hull of the inverted nearest ones encloses that disc, the farther ones lie
    inside it and cannot be Delaunay neighbours. The other rows are scanned in full.
    """
    count, width = planar.shape[:2]
    near = min(NEAREST_FIRST, width)
    fans = delaunay_fans(planar[:, :near])
    if near == width:
        return fans
    ring_row, _, tri_row, j_slot, l_slot = fans
    inverted = planar / np.maximum((planar**2).sum(axis=-1), 1e-300)[..., None]
    a, b = inverted[tri_row, j_slot], inverted[tri_row, l_slot]
    edge_reach = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / np.maximum(np.linalg.norm(a - b, axis=1), 1e-300)
    reach = np.full(count, np.inf)
    np.minimum.at(reach, tri_row, edge_reach)
    closed = np.bincount(tri_row, minlength=count) == np.bincount(ring_row, minlength=count)
    excluded = np.linalg.norm(inverted[:, near:], axis=-1).max(axis=1)  # projection can reorder distances
    redo = np.flatnonzero(~(closed & (reach > excluded)))
    if len(redo) == 0:
        return fans
    full = delaunay_fans(planar[redo])
    kept = np.ones(count, bool)
    kept[redo] = False  # a mask: np.isin took 30 times as long on 100k points' rings
    keep_ring, keep_tri = kept[ring_row], kept[tri_row]
    ring_rows = np.concatenate([ring_row[keep_ring], redo[full[0]]])
    tri_rows = np.concatenate([tri_row[keep_tri], redo[full[2]]])
    ring_order, tri_order = np.argsort(ring_rows, kind="stable"), np.argsort(tri_rows, kind="stable")
    return (ring_rows[ring_order], np.concatenate([fans[1][keep_ring], full[1]])[ring_order],
            tri_rows[tri_order], np.concatenate([j_slot[keep_tri], full[3]])[tri_order],
            np.concatenate([l_slot[keep_tri], full[4]])[tri_order])


def delaunay_fans(planar: np.ndarray, valid: np.ndarray | None = None):
    """Delaunay fan of the origin among each row's valid 2-D points (planar (rows, w, 2)), by inversion and
    a convex chain (module docstring). Rows may differ in length: the empty slots, and points behind a nearer one
    on its ray (behind_nearer), repeat the row's nearest point, always a vertex of the inverted hull, so they only
    add repeated ring entries and degenerate triangles, both dropped. Returns (row, slot) of the ring entries in
    fan order and (row, slot_j, slot_l) of the triangles."""
    count, width = planar.shape[:2]
    valid = np.ones((count, width), dtype=bool) if valid is None else valid
    rows = np.arange(count)
    radius2 = np.maximum((planar**2).sum(axis=-1), 1e-300)
    angle = np.arctan2(planar[..., 1], planar[..., 0])
    valid = valid & ~behind_nearer(angle, radius2, valid)
    nearest = np.argmin(np.where(valid, radius2, np.inf), axis=1)
    slot = np.where(valid, np.arange(width), nearest[:, None])
    planar, radius2, angle = (values[rows[:, None], slot] for values in (planar, radius2, angle))
    order = np.argsort(angle, axis=1, kind="stable")
    angle, slot = np.take_along_axis(angle, order, axis=1), np.take_along_axis(slot, order, axis=1)
    inverted = np.take_along_axis(planar / radius2[..., None], order[..., None], axis=1)
    gaps = np.diff(angle, axis=1, append=angle[:, :1] + 2 * np.pi)
    widest = np.argmax(gaps, axis=1)
    is_open = gaps[rows, widest] >= np.pi - RAY_TIE  # a centre on a straight edge (a lattice's) has an open fan
    start = np.where(is_open, widest + 1, np.argmin(np.take_along_axis(radius2, order, axis=1), axis=1))
    sequence = np.mod(start[:, None] + np.arange(width + 1), width)
    sequence[is_open] = np.concatenate([np.full((is_open.sum(), 1), width), sequence[is_open, :width]], axis=1)
    hull, size = _graham_scan(np.concatenate([inverted, np.zeros((count, 1, 2))], axis=1), sequence)

    # Drop the closing repeat (closed) or the centre (open); consecutive slots are triangles.
    first, length = np.where(is_open, 1, 0), size - 1
    steps = np.arange(width + 1)
    in_ring = (steps >= first[:, None]) & (steps < (first + length)[:, None])
    ring_row = np.repeat(rows, length)
    in_pairs = (steps[:-1] >= first[:, None]) & (steps[:-1] < (first + length - is_open)[:, None])
    tri_row = np.repeat(rows, length - is_open)
    tri_j, tri_l = slot[tri_row, hull[:, :-1][in_pairs]], slot[tri_row, hull[:, 1:][in_pairs]]
    proper = tri_j != tri_l
    ring_slot = slot[ring_row, hull[in_ring]]
    # the repeats of the nearest point lie together in the fan order (they share its angle)
    single = np.ones(len(ring_row), dtype=bool)
    single[1:] = (ring_slot[1:] != ring_slot[:-1]) | (ring_row[1:] != ring_row[:-1])
    return ring_row[single], ring_slot[single], tri_row[proper], tri_j[proper], tri_l[proper]


def behind_nearer(angle: np.ndarray, radius2: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(rows, w) which valid points lie on the ray from the centre through a nearer valid point of their row (their
    angles within RAY_TIE): the segment from the centre to such a point is a chord of every circle through both,
    so the nearer point lies inside each and the farther one is no Delaunay neighbour. Sampled on a grid (a depth
    camera's layers, a regular mesh's vertices) whole rows of neighbours tie; left in, they invert onto one ray,
    the convex chain keeps them as collinear, and their flat fan triangles take cotangents of COT_LIMIT."""
    count, width = angle.shape
    angle = np.where(angle > np.pi - RAY_TIE, angle - 2 * np.pi, angle)  # a ray along -x sorts as one at -pi
    order = np.argsort(np.where(valid, angle, np.inf), axis=1, kind="stable")
    angle, radius2, present = (np.take_along_axis(values, order, axis=1) for values in (angle, radius2, valid))
    starts = np.ones((count, width), dtype=bool)  # the first of each ray in angular order
    starts[:, 1:] = ~(present[:, 1:] & (np.diff(angle, axis=1) <= RAY_TIE))
    nearest = np.minimum.reduceat(radius2.ravel(), np.flatnonzero(starts.ravel()))
    ray = np.cumsum(starts.ravel()).reshape(count, width) - 1
    hidden = np.zeros((count, width), dtype=bool)
    np.put_along_axis(hidden, order, present & (radius2 > nearest[ray]), axis=1)
    return hidden


def _graham_scan(plane: np.ndarray, sequence: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Convex chain of each row's star-shaped sequence, all rows at once: a stack per row.

    plane (n, w, 2) holds each row's points; sequence (n, s) the slots in scan order. Returns the stack
    of slots (n, s) and its size per row. Flat 1-D indexing keeps the per-column work cheap; collinear
    points stay (they are cocircular in the original plane, a Delaunay tie kept as an edge).
    """
    n, steps = sequence.shape
    width = plane.shape[1]
    px, py = plane[..., 0].ravel(), plane[..., 1].ravel()
    rows = np.arange(n)
    flat = sequence + (rows * width)[:, None]
    base = rows * steps
    stack = np.zeros(n * steps, dtype=np.int64)
    stack[base], stack[base + 1] = flat[:, 0], flat[:, 1]
    size = np.full(n, 2)
    for column in range(2, steps):
        incoming = flat[:, column]
        qx, qy = px[incoming], py[incoming]
        pending = rows
        while len(pending):
            top = base[pending] + size[pending] - 1
            b, a = stack[top], stack[top - 1]
            ux, uy = px[b] - px[a], py[b] - py[a]
            vx, vy = qx[pending] - px[b], qy[pending] - py[b]
            right_turn = ux * vy - uy * vx < -1e-12 * (ux * ux + uy * uy + vx * vx + vy * vy)
            pending = pending[(size[pending] >= 2) & right_turn]
            size[pending] -= 1
        stack[base + size] = incoming
        size += 1
    return stack.reshape(n, steps) - (rows * width)[:, None], size


def plane_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane normal to each unit normal (both zero where a normal is zero)."""
    axis = np.eye(3)[np.argmin(np.abs(normals), axis=1)]
    first = np.cross(normals, axis)
    first /= np.maximum(np.linalg.norm(first, axis=1, keepdims=True), 1e-300)
    return first, np.cross(normals, first)


def widest_gap(offsets: np.ndarray, first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(angle, direction): the widest angle around each point that its neighbours' `offsets` (n, k, 3) leave empty
    in the plane of the unit axes `first` and `second` (n, 3), and the unit direction through its middle (off a
    surface's edge, where the angle is wide)."""
    angles = np.sort(np.arctan2(np.einsum("ikj,ij->ik", offsets, second),
                                np.einsum("ikj,ij->ik", offsets, first)), axis=1)
    gaps = np.diff(np.concatenate([angles, angles[:, :1] + 2 * np.pi], axis=1), axis=1)
    widest = gaps.argmax(axis=1)
    rows = np.arange(len(offsets))
    angle = gaps[rows, widest]
    middle = angles[rows, widest] + angle / 2
    return angle, np.cos(middle)[:, None] * first + np.sin(middle)[:, None] * second
