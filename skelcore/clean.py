"""Cleaning before contraction: outliers and stray pieces out, so that they neither rescale the object nor
tie its skeleton together.

Both rules compare each point with the cloud's own typical spacing, so they follow the sampling:
- statistical outliers: a point whose mean distance to its `neighbours` nearest points (its spacing) is
  both `outlier_ratio` times the median spacing of those neighbours (it lies apart from them, where a
  sparsely sampled part is sparse all round) and `outlier_spread` robust standard deviations (1.4826 MAD)
  above the cloud's median spacing (it lies apart from the surface as a whole). Median and MAD, rather than
  open3d's mean and standard deviation, which the outliers themselves inflate;
- noise: every kept point is projected onto the PCA plane of its `neighbours` nearest kept points
  (centred on their mean), once. Sampling noise inflates the initial one-ring sizes s^0, so after the
  first step smooths it, W_H = W_H0 s^0 / s^t pins the points before they contract, and noisy fans give
  degenerate cotangents; the projection removes the normal part of the noise. On a clean surface it
  moves a point by about the sagitta of its neighbourhood, a fraction of a point spacing. Where the
  neighbourhood holds two parallel sheets (a wall thinner than its reach) the plane pulls them together;
  the cloud's `surface`, which its inside tests sample, keeps them apart (`_own_sheets`). A neighbourhood with
  no plane stays as it is: a thin tube a few points around (a bucket's wire bail) lines its neighbours up
  along its axis, spread alike in both directions across it, and the plane PCA picks there is set by which
  sides the few samples happen to lie on; projected onto it, the tube flattens into a ribbon whose
  cross-section no longer reads as a hollow tube (skelcore.curveness.thin_tubes);
- stray pieces: the cloud is split into pieces where no chain of near neighbours (each step at most
  `piece_gap` times the typical spacing) joins them; pieces holding less than `min_piece_share` of the
  points are removed (a scan's stray clusters, far or near). A piece of the object holding that share is
  kept however far it lies: two separate rings stay two rings. So is a surface sparser than the typical
  spacing, which the chains cut into fragments: the points the rule would remove are joined again at their own
  spacing, and a piece of them holding that share with flat neighbourhoods stays (`_sparse_surfaces`).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .coordinates import on_one_line
from .curveness import CURVE_RATIO
from .density import group_medians
from .errors import InputError
from .io import Cloud
from .neighbours import CHUNK, joined_pieces, knn, leaf_knn, local_frames, stray_pieces
from .normalise import far_pieces
from .normals import COLLAPSED
from .params import CleaningParams


ROUND_ACROSS = 0.5  # a curve-like neighbourhood's two spreads across its line at least this near: a tube, no plane
SHEET_GAP = 4.0  # a neighbourhood holds two sheets where its heights part by this many times their spread...
SHEET_POINTS = 3  # ... into groups of at least this many (a plane needs three)
SHEET_NEAREST = 5  # the heights are taken along the plane of this many nearest (itself included)
SHEET_ANGLE = 25.0  # degrees: two groups of points on planes this near parallel are two sheets, not an edge


@dataclass
class CleaningReport:
    """What cleaning found: the ids of the outliers and of the stray points, in input order."""
    input_points: int
    outliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # removed ids, input order
    stray: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    # (n, neighbours + 1) kNN of every input point (itself first), which the denoising reuses (None: not queried);
    # rows and entries are positions in `order`, the tree's leaf order (row j is input point order[j])
    neighbours: np.ndarray | None = field(default=None, repr=False, compare=False)
    tree: cKDTree | None = field(default=None, repr=False, compare=False)  # over the input points, for that kNN

    @property
    def order(self) -> np.ndarray | None:
        """The tree's leaf order, that of `neighbours` (None: no kNN queried)."""
        return None if self.tree is None else self.tree.indices

    @property
    def kept(self) -> np.ndarray:
        """The ids of the points kept, ascending."""
        mask = np.ones(self.input_points, dtype=bool)
        mask[self.outliers] = False
        mask[self.stray] = False
        return np.flatnonzero(mask)

    def to_dict(self) -> dict:
        """The counts, for metrics.json."""
        return {"input_points": self.input_points, "outliers_removed": len(self.outliers),
                "stray_removed": len(self.stray), "kept": self.input_points - len(self.outliers) - len(self.stray)}

    def note(self) -> str:
        """One line for the cloud's notes, made where cleaning removed points."""
        outliers, stray = len(self.outliers), len(self.stray)
        removed = [f"{outliers:,} outlier{'' if outliers == 1 else 's'}" if outliers else "",
                   f"{stray:,} point{'' if stray == 1 else 's'} of stray pieces" if stray else ""]
        return (f"cleaning removed {' and '.join(filter(None, removed))} "
                f"({self.input_points:,} -> {self.input_points - outliers - stray:,} points)")


MIN_KEPT = 20  # cleaning never leaves fewer points than the engine needs
# A neighbourhood at most this flat (surface variation, smallest eigenvalue over their sum: 0 on a plane, 1/3 for a
# ball of scattered points) is a surface's: a tenth of a volume's. A torus's sparse points beside a dense blob read
# 0.005, points scattered through a box 0.17, the benchmark's outliers 0.09-0.18.
FLAT = 1 / 30


def clean(points: np.ndarray, params: CleaningParams = CleaningParams()) -> CleaningReport:
    """Which points of `points` (n,3) are outliers or stray; the rest are `report.kept`."""
    params = params.validated()
    n = len(points)
    if n <= max(MIN_KEPT, params.neighbours + 1) or not (params.remove_outliers or params.remove_stray):
        return CleaningReport(n)
    # Every step runs in the tree's leaf order, where points near in space lie near in memory: in a file's own order
    # each gather of neighbours misses the cache (a 1M-point torus: 6.8-8.1 -> 5.5-5.7 s, the same results).
    tree = cKDTree(points)
    distance, index = leaf_knn(tree, params.neighbours + 1)
    spacing = distance[:, 1:].mean(axis=1)
    keep = np.ones(n, dtype=bool)
    if params.remove_outliers:
        median = np.median(spacing)
        mad = 1.4826 * np.median(np.abs(spacing - median))
        apart = spacing > params.outlier_ratio * np.median(spacing[index[:, 1:]], axis=1)
        keep &= ~(apart & (spacing > median + params.outlier_spread * max(mad, 1e-12 * median)))
    stray = np.zeros(n, dtype=bool)
    if params.remove_stray:
        stray = stray_pieces(distance, index, spacing, keep, params.piece_gap, params.min_piece_share)
        if stray.any():
            stray &= ~_sparse_surfaces(tree, distance, index, spacing, stray, keep.sum(), params)
        keep &= ~stray
    if keep.sum() < MIN_KEPT:  # nothing left to clean against: keep everything
        return CleaningReport(n, neighbours=index, tree=tree)
    return CleaningReport(n, outliers=np.sort(tree.indices[~keep & ~stray]), stray=np.sort(tree.indices[stray]),
                          neighbours=index, tree=tree)


def _sparse_surfaces(tree: cKDTree, distance: np.ndarray, index: np.ndarray, spacing: np.ndarray,
                     stray: np.ndarray, kept: int, params: CleaningParams) -> np.ndarray:
    """(n,) the `stray` points (leaf order) that are a surface sparser than the rest, not strays: joined at their own
    median spacing, a piece of at least min_piece_share of the `kept` points whose neighbourhoods are flat (median
    surface variation at most FLAT). Where a small dense part holds most of the points (a patch a scanner dwelt
    on), the cloud's median spacing is that part's, and a larger object's steps all exceed the stray rule's gap;
    scattered noise joins at its own spacing too, but its neighbourhoods span a volume."""
    piece = joined_pieces(distance, index, stray, params.piece_gap * np.median(spacing[stray]))
    sizes = np.bincount(piece[stray], minlength=piece.max() + 1)
    rows = np.flatnonzero(stray & (sizes[piece] >= params.min_piece_share * kept))
    surface = np.zeros(len(stray), dtype=bool)
    if len(rows):
        values, _, _ = local_frames(tree.data[tree.indices[index[rows]]])
        variation = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)  # the curvature of eq. 7
        at = np.unique(piece[rows], return_inverse=True)[1].ravel()
        surface[rows[(group_medians(variation, at) <= FLAT)[at]]] = True
    return surface


def cleaned(cloud: Cloud, params: CleaningParams = CleaningParams(), report: CleaningReport | None = None,
            walls: bool = False) -> Cloud:
    """`cloud` without its outliers and stray pieces (those of `report` when given) and, with `denoise`,
    projected onto its local planes; the counts in `cleaning` and a note; its labels follow the points kept;
    mesh faces that lose a corner are dropped and the rest renumbered. walls: also its `surface`, the points
    projected with thin walls' faces kept apart, where that differs (a cloud whose inside test samples its
    points, not the voxel centroids of a reduction)."""
    report = report or clean(cloud.points, params)
    kept = report.kept
    if len(kept) < len(cloud.points) and on_one_line(cloud.points[kept]):
        raise InputError(f"{cloud.name}: without the {len(cloud.points) - len(kept)} points cleaning removed "
                         f"(outliers and stray pieces), all points lie on one line; a surface is needed")
    faces = cloud.faces
    if faces is not None and len(kept) < len(cloud.points):
        new_id = np.full(len(cloud.points), -1, dtype=np.int64)
        new_id[kept] = np.arange(len(kept))
        faces = new_id[faces]
        faces = faces[(faces >= 0).all(axis=1)]
        faces = faces if len(faces) else None
    notes = list(cloud.notes) + ([report.note()] if len(kept) < len(cloud.points) else [])
    points, surface = (_denoised_kept(cloud.points, report, params.neighbours, walls) if params.denoise
                       else (cloud.points[kept], None))
    far = far_pieces(points)
    if far is not None:
        notes.append(f"{int(far.sum()):,} points lie further from the largest piece than its own size: they are "
                     f"skeletonised as pieces of their own and do not set the skeleton's scale")
    return Cloud(points=points, faces=faces, name=cloud.name, notes=notes, cleaning=report.to_dict(),
                 labels=None if cloud.labels is None else cloud.labels[kept], scale=cloud.scale,
                 solid_loops=cloud.solid_loops, solid_pieces=cloud.solid_pieces, surface=surface)


def denoised(points: np.ndarray, neighbours: int, index: np.ndarray | None = None,
             weights: np.ndarray | None = None, walls: bool = False):
    """Each point projected onto the PCA plane of its `neighbours` nearest points (itself included), but where
    they have no plane (`_tube_like`: left as it is).
    `index`: those neighbours when known, (n, neighbours) rows into `points`. `weights`: (n,) how many points
    each stands for (a voxel centroid's count), which weigh the plane's fit (None: one each). walls: also the
    points projected with a thin wall's faces kept apart (`_own_sheets`), which the inside tests sample:
    (projected, kept apart), the latter `projected` itself where no neighbourhood holds two sheets."""
    if len(points) <= neighbours:
        return (points, points) if walls else points
    if index is None:
        _, index = knn(points, neighbours)
    projected = np.empty_like(points)

    def project(start: int) -> tuple[np.ndarray, np.ndarray]:  # a block of CHUNK rows: bounded temporaries
        rows = slice(start, start + CHUNK)
        local = points[index[rows]]
        counts = None if weights is None else weights[index[rows]]
        spreads, frames, mean = local_frames(local, counts)
        tube = _tube_like(spreads)
        projected[rows] = np.where(tube[:, None], points[rows], _onto_plane(points[rows], frames, mean))
        if not walls:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        sheets, frames, mean = _own_sheets(local, points[rows], counts, frames, mean)
        flat = ~tube[sheets]
        return start + sheets[flat], _onto_plane(points[start + sheets[flat]], frames[flat], mean[flat])

    starts = range(0, len(points), CHUNK)
    if len(starts) == 1:
        blocks = [project(0)]
    else:  # numpy's gathers and LAPACK release the GIL: blocks on every core (1M points: 1.8 -> 1.0 s on two)
        with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
            blocks = list(pool.map(project, starts))
    if not walls:
        return projected
    walled = np.concatenate([ids for ids, _ in blocks])
    if not len(walled):
        return projected, projected
    apart = projected.copy()
    apart[walled] = np.concatenate([onto for _, onto in blocks])
    return projected, apart


def _tube_like(spreads: np.ndarray) -> np.ndarray:
    """(n,) which neighbourhoods, by their PCA variances `spreads` (n, 3) ascending, have no plane: curve-like
    (the spread across at most CURVE_RATIO of the spread along, as curveness reads a curve) and about as wide
    in both directions across (ROUND_ACROSS): a thin tube's few points around. A noisy sheet is wide along two
    directions, a ribbon or a crease narrow across one."""
    along, across, least = spreads[:, 2], spreads[:, 1], np.maximum(spreads[:, 0], 0.0)
    return (across <= CURVE_RATIO ** 2 * along) & (least >= ROUND_ACROSS ** 2 * across)


def _onto_plane(points: np.ndarray, frames: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """`points` (n, 3) projected onto the planes through `mean` (n, 1, 3) normal to the frames' first axis."""
    normal = frames[:, :, 0]
    return points - np.einsum("ij,ij->i", points - mean[:, 0], normal)[:, None] * normal


def _own_sheets(local: np.ndarray, centres: np.ndarray, counts: np.ndarray | None, frames: np.ndarray,
                mean: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows whose neighbourhood `local` (n, k, 3) of the point `centres` holds two parallel sheets (a wall or a
    gap thinner than its reach), with the PCA frames and means of the point's own sheet there, from the whole
    neighbourhood's `frames` and `mean` (n, 3, 3), (n, 1, 3): the plane midway between both faces pulls them
    together into one, which no inside test reads (a door pull's back plate closed its opening; a basket's and a
    coffee table's loops were cut as false). Faces meeting at an edge are no such pair."""
    _, near, near_mean = local_frames(local[:, :SHEET_NEAREST])
    other = np.zeros(local.shape[:2], bool)
    # heights along the whole neighbourhood's plane, else along that of the nearest few, which lie on the
    # point's own sheet where both faces tilt the whole one's
    for normal, centre in ((frames[:, :, 0], mean), (near[:, :, 0], near_mean)):
        undecided = ~other.any(axis=1)
        other[undecided] = _other_sheet(
            np.einsum("ikj,ij->ik", local[undecided] - centre[undecided], normal[undecided]),
            np.einsum("ij,ij->i", centres[undecided] - centre[undecided, 0], normal[undecided]))
    walls = np.flatnonzero(other.sum(axis=1) >= SHEET_POINTS)  # one or two points apart make no sheet
    if not len(walls):
        return walls, frames[:0], mean[:0]
    weight = 1.0 if counts is None else counts[walls]
    _, own, own_mean = local_frames(local[walls], np.where(other[walls], 0.0, weight))
    _, across, _ = local_frames(local[walls], np.where(other[walls], weight, 0.0))
    parallel = np.abs(np.einsum("ij,ij->i", own[:, :, 0], across[:, :, 0])) > np.cos(np.radians(SHEET_ANGLE))
    return walls[parallel], own[parallel], own_mean[parallel]


def _other_sheet(heights: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(n, k) which neighbours lie on another sheet than the point, by their `heights` (n, k) and the point's `own`
    (n,) along a plane: two groups of heights apart by more than SHEET_GAP times the spread within either and by
    COLLAPSED of the neighbourhood's size (the rounding of a flat sheet's heights is no gap), the point's own of
    at least SHEET_POINTS; noise spreads one group with no such gap, so a noisy sheet keeps its neighbourhood."""
    order = np.sort(heights, axis=1)
    gaps = np.diff(order, axis=1)
    cut = gaps.argmax(axis=1)  # the widest gap: below it one group, above it the other
    low = np.arange(heights.shape[1])[None, :] <= cut[:, None]
    spread = np.maximum(_group_spread(order, low), _group_spread(order, ~low))
    gap = gaps[np.arange(len(cut)), cut]
    size = np.ptp(order, axis=1)
    split = (order[np.arange(len(cut)), cut] + order[np.arange(len(cut)), cut + 1]) / 2
    mine = (own > split)[:, None] == (heights > split[:, None])
    two = (gap > SHEET_GAP * spread) & (gap > COLLAPSED * size) & (mine.sum(axis=1) >= SHEET_POINTS)
    return two[:, None] & ~mine


def _group_spread(order: np.ndarray, member: np.ndarray) -> np.ndarray:
    """The RMS deviation of each row's heights in `member` from their mean (0 for an empty group)."""
    count = np.maximum(member.sum(axis=1), 1)
    mean = np.where(member, order, 0.0).sum(axis=1) / count
    return np.sqrt(np.where(member, (order - mean[:, None]) ** 2, 0.0).sum(axis=1) / count)


def _denoised_kept(points: np.ndarray, report: CleaningReport, k: int, walls: bool
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """denoised() of the points `report` keeps of the input `points`, in input order, and with `walls` the points
    with thin walls' faces kept apart where any are (else None); with cleaning's kNN at hand, computed in the
    tree's leaf order (clean) on the neighbours read from it."""
    kept = report.kept
    if report.neighbours is None:
        projected, apart = denoised(points[kept], k, walls=True) if walls else (denoised(points[kept], k), None)
        return projected, None if apart is projected else apart
    is_kept = np.zeros(report.input_points, dtype=bool)
    is_kept[kept] = True
    leaf_kept = np.flatnonzero(is_kept[report.order])
    index = _kept_neighbours(report, k, points, leaf_kept)
    in_leaf_order = points[report.order[leaf_kept]]
    projected, apart = (denoised(in_leaf_order, k, index, walls=True) if walls
                        else (denoised(in_leaf_order, k, index), None))
    position = np.empty(report.input_points, dtype=np.int64)
    position[kept] = np.arange(len(kept))
    target = position[report.order[leaf_kept]]  # each leaf row's place in input order

    def in_input_order(values: np.ndarray) -> np.ndarray:
        ordered = np.empty_like(values)
        ordered[target] = values
        return ordered
    return in_input_order(projected), None if apart is None or apart is projected else in_input_order(apart)


def _kept_neighbours(report: CleaningReport, k: int, points: np.ndarray, leaf_kept: np.ndarray) -> np.ndarray:
    """The `k` nearest kept points of every kept point (itself first), both as rows of `leaf_kept` (the leaf
    positions of the kept points, ascending), read from cleaning's kNN of the input `points`: a row holding at
    least k kept points among its neighbours + 1 nearest has them in its first k kept entries. The few other rows
    ask cleaning's tree for more neighbours, until k of them are kept."""
    n = report.input_points
    new_id = np.full(n, -1, dtype=np.int64)
    new_id[leaf_kept] = np.arange(len(leaf_kept))
    leaf = np.empty(n, dtype=np.int64)
    leaf[report.order] = np.arange(n)
    rows = new_id[report.neighbours[leaf_kept]]
    lost = np.flatnonzero(~(rows[:, :k] >= 0).all(axis=1))  # the few rows with a removed point among the first k
    width = rows.shape[1]
    found = rows[lost]
    while len(lost):
        present = found >= 0
        shifted = np.argsort(~present, axis=1, kind="stable")  # kept entries first, in distance order
        rows[lost, :k] = np.take_along_axis(found, shifted, axis=1)[:, :k]
        short = (present.sum(axis=1) < k) & (width < len(points))
        lost, width = lost[short], min(2 * width, len(points))
        if len(lost):
            asked = report.tree.query(points[report.order[leaf_kept[lost]]], k=width, workers=-1)[1]
            found = new_id[leaf[asked.reshape(len(lost), width)]]
    return rows[:, :k]
