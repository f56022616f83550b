"""Scan-like variants of a clean cloud for the quality benchmark: each a pure function of (points, seed).

Every variant keeps the truth of the shape it perturbs (cycles and components of its curve skeleton):
noise and outliers are small or sparse, the thinned half still covers its surface, the partial scan is
taken from a view that leaves every piece of the shape in one piece (see `partial_scan`), and the two scans'
sheets and the layers lie a fraction of the skeleton's sample radius apart (0.4% and 0.5% of the diagonal
against 2%). The scan lines (`scan_lines`, a function of the shape's mesh) lie 1.5% of the diagonal apart, under
the skeleton's sample radius too.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .errors import ParameterError

VARIANTS = ("clean", "noise_0.5", "noise_1", "outliers_2", "density_30", "partial")
# Run only when named: two registered scans of the object slightly misaligned; a depth sensor's layered values
MORE_VARIANTS = ("two_scans", "layered")

NOISE = {"noise_0.5": 0.005, "noise_1": 0.01}  # std of Gaussian noise per coordinate, share of the bbox diagonal
OUTLIER_SHARE = 0.02  # uniform points added in the bounding box, share of the cloud's size
DENSITY_KEPT = 0.3  # share of the points kept on the thinned half
NORMAL_K = 15  # neighbours of a PCA normal when the caller has no normals
# Points of a partial scan belong to one patch when they join within this many median neighbour spacings of
# the input (a gap of a few samples still reads as one surface).
LINK_SPACINGS = 3.0
ISLAND_SHARE = 0.02  # largest share of the visible points a view may lose as islands
# A neighbourhood this linear is a curve at the sampling's scale (a surface patch stays below about 0.7).
LINEAR = 0.8
# A registration error: half the points (a second scan) turned this many radians about the principal axis through
# the centre and moved this share of the diagonal across it, as two scans' alignment commonly leaves them
MISREGISTRATION = (0.01, 0.004)
LAYER_STEP = 0.005  # coordinates rounded to multiples of this share of the diagonal (a depth camera's layers)
# A profile scanner's lines: the mesh cut by parallel planes this share of the diagonal apart, a point every this
# share along each cut (lines five times farther apart than the points on them)
SCAN_LINES = "scan_lines"
SCAN_LINE_GAP, SCAN_LINE_STEP = 0.015, 0.003


def perturb(points: np.ndarray, variant: str, seed: int = 0, normals: np.ndarray | None = None,
            loops: bool = False) -> np.ndarray:
    """The `variant` (one of VARIANTS or MORE_VARIANTS) of a clean cloud; the same inputs give the same points.

    normals: outward unit normals at the points (from the mesh), used by 'partial'; without them PCA normals
    are estimated and oriented outward. loops: the shape has loops, so the partial view keeps every patch it
    sees (see `partial_scan`).
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 20:
        raise ParameterError(f"perturb: expected at least 20 points as an (n,3) array, got shape {points.shape}")
    named = (*VARIANTS, *MORE_VARIANTS)
    if variant not in named:
        raise ParameterError(f"perturb: unknown variant {variant!r} (choose from {', '.join(named)})")
    # A stream of the variant's own: a sampler drawing from default_rng(seed) too would have placed the points
    # by the very draws that thin or move them (the capsule's thinned half lost its cap and a band, 2 pieces).
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(named.index(variant),)))
    if variant == "clean":
        return points.copy()
    if variant in NOISE:
        return points + rng.normal(0.0, NOISE[variant] * _diagonal(points), points.shape)
    if variant == "outliers_2":
        low, high = points.min(axis=0), points.max(axis=0)
        return np.vstack([points, rng.uniform(low, high, (round(OUTLIER_SHARE * len(points)), 3))])
    if variant == "density_30":
        return thin_half(points, DENSITY_KEPT, rng)
    if variant == "two_scans":
        return misregistered_half(points, rng)
    if variant == "layered":
        step = LAYER_STEP * _diagonal(points)
        return np.round(points / step) * step
    return points[partial_scan(points, normals, 0.0 if loops else ISLAND_SHARE)[0]]  # "partial"


def scan_lines(vertices: np.ndarray, faces: np.ndarray, seed: int = 0) -> np.ndarray:
    """The surface of a mesh as a profile scanner samples it: cut by parallel planes SCAN_LINE_GAP of its diagonal
    apart, across a direction drawn from `seed`, a point every SCAN_LINE_STEP along each cut."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    diagonal = float(np.linalg.norm(mesh.extents))
    direction = scan_direction(seed)
    height = mesh.vertices @ direction
    gap = SCAN_LINE_GAP * diagonal
    heights = np.arange(gap / 2, np.ptp(height), gap)
    lines = []
    for section in mesh.section_multiplane(direction * height.min(), direction, heights):
        for polyline in [] if section is None else section.to_3D().discrete:
            along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(polyline, axis=0), axis=1))])
            at = np.arange(0.0, along[-1], SCAN_LINE_STEP * diagonal)
            lines.append(np.column_stack([np.interp(at, along, polyline[:, axis]) for axis in range(3)]))
    return np.unique(np.vstack(lines), axis=0)


def scan_direction(seed: int = 0) -> np.ndarray:
    """The unit normal of the planes `scan_lines` cuts along, drawn from `seed` (a stream of its own)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(len(VARIANTS) + len(MORE_VARIANTS),)))
    direction = rng.normal(size=3)
    return direction / np.linalg.norm(direction)


def thin_half(points: np.ndarray, kept: float, rng: np.random.Generator) -> np.ndarray:
    """Keep a random share `kept` of the points on the far half along the principal axis (split at the
    median), all points on the near half: one cloud with two densities."""
    axis = _principal_axes(points)[:, 0]
    along = (points - points.mean(axis=0)) @ axis
    thinned = along > np.median(along)
    keep = ~thinned | (rng.random(len(points)) < kept)
    return points[keep]


def misregistered_half(points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random half of the points as a second scan registered slightly wrong (MISREGISTRATION): turned about
    the principal axis through the centre and moved across it, so every surface is two sheets a fraction of a
    percent apart."""
    angle, shift = MISREGISTRATION
    axes = _principal_axes(points)
    centre = points.mean(axis=0)
    second = rng.random(len(points)) < 0.5
    local = (points[second] - centre) @ axes  # the principal frame: the turn is about its first axis
    cos, sin = np.cos(angle), np.sin(angle)
    local[:, 1], local[:, 2] = cos * local[:, 1] - sin * local[:, 2], sin * local[:, 1] + cos * local[:, 2]
    moved = points.copy()
    moved[second] = centre + local @ axes.T + shift * _diagonal(points) * axes[:, 1]
    return moved


def partial_scan(points: np.ndarray, normals: np.ndarray | None = None,
                 island_share: float = ISLAND_SHARE) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the points one orthographic view sees, and the unit direction towards the viewer: those
    whose outward normal has a positive component towards the viewer (back faces dropped, as a scanner sees
    one side), and of those, per piece of the input, only the largest connected patch (a scan keeps its main
    surface; islands a view cuts off, such as a far ear or the rim of a thin part, go as a scan's clean-up
    would remove them). So each piece of the input stays one piece, and its loops stay loops as long as the
    view does not cut the piece apart.

    The view: the first of a fixed list of directions in the cloud's principal frame whose islands hold at
    most `island_share` of the visible points, else the one that loses the fewest. On a shape with loops pass
    0: there an island can be the whole visible arc of a handle whose feet face away, and dropping it would
    take a loop from the truth. The list starts along the
    thinnest principal axis (the view that shows the most surface) tilted by about 30 and 15 degrees
    towards the other two: a ring lying exactly edge-on to the view would be cut into two arcs.

    Without normals, PCA normals are estimated, and points whose neighbourhood is a line (a twig thinner
    than the sampling, linearity above LINEAR) count as seen from every side: they have no back face.
    """
    always = np.zeros(len(points), dtype=bool)
    if normals is None:
        normals = estimate_normals(points)
        always = linearity(points) > LINEAR
    normals = np.asarray(normals, dtype=np.float64)
    if normals.shape != points.shape:
        raise ParameterError(f"perturb: normals of shape {normals.shape} do not match points {points.shape}")
    axes = _principal_axes(points)
    radius = LINK_SPACINGS * np.median(cKDTree(points).query(points, k=2)[0][:, 1])
    piece_of = _labels(points, radius)
    best, best_lost = None, np.inf
    for weights in _VIEWS:
        direction = axes @ (np.asarray(weights) / np.linalg.norm(weights))
        seen = np.flatnonzero((normals @ direction > 0) | always)
        if len(seen) == 0:
            continue
        kept = seen[_largest_patches(points[seen], piece_of[seen], radius)]
        lost = 1.0 - len(kept) / len(seen)
        if lost <= island_share:
            return kept, direction
        if lost < best_lost:
            best, best_lost = (kept, direction), lost
    return best


# Directions as weights of the principal axes (largest, middle, thinnest), in order of preference.
_VIEWS = [(0.25, 0.5, 1.0), (0.5, 1.0, 0.25), (1.0, 0.25, 0.5), (-0.25, -0.5, -1.0), (1.0, 1.0, 1.0),
          (-1.0, 1.0, 1.0), (1.0, -1.0, 1.0), (1.0, 1.0, -1.0)]


def _largest_patches(points: np.ndarray, piece_of: np.ndarray, radius: float) -> np.ndarray:
    """Mask of the points in the largest connected patch of each piece (patches lie inside one piece)."""
    patch = _labels(points, radius)
    sizes = np.bincount(patch)
    first = np.unique(patch, return_index=True)[1]
    patch_piece = piece_of[first]
    order = np.lexsort((-sizes, patch_piece))  # by piece, largest patch first
    winners = order[np.r_[True, np.diff(patch_piece[order]) != 0]]
    return np.isin(patch, winners)


def estimate_normals(points: np.ndarray, k: int = NORMAL_K) -> np.ndarray:
    """PCA normals oriented consistently and outward (the paper's eq. 6 normals and skelcore's orientation)."""
    from .normals import orient_outward, pca_features

    normals, _, idx = pca_features(points, k=k)
    return orient_outward(points, normals, idx)


def linearity(points: np.ndarray, k: int = NORMAL_K) -> np.ndarray:
    """(l1 - l2) / l1 of each point's k-neighbourhood covariance (eigenvalues l1 >= l2 >= l3): 1 on a line."""
    _, idx = cKDTree(points).query(points, k=min(k, len(points)))
    neighbourhoods = points[idx] - points[idx].mean(axis=1, keepdims=True)
    eigenvalues = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", neighbourhoods, neighbourhoods))
    return (eigenvalues[:, 2] - eigenvalues[:, 1]) / np.maximum(eigenvalues[:, 2], 1e-300)


def _labels(points: np.ndarray, radius: float) -> np.ndarray:
    """Connected piece of every point, points joined within `radius`."""
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    return connected_components(graph, directed=False)[1]


def _principal_axes(points: np.ndarray) -> np.ndarray:
    """Columns: unit principal axes, largest spread first."""
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred[:: max(1, len(points) // 20_000)], full_matrices=False)
    return vt.T


def _diagonal(points: np.ndarray) -> float:
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
