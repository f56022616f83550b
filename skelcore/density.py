"""Parts of a cloud far denser than the rest: a small object beside a large one, a patch a scanner dwelt on, a
registration that laid one view over itself.

A rule that judges every point of a neighbourhood lets such a part cost the square of its points: where it fits in
one neighbourhood, each probe among its points judges them all. `capped` names the points of a copy whose
over-dense cells keep only as many points as the cap, a fixed random choice; an evenly sampled cloud has no such
cell, so it is read as it is.

Not used for the cloud's typical spacing (cleaning's median): by counts alone a dense small part beside a sparse
large object (whose median spacing is then the part's) cannot be told from a compact object in sparse scattered
noise (whose cells the noise's single points outnumber); cleaning tells those apart by their neighbourhoods'
flatness instead (skelcore.clean).
"""
from __future__ import annotations

import numpy as np

# A cell holding more than DENSE times the points of the median occupied cell is over-dense. Counts of an evenly
# sampled cloud scatter as Poisson's: with one point a cell, 17 or more come once in 10^15 cells; a part that dense
# puts that many times the points of elsewhere into a neighbourhood, and as many times more probes among them.
DENSE = 16
CELLS_PER_RADIUS = 4  # cells of a quarter of the skeleton's sample radius: far below what it resolves


def capped(points: np.ndarray, cell: float) -> np.ndarray | None:
    """Ids (ascending) of the points kept when every cell of edge `cell` keeps at most DENSE times the points of the
    median occupied cell, the first of a fixed random order; None when no cell holds more."""
    if not len(points):
        return None
    rows, counts = _cells(points, cell)
    cap = int(DENSE * np.median(counts))
    if counts.max() <= cap:
        return None
    order = np.random.default_rng(0).permutation(len(points))
    order = order[np.argsort(rows[order], kind="stable")]
    rank = np.arange(len(points)) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.sort(order[rank < cap])


def _cells(points: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """(the row of each point's cell of edge `cell`, numbered in key order; the points of each cell). A cell's
    three indices are packed into one integer, 21 bits apiece, which tells apart any two cells fewer than 2^20
    apart on every axis (an object spans a few hundred) however far from the origin; so a far-flung stray point
    neither overflows a grid nor stretches one over the empty space between it and the object."""
    cells = np.clip(np.floor(points / cell), -(2.0**62), 2.0**62).astype(np.int64)
    keys = (cells[:, 0] << 42) + (cells[:, 1] << 21) + cells[:, 2]  # wraps past 64 bits, as a packing may
    _, rows, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return rows.ravel(), counts
