"""`skelcore bench`: time the contraction per stage on a torus; every figure is a ratio taken in one run.

Stages per iteration: one-ring (LBC: once per run, shown apart; GLSkeleton: the in-loop reduction and
re-triangulation), Laplacian build (cotangent weights and the normal-equation matrix), factorise+solve, rest
(ring sizes, checks, coordinates). Per-iteration figures are means over the iterations after the first,
whose solve also pays CHOLMOD's one symbolic analysis. The 'ratio' is a whole iteration over one bare
factorise+solve of a matrix of the last iteration; the baseline solves that matrix as pc-skeletor does
(scipy spsolve with SuperLU/COLAMD, once per coordinate: three factorisations).
"""
from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse.linalg as spla

from .contraction import run_contraction
from .laplacian import LaplacianSystem
from .normalise import Normalisation
from .params import ContractionParams
from .shapes import make_shape
from .solver import CholeskySolver, backend


def run_bench(sizes: list[int], *, iterations: int = 4, method: str = "lbc", baseline: bool = False,
              metrics: bool = False, out=print) -> list[dict]:
    """Time the contraction per stage on tori of the given sizes; print a table and return its rows."""
    methods = ["lbc", "glskeleton"] if method == "both" else [method]
    out(f"skelcore bench: torus, {iterations} iterations per run, solver {backend()}")
    rows = []
    for n in sizes:
        points = make_shape("torus", n, seed=0).points
        for name in methods:
            row = _bench_one(points, name, iterations, baseline, metrics)
            rows.append(row)
            _print_row(row, out)
    for name in methods:
        timed = [row for row in rows if row["method"] == name]
        if len(timed) >= 2:
            first, last = timed[0], timed[-1]
            exponent = math.log(last["iteration"] / first["iteration"]) / math.log(last["n"] / first["n"])
            out(f"{name}: time per iteration grows as n^{exponent:.2f} from {first['n']} to {last['n']} points")
    if len(methods) == 2:
        for n in sizes:
            lbc, gls = [next(r for r in rows if r["n"] == n and r["method"] == m) for m in methods]
            out(f"n={n}: glskeleton total {gls['total']:.2f} s vs lbc {lbc['total']:.2f} s: "
                f"speed-up {lbc['total'] / gls['total']:.2f}x")
    return rows


def _bench_one(points: np.ndarray, method: str, iterations: int, baseline: bool, metrics: bool) -> dict:
    # Tiny thresholds make every run do the same number of solves.
    params = ContractionParams(method=method, max_iterations=iterations, termination=1e-9, gl_covariance=1e-9)
    started = time.perf_counter()
    states = run_contraction(points, params)
    total = time.perf_counter() - started
    steady = states[2:] or states[1:]
    stage = {key: float(np.mean([s.timings.get(key, 0.0) for s in steady]))
             for key in ("rings", "laplacian", "solve", "rest")}
    if method == "lbc":
        stage["rings"] = 0.0
    row = {"n": len(points), "method": method, "total": total, "iterations": len(states) - 1,
           "rings_once": states[0].timings["rings"], "first_solve": states[1].timings["solve"], **stage,
           "iteration": sum(stage.values()), "system_sizes": [s.n_points for s in states]}

    if method != "lbc":
        return row  # its matrices shrink every iteration: no single matrix to compare with
    # A matrix of the last iteration solved bare: numeric factorisation and solve only (analysis done).
    last = states[-1]
    current = Normalisation.fit(points).forward(last.points)
    matrix = LaplacianSystem(last.rings).normal_matrix(current, last.wl, last.wh)
    rhs = last.wh[:, None] ** 2 * current
    solver = CholeskySolver()
    solver.solve(matrix, rhs)
    bare_start = time.perf_counter()
    solver.solve(matrix, rhs)
    row["bare_solve"] = time.perf_counter() - bare_start
    row["ratio"] = row["iteration"] / row["bare_solve"]
    if baseline:
        superlu_start = time.perf_counter()
        csc = matrix.tocsc()
        for column in range(3):
            spla.spsolve(csc, rhs[:, column])
        row["baseline"] = time.perf_counter() - superlu_start
    if metrics:
        from .io import Cloud
        from .pipeline import IterationMetricsCache

        cache = IterationMetricsCache(Cloud(points=points))
        cache.get(states, 0)
        metrics_start = time.perf_counter()
        cache.get(states, 1)
        row["metrics"] = time.perf_counter() - metrics_start
    return row


def _print_row(row: dict, out) -> None:
    out(f"\n{row['method']}  n={row['n']}  ({row['iterations']} iterations, total {row['total']:.2f} s; once per run: "
        f"one-rings and sparsity patterns {row['rings_once']:.3f} s, first solve with symbolic analysis {row['first_solve']:.3f} s)")
    out(f"  per iteration: one-ring {row['rings']:.4f} s | laplacian {row['laplacian']:.4f} s | "
        f"factorise+solve {row['solve']:.4f} s | rest {row['rest']:.4f} s | whole {row['iteration']:.4f} s")
    if len(set(row["system_sizes"])) > 1:
        out(f"  system size per iteration: {row['system_sizes']}")
    if "bare_solve" in row:
        out(f"  bare factorise+solve of the same matrix {row['bare_solve']:.4f} s -> ratio whole/bare {row['ratio']:.2f}")
    if "baseline" in row:
        out(f"  pc-skeletor-style solve (3x SuperLU) {row['baseline']:.4f} s -> our whole iteration is "
            f"{row['baseline'] / row['iteration']:.1f}x faster")
    if "metrics" in row:
        out(f"  metrics for one iteration {row['metrics']:.4f} s = {100 * row['metrics'] / row['iteration']:.0f}% "
            f"of one contraction iteration")
