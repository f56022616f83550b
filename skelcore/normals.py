"""Per-point PCA features of a cloud: normals (eq. 6 of the seed paper) and curvature (eq. 7), their
closed-form 3x3 eigen-solutions, and a consistent orientation of normals along a minimum spanning tree.

The normal of a point is the eigenvector of the smallest eigenvalue of the covariance of its k nearest
neighbours; the curvature kappa = lambda_1 / (lambda_1 + lambda_2 + lambda_3), lambda_1 the smallest. The
covariance is taken about the neighbours' mean, or (eq. 6 as written) about the point itself.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree

from .neighbours import knn
from .normalise import pieces_apart

COLLAPSED = 1e-6  # a neighbourhood smaller than this fraction of the object's diagonal has no frame
_ORIENT_NEIGHBOURS = 10  # Riemannian graph of the MST orientation
_TANGENT = 0.5  # an orientation edge must run along both surfaces: |n . edge direction| below this


def pca_features(points: np.ndarray, k: int, collapsed: float = 0.0, anchored: bool = False,
                 neighbours: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals (eq. 6, sign as the solver gives it), curvature (eq. 7) and kNN indices of every point,
    its neighbours taken among `points`.

    anchored: the covariance is taken about each point itself (eq. 6 as written) instead of about the mean
    of its neighbours. Neighbourhoods whose covariance trace is <= collapsed**2 get NaN normal and curvature.
    neighbours: those kNN indices (one row per point, k columns), when the caller has queried them.
    """
    k = min(k, len(points))
    idx = neighbours if neighbours is not None else knn(points, k)[1]
    anchors = points if anchored else None
    covariance = _covariances(points, idx, anchors)
    smallest, _, trace = _eigenvalues(*covariance)
    normals = _eigenvector(*covariance, smallest)
    kappa = np.clip(smallest / np.where(trace > 0, trace, 1.0), 0.0, 1.0 / 3.0)  # eq. 7
    undefined = trace <= collapsed ** 2
    normals[undefined] = np.nan
    kappa[undefined] = np.nan
    return normals, kappa, idx


def _covariances(points: np.ndarray, idx: np.ndarray, anchors: np.ndarray | None = None):
    """The six entries xx, xy, xz, yy, yz, zz of each neighbourhood's covariance, about its mean or, given
    `anchors` (one point per row of idx), about that point."""
    m, k = idx.shape
    # Neighbourhood means of x and x x^T at once: one sparse averaging operator, 9 columns.
    origin = points.mean(axis=0)
    x, y, z = (points - origin).T
    columns = np.column_stack([x, y, z, x * x, x * y, x * z, y * y, y * z, z * z])
    average = sp.csr_matrix((np.full(m * k, 1.0 / k), idx.ravel(), np.arange(0, m * k + 1, k)),
                            shape=(m, len(points)))
    moments = average @ columns
    mean = moments[:, :3]
    pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    entries = [moments[:, 3 + j] - mean[:, a] * mean[:, b] for j, (a, b) in enumerate(pairs)]
    if anchors is not None:
        # About c instead of the mean: C_c = C + (mean - c)(mean - c)^T (eq. 6).
        offset = mean - (anchors - origin)
        entries = [entry + offset[:, a] * offset[:, b] for entry, (a, b) in zip(entries, pairs)]
    return entries


def _eigenvalues(xx, xy, xz, yy, yz, zz):
    """Smallest and largest eigenvalues and trace of symmetric 3x3 matrices, closed form (trigonometric
    solution of the cubic)."""
    q = (xx + yy + zz) / 3.0
    off = xy * xy + xz * xz + yz * yz
    p = np.sqrt(np.maximum(((xx - q) ** 2 + (yy - q) ** 2 + (zz - q) ** 2 + 2.0 * off) / 6.0, 0.0))
    s = np.where(p > 0, p, 1.0)
    a, b, c, d, e, f = (xx - q) / s, xy / s, xz / s, (yy - q) / s, yz / s, (zz - q) / s
    half_det = (a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c)) / 2.0
    phi = np.arccos(np.clip(half_det, -1.0, 1.0)) / 3.0
    return q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0), q + 2.0 * p * np.cos(phi), 3.0 * q


def _eigenvector(xx, xy, xz, yy, yz, zz, eigenvalue):
    """Unit eigenvector for `eigenvalue`: the largest cross product of two rows of (C - lambda I)."""
    rows = np.stack([np.column_stack([xx - eigenvalue, xy, xz]),
                     np.column_stack([xy, yy - eigenvalue, yz]),
                     np.column_stack([xz, yz, zz - eigenvalue])], axis=1)
    crosses = np.stack([np.cross(rows[:, 0], rows[:, 1]), np.cross(rows[:, 0], rows[:, 2]),
                        np.cross(rows[:, 1], rows[:, 2])], axis=1)
    sizes = np.einsum("nij,nij->ni", crosses, crosses)
    best = np.argmax(sizes, axis=1)
    vectors = crosses[np.arange(len(best)), best]
    scale = np.einsum("nij,nij->n", rows, rows)
    # A double smallest eigenvalue (line-like neighbourhood) leaves a plane of normals: take one across
    # the dominant row, which spans the line.
    flat = sizes[np.arange(len(best)), best] <= 1e-16 * scale ** 2
    if flat.any():
        row_sizes = np.einsum("nij,nij->ni", rows[flat], rows[flat])
        dominant = rows[flat][np.arange(flat.sum()), np.argmax(row_sizes, axis=1)]
        helper = np.eye(3)[np.argmin(np.abs(dominant), axis=1)]
        across = np.cross(dominant, helper)
        # Isotropic neighbourhood (C = lambda I): every direction is a normal.
        across[np.einsum("ij,ij->i", across, across) == 0] = (0.0, 0.0, 1.0)
        vectors[flat] = across
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def tangent_edges(points: np.ndarray, normals: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols): the edges from each point to its first _ORIENT_NEIGHBOURS neighbours in `idx` (column 0 the
    point itself) that run along the tangent planes of both ends, so do not cross the surface (across a thin tube
    or plate, where the two sides face opposite ways). normals: without NaN."""
    cols = idx[:, 1:_ORIENT_NEIGHBOURS + 1].ravel()
    rows = np.repeat(np.arange(len(points)), idx[:, 1:_ORIENT_NEIGHBOURS + 1].shape[1])
    direction = points[cols] - points[rows]
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    along = ((np.abs(np.einsum("ij,ij->i", normals[rows], direction)) < _TANGENT)
             & (np.abs(np.einsum("ij,ij->i", normals[cols], direction)) < _TANGENT))
    return rows[along], cols[along]


def orient_outward(points: np.ndarray, normals: np.ndarray, idx: np.ndarray,
                   edges: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Flip normals consistently along a minimum spanning tree of the kNN graph (weight 2 - |n_i.n_j|), then
    turn each connected part outward as a whole: by the divergence theorem the flux of x - c through a closed
    surface with outward normals is three times its volume whatever the point c, so the sum of n_i.(p_i - c)
    over a part must be positive; c is the cloud's centroid, which turns an open patch away from the object's
    centre, or for a piece far from the rest (skelcore.normalise.pieces_apart) the piece's own: the sum carries c
    times the sum of the piece's normals, which sampling leaves a little off zero, and with c thirty piece sizes
    away that term outweighed a thin torus's volume and turned both of two tori inward. (One point's sign, such
    as the farthest point's, fails where its PCA normal is ill-defined: a tip, or noise; with 1% noise it turned
    whole clouds inward.) Edges that cross the surface (across a thin tube or plate, where the two sides face
    opposite ways) are left out: an edge must run along the tangent planes of both its ends (tangent_edges)."""
    n = len(points)
    usable = np.nan_to_num(normals)
    rows, cols = tangent_edges(points, usable, idx) if edges is None else edges
    weights = 2.0 - np.abs(np.einsum("ij,ij->i", usable[rows], usable[cols]))
    graph = sp.csr_matrix((weights, (rows, cols)), shape=(n, n))
    # Weights and the tangent test are symmetric, so the upper triangle of the symmetrised graph holds every
    # edge once: Kruskal (stable in entry order) keeps the same edges as on both triangles, in 0.6 of the time.
    tree = minimum_spanning_tree(sp.triu(graph.maximum(graph.T), format="csr"))
    parts, labels = connected_components(tree, directed=False)
    apart = pieces_apart(points)
    if apart is None:
        offsets = points - points.mean(axis=0)
    else:
        centres = np.stack([np.bincount(apart, column) for column in points.T], axis=1) / np.bincount(apart)[:, None]
        offsets = points - centres[apart]
    roots = np.unique(labels, return_index=True)[1]  # any point of a part: the flux sets the part's sign
    # A virtual node n joined to every part's root makes the forest one tree: one BFS gives all parents.
    root = n
    tree = sp.bmat([[tree + tree.T, None], [None, sp.csr_matrix((1, 1))]], format="csr")
    tree = tree + sp.csr_matrix((np.ones(parts), (np.full(parts, root), roots)), shape=(n + 1, n + 1))
    _, parent = breadth_first_order(tree, root, directed=False, return_predecessors=True)
    parent[root] = root
    relative = np.ones(n + 1)
    relative[:n] = np.where(np.einsum("ij,ij->i", usable, usable[np.minimum(parent[:n], n - 1)]) < 0, -1.0, 1.0)
    relative[roots] = 1.0
    # Pointer jumping: the sign of a point is the product of relative flips along its path to the root.
    ancestor = parent.copy()
    while (ancestor != root).any():
        relative = relative * relative[ancestor]
        ancestor = ancestor[ancestor]
    flux = np.bincount(labels, relative[:n] * np.einsum("ij,ij->i", usable, offsets), minlength=parts)
    return normals * (relative[:n] * np.where(flux < 0, -1.0, 1.0)[labels])[:, None]


def away_from_centroid(points: np.ndarray, normals: np.ndarray, centroid: np.ndarray | None = None) -> np.ndarray:
    """Normals flipped to point away from the cloud's centroid (the "outward" convention)."""
    centroid = points.mean(axis=0) if centroid is None else centroid
    return np.where((np.einsum("ij,ij->i", normals, points - centroid) < 0)[:, None], -normals, normals)
