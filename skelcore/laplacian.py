"""Cotangent Laplacian over the point one-rings (Cao et al. 2010, eq. 1) and the normal equations of eq. 2.

For one set of rings the sparsity of L is fixed: `LaplacianSystem` works out its pattern once and the
cotangents of every iteration scatter into its slots.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .neighbours import OneRings

COT_LIMIT = 1e4  # a cotangent beyond this comes from a near-degenerate triangle
ROW_LIMIT = 1e4  # cloudcontr rescales rows whose weight sum exceeds this


def cotangent_weights(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and weights of eq. 1: ring triangle (i, j, l) adds cot(angle at l) to w_ij and
    cot(angle at j) to w_il. The weights are not symmetric: every point has its own ring."""
    i, j, l = triangles.T
    pi, pj, pl = points[i], points[j], points[l]
    weights = np.concatenate([_cot(pi - pl, pj - pl), _cot(pi - pj, pl - pj)])
    return np.concatenate([i, i]), np.concatenate([j, l]), weights


class LaplacianSystem:
    """Fixed sparsity of L for one set of rings; values are refilled per iteration.

    The normal matrix W_L^2 L^T L + W_H^2 comes from scipy's sparse product each time: 0.27 s of CPU at 100k
    points. A precomputed list of the entry pairs that share a row of L refills L^T L no faster (0.21-0.30 s)
    and costs 2 s to build, paid again by GLSkeleton after every reduction.
    """

    def __init__(self, rings: OneRings) -> None:
        n = rings.n_points
        self.n = n
        self._triangles = rings.triangles
        i, j, l = rings.triangles.T
        self._rows = np.concatenate([i, i])
        rows = np.concatenate([self._rows, np.arange(n)])
        columns = np.concatenate([j, l, np.arange(n)])
        # Group the entries by row (a stable sort of a few sorted runs: fans come by centre), then sort each row's
        # columns carrying every entry's index along (scipy's per-row sort): 2.3x faster than np.unique of keys.
        by_row = np.argsort(rows, kind="stable")
        grouped = sp.csr_matrix((by_row.astype(np.float64), columns[by_row], _offsets(rows, n)), shape=(n, n))
        grouped.has_sorted_indices = False
        grouped.sort_indices()
        entry_rows = np.repeat(np.arange(n), np.diff(grouped.indptr))
        first = np.ones(len(rows), dtype=bool)  # the first entry of each (row, column)
        first[1:] = (grouped.indices[1:] != grouped.indices[:-1]) | (entry_rows[1:] != entry_rows[:-1])
        slots = np.empty(len(rows), dtype=np.int64)
        slots[grouped.data.astype(np.int64)] = np.cumsum(first) - 1
        self._weight_slots, self._diagonal_slots = slots[: len(self._rows)], slots[len(self._rows):]
        self._l_indices = grouped.indices[first].astype(np.int64)
        self._l_rows = entry_rows[first]
        self._l_indptr = _offsets(self._l_rows, n)

    def laplacian_values(self, points: np.ndarray) -> np.ndarray:
        """The values of L (eq. 1) at `points`, in the order of its fixed sparsity pattern."""
        _, _, weights = cotangent_weights(points, self._triangles)
        # float even without a triangle (numpy's bincount of nothing is of integers)
        row_sum = np.bincount(self._rows, weights=weights, minlength=self.n).astype(np.float64, copy=False)
        scale = np.where(np.abs(row_sum) > ROW_LIMIT, ROW_LIMIT / np.maximum(np.abs(row_sum), 1e-300), 1.0)
        values = np.bincount(self._weight_slots, weights=weights * scale[self._rows],
                             minlength=len(self._l_indices)).astype(np.float64, copy=False)
        values[self._diagonal_slots] -= row_sum * scale
        return values

    def laplacian(self, points: np.ndarray, values: np.ndarray | None = None) -> sp.csr_matrix:
        """L (eq. 1) at `points` as a CSR matrix (`values`: laplacian_values(points), when known)."""
        values = self.laplacian_values(points) if values is None else values
        return sp.csr_matrix((values, self._l_indices, self._l_indptr), shape=(self.n, self.n))

    def normal_matrix(self, points: np.ndarray, wl: float, wh: np.ndarray, row_weights: np.ndarray | None = None,
                      values: np.ndarray | None = None) -> sp.csr_matrix:
        """W_L^2 L^T L + W_H^2, the matrix of the normal equations of eq. 2. `row_weights` (n,): per-point
        contraction weights w, the system's Laplacian rows become W_L w_i L_i (semantic LBC: w_i multiplies
        point i's contraction weight), so the first term is W_L^2 L^T diag(w^2) L. `values`:
        laplacian_values(points), when known."""
        values = self.laplacian_values(points) if values is None else values
        if row_weights is not None:
            values = values * row_weights[self._l_rows]
        laplacian = sp.csr_matrix((values, self._l_indices, self._l_indptr), shape=(self.n, self.n))
        product = (wl**2 * (laplacian.T @ laplacian) + sp.diags(wh**2)).tocsr()
        product.sort_indices()
        return product


def _offsets(rows: np.ndarray, n: int) -> np.ndarray:
    """CSR row offsets of entries grouped by row."""
    return np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))])


def _cot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """cot of the angle between u and v: dot / |cross|, floored against degenerate triangles."""
    (ux, uy, uz), (vx, vy, vz) = u.T, v.T
    dot = ux * vx + uy * vy + uz * vz
    cross = np.sqrt((uy * vz - uz * vy) ** 2 + (uz * vx - ux * vz) ** 2 + (ux * vy - uy * vx) ** 2)
    floor = 1e-12 * np.sqrt((ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz))
    return np.clip(dot / np.maximum(cross, np.maximum(floor, 1e-300)), -COT_LIMIT, COT_LIMIT)
