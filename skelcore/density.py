"""Parts of a cloud far denser than the rest: a small object beside a large one, a patch a scanner dwelt on, a
registration that laid one view over itself.

A rule that judges every point of a neighbourhood lets such a part cost the square of its points: where it fits in
one neighbourhood, each probe among its points judges them all. `capped` names the points of a copy whose
over-dense cells keep only as many points as the cap, a fixed random choice; an evenly sampled cloud has no such
cell, so it is read as it is. The contraction reads density too (skelcore.multires.thin_dense): `evened` names the
points of a copy whose over-dense parts are brought to about twice the typical density of the surface around them.

Not used for the cloud's typical spacing (cleaning's median): by counts alone a dense small part beside a sparse
large object (whose median spacing is then the part's) cannot be told from a compact object in sparse scattered
noise (whose cells the noise's single points outnumber); cleaning tells those apart by their neighbourhoods'
flatness instead (skelcore.clean).
"""
from __future__ import annotations

import numpy as np

from .distinct import row_groups

# A cell holding more than DENSE times the points of the median occupied cell is over-dense. Counts of an evenly
# sampled cloud scatter as Poisson's: with one point a cell, 17 or more come once in 10^15 cells; a part that dense
# puts that many times the points of elsewhere into a neighbourhood, and as many times more probes among them.
DENSE = 16
CELLS_PER_RADIUS = 4  # cells of a quarter of the skeleton's sample radius: far below what it resolves
# `evened`: a point whose surface density (from its SPACING_NEIGHBOURS-th nearest neighbour) is over DENSE times
# its piece's typical one is over-dense; where a cloud has such points, the parts over EVEN times the typical
# density are brought to about EVEN times. The contraction takes a part a few times denser than the rest in its
# stride (the benchmark's density_30 variant, one half 3.3 times denser, keeps its loops), not one a hundred times.
EVEN = 2
SPACING_NEIGHBOURS = 8
# ... and only where the over-dense points are at least this share of the cloud: fewer barely move W_L0 (from the
# mean ring edge) or a_t, and a few fans of a mesh's small triangles are no patch (the benchmark's clouds have no
# over-dense point; cloudcontr's meshes and scans up to 0.3% in such fans, the reference hand mesh 0.7%, and 2-25%
# where a part's detail is sampled densely; a patch a scanner dwelt on, 13-50% in the measured cases).
OVER_DENSE_SHARE = 0.01
COINCIDENT = 1e-6  # in cells: points closer are read as this far apart (repeated points are not infinitely dense)
# The 13 offsets of a cell's 26 neighbours that follow it in key order: each adjacent pair once.
_FORWARD = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) > (0, 0, 0)])


def capped(points: np.ndarray, cell: float) -> np.ndarray | None:
    """Ids (ascending) of the points kept when every cell of edge `cell` keeps at most DENSE times the points of the
    median occupied cell, the first of a fixed random order; None when no cell holds more."""
    if not len(points):
        return None
    _, rows, counts = _cells(points, cell)
    cap = int(DENSE * np.median(counts))
    if counts.max() <= cap:
        return None
    order = np.random.default_rng(0).permutation(len(points))
    order = order[np.argsort(rows[order], kind="stable")]
    rank = np.arange(len(points)) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.sort(order[rank < cap])


def evened(points: np.ndarray, cell: float) -> np.ndarray | None:
    """Ids (ascending) of the points kept when every part over EVEN times as dense as its piece's typical surface
    is brought to about EVEN times, one point a voxel (that nearest the voxel's centre: a regular subset, whose
    one-rings are as well shaped as the input's; a random one would leave clumps and gaps); None when fewer than
    OVER_DENSE_SHARE of the points are over-dense (over DENSE times).

    A point's density is that of its SPACING_NEIGHBOURS nearest (the inverse square of their reach); a cell of
    edge `cell` reads the median of its points', and a piece's typical density is the median over its cells:
    over its space, so neither a patch holding most of the points nor a few sparse points sets it. A piece is a
    set of occupied cells joined through their 26 neighbours: a separate small object sampled finely (one the
    skeleton must resolve by its own points) more than a cell from a larger one is measured against itself, not
    thinned to the density of the larger one. Counting the points of each cell would not do: a thin handle
    crossing a cell puts more surface into it than a sheet does, and would read dense."""
    from scipy.spatial import cKDTree

    if len(points) <= SPACING_NEIGHBOURS or not cell > 0:
        return None
    keys, rows, _ = _cells(points, cell)
    reach = cKDTree(points).query(points, k=SPACING_NEIGHBOURS + 1, workers=-1)[0][:, -1] / cell  # in cells
    density = 1.0 / np.maximum(reach, COINCIDENT) ** 2
    cell_piece = _pieces(keys)
    piece = cell_piece[rows]
    typical = group_medians(group_medians(density, rows), cell_piece)[piece]
    ratio = density / typical
    if (ratio > DENSE).mean() < OVER_DENSE_SHARE:
        return None
    dense = np.flatnonzero(ratio > EVEN)
    # a point stands for pi r^2 / SPACING_NEIGHBOURS of surface (r its reach), and a plane crosses 1 to 1.7 voxels
    # of edge e per e^2 of its area: voxels of this edge hold about one point of a surface EVEN times as dense
    edge = np.sqrt(np.pi / (SPACING_NEIGHBOURS * EVEN * typical[dense]))
    scaled = points[dense] / cell / edge[:, None]
    voxel = np.floor(scaled)
    voxel_row = row_groups(np.column_stack([voxel, piece[dense]]))[0]
    order = np.lexsort((np.linalg.norm(scaled - voxel - 0.5, axis=1), voxel_row))
    nearest_centre = order[np.r_[True, voxel_row[order][1:] != voxel_row[order][:-1]]]
    keep = ratio <= EVEN
    keep[dense[nearest_centre]] = True
    return np.flatnonzero(keep)


def _pieces(keys: np.ndarray) -> np.ndarray:
    """(m,) the piece of each occupied cell (keys ascending, as `_cells` gives them): cells joined through their
    26 neighbours."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    shifts = (_FORWARD[:, 0] << 42) + (_FORWARD[:, 1] << 21) + _FORWARD[:, 2]  # packed as _cells packs a cell
    neighbour = keys[:, None] + shifts[None, :]
    at = np.minimum(np.searchsorted(keys, neighbour), len(keys) - 1)
    cell, offset = np.nonzero(keys[at] == neighbour)
    graph = coo_matrix((np.ones(len(cell)), (cell, at[cell, offset])), shape=(len(keys), len(keys)))
    return connected_components(graph, directed=False)[1]


def group_medians(values: np.ndarray, group: np.ndarray) -> np.ndarray:
    """(groups,) the median of `values` over each group (group: (n,) ids 0.. with none empty), all groups at once."""
    order = np.lexsort((values, group))
    ordered = values[order]
    sizes = np.bincount(group)
    starts = np.cumsum(sizes) - sizes
    return 0.5 * (ordered[starts + (sizes - 1) // 2] + ordered[starts + sizes // 2])


def _cells(points: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the packed key of each occupied cell of edge `cell`, ascending; the row of each point's cell in them; the
    points of each cell). A cell's three indices are packed into one integer, 21 bits apiece, which tells apart any
    two cells fewer than 2^20 apart on every axis (an object spans a few hundred) however far from the origin; so a
    far-flung stray point neither overflows a grid nor stretches one over the empty space between it and the
    object."""
    cells = np.clip(np.floor(points / cell), -(2.0**62), 2.0**62).astype(np.int64)
    keys = (cells[:, 0] << 42) + (cells[:, 1] << 21) + cells[:, 2]  # wraps past 64 bits, as a packing may
    keys, rows, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return keys, rows.ravel(), counts
