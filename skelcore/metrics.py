"""Stability metrics of a contraction: D_theta, delta_kappa, their histograms (skelcore.histogram_stats),
boundedness, curve-likeness and the verdict of each iteration.

Per point and iteration (seed paper): the PCA normal n (eq. 6) and the curvature kappa (eq. 7) of the k
nearest neighbours in the CURRENT cloud (skelcore.normals), D_theta = arccos(cos_sim(n_k, n_0)) / pi (eqs. 3-5) and delta_kappa = kappa_k - kappa_0 (eq. 8).

k defaults to 30: the largest neighbourhood the contraction itself uses (cloudcontr's k=30, our
clamp(0.012 n, 8, 30)) and the usual kNN size for PCA normals (Open3D's examples); fewer neighbours make
the normal of a contracted, nearly one-dimensional neighbourhood follow the sampling noise.

Normal conventions (`NORMAL_CONVENTIONS`). The eigen-solver returns +n or -n at random, yet eq. 5 uses the
signed cosine, so how the signs are chosen decides what the D_theta histogram shows.
- "outward" (the paper's reading, the default): eq. 6 centred on the anchor point (the covariance of the
  neighbours about the point itself, not about their mean), and every normal, at iteration 0 and at k,
  oriented away from its cloud's centroid. D_theta moves from left-skewed toward a bell centred on 0.5 as
  the paper describes (in `skelcore study`, 18 of 27 default runs end within 0.1 of 0.5 with one peak).
- "tracked": mean-centred covariance and each normal's sign carried over from the previous iteration
  (n_k . n_{k-1} >= 0): D_theta is the total turn of a continuous normal field, 0 for an unchanged cloud;
  its mean ends at 0.19-0.39 (none of 27 default runs near 0.5).
The study (810 runs, README "The stability verdict") found outward D_theta predicting a right skeleton
better (ROC AUC of its mean 0.70 [0.67, 0.74] against 0.59 [0.55, 0.63] tracked, of its symmetry 0.70
against 0.61) and the calibrated verdicts labelling the same number of held-out runs (126 each, all right),
so the default is the one that shows the paper's behaviour. Reference normals for the boundedness test are
always MST-oriented (Hoppe et al. 1992).
A neighbourhood that has collapsed to a point has no normal or curvature: its values are NaN, left out
of the statistics (counted in "n_undefined"); a tracked normal carries the previous one forward.

Curve-likeness: the share of the cloud that is curve-like at the skeleton's scale
(skelcore.curveness.skeleton_scale_share, radius a fraction of the input's diagonal), the same figure the
contraction's stop rule and the inspector's status read.

Points that disappear (GLSkeleton): the caller passes `point_ids`, ids into the input cloud of the
points present, and every quantity compares them with iteration 0 at those ids.

Boundedness (X_{k+1} <= X_k << X_o): the share of points inside the original shape, judged by the
side of the nearest reference surface sample's outward normal, within a band of `surface_tolerance`
times the original object diagonal (skelcore.normalise.object_box; points on the surface count as inside;
skelcore.inside). A point cloud is its own sample with MST-oriented PCA normals of 10 neighbours
(orientation edges that cross a thin part are left out), or if it is a single view, PCA normals signed to face the
viewer (skelcore.single_view); a mesh is sampled densely with its face normals.
The size X of a cloud is its RMS distance to its centroid (it follows the collapse of every cross-section; a
bounding box only sees the extreme tips and stays put while a tube collapses): shrinking means
X_k <= (1 + shrink_tolerance) X_{k-1}, X_0 and X_{k-1} taken over the same ids (GLSkeleton merges points
away); a fall of more than max_step_shrink in one iteration is a collapse.

The verdict of an iteration is skelcore.verdict.judge over these figures.

Scale. A cloud above `max_points` (5,000) is judged on a fixed random sample of that many input points, and
their k nearest neighbours are taken among the sample too (see MetricsReference): the neighbourhood of a PCA
normal then spans the same share of the object at any density. Taken from the whole cloud, k = 30 neighbours
of a 300k-point scan lie within a sliver of a contracted tube's cross-section, and the same noisy torus read
D_theta mean 0.51 and stable at 10k points, 0.32 at 30k, two D_theta peaks and "unstable" at 300k.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .curveness import skeleton_scale_share
from .errors import InputError, ParameterError
from .histogram_stats import distribution_stats
from .inside import InsideTest, mesh_surface
from .io import as_points
from .multires import POINT_BUDGET, Reduction, voxel_reduction
from .normalise import object_diagonal
from .normals import COLLAPSED, away_from_centroid, pca_features
from .verdict import DELTA_KAPPA_RANGE, D_THETA_RANGE, StabilityThresholds, features, judge

NORMAL_CONVENTIONS = ("outward", "tracked")
METRICS_K = 30  # the paper's neighbourhood for PCA normals and curvature (module docstring)
NORMAL_CONVENTION = "outward"  # chosen by `skelcore study` (module docstring)
JUDGED_POINTS = 5_000  # a larger cloud is judged on a fixed random sample of this many of its points (Scale)


class Unread:
    """MetricsReference.from_points' default reduction: the caller has not read the cloud's voxel reduction."""


UNREAD = Unread()


# --- per-point features -------------------------------------------------------------------------


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
    present_ids: np.ndarray = field(repr=False, default=None)  # (n_present,) input ids of all the points present
    positions: np.ndarray = field(repr=False, default=None)  # (n_present,3) their positions (the state's array)

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
    (`evaluated`), with their neighbourhoods among the subset's present points: every cloud is measured at the
    scale of a max_points sample of it, whatever its density (module docstring), and the histograms hold 5,000
    values (the 2% peak threshold at 100 counts, five times the counting noise of a well-filled bin of 400).
    max_points=None evaluates every point among all the others.
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
    spread: float = float("nan")  # X_0 of the whole input, for the iterations where every point is present

    @classmethod
    def from_points(cls, points0, faces=None, k: int = METRICS_K, *, bins: int = 50,
                    thresholds: StabilityThresholds | None = None, max_points: int | None = JUDGED_POINTS,
                    seed: int = 0, convention: str = NORMAL_CONVENTION,
                    reduction: Reduction | None | Unread = UNREAD, tree: cKDTree | None = None,
                    surface: np.ndarray | None = None) -> "MetricsReference":
        """The reference of the input `points0` (and its mesh `faces`, if any). reduction: the voxel reduction
        of points0 at POINT_BUDGET (skelcore.multires.voxel_reduction) when the caller has read it already, None
        when that read found none (a cloud within the budget, not on scan lines); by default it is read here. A
        large cloud's inside test samples its surface by these voxel centroids, as does one on scan lines. tree: a
        cKDTree (default build) the caller has made already, used when it covers exactly those surface samples
        (points0, or the centroids of a large cloud). surface: what the inside test samples in place of points0
        (io.Cloud.surface: thin walls' faces kept apart)."""
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
        diagonal = object_diagonal(points0)
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
        normals[rows], kappa[rows], _ = pca_features(points0[rows], k, collapsed=COLLAPSED * diagonal,
                                                     anchored=outward)
        if outward:
            normals[rows] = away_from_centroid(points0[rows], normals[rows], points0.mean(axis=0))
        band = thresholds.surface_tolerance * diagonal
        if faces is not None and len(faces):
            inside = InsideTest.from_samples(*mesh_surface(points0, faces, band, seed), band)
        else:
            # A large cloud's surface is sampled by voxel centroids (multi-resolution's point budget, spacing
            # far below band), as is one on scan lines (one line spacing apart: the lines' own neighbourhoods
            # read most contracted points outside, the pretzel's half of them)
            if reduction is UNREAD or (reduction is not None and reduction.n_input != len(points0)):
                reduction = voxel_reduction(points0, POINT_BUDGET)
            samples = (points0 if surface is None else surface) if reduction is None else reduction.points
            if tree is None or tree.data.shape != samples.shape or not np.array_equal(tree.data, samples):
                tree = None
            inside = InsideTest.of_cloud(samples, band, COLLAPSED * diagonal, tree)
        return cls(points0, normals, kappa, k, int(bins), thresholds, diagonal, inside, evaluated, convention,
                   _spread(points0))

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
        everyone = len(ids) == n and np.array_equal(ids, np.arange(n))  # every input point, in order
        known = everyone and np.isfinite(self.spread)  # X_0 of the whole input, set by from_points
        spread, spread0 = _spread(points), (self.spread if known else _spread(self.points[ids]))
        spread_before = spread0 if previous is None else _spread_before(previous, ids, n)
        present_ids = ids
        bbox = object_diagonal(points)
        rows = np.flatnonzero(self.evaluated[ids])
        if len(rows) == len(ids):
            rows = None
        elif len(rows):
            ids = ids[rows]
        else:
            raise InputError("point_ids: none of the present points is among the evaluated ones")
        outward = self.convention == "outward"
        everything, points = points, (points if rows is None else points[rows])
        if everyone and everything is self.points:  # the input itself (iteration 0): its features are known
            normals, kappa = self.normals[ids], self.kappa[ids]
        else:
            normals, kappa, _ = pca_features(points, self.k, collapsed=COLLAPSED * self.diagonal, anchored=outward)
        curve = {"curve_share": skeleton_scale_share(everything, self.diagonal)}
        undefined = ~np.isfinite(normals).all(axis=1)
        if outward:
            normals = away_from_centroid(points, normals, everything.mean(axis=0))
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
        bounded = self._boundedness(points, spread, spread0, bbox, spread_before)
        verdict = judge(features({"d_theta": d_stats, "delta_kappa": k_stats, "boundedness": bounded,
                                  "curve": curve}), int(iteration), t)
        return IterationMetrics(int(iteration), ids, np.arange(n_present) if rows is None else rows, n_present,
                                d_theta, delta_kappa, normals, kappa, spread, d_stats, k_stats, bounded, curve,
                                verdict, present_ids, everything)

    def _boundedness(self, points: np.ndarray, spread: float, spread0: float, bbox: float, before: float) -> dict:
        """Inside share of the evaluated points; spread and bounding box of all the points present; `before` their
        spread one iteration earlier."""
        inside = self.inside.contains(points)
        growth = spread / before - 1.0 if before > 0 else 0.0
        return {"inside_share": float(inside.mean()), "n_outside": int((~inside).sum()),
                "spread_ratio": float(spread / spread0) if spread0 > 0 else 1.0,
                "bbox_ratio": bbox / self.diagonal,
                "growth": float(growth), "shrinking": bool(growth <= self.thresholds.shrink_tolerance)}


def _spread_before(previous: IterationMetrics, ids: np.ndarray, n: int) -> float:
    """The spread one iteration earlier of the points present now: X_{k+1} <= X_k compares one cloud, and when
    points merge away (GLSkeleton) the spread of the ones left differs from that of all the earlier ones."""
    if previous.positions is None or np.array_equal(previous.present_ids, ids):  # the same points (LBC)
        return previous.spread
    row_of = np.full(n, -1)
    row_of[previous.present_ids] = np.arange(len(previous.present_ids))
    rows = row_of[ids]
    return previous.spread if (rows < 0).any() else _spread(previous.positions[rows])


def _spread(points: np.ndarray) -> float:
    """RMS distance to the centroid: the size X of a cloud in X_{k+1} <= X_k."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))
