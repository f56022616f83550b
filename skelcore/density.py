"""Parts of a cloud far denser than the rest: a small object beside a large one, a patch a scanner dwelt on, a
registration that laid one view over itself.

Rules that read the cloud's typical spacing as the median over its points, or that judge every point of a
neighbourhood, let such a part stand for the whole: where it holds most of the points, its spacing becomes the
cloud's (cleaning then shredded a large, sparser object into stray pieces and removed all of it), and where it
fits in one neighbourhood, each probe among its points judged them all (work and memory as their square).
`capped` names the points of a copy whose over-dense cells keep only as many points as the cap, a fixed random
choice; an evenly sampled cloud has no such cell, so it is read as it is.
"""
from __future__ import annotations

import numpy as np

from .normalise import SAMPLE_RADIUS, object_diagonal

# A cell holding more than DENSE times the points of the median occupied cell is over-dense. At a typical count of
# 2 an evenly sampled cloud has a cell of 17 or more once in 10^11; a part that dense puts that many times the
# points of elsewhere into a neighbourhood, and as many times more probes among them.
DENSE = 16
CELLS_PER_RADIUS = 4  # cells of a quarter of the skeleton's sample radius: far below what it resolves


def cell_size(points: np.ndarray) -> float:
    """The cells' edge for `points`: a quarter of the skeleton's default sample radius."""
    return SAMPLE_RADIUS * object_diagonal(points) / CELLS_PER_RADIUS


def capped(points: np.ndarray, cell: float) -> np.ndarray | None:
    """Ids (ascending) of the points kept when every cell of edge `cell` keeps at most DENSE times the points of the
    median occupied cell, the first of a fixed random order; None when no cell holds more."""
    rows, counts = _cells(points, cell)
    cap = DENSE * int(np.median(counts))
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


def counted(points: np.ndarray) -> np.ndarray:
    """(n,) the points a statistic of the cloud's typical spacing counts: those `capped` keeps at `cell_size`, all
    of an evenly sampled cloud."""
    kept = capped(points, cell_size(points))
    if kept is None:
        return np.ones(len(points), dtype=bool)
    mask = np.zeros(len(points), dtype=bool)
    mask[kept] = True
    return mask
