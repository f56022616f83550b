"""Stability metrics of a contraction: D_theta, delta_kappa, their histograms, boundedness, verdict.

Per point and iteration (seed paper): the PCA normal n (eq. 6, eigenvector of the smallest eigenvalue of
the covariance of the k nearest neighbours in the CURRENT cloud), the curvature
kappa = lambda_1 / (lambda_1 + lambda_2 + lambda_3), lambda_1 the smallest (eq. 7),
D_theta = arccos(cos_sim(n_k, n_0)) / pi (eqs. 3-5) and delta_kappa = kappa_k - kappa_0 (eq. 8).

k defaults to 30: the largest neighbourhood the contraction itself uses (cloudcontr's k=30, our
clamp(0.012 n, 8, 30)) and the usual kNN size for PCA normals (Open3D's examples); fewer neighbours make
the normal of a contracted, nearly one-dimensional neighbourhood follow the sampling noise.

Normal conventions (`NORMAL_CONVENTIONS`). The eigen-solver returns +n or -n at random, yet eq. 5 uses the
signed cosine, so how the signs are chosen decides what the D_theta histogram shows.
- "outward" (the paper's reading, the default): eq. 6 centred on the anchor point (the covariance of the
  neighbours about the point itself, not about their mean), and every normal, at iteration 0 and at k,
  oriented away from its cloud's centroid. D_theta moves from left-skewed toward a bell centred on 0.5 as
  the paper describes (in `skelcore study`, 15 of 25 default runs end within 0.1 of 0.5 with one peak).
- "tracked": mean-centred covariance and each normal's sign carried over from the previous iteration
  (n_k . n_{k-1} >= 0): D_theta is the total turn of a continuous normal field, 0 for an unchanged cloud;
  its mean ends at 0.20-0.44 (1 of 25 default runs near 0.5).
The study (375 runs, README "The stability verdict") found D_theta's statistics predicting a right skeleton
about equally under both (best ROC AUC 0.69 [0.64, 0.75] outward, 0.67 [0.62, 0.72] tracked) and the
calibrated verdicts identical on held-out shapes, so the default is the one that shows the paper's
behaviour. Reference normals for the boundedness test are always MST-oriented (Hoppe et al. 1992).
A neighbourhood that has collapsed to a point has no normal or curvature: its values are NaN, left out
of the statistics (counted in "n_undefined"); a tracked normal carries the previous one forward.

Curve-likeness: the share of the cloud that is curve-like at the skeleton's scale
(skelcore.curveness.skeleton_scale_share, radius a fraction of the input's diagonal), the same figure the
contraction's stop rule and the inspector's status read.

Points that disappear (GLSkeleton): the caller passes `point_ids`, ids into the input cloud of the
points present, and every quantity compares them with iteration 0 at those ids.

Boundedness (X_{k+1} <= X_k << X_o): the share of points inside the original shape, judged by the
side of the nearest reference surface sample's outward normal, within a band of `surface_tolerance`
times the original bounding-box diagonal (points on the surface count as inside); see InsideTest for
how deep points are decided cheaply. A point cloud is its own sample with MST-oriented PCA normals of
10 neighbours (orientation edges that cross a thin part are left out); a
mesh is sampled densely with its face normals after trimesh's winding repair. Away from the band this
agrees with the winding number of a closed mesh: the nearest sample lies within half a sample spacing
of the nearest surface point, whose normal gives the exact side. The size X of a cloud is its RMS
distance to its centroid (it follows the collapse of every cross-section; a bounding box only sees the
extreme tips and stays put while a tube collapses): shrinking means X_k <= (1 + shrink_tolerance) X_{k-1},
X_0 taken over the same ids; a fall of more than max_step_shrink in one iteration is a collapse.

The verdict of an iteration is skelcore.verdict.judge over these figures.

Cost: the kNN search dominates. A cloud above `max_points` (5,000) is judged on a fixed random sample of
that many input points, each still measured against the whole current cloud (see MetricsReference).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree

from .curveness import skeleton_scale_share
from .errors import InputError, ParameterError
from .multires import POINT_BUDGET, reduce_cloud
from .io import as_points
from .neighbours import knn
from .verdict import StabilityThresholds, features, judge

D_THETA_RANGE = (0.0, 1.0)
DELTA_KAPPA_RANGE = (-1.0 / 3.0, 1.0 / 3.0)  # kappa lies in [0, 1/3]
_COLLAPSED = 1e-6  # a neighbourhood smaller than this fraction of the original diagonal has no frame
_ORIENT_NEIGHBOURS = 10  # Riemannian graph of the MST orientation
_SURFACE_NEIGHBOURS = 10  # PCA neighbourhood of the surface normals of the inside test
_TANGENT = 0.5  # an orientation edge must run along both surfaces: |n . edge direction| below this
_SYMMETRY_LEVELS = np.linspace(0.02, 0.48, 24)
NORMAL_CONVENTIONS = ("outward", "tracked")
NORMAL_CONVENTION = "outward"  # chosen by `skelcore study` (module docstring)


# --- per-point features -------------------------------------------------------------------------

def pca_features(points: np.ndarray, k: int = 30, rows: np.ndarray | None = None, collapsed: float = 0.0,
                 anchored: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals (eq. 6, sign as the solver gives it), curvature (eq. 7) and kNN indices of the points
    `rows` (default all), their neighbours taken among all `points`.

    anchored: the covariance is taken about each point itself (eq. 6 as written) instead of about the mean
    of its neighbours. Neighbourhoods whose covariance trace is <= collapsed**2 get NaN normal and curvature.
    """
    k = min(k, len(points))
    # For a few rows the build dominates: a sliding-midpoint tree builds in under half the time.
    tree = cKDTree(points) if rows is None else cKDTree(points, balanced_tree=False, compact_nodes=False)
    if rows is None:
        _, idx = knn(points, k, tree)
    else:
        _, idx = tree.query(points[rows], k=k, workers=-1)
        idx = idx.reshape(len(rows), k)
    anchors = (points if rows is None else points[rows]) if anchored else None
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


def orient_outward(points: np.ndarray, normals: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Flip normals consistently along a minimum spanning tree of the kNN graph (weight 2 - |n_i.n_j|),
    each connected part made outward at its point farthest from the part's centroid. Edges that cross the
    surface (across a thin tube or plate, where the two sides face opposite ways) are left out: an edge
    must run along the tangent planes of both its ends."""
    n = len(points)
    usable = np.nan_to_num(normals)
    cols = idx[:, 1:_ORIENT_NEIGHBOURS + 1].ravel()
    rows = np.repeat(np.arange(n), idx[:, 1:_ORIENT_NEIGHBOURS + 1].shape[1])
    direction = points[cols] - points[rows]
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    along = ((np.abs(np.einsum("ij,ij->i", usable[rows], direction)) < _TANGENT)
             & (np.abs(np.einsum("ij,ij->i", usable[cols], direction)) < _TANGENT))
    rows, cols = rows[along], cols[along]
    weights = 2.0 - np.abs(np.einsum("ij,ij->i", usable[rows], usable[cols]))
    graph = sp.csr_matrix((weights, (rows, cols)), shape=(n, n))
    tree = minimum_spanning_tree(graph.maximum(graph.T))
    parts, labels = connected_components(tree, directed=False)
    centroids = np.stack([np.bincount(labels, points[:, a], parts) for a in range(3)], axis=1)
    centroids /= np.bincount(labels, minlength=parts)[:, None]
    offsets = points - centroids[labels]
    order = np.lexsort((np.einsum("ij,ij->i", offsets, offsets), labels))
    roots = order[np.r_[np.flatnonzero(np.diff(labels[order])), n - 1]]
    # A virtual node n joined to every part's root makes the forest one tree: one BFS gives all parents.
    root = n
    tree = sp.bmat([[tree + tree.T, None], [None, sp.csr_matrix((1, 1))]], format="csr")
    tree = tree + sp.csr_matrix((np.ones(parts), (np.full(parts, root), roots)), shape=(n + 1, n + 1))
    _, parent = breadth_first_order(tree, root, directed=False, return_predecessors=True)
    parent[root] = root
    relative = np.ones(n + 1)
    relative[:n] = np.where(np.einsum("ij,ij->i", usable, usable[np.minimum(parent[:n], n - 1)]) < 0, -1.0, 1.0)
    relative[roots] = np.where(np.einsum("ij,ij->i", usable[roots], offsets[roots]) < 0, -1.0, 1.0)
    # Pointer jumping: the sign of a point is the product of relative flips along its path to the root.
    ancestor = parent.copy()
    while (ancestor != root).any():
        relative = relative * relative[ancestor]
        ancestor = ancestor[ancestor]
    return normals * relative[:n, None]


# --- histogram statistics -----------------------------------------------------------------------

def significant_peaks(counts: np.ndarray, n_points: int, drop: float = 0.02) -> np.ndarray:
    """Bins of the peaks whose frequency falls by at least drop * n_points on both sides (the paper's rule).

    A side is followed until a higher bin (to the left) or an equally high one (to the right), so a
    plateau, or two equal maxima with a shallow dip between them, counts once; beyond the ends the
    frequency is 0. A loop over bins (about 50), not points.
    """
    heights = np.concatenate([[0.0], np.asarray(counts, dtype=float), [0.0]])
    needed = drop * n_points
    peaks = []
    for i in range(1, len(heights) - 1):
        top = heights[i]
        if top <= 0 or top < heights[i - 1] or top < heights[i + 1]:
            continue
        left, right = heights[i - 1::-1], heights[i + 1:]
        left = left[:np.argmax(left > top)] if (left > top).any() else left
        right = right[:np.argmax(right >= top)] if (right >= top).any() else right
        if len(right) and top - left.min() >= needed and top - right.min() >= needed:
            peaks.append(i - 1)
    return np.asarray(peaks, dtype=np.int64)


def distribution_stats(values: np.ndarray, value_range: tuple[float, float], bins: int = 50,
                       peak_drop: float = 0.02) -> dict:
    """JSON-ready statistics of one per-point measure; NaN values are left out and counted."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    n = len(finite)
    counts, edges = np.histogram(finite, bins=bins, range=value_range)
    peaks = significant_peaks(counts, n, peak_drop)
    centres = (edges[:-1] + edges[1:]) / 2
    stats = {"histogram": {"edges": edges.tolist(), "counts": counts.tolist()}, "n": n,
             "n_undefined": int(len(values) - n),
             "peaks": {"count": int(len(peaks)), "positions": centres[peaks].tolist(),
                       "heights": counts[peaks].tolist()},
             "mean": None, "median": None, "std": None, "skewness": None, "kurtosis": None,
             "symmetry": None, "unimodality": None}
    if n == 0:
        return stats
    mean = float(finite.mean())
    deviation = finite - mean
    m2, m3, m4 = (float(np.mean(deviation ** p)) for p in (2, 3, 4))
    quantiles = np.quantile(finite, np.concatenate([[0.5], _SYMMETRY_LEVELS, 1.0 - _SYMMETRY_LEVELS]))
    median, low, high = quantiles[0], quantiles[1:1 + len(_SYMMETRY_LEVELS)], quantiles[1 + len(_SYMMETRY_LEVELS):]
    stats.update(mean=mean, median=float(median), std=float(np.sqrt(m2)))
    spread = float(np.mean(high - low))
    # Symmetry: quantiles mirrored about the median (Bowley's skewness over many levels), 1 = symmetric.
    mismatch = float(np.mean(np.abs(high + low - 2 * median)))
    stats["symmetry"] = 1.0 if spread <= 0 else float(np.clip(1.0 - mismatch / spread, 0, 1))
    if m2 > 1e-18:  # the measures live on ranges of order 1
        skewness, kurtosis = m3 / m2 ** 1.5, m4 / m2 ** 2 - 3.0
        stats.update(skewness=float(skewness), kurtosis=float(kurtosis))
        if n > 3:
            # Sarle's bimodality coefficient BC (5/9 for a uniform, 1/3 for a normal); reported as 1 - BC.
            # Informative only: heavy tails also raise BC, so the verdict counts peaks (the paper's rule).
            bc = (skewness ** 2 + 1) / (kurtosis + 3 * (n - 1) ** 2 / ((n - 2) * (n - 3)))
            stats["unimodality"] = float(np.clip(1.0 - bc, 0.0, 1.0))
    else:
        # A single value: skewness and kurtosis are undefined, the distribution is one spike.
        stats["unimodality"] = 1.0
    return stats


# --- reference and per-iteration evaluation -----------------------------------------------------

@dataclass
class IterationMetrics:
    """Metrics of one iteration; per-point arrays follow `point_ids` and stay out of to_dict()."""
    iteration: int
    point_ids: np.ndarray  # (m,) ids into the input cloud of the evaluated points (see MetricsReference)
    rows: np.ndarray  # (m,) their rows in the evaluated `points`
    n_present: int  # rows of the evaluated `points`
    d_theta: np.ndarray  # (m,) eqs. 3-5, NaN where undefined
    delta_kappa: np.ndarray  # (m,) eq. 8, NaN where undefined
    normals: np.ndarray  # (m,3) normals, signed by the normal convention (see the module docstring)
    kappa: np.ndarray  # (m,) eq. 7 at this iteration
    spread: float  # RMS distance of all the points present to their centroid
    d_theta_stats: dict
    delta_kappa_stats: dict
    boundedness: dict
    curve: dict  # {"curve_share": share of all present points curve-like at the skeleton's scale}
    verdict: dict  # skelcore.verdict.judge of this iteration (label None at iteration 0)

    def per_point(self, quantity: str) -> np.ndarray:
        """(n_present,) values of "d_theta" or "delta_kappa" for every row of the evaluated points, NaN
        where a point was not evaluated (or its neighbourhood collapsed)."""
        if quantity not in ("d_theta", "delta_kappa"):
            raise ParameterError(f"quantity={quantity!r}: must be 'd_theta' or 'delta_kappa'")
        values = np.full(self.n_present, np.nan)
        values[self.rows] = getattr(self, quantity)
        return values

    def to_dict(self) -> dict:
        """The statistics, boundedness and verdict for metrics.json (no per-point arrays)."""
        return {"d_theta": self.d_theta_stats, "delta_kappa": self.delta_kappa_stats,
                "boundedness": self.boundedness, "curve": self.curve, "verdict": self.verdict}


@dataclass(frozen=True)
class MetricsReference:
    """Iteration-0 features, computed once per run; `evaluate` compares an iteration with them.

    Clouds larger than max_points are judged on a fixed random subset of max_points input points
    (`evaluated`): their neighbourhoods still come from the whole current cloud, so each value is exact;
    only the histograms are those of a sample (5,000 values put the 2% peak threshold at 100 counts,
    five times the counting noise of a well-filled bin of 400). The kNN search is most of the cost, so this keeps
    one iteration's metrics well under a quarter of a contraction step at 30k points. max_points=None
    evaluates every point (e.g. to colour all of them).
    """
    points: np.ndarray  # (n,3) the input cloud
    normals: np.ndarray  # (n,3) PCA normals (eq. 6) signed by the convention
    kappa: np.ndarray  # (n,) eq. 7
    k: int
    bins: int
    thresholds: StabilityThresholds
    diagonal: float
    inside: "InsideTest" = field(repr=False)  # the original shape, for boundedness
    evaluated: np.ndarray = field(repr=False)  # (n,) bool: input points whose metrics are computed
    convention: str = NORMAL_CONVENTION  # how normals are centred and signed (module docstring)

    @classmethod
    def from_points(cls, points0, faces=None, k: int = 30, *, bins: int = 50,
                    thresholds: StabilityThresholds | None = None, max_points: int | None = 5_000,
                    seed: int = 0, convention: str = NORMAL_CONVENTION) -> "MetricsReference":
        points0 = as_points(points0, "points0")
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 3:
            raise ParameterError(f"k={k}: need an integer >= 3 neighbours for a PCA normal")
        if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or not 2 <= bins <= 10_000:
            raise ParameterError(f"bins={bins}: need an integer in [2, 10000]")
        if max_points is not None and (isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer))
                                       or max_points < 100):
            raise ParameterError(f"max_points={max_points}: need None or an integer >= 100")
        if len(points0) < 4:
            raise InputError(f"points0: {len(points0)} points, need at least 4")
        if convention not in NORMAL_CONVENTIONS:
            raise ParameterError(f"convention={convention!r}: must be one of {', '.join(NORMAL_CONVENTIONS)}")
        thresholds = (thresholds or StabilityThresholds()).validated()
        diagonal = float(np.linalg.norm(np.ptp(points0, axis=0)))
        if diagonal <= 0:
            raise InputError("points0: all points coincide")
        k = int(min(k, len(points0)))
        evaluated = np.ones(len(points0), bool)
        if max_points is not None and len(points0) > max_points:
            evaluated[:] = False
            evaluated[np.random.default_rng(seed).choice(len(points0), max_points, replace=False)] = True
        # Only the evaluated points are ever compared with iteration 0: their features, NaN elsewhere.
        rows = np.flatnonzero(evaluated)
        outward = convention == "outward"
        normals, kappa = np.full((len(points0), 3), np.nan), np.full(len(points0), np.nan)
        normals[rows], kappa[rows], _ = pca_features(points0, k, rows, collapsed=_COLLAPSED * diagonal,
                                                     anchored=outward)
        if outward:
            normals[rows] = _away_from_centroid(points0[rows], normals[rows], points0.mean(axis=0))
        band = thresholds.surface_tolerance * diagonal
        if faces is not None and len(faces):
            samples, sample_normals = _mesh_surface(points0, faces, band, seed)
        else:
            # The inside test needs the surface's own normals: k neighbours wrap around a thin tube, whose
            # PCA normal then runs along its axis, so a small neighbourhood gives them. A large cloud's
            # surface is sampled by voxel centroids (multi-resolution's point budget, spacing far below band).
            reduction = reduce_cloud(points0, POINT_BUDGET)
            samples = points0 if reduction is None else reduction.points
            surface_normals, _, surface_idx = pca_features(samples, min(_SURFACE_NEIGHBOURS, len(samples)),
                                                           collapsed=_COLLAPSED * diagonal)
            sample_normals = orient_outward(samples, surface_normals, surface_idx)
        inside = InsideTest.from_samples(samples, sample_normals, band)
        return cls(points0, normals, kappa, k, int(bins), thresholds, diagonal, inside, evaluated, convention)

    def evaluate(self, points, point_ids=None, previous: IterationMetrics | None = None,
                 iteration: int | None = None) -> IterationMetrics:
        """Metrics of the cloud `points`, rows matching `point_ids` (default: all input points, in order).

        previous: the metrics of the iteration before, for the normal tracking and the shrinking test
        (None: compare with iteration 0). The result's arrays cover the present points that are in
        `evaluated`, in the order of `points`.
        """
        points = as_points(points, "points")
        n = len(self.points)
        ids = np.arange(n) if point_ids is None else np.asarray(point_ids)
        if ids.shape != (len(points),) or not np.issubdtype(ids.dtype, np.integer):
            raise InputError(f"point_ids: need {len(points)} integer ids, one per point, got shape {ids.shape}")
        if len(ids) < 4 or ids.min() < 0 or ids.max() >= n or np.bincount(ids, minlength=n).max() > 1:
            raise InputError(f"point_ids: need at least 4 distinct ids in [0, {n})")
        if iteration is None:
            iteration = previous.iteration + 1 if previous is not None else 1
        n_present = len(points)
        spread, spread0 = _spread(points), _spread(self.points[ids])
        bbox = float(np.linalg.norm(np.ptp(points, axis=0)))
        rows = np.flatnonzero(self.evaluated[ids])
        if len(rows) == len(ids):
            rows = None
        elif len(rows):
            ids = ids[rows]
        else:
            raise InputError("point_ids: none of the present points is among the evaluated ones")
        outward = self.convention == "outward"
        normals, kappa, _ = pca_features(points, self.k, rows, _COLLAPSED * self.diagonal, anchored=outward)
        curve = {"curve_share": skeleton_scale_share(points, self.diagonal)}
        everything, points = points, (points if rows is None else points[rows])
        undefined = ~np.isfinite(normals).all(axis=1)
        if outward:
            normals = _away_from_centroid(points, normals, everything.mean(axis=0))
        else:
            # Carry each normal's sign over from the previous iteration (module docstring).
            before = self.normals.copy()
            if previous is not None:
                before[previous.point_ids] = previous.normals
            before = before[ids]
            flip = np.einsum("ij,ij->i", normals, before) < 0
            normals[flip] *= -1
            normals[undefined] = before[undefined]
        # eqs. 3-5: arccos(cos_sim(n_k, n_0)) / pi, evaluated as 2 atan2(|a - b|, |a + b|) for unit
        # vectors, the same angle without arccos's round-off near 0 (an unchanged normal gives exactly 0).
        reference = self.normals[ids]
        d_theta = 2.0 * np.arctan2(np.linalg.norm(normals - reference, axis=1),
                                   np.linalg.norm(normals + reference, axis=1)) / np.pi
        d_theta[undefined] = np.nan
        delta_kappa = kappa - self.kappa[ids]  # eq. 8
        t = self.thresholds
        d_stats = distribution_stats(d_theta, D_THETA_RANGE, self.bins, t.peak_drop)
        k_stats = distribution_stats(delta_kappa, DELTA_KAPPA_RANGE, self.bins, t.peak_drop)
        bounded = self._boundedness(points, spread, spread0, bbox, previous)
        verdict = judge(features({"d_theta": d_stats, "delta_kappa": k_stats, "boundedness": bounded,
                                  "curve": curve}), int(iteration), t)
        return IterationMetrics(int(iteration), ids, np.arange(n_present) if rows is None else rows, n_present,
                                d_theta, delta_kappa, normals, kappa, spread, d_stats, k_stats, bounded, curve,
                                verdict)

    def _boundedness(self, points: np.ndarray, spread: float, spread0: float, bbox: float,
                     previous: IterationMetrics | None) -> dict:
        """Inside share of the evaluated points; spread and bounding box of all the points present."""
        inside = self.inside.contains(points)
        before = previous.spread if previous is not None else spread0
        growth = spread / before - 1.0 if before > 0 else 0.0
        return {"inside_share": float(inside.mean()), "n_outside": int((~inside).sum()),
                "spread_ratio": float(spread / spread0) if spread0 > 0 else 1.0,
                "bbox_ratio": bbox / self.diagonal,
                "growth": float(growth), "shrinking": bool(growth <= self.thresholds.shrink_tolerance)}


def _away_from_centroid(points: np.ndarray, normals: np.ndarray, centroid: np.ndarray | None = None) -> np.ndarray:
    """Normals flipped to point away from the cloud's centroid (the "outward" convention)."""
    centroid = points.mean(axis=0) if centroid is None else centroid
    return np.where((np.einsum("ij,ij->i", normals, points - centroid) < 0)[:, None], -normals, normals)


def _spread(points: np.ndarray) -> float:
    """RMS distance to the centroid: the size X of a cloud in X_{k+1} <= X_k."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


@dataclass(frozen=True)
class InsideTest:
    """Which points lie inside a closed surface given by samples with outward normals.

    The side of a point is that of the nearest sample's normal, (p - s).n <= band counting as inside.
    Deep inside a shape that nearest-sample query is slow (a point on a tube's axis is almost as far from
    a whole ring of samples), so it is only made near the surface: a voxel grid of cell `size` marks the
    cells holding a sample, dilated by one, as the shell; every connected region of empty cells lies on
    one side of the surface and takes the side most of its cells next to the shell vote for (regions
    touching the grid's border are outside). A region whose votes split (a surface with holes joins
    inside and outside) is judged cell by cell, once.
    """
    origin: np.ndarray  # (3,) corner of the grid
    size: float  # cell edge
    cells: np.ndarray  # (nx,ny,nz) int8: 1 inside, 0 outside, -1 shell (decided per point)
    samples: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    band: float

    @classmethod
    def from_samples(cls, samples: np.ndarray, normals: np.ndarray, band: float) -> "InsideTest":
        from scipy import ndimage

        keep = np.linalg.norm(np.nan_to_num(normals), axis=1) > 0.5  # mesh vertices without faces have none
        if keep.sum() < 4:
            raise InputError("no part of the cloud is large enough for its extent to have a surface normal "
                             "(small clusters far apart?); skeletonise the parts one by one")
        samples, normals = samples[keep], normals[keep]
        tree = cKDTree(samples)
        spacing, _ = tree.query(samples, k=2, workers=-1)
        extent = np.ptp(samples, axis=0)
        # Cells at least twice the sample spacing keep the dilated shell closed; at most 256 per axis.
        size = max(band, 2.0 * float(np.quantile(spacing[:, 1], 0.9)), float(extent.max()) / 256, 1e-12)
        origin = samples.min(axis=0) - 2.5 * size
        shape = tuple(np.ceil(extent / size).astype(int) + 6)
        occupied = np.zeros(shape, bool)
        occupied[tuple(np.floor((samples - origin) / size).astype(int).T)] = True
        shell = ndimage.binary_dilation(occupied, np.ones((3, 3, 3), bool))
        regions, count = ndimage.label(~shell)
        test = cls(origin, size, np.full(shape, -1, np.int8), samples, normals, tree, band)
        centres = lambda where: origin + (np.argwhere(where) + 0.5) * size
        voters = ~shell & ndimage.binary_dilation(shell)
        votes = test._side(centres(voters)) <= 0
        inside_share = (np.bincount(regions[voters], votes, count + 1)
                        / np.maximum(np.bincount(regions[voters], minlength=count + 1), 1))
        border = np.unique(np.concatenate([regions[[0, -1]].ravel(), regions[:, [0, -1]].ravel(),
                                           regions[:, :, [0, -1]].ravel()]))
        side = (inside_share > 0.5).astype(np.int8)
        side[border] = 0
        side[0] = -1  # label 0 is the shell
        mixed = (inside_share > 0.25) & (inside_share < 0.75)
        mixed[border] |= inside_share[border] > 0.25
        mixed[0] = False
        cells = side[regions]
        split = mixed[regions]
        cells[split] = test._side(centres(split)) <= 0
        test.cells[...] = cells
        return test

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean mask: inside the surface, or within `band` of it."""
        index = np.floor((points - self.origin) / self.size).astype(np.int64)
        on_grid = ((index >= 0) & (index < self.cells.shape)).all(axis=1)
        verdict = np.zeros(len(points), np.int8)
        verdict[on_grid] = self.cells[tuple(index[on_grid].T)]
        near = verdict < 0
        verdict[near] = self._side(points[near]) <= self.band
        return verdict.astype(bool)

    def _side(self, points: np.ndarray) -> np.ndarray:
        """Signed offset along the nearest sample's outward normal (eq.: (p - s) . n_s)."""
        _, nearest = self.tree.query(points, k=1, workers=-1)
        return np.einsum("ij,ij->i", points - self.samples[nearest], self.normals[nearest])


def _mesh_surface(vertices: np.ndarray, faces, spacing: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Dense surface samples with outward face normals (winding repaired), spaced about `spacing`/2."""
    import trimesh

    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise InputError(f"faces: need an (m,3) integer array, got shape {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(f"faces: indices must lie in [0, {len(vertices)})")
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.update_faces(mesh.nondegenerate_faces())
    if not len(mesh.faces):
        raise InputError("faces: every face is degenerate")
    trimesh.repair.fix_normals(mesh)
    count = int(np.clip(4.0 * mesh.area / spacing ** 2, 10_000, 200_000))
    samples, face_index = trimesh.sample.sample_surface(mesh, count, seed=seed)
    return (np.concatenate([np.asarray(samples), mesh.vertices]),
            np.concatenate([mesh.face_normals[face_index], mesh.vertex_normals]))
