"""Laplacian-based contraction (Cao et al. 2010) as a generator of per-iteration states.

Each step solves eq. 2, [W_L L; W_H] P' = [0; W_H P], in the least-squares sense through its normal
equations (W_L^2 L^T L + W_H^2) P' = W_H^2 P with one sparse Cholesky factorisation for all three
coordinates. W_L grows by s_L per step up to a cap; W_H,i = W_H0 s_i^0 / s_i^t follows how far each
one-ring has shrunk (cloudcontr: s_i is the smallest distance from point i to its ring).
"""
from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass, field
from typing import Generator

import numpy as np
from .curveness import curve_share
from .errors import ParameterError, SolverError
from .labels import check_weights
from .laplacian import LaplacianSystem
from .neighbours import OneRings, one_rings
from .normalise import Normalisation, robust_extent
from .params import ContractionParams, default_k
from .skeleton import SkeletonParams
from .solver import CholeskySolver

TERMINATION_MESSAGES = {
    "ring_ratio": "the one-ring size ratio stopped falling",
    "max_iterations": "the maximum number of iterations was reached",
    "nan": "the solve produced NaN; the last good state is kept",
    "solver_failure": "the sparse solver failed; the last good state is kept",
    "bbox_growth": "the bounding box grew past its limit; the last good state is kept",
    "collapse": "one step shrank the cloud's length past its limit (a curve collapsing); the last good state is kept",
    "covariance": "the cloud's covariance shows a converged curve",
}
RESTART_FIELDS = ("method", "k", "normalise")


@dataclass(frozen=True)
class IterationState:
    """One iteration of a contraction: the present points and the weights and figures of the step."""
    iteration: int  # 0 is the input
    points: np.ndarray  # (m,3) positions of the present points, in the user's coordinates
    point_ids: np.ndarray  # (m,) ids into the input of the present points
    owner: np.ndarray  # (n,) for each input point, the row of `points` that represents it
    rings: OneRings  # one-rings over the present points
    wl: float
    wh: np.ndarray  # (m,)
    ring_ratio: float  # a_t = sum s^t / sum s^0
    params: ContractionParams
    timings: dict = field(default_factory=dict)  # seconds: rings, laplacian, solve, rest
    termination: str | None = None  # set on the last state of a run (see TERMINATION_MESSAGES)
    message: str = ""

    @property
    def n_points(self) -> int:
        """The number of present points (GLSkeleton: fewer than the input after merges)."""
        return len(self.points)

    @property
    def removed_ids(self) -> np.ndarray:
        """Ids of the input points no longer present (GLSkeleton's absorbed points; empty for LBC)."""
        present = np.zeros(len(self.owner), dtype=bool)
        present[self.point_ids] = True
        return np.flatnonzero(~present)


def contract(points: np.ndarray, params: ContractionParams = ContractionParams(), weights=None, *,
             stages: bool = False) -> Generator[IterationState | None, ContractionParams | None, None]:
    """Yield the input state, then one state per solve; `send(params)` retunes the following steps.

    The last state yielded carries `termination`. When a rule rejects the candidate of a step (NaN,
    solver failure, bounding-box growth, ring ratio no longer falling: cloudcontr discards that step),
    the last accepted state is yielded again with the reason set.
    weights: optional (n,) positive per-point contraction weights; point i's Laplacian row of eq. 2 is
    W_L w_i L_i (see skelcore.labels). None: every weight is 1.
    stages: also yield None between the stages of a step (Laplacian, solve, checks), so that a caller
    can stop within a step and resume it later with next() (the inspector's Pause).
    """
    params = params.validated()
    points = np.asarray(points, dtype=np.float64)
    weights = None if weights is None else check_weights(weights, len(points))
    if params.method != "lbc":
        from .glskeleton import contract_with_reduction
        yield from contract_with_reduction(points, params, weights, stages=stages)
        return
    normalisation = Normalisation.fit(points) if params.normalise else Normalisation.identity()
    unit = normalisation.forward(points)
    k = params.k or default_k(len(points))
    started = time.perf_counter()
    rings = one_rings(unit, k)
    system_builder = LaplacianSystem(rings)  # the sparsity patterns, fixed for the run
    rings_time = time.perf_counter() - started
    sizes0 = rings.sizes(unit)
    auto_wl0 = 1.0 / (5.0 * rings.mean_edge_length(unit))
    ids = np.arange(len(points))
    extent0 = robust_extent(unit)

    state = IterationState(iteration=0, points=points, point_ids=ids, owner=ids, rings=rings,
                           wl=params.wl0 or auto_wl0, wh=np.full(len(points), params.wh0), ring_ratio=1.0,
                           params=params, timings={"rings": rings_time})
    current, sizes, ratio = unit, sizes0, 1.0
    solver = CholeskySolver()
    for iteration in itertools.count(1):
        params, notes = retune(params, (yield state))
        step_start = time.perf_counter()
        wl, wh = schedule(params, auto_wl0, iteration, sizes0, sizes)
        candidate, failure, timings = yield from solve_stages(system_builder, solver, current, wl, wh, params,
                                                              extent0, first_step=iteration == 1, stages=stages,
                                                              row_weights=weights)
        if stages:
            yield None
        if failure is None:
            new_sizes = rings.sizes(candidate)
            new_ratio = float(new_sizes.sum() / sizes0.sum())
            # cloudcontr: from the second step on, stop once a_{t-1} - a_t < threshold; while the rings still
            # shrink, a cloud not yet curve-like (a sheet) goes on contracting, as long as each such step
            # leaves it more curve-like (thin parts pulled into a blob would not)
            drop = ratio - new_ratio
            if iteration > 1 and drop < params.termination and not (drop >= 0 and goes_on(current, candidate, params)):
                failure = ("ring_ratio", f"a_t fell by {drop:.4f} < {params.termination:g}")
        if failure is not None:
            reason, detail = failure
            message = "; ".join(filter(None, [TERMINATION_MESSAGES[reason], detail, *notes]))
            yield dataclasses.replace(state, termination=reason, message=message)
            return
        current, sizes, ratio = candidate, new_sizes, new_ratio
        termination = "max_iterations" if iteration >= params.max_iterations else None
        message = "; ".join(filter(None, [TERMINATION_MESSAGES.get(termination, ""), *notes]))
        user_points = normalisation.inverse(current)
        timings["rest"] = time.perf_counter() - step_start - timings["laplacian"] - timings["solve"]
        state = IterationState(iteration=iteration, points=user_points, point_ids=ids, owner=ids, rings=rings,
                               wl=wl, wh=wh, ring_ratio=ratio, params=params, timings=timings,
                               termination=termination, message=message)
        if termination:
            yield state
            return


def goes_on(current: np.ndarray, candidate: np.ndarray, params: ContractionParams) -> bool:
    """Whether a step past the ring-ratio stall is taken: the candidate (normalised units) is less than
    params.curve_share curve-like at the skeleton's default sample radius, and more so than the current."""
    if params.curve_share <= 0:
        return False
    radius = SkeletonParams.sample_radius * float(np.linalg.norm(robust_extent(current)))
    after = curve_share(candidate, radius)
    return after < params.curve_share and after > curve_share(current, radius)


def schedule(params: ContractionParams, auto_wl0: float, iteration: int, sizes0: np.ndarray,
             sizes: np.ndarray) -> tuple[float, np.ndarray]:
    """W_L = W_L0 s_L^(t-1), capped; W_H,i = W_H0 s_i^0 / s_i^t, capped (DESIGN.md section 3, step 6)."""
    wl = min((params.wl0 or auto_wl0) * params.sl ** (iteration - 1), params.wl_max)
    return wl, np.minimum(params.wh0 * sizes0 / np.maximum(sizes, 1e-300), params.wh_max)


def solve_stages(system_builder: LaplacianSystem, solver: CholeskySolver, current: np.ndarray, wl: float,
                 wh: np.ndarray, params: ContractionParams, extent0: np.ndarray, first_step: bool,
                 stages: bool = False, row_weights: np.ndarray | None = None
                 ) -> Generator[None, None, tuple[np.ndarray | None, tuple[str, str] | None, dict]]:
    """One solve of eq. 2 and the checks that reject its candidate: solver failure, NaN, bounding-box growth
    past params.bbox_growth of the original extent0 (robust extents: a few points flung out by degenerate
    rings do not end the contraction of the rest), and collapse: once a cloud is a thin curve its rings
    degenerate and a step can pull the whole curve together; the longest extent falling below
    params.collapse of the current one in a single step is that, never a contraction onto the skeleton.
    The first step solves on the input's own rings, so it is exempt: an over-strong first step is a
    contraction to show (and judge), not a degenerate one.

    row_weights: per-point contraction weights of the present points (None: all 1).

    A generator for `yield from`: with `stages` it yields None between the Laplacian and the solve; its
    value is (candidate, failure as (reason, detail) or None, timings of 'laplacian' and 'solve')."""
    laplacian_start = time.perf_counter()
    system = system_builder.normal_matrix(current, wl, wh, row_weights)
    laplacian_end = time.perf_counter()
    if stages:  # a pause may land here, between the Laplacian and its solve
        yield None
    solve_start = time.perf_counter()
    failure = None
    try:
        candidate = solver.solve(system, wh[:, None] ** 2 * current)
    except SolverError as error:
        failure, candidate = ("solver_failure", str(error)), None
    solve_end = time.perf_counter()
    timings = {"laplacian": laplacian_end - laplacian_start, "solve": solve_end - solve_start}
    if failure is None and not np.isfinite(candidate).all():
        failure = ("nan", "")
    if failure is None and (robust_extent(candidate) > params.bbox_growth * extent0).any():
        failure = ("bbox_growth", "")
    if failure is None and not first_step:
        longest, before = np.ptp(candidate, axis=0).max(), np.ptp(current, axis=0).max()
        if longest < params.collapse * before:
            failure = ("collapse", f"longest extent {longest / before:.0%} of the step before")
    return candidate, failure, timings


def record(history: list[IterationState], state: IterationState) -> bool:
    """Add a yielded state to a run's history; False when it repeats the last one (a rejected step:
    the last good state again, now with the reason), which it then replaces."""
    if history and history[-1].iteration == state.iteration:
        history[-1] = state
        return False
    history.append(state)
    return True


def run_contraction(points: np.ndarray, params: ContractionParams = ContractionParams(),
                    weights=None) -> list[IterationState]:
    """Run to the end; the last state carries the termination reason."""
    history: list[IterationState] = []
    for state in contract(points, params, weights):
        record(history, state)
    return history


def retune(current: ContractionParams, sent: ContractionParams | None) -> tuple[ContractionParams, list[str]]:
    """The parameters of the next step: those sent into the generator (None: unchanged), checked against
    the run's, with a note naming what changed."""
    if sent is None:
        return current, []
    sent = sent.validated()
    changed = [name for name in current.to_dict() if getattr(sent, name) != getattr(current, name)]
    blocked = [name for name in changed if name in RESTART_FIELDS]
    if blocked:
        raise ParameterError(f"parameter {', '.join(blocked)} can only change on restart")
    note = ", ".join(f"{name}={getattr(sent, name)}" for name in changed)
    return sent, [f"retuned {note}"] if note else []
