"""Multi-resolution contraction for large or unevenly dense clouds: contract a reduced cloud, then carry every
input point.

Above POINT_BUDGET input points, the contraction runs on the centroids of a voxel grid whose voxel size is
chosen so that about POINT_BUDGET voxels are occupied (the centroid also averages the scanner's noise). Every
input point is then carried along with the reduced cloud: from the first step on, its position is a fixed convex
combination of the positions of the nearest few among its voxel's centroid and that centroid's one-ring
neighbours (inverse squared distance weights, set once in the input), so it follows its own sheet of the
surface (never a neighbouring one: the ring is the local surface), ends on the skeleton with it, and keeps
its own row. The paper's metrics are therefore still those of every input point, and the skeleton's
correspondence names the node of every input point (that of its voxel's centroid).

The centroids are then denoised as cleaning denoises a cloud of that size: each is projected onto the PCA plane
of its nearest centroids, weighted by their counts, that is the plane of the input points they stand for.
Cleaning's own projection works on the input's spacing, and in a dense cloud its 16 nearest points span less
than a scanner's noise, so the centroids of a noisy scan would stay a shell several voxels thick, the thicker
the denser the cloud (the noise's tails occupy voxels of their own, each of a few points: unweighted, those
tilt the planes). On the real-shape benchmark at 100k and 300k points with noise of 1% of the diagonal, the
solids with holes (blocks, gear) then keep their loops as they do at 10k.

Why 20,000: at about that many points on a compact object the Laplacian's one-ring (k = 30 nearest) reaches
the skeleton's sampling radius (0.02 of the diagonal). A denser cloud only resolves detail below the radius
the skeleton keeps, and there a scanner's noise outweighs the shape: on the real-shape benchmark at 30k
points with noise, contracting 20k centroids instead of 30k points kept the topology in 31 of 42 runs
instead of 24 (LBC), and at 100k/300k it removed false loops on noisy scans.

A cloud within the budget is contracted as it is, unless a part of it is many times denser than the surface
around it (a patch a scanner dwelt on, a detail scanned again from close by): that part is thinned to
about twice the density around it (skelcore.density.evened) and its left-out points are carried along in the
same way, each with its nearest kept point (`thin_dense`). A separate object sampled more finely than a larger
one beside it, more than a sample radius from it, is its own piece and is not thinned.

A cloud whose points lie on scan lines far apart (skelcore.scan_lines) is contracted as the centroids of voxels one
line spacing across, at any size (above the budget where the budget's voxels are the smaller), every input point
carried in the same way (`even_scan_lines`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import density
from .errors import ParameterError
from .io import MIN_POINTS
from .normalise import SAMPLE_RADIUS, object_diagonal

if TYPE_CHECKING:  # the CLI reads POINT_BUDGET: no scipy or networkx for that
    import scipy.sparse as sp

    from .neighbours import OneRings
    from .skeleton import Skeleton
    from .step import IterationState

POINT_BUDGET = 20_000  # clouds with more points are contracted at this resolution (0 or None: never)
VOXEL_ROUNDS = 6  # secant steps on the voxel size to land in BUDGET_BAND
BUDGET_BAND = (0.8, 1.0)  # accepted share of the budget for the reduced cloud
WEIGHT_FLOOR = 0.05  # in voxel sizes: the distance below which every weight is the same
CARRIERS = 4  # an input point moves with this many of its nearest candidates (its centroid and that one's ring)
CHUNK = 131_072  # input points per block while the weights are set
DENSE_GRID = 1 << 25  # voxel grids of up to this many cells are numbered through an occupancy array (no sort)
# ... and of up to this many cells per point: the array costs about 15 ns a cell, the sort about as much a point
# times log2 of the count, so a grid much larger than the cloud (26k points in 33M cells: 0.5 s) is sorted instead
DENSE_PER_POINT = 8


@dataclass(frozen=True)
class Reduction:
    """A voxel reduction of an input cloud and the carrying of its points."""
    points: np.ndarray  # (m,3) voxel centroids, the cloud that is contracted
    voxel_of: np.ndarray  # (n,) row of `points` (voxel) of every input point
    voxel_size: float
    input_points: np.ndarray = dataclasses.field(repr=False)  # (n,3)
    denoise_neighbours: int = 0  # the centroids were projected onto the planes of this many nearest (0: not)
    thinned: bool = False  # thin_dense's: `points` are input points, voxel_size the cells' edge
    scan_lines: float = 0.0  # even_scan_lines': how many times farther apart the lines lie than the points on them

    @property
    def n_input(self) -> int:
        """The number of input points."""
        return len(self.voxel_of)

    @property
    def counts(self) -> np.ndarray:
        """(m,) how many input points each voxel centroid stands for."""
        return np.bincount(self.voxel_of, minlength=len(self.points))

    def note(self) -> str:
        """One progress line: what was reduced and how to turn it off."""
        if self.thinned:
            return (f"dense parts: {self.n_input - len(self.points):,} of {self.n_input:,} points, in parts many "
                    f"times denser than the surface around them, were left out of the contraction, each carried "
                    f"along with its nearest contracted point (turn off with --full-resolution)")
        if self.scan_lines:
            return (f"scan lines: the points lie on lines {self.scan_lines:.1f} times farther apart than the points "
                    f"along them; contracted {len(self.points):,} voxel centroids (voxel {self.voxel_size:.4g}, the "
                    f"lines' spacing{self._denoised_note()}), every input point carried along (turn off with "
                    f"--full-resolution)")
        return (f"multi-resolution: {self.n_input:,} points above the budget of the contraction; contracted "
                f"{len(self.points):,} voxel centroids (voxel {self.voxel_size:.4g}{self._denoised_note()}), every "
                f"input point carried along (turn off with --full-resolution)")

    def _denoised_note(self) -> str:
        return f", denoised on their {self.denoise_neighbours} nearest" if self.denoise_neighbours else ""

    def denoised(self, neighbours: int) -> "Reduction":
        """This reduction with every centroid projected onto the PCA plane of its `neighbours` nearest
        centroids, each weighted by its count (skelcore.clean.denoised; 0: as it is)."""
        if not neighbours or self.thinned:  # thinned: input points, which cleaning has denoised
            return self
        from .clean import denoised

        points = denoised(self.points, neighbours, weights=self.counts.astype(np.float64))
        return dataclasses.replace(self, points=points, denoise_neighbours=neighbours)

    def describe(self) -> dict:
        """metrics.json's `multiresolution`: input and contracted points, voxel size, the centroids' denoising, and
        how the reduction came (dense parts thinned; scan lines, their spacing's ratio, 0 for none)."""
        return {"input_points": self.n_input, "contracted_points": len(self.points), "voxel_size": self.voxel_size,
                "denoise_neighbours": self.denoise_neighbours, "dense_parts_thinned": self.thinned,
                "scan_lines": self.scan_lines}

    def mean(self, values: np.ndarray) -> np.ndarray:
        """(m,) the mean of per-input-point values over each voxel (e.g. contraction weights)."""
        return np.bincount(self.voxel_of, weights=values, minlength=len(self.points)) / self.counts

    def carrier(self, rings: OneRings) -> sp.csr_matrix:
        """(n, m) convex weights: each input point over the CARRIERS nearest of its voxel's centroid and that
        centroid's ring (a thinned cloud's kept point: itself alone)."""
        import scipy.sparse as sp

        counts = np.diff(rings.indptr)
        width = 1 + int(counts.max(initial=0))
        # candidates[c]: the centroid c, then its ring, padded with c (a repeated candidate adds no weight)
        candidates = np.repeat(np.arange(len(self.points))[:, None], width, axis=1)
        column = np.arange(len(rings.indices)) - np.repeat(rings.indptr[:-1], counts)
        candidates[rings.centres(), 1 + column] = rings.indices
        valid = np.ones(candidates.shape, dtype=bool)
        valid[:, 1:] = np.arange(1, width) <= counts[:, None]
        keep = min(CARRIERS, width)
        columns = np.empty((self.n_input, keep), dtype=np.int64)
        weights = np.empty((self.n_input, keep))
        for start in range(0, self.n_input, CHUNK):  # bounded temporaries: (CHUNK, width, 3)
            rows = slice(start, start + CHUNK)
            mine, usable = candidates[self.voxel_of[rows]], valid[self.voxel_of[rows]]
            # only the valid candidates are measured (a ring is about half as long as the longest one)
            distance2 = np.full(mine.shape, np.inf)
            point = start + np.nonzero(usable)[0]
            distance2[usable] = ((self.points[mine[usable]] - self.input_points[point]) ** 2).sum(axis=-1)
            nearest = np.argpartition(distance2, keep - 1, axis=1)[:, :keep]
            near2 = np.take_along_axis(distance2, nearest, axis=1)
            columns[rows] = np.take_along_axis(mine, nearest, axis=1)
            weights[rows] = np.where(np.isfinite(near2),
                                     1.0 / np.maximum(near2, (WEIGHT_FLOOR * self.voxel_size) ** 2), 0.0)
        if self.thinned:  # a kept point is where the contraction put it (the blend above moves it a little)
            kept = np.flatnonzero(np.all(self.input_points == self.points[self.voxel_of], axis=1))
            columns[kept], weights[kept] = self.voxel_of[kept, None], 0.0
            weights[kept, 0] = 1.0
        weights /= weights.sum(axis=1, keepdims=True)
        indptr = np.arange(0, weights.size + 1, keep)
        return sp.csr_matrix((weights.ravel(), columns.ravel(), indptr), shape=(self.n_input, len(self.points)))

    def skeleton_for_input(self, skeleton: Skeleton) -> Skeleton:
        """The skeleton of the reduced cloud with the correspondence of every input point (its voxel's)."""
        correspondence = skeleton.correspondence[self.voxel_of]
        counts = np.bincount(correspondence, minlength=skeleton.graph.number_of_nodes())
        graph = skeleton.graph.copy()
        for node in graph.nodes:
            graph.nodes[node]["point_count"] = int(counts[node])
        return dataclasses.replace(skeleton, graph=graph, correspondence=correspondence)

    def lift(self, state: IterationState, carrier: sp.csr_matrix) -> IterationState:
        """The state of every input point: carried positions, all present, each representing itself. Iteration 0
        is the input itself: carried, it would be its voxels' interpolation, moved before any step."""
        ids = np.arange(self.n_input)
        positions = self.input_points if state.iteration == 0 else np.asarray(carrier @ state.points[state.owner])
        return dataclasses.replace(state, points=positions, point_ids=ids, owner=ids)


def contracted_cloud(points: np.ndarray, budget: int | None = POINT_BUDGET) -> Reduction | None:
    """What a run contracts in place of every point: its voxel reduction (voxel_reduction), else the cloud with its
    over-dense parts thinned (thin_dense); None for every point as it is, and always with budget off (None or 0)."""
    reduction = voxel_reduction(points, budget)
    return thin_dense(points) if reduction is None and budget else reduction


def voxel_reduction(points: np.ndarray, budget: int | None = POINT_BUDGET) -> Reduction | None:
    """The voxel reduction above `budget` points, or a coarser one where the points lie on scan lines farther apart
    than its voxels (even_scan_lines); None for a cloud within the budget sampled evenly, and with budget off."""
    reduction = reduce_cloud(points, budget)
    if not budget:
        return reduction
    # read on the budget's centroids where there are some: they lie on the same lines, fewer (a million points'
    # tree alone took 0.5 s), and where its voxels are wider than the lines' spacing they no longer lie on lines
    lines = even_scan_lines(points, None if reduction is None else reduction.points)
    return lines if lines is not None and (reduction is None or reduction.voxel_size < lines.voxel_size) else reduction


def within_budget(n: int, budget: int | None = POINT_BUDGET) -> bool:
    """Whether a cloud of `n` points is contracted without the budget's voxel reduction (budget off: None or 0)."""
    return not budget or n <= budget


def reduce_cloud(points: np.ndarray, budget: int | None = POINT_BUDGET) -> Reduction | None:
    """The voxel reduction of a cloud above `budget` points (None when it is within it, or budget is off: None
    or 0)."""
    if budget is not None and budget != 0 and not budget >= MIN_POINTS:
        raise ParameterError(f"point_budget={budget}: must be 0 (off) or at least {MIN_POINTS} points")
    n = len(points)
    if within_budget(n, budget):
        return None
    lower, upper = (int(share * budget) for share in BUDGET_BAND)
    low = points.min(axis=0)
    extent = float(np.ptp(points, axis=0).max())
    size = extent / np.sqrt(budget)  # a surface's voxel count goes as size^-2
    best, previous, slope = None, None, -2.0
    for _ in range(VOXEL_ROUNDS):
        voxel_of, count = _voxels(points, low, size)
        if count <= upper and (best is None or count > best[2]):
            best = (size, voxel_of, count)
        if lower <= count <= upper:
            break
        if previous is not None and previous[0] != size and previous[1] != count:
            # secant in log-log: a surface's count goes as size^-2, a volume's (thick noise) up to size^-3
            slope = float(np.clip(np.log(count / previous[1]) / np.log(size / previous[0]), -3.5, -1.0))
        previous = (size, count)
        size *= (0.5 * (lower + upper) / count) ** (1.0 / slope)
    if best is None:  # every round above the budget: a coarser grid is sure to fit
        size *= 2.0
        best = (size, *_voxels(points, low, size))
    size, voxel_of, count = best
    return Reduction(points=_centroids(points, voxel_of, count), voxel_of=voxel_of, voxel_size=float(size),
                     input_points=points)


def even_scan_lines(points: np.ndarray, read_on: np.ndarray | None = None) -> Reduction | None:
    """The voxel reduction of a cloud sampled on scan lines (skelcore.scan_lines), its voxels one line spacing
    across, so that the centroids lie about as far apart along the lines as across them; None for a cloud sampled
    evenly. read_on: points on the same lines the spacing is read on (default: `points`)."""
    from .scan_lines import line_spacing

    lines = line_spacing(points if read_on is None else read_on)
    if lines is None:
        return None
    spacing, ratio = lines
    voxel_of, count = _voxels(points, points.min(axis=0), spacing)
    return Reduction(points=_centroids(points, voxel_of, count), voxel_of=voxel_of, voxel_size=spacing,
                     input_points=points, scan_lines=ratio)


def _centroids(points: np.ndarray, voxel_of: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) the centroid of each voxel's points."""
    centroids = np.zeros((count, 3))
    for axis in range(3):
        centroids[:, axis] = np.bincount(voxel_of, weights=points[:, axis], minlength=count)
    return centroids / np.bincount(voxel_of, minlength=count)[:, None]


def thin_dense(points: np.ndarray) -> Reduction | None:
    """The cloud with its over-dense parts thinned (density.evened, its pieces and typical density read on cells
    of the skeleton's default sample radius), each left-out point carried with its nearest kept one; None when it
    has none. The Laplacian's cotangent weights do not see the density, so a part many times denser than the
    surface around it contracts more slowly under the same W_L and holds its surroundings back: the ball with
    thin handles with 2,900 more points within 3% of its diagonal of one of its points stopped after one step
    with 11 ends, against 9 steps and none once thinned."""
    from scipy.spatial import cKDTree

    cell = SAMPLE_RADIUS * object_diagonal(points)
    kept = density.evened(points, cell)
    if kept is None:
        return None
    carried_by = cKDTree(points[kept]).query(points, workers=-1)[1]
    carried_by[kept] = np.arange(len(kept))
    return Reduction(points=points[kept], voxel_of=carried_by, voxel_size=cell, input_points=points, thinned=True)


def _voxels(points: np.ndarray, low: np.ndarray, size: float) -> tuple[np.ndarray, int]:
    """Voxel row of every point (numbered in key order) and the number of occupied voxels."""
    cells = ((points - low) / size).astype(np.int64)
    span = cells.max(axis=0) + 1
    keys = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
    if int(np.prod(span)) > min(DENSE_GRID, DENSE_PER_POINT * len(points)):
        _, voxel_of = np.unique(keys, return_inverse=True)
        return voxel_of.ravel(), int(voxel_of.max()) + 1
    # The same numbering without a sort: mark the occupied cells of the whole grid, rank them in key order.
    occupied = np.zeros(int(np.prod(span)), dtype=bool)
    occupied[keys] = True
    rank = np.cumsum(occupied, dtype=np.int64) - 1
    return rank[keys], int(rank[-1]) + 1
