"""Cotangent Laplacian over the point one-rings (Cao et al. 2010, eq. 1) and the normal equations of eq. 2.

The rings are fixed for a run, so the sparsity of L and of L^T L is too. `LaplacianSystem` works out
both patterns once; every iteration then only fills values: the cotangents scatter into L's slots and
L^T L is a weighted sum over a precomputed list of entry pairs, with no sparse sorting or matrix product
(two to three times faster than scipy's product per iteration, which LBC repeats up to 20 times).
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


def cotangent_laplacian(points: np.ndarray, rings: OneRings) -> sp.csr_matrix:
    """L with L_ij = w_ij and L_ii = -sum_j w_ij (eq. 1)."""
    return LaplacianSystem(rings).laplacian(points)


class LaplacianSystem:
    """Fixed sparsity of L and of L^T L for one set of rings; values are refilled per iteration."""

    def __init__(self, rings: OneRings) -> None:
        n = rings.n_points
        self.n = n
        rows, cols, _ = cotangent_weights(np.zeros((n, 3)), rings.triangles)
        self._triangles = rings.triangles
        self._rows = rows
        keys = np.concatenate([rows * n + cols, np.arange(n) * (n + 1)])
        unique_keys, slots = np.unique(keys, return_inverse=True)
        self._weight_slots, self._diagonal_slots = slots[: len(rows)], slots[len(rows):]
        self._l_indices = unique_keys % n
        l_rows = unique_keys // n
        self._l_indptr = np.searchsorted(l_rows, np.arange(n + 1))
        self._l_rows = l_rows

        # (L^T L)_ab = sum_r L_ra L_rb: every ordered pair of entries that share a row of L.
        row_length = np.diff(self._l_indptr)
        first = np.repeat(np.arange(len(unique_keys)), row_length[l_rows])
        offset = np.arange(len(first)) - np.repeat(np.cumsum(row_length[l_rows]) - row_length[l_rows],
                                                   row_length[l_rows])
        second = self._l_indptr[l_rows[first]] + offset
        # The pattern of L^T L from scipy's sparse product; each pair looks up its slot within its row.
        ones = sp.csr_matrix((np.ones(len(unique_keys)), self._l_indices, self._l_indptr), shape=(n, n))
        pattern = (ones.T @ ones).tocsr()
        pattern.sort_indices()
        slot_of = sp.csr_matrix((np.arange(1, pattern.nnz + 1, dtype=float), pattern.indices, pattern.indptr),
                                shape=(n, n))
        a, b = self._l_indices[first], self._l_indices[second]
        self._pair_slots = np.asarray(slot_of[a, b]).ravel().astype(np.int64) - 1
        self._pair_first, self._pair_second = first, second
        self._m_indices = pattern.indices.astype(np.int64)
        self._m_indptr = pattern.indptr.astype(np.int64)
        self._m_diagonal = np.asarray(slot_of[np.arange(n), np.arange(n)]).ravel().astype(np.int64) - 1

    def laplacian_values(self, points: np.ndarray) -> np.ndarray:
        """The values of L (eq. 1) at `points`, in the order of its fixed sparsity pattern."""
        _, _, weights = cotangent_weights(points, self._triangles)
        row_sum = np.bincount(self._rows, weights=weights, minlength=self.n)
        scale = np.where(np.abs(row_sum) > ROW_LIMIT, ROW_LIMIT / np.maximum(np.abs(row_sum), 1e-300), 1.0)
        values = np.bincount(self._weight_slots, weights=weights * scale[self._rows], minlength=len(self._l_indices))
        values[self._diagonal_slots] -= row_sum * scale
        return values

    def laplacian(self, points: np.ndarray) -> sp.csr_matrix:
        """L (eq. 1) at `points` as a CSR matrix."""
        return sp.csr_matrix((self.laplacian_values(points), self._l_indices, self._l_indptr), shape=(self.n, self.n))

    def normal_matrix(self, points: np.ndarray, wl: float, wh: np.ndarray,
                      row_weights: np.ndarray | None = None) -> sp.csr_matrix:
        """W_L^2 L^T L + W_H^2, the matrix of the normal equations of eq. 2. `row_weights` (n,): per-point
        contraction weights w, the system's Laplacian rows become W_L w_i L_i (semantic LBC: w_i multiplies
        point i's contraction weight), so the first term is W_L^2 L^T diag(w^2) L."""
        values = self.laplacian_values(points)
        if row_weights is not None:
            values = values * row_weights[self._l_rows]
        data = np.bincount(self._pair_slots, weights=values[self._pair_first] * values[self._pair_second],
                           minlength=len(self._m_indices)) * wl**2
        data[self._m_diagonal] += wh**2
        return sp.csr_matrix((data, self._m_indices, self._m_indptr), shape=(self.n, self.n))


def _cot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """cot of the angle between u and v: dot / |cross|, floored against degenerate triangles."""
    (ux, uy, uz), (vx, vy, vz) = u.T, v.T
    dot = ux * vx + uy * vy + uz * vz
    cross = np.sqrt((uy * vz - uz * vy) ** 2 + (uz * vx - ux * vz) ** 2 + (ux * vy - uy * vx) ** 2)
    floor = 1e-12 * np.sqrt((ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz))
    return np.clip(dot / np.maximum(cross, np.maximum(floor, 1e-300)), -COT_LIMIT, COT_LIMIT)
