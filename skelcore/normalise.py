"""cloudcontr's normalisation (GS.normalize): centre the bounding box, largest extent 1.6.

The box is the OBJECT's box (`object_box`): stray points far from the object, which a scan leaves and which
cleaning may be told to keep, and pieces lying further from the object than its own size (a second object, a
patch of background), neither rescale nor shift it, so they cannot shrink the object in the working frame nor
the skeleton's sample radius that is a fraction of its diagonal."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNIT_EXTENT = 1.6


@dataclass(frozen=True)
class Normalisation:
    """The similarity to the working frame: bounding box centred, largest extent scaled to UNIT_EXTENT."""
    centre: np.ndarray
    scale: float

    @classmethod
    def fit(cls, points: np.ndarray) -> "Normalisation":
        low, high = object_box(points)
        return cls(centre=(low + high) / 2, scale=UNIT_EXTENT / float((high - low).max()))

    @classmethod
    def identity(cls) -> "Normalisation":
        return cls(centre=np.zeros(3), scale=1.0)

    def forward(self, points: np.ndarray) -> np.ndarray:
        """Points in the working frame."""
        return (points - self.centre) * self.scale

    def inverse(self, points: np.ndarray) -> np.ndarray:
        """Points back in the user's frame."""
        return points / self.scale + self.centre


def bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(3,) lowest and highest coordinates on each axis. Column by column: min(axis=0) of an (n,3) array
    reduces across strided rows, about 10x slower on a million points."""
    return np.array([column.min() for column in points.T]), np.array([column.max() for column in points.T])


def half_extent(points: np.ndarray) -> float:
    """Half the largest extent of the points' bounding box, computed from halves: it cannot overflow."""
    low, high = bounds(points)
    return float(np.max(high / 2 - low / 2))


def binary_unit(length: float) -> float:
    """The power of two in (length, 2 length]: coordinates divided by it (exactly) bring `length` to [0.5, 1);
    from 2^1023 on, where that power would be inf, 2^1023 itself (`length` to [1, 2))."""
    return float(np.ldexp(1.0, min(int(np.frexp(length)[1]), 1023)))


ROBUST_SHARE = 0.01  # the share of points each side that a robust extent ignores
# How far past the middle 98% a point may lie, in robust extents, and still belong to the object: a fence in
# the manner of Tukey's. The object's own extremities (a tail, a branch tip, a noisy or partial scan's rim)
# reach at most 0.25 on the 20 benchmark shapes and their scan-like variants; strays beyond are not the object.
OBJECT_FENCE = 0.5


def _middle_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(3,) low and high ends of the middle 98% of the points along each axis. Column by column: np.quantile
    along axis 0 of an (n,3) array partitions strided data, about 5x slower on a million points."""
    ends = np.array([np.quantile(points[:, axis], [ROBUST_SHARE, 1.0 - ROBUST_SHARE])
                     for axis in range(points.shape[1])])
    return ends[:, 0], ends[:, 1]


def robust_extent(points: np.ndarray) -> np.ndarray:
    """(3,) the extent of the middle 98% of the points along each axis: a few points flung far by a
    degenerate ring, or stray points a scan left, do not change it."""
    low, high = _middle_box(points)
    return high - low


# Cells along the largest extent of the grid that finds pieces apart (`far_pieces`). Pieces within two cells of
# each other are one piece to it, so a piece is found far only once its gap also exceeds an eighth of the cloud's
# largest extent: a piece it misses lies near the object, inside the box the object and its close pieces span.
PIECE_GRID = 16
# Points per occupied cell below which the grid's gaps are the sampling's: a surface sampled p points a cell has a
# spacing of about a cell over sqrt(p), so the two-cell gap between pieces is 2 sqrt(p) spacings, which at 4 is
# beyond cleaning's piece_gap (3 spacings). A sparse cloud (tens of points) breaks into such pieces of a few
# points each, none of which is an object whose size could set the scale.
MIN_PER_CELL = 4


def pieces_apart(points: np.ndarray) -> np.ndarray | None:
    """(n,) 0 for the points of the object, 1, 2, ... for those of each piece whose gap to the object exceeds the
    object's own largest extent: the object is the piece holding the most points with the pieces near it; None
    when nothing lies that far, or when the cloud is sampled too sparsely for the grid (MIN_PER_CELL). A cluster
    of a few percent of the points that far (a second object, a patch of wall) would otherwise pull the middle
    98% out to it and, as it sets the scale, shrink the object to a few nodes; so would a row of like objects
    far apart, where no piece holds most of the cloud: each is resolved at the scale of the largest (which of
    equals does not matter, the others are far from it too)."""
    from .regions import dilated, label_regions  # scipy: imported only when a cloud is measured

    low, high = bounds(points)
    size = float((high - low).max()) / PIECE_GRID
    if not size > 0:
        return None
    shape = np.minimum(((high - low) / size).astype(np.int64) + 1, PIECE_GRID)
    cell = np.zeros(len(points), np.int64)  # the flat cell of each point, built column by column (see `bounds`)
    for axis, column in enumerate(points.T):
        cell *= shape[axis]
        cell += np.minimum(((column - low[axis]) / size).astype(np.int64), shape[axis] - 1)
    occupied = (np.bincount(cell, minlength=int(np.prod(shape))) > 0).reshape(shape)
    if len(points) < MIN_PER_CELL * occupied.sum():
        return None
    regions, count = label_regions(dilated(occupied))  # cells within two of each other: one piece
    if count < 2:
        return None
    piece = regions.ravel()[cell] - 1
    members = piece == int(np.argmax(np.bincount(piece, minlength=count)))
    main_low, main_high = bounds(points[members])
    piece_low, piece_high = np.full((count, 3), np.inf), np.full((count, 3), -np.inf)
    np.minimum.at(piece_low, piece, points)
    np.maximum.at(piece_high, piece, points)
    gap = np.linalg.norm(np.maximum(np.maximum(piece_low - main_high, main_low - piece_high), 0.0), axis=1)
    far = gap > float((main_high - main_low).max())
    if not far.any():
        return None
    number = np.zeros(count, np.int64)
    number[far] = np.arange(1, far.sum() + 1)
    return number[piece]


def far_pieces(points: np.ndarray) -> np.ndarray | None:
    """(n,) True for the points of pieces far from the object (`pieces_apart`), None when there are none."""
    apart = pieces_apart(points)
    return None if apart is None else apart > 0


def object_core(points: np.ndarray) -> np.ndarray | None:
    """(n,) True for the points of the object: not in `far_pieces`, and within OBJECT_FENCE robust extents of the
    middle 98% of the rest on every axis (the object without the strays far out); None when nothing lies far out
    (every point belongs)."""
    far = far_pieces(points)
    low, high = _middle_box(points if far is None else points[~far])
    margin = OBJECT_FENCE * (high - low)
    lowest, highest = bounds(points)
    if far is None and (lowest >= low - margin).all() and (highest <= high + margin).all():
        return None
    inside = np.all((points >= low - margin) & (points <= high + margin), axis=1)
    return None if inside.all() else inside  # far pieces within the fence of the object and its near pieces


def object_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box of the object_core: the whole cloud's box when nothing lies far out, the object's alone
    when strays do."""
    inside = object_core(points)
    return bounds(points if inside is None else points[inside])


# The skeleton's ball radius by default (SkeletonParams.sample_radius), a fraction of `object_diagonal`: owned
# here, where the object's scale is, so that loading can weigh coordinates against it without the skeleton.
SAMPLE_RADIUS = 0.02


def object_diagonal(points: np.ndarray) -> float:
    """The diagonal of `object_box`: the scale of the skeleton's sample radius and of the metrics."""
    low, high = object_box(points)
    return float(np.linalg.norm(high - low))
