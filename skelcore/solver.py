"""Sparse Cholesky for the normal equations of eq. 2.

CHOLMOD through scikit-sparse when it is installed (the set-up builds it against Debian's SuiteSparse
and OpenBLAS): the symbolic analysis is kept while the sparsity pattern stays the same, so an LBC
iteration pays for the numeric factorisation only, and it refactorises in place into the factor of the
analysis (a new factor per call would copy the symbolic one and allocate its values afresh: 13-17% more CPU
per factor+solve at 43.5k points). Otherwise cholespy (a plain wheel; CHOLMOD inside, but it analyses and
factorises anew every call).

Measured and left out (30k-point noisy torus, CPU, one thread): the quasi-definite augmented system
[[-I, W_L L], [W_L L^T, W_H^2]] has L's pattern only (480k entries against the normal matrix's 622k) and
CHOLMOD's simplicial LDL^T solves it to 2e-11 of the normal equations, but its factor is no sparser
(3.6M entries with AMD, 2.8M with METIS, against 3.9M) and, without supernodes, it is slower: 0.22-0.52 s
against 0.15 s per factor+solve. CHOLMOD's own A A^T + I factorisation (no scipy product) saves 5%.
GLSkeleton reusing the last ordering after a reduction (restricted to the kept points, a merged pair at
the later rank) fills 1.3-7.4x more than a new AMD, whose analysis costs a third of a factorisation.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .errors import SolverError

# CHOLMOD's default analysis tries AMD and, when AMD's fill is high (every cloud from about 30k points),
# METIS as well: at 100k that analysis costs about one factorisation more (CPU time 1.2 s against AMD's 0.3 s)
# and buys a factor of 12.7M instead of 16.1M entries, which a few solves never win back. GLSkeleton
# analyses anew after every reduction; LBC once.
ORDERING = "amd"

try:
    from sksparse.cholmod import CholmodError, analyze
except ImportError:  # the plain-wheel fallback
    analyze = None
    CholmodError = RuntimeError


def backend() -> str:
    """The name of the sparse Cholesky in use."""
    return "scikit-sparse (CHOLMOD)" if analyze is not None else "cholespy (CHOLMOD)"


class CholeskySolver:
    """Solves symmetric positive-definite systems with one numeric factorisation per call."""

    def __init__(self) -> None:
        self._analysis = None
        self._pattern: tuple[np.ndarray, np.ndarray] | None = None

    def solve(self, system: sp.spmatrix, rhs: np.ndarray) -> np.ndarray:
        """Solve system @ x = rhs (rhs (n,) or (n,k)); a SolverError when the factorisation fails."""
        system = system.tocsr()
        try:
            if analyze is not None:
                return self._solve_cholmod(system, rhs)
            return _solve_cholespy(system, rhs)
        except (CholmodError, RuntimeError, ValueError, MemoryError) as error:
            raise SolverError(f"Cholesky factorisation failed ({_reason(error)})") from None

    def _solve_cholmod(self, system: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
        # A symmetric CSR matrix read as CSC is itself: no copy, no transpose.
        matrix = sp.csc_matrix((system.data, system.indices, system.indptr), shape=system.shape)
        pattern = (matrix.indptr, matrix.indices)
        if self._pattern is None or not (np.array_equal(pattern[0], self._pattern[0])
                                         and np.array_equal(pattern[1], self._pattern[1])):
            self._analysis = analyze(matrix, ordering_method=ORDERING)
        self._pattern = None  # until the factorisation succeeds: a failed one leaves no factor to refill
        self._analysis.cholesky_inplace(matrix)
        self._pattern = pattern
        return np.asarray(self._analysis(np.asarray(rhs, dtype=np.float64)))


def _reason(error: Exception) -> str:
    """The solver's complaint in our words (its own text names C source files and C++ exceptions)."""
    text = str(error).lower()
    if isinstance(error, MemoryError) or "bad_alloc" in text or "out of memory" in text:
        return "out of memory"
    if "positive definite" in text:
        return "the system is not positive definite: the one-rings have degenerated"
    if "nan" in text or "inf" in text:
        return "the system holds values that are not finite"
    return "the solver reported an error"


def _solve_cholespy(system: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
    from cholespy import CholeskySolverD, MatrixType

    solver = CholeskySolverD(system.shape[0], system.indptr.astype(np.int32), system.indices.astype(np.int32),
                             system.data.astype(np.float64), MatrixType.CSR)
    solution = np.zeros(rhs.shape, dtype=np.float64)
    solver.solve(np.ascontiguousarray(rhs, dtype=np.float64), solution)
    return solution
