"""GLSkeleton (Wen et al., RA-L 2024): Laplacian-based contraction with in-loop point reduction.

Each step is an LBC solve (Cao et al. 2010, eq. 2; same weights and schedule as LBC, skelcore.step). After
it, points whose local contraction has converged absorb their nearest ring neighbour, so the next system is
smaller. The rules follow the authors' MATLAB (weiqimeng1/GLSkeleton, Source/
laplacian_contraction_with_reduction.m, "LCWR" below, and the files it calls); in the run's frame:

Merge rule, after solve t (LCWR lines 96-104 for t = 1, 158-166 after; Remove_points_in_rings.m lines 14-17):
  G_i = (L(x_{t-1}) x_{t-1})_i, the Laplacian vector that drove the step; d_i = p_i^0 - x_i^t;
  s_i^0, s_i^t the ring sizes (smallest distance to the ring) at the input and now; a_t = sum s^t / sum s^0;
  c = CONTROL a_1 at t = 1, CONTROL (a_{t-1} - a_t) after;  rho_i = max(s_i^t - c s_i^0, S_FLOOR) / s_i^0;
  score_i = |s_L^(t+1) W_L0 rho_i G_i|^2 - |c s_i^0 / (s_i^0 - s_i^t) / rho_i d_i|^2 + SMOOTH |G_i - mean_ring G|^2
  and point i absorbs its nearest ring neighbour j when score_i < gl_merge (s_i^t)^2 (a NaN score never
  merges, as in MATLAB) and point i is curve-like (below). MATLAB's smoothness term reads G of row 1 instead
  of G_i, an evident slip: we use G_i. A point takes part in at most one merge per step; the MATLAB pairs
  them greedily in index order, we pair them greedily in a fixed random order of the input ids (parallel
  rounds; index order makes long chains, hence many rounds, on spatially sorted files).
Curve-like points only (not in LCWR): in this frame the threshold admits nearly every point at every step (the
  force and smoothness terms are ~1e-3 against gl_merge s^2 ~ 4), so LCWR merges points whether or not their
  contraction has converged. Merged early, a bulky part contracts as a coarser cloud whose merges re-form
  longer rings at every step: a thick torus flattens into an annulus that the next solves shorten instead of
  thinning (its ring shrank to 0.6 of its radius, skeleton 8x LBC's Chamfer distance). A point may merge only
  where the candidate is curve-like at the skeleton's scale (skelcore.curveness.curve_like_points, the scale
  the skeleton samples at): there the contraction has reached the curve the skeleton draws, and merging
  thins out points along it. Points the rule admits elsewhere wait for a later step.
Share cap (not in LCWR): the score still ranks the points: at most gl_merge_share of them qualify per step,
  those furthest below the threshold, and of them the curve-like ones merge (gl_merge_share = 1: every admitted
  curve-like point). Both must agree: filling the share with curve-like points of poorer score reduced an
  animal's thin legs so fast that they zipped together below its shoulder (two junctions for one).
Merged ring (Ring_combination.m): the Delaunay fan of both rings at the input positions (skelcore.ring_merge).
  The absorbed point leaves the system; the absorber keeps its position and its ring sizes (LCWR lines 110-111,
  124). The first step whose rule admits no point at all ends the reduction for the run (`cflag`).
Attraction weights (not in LCWR): LBC's W_H,i times m_i, the number of input points that point i stands
  for. A cot Laplacian row scales with the area per point, so a merged point is pulled m_i times harder
  while LCWR leaves its attraction at one point's: every reduction acts as a larger W_L (x2.6 on the helix
  by step 3, about one s_L step ahead of LBC) and a thin coil shrinks onto its axis. With the weight, eq. 2
  keeps the balance it has on the input cloud. With balance_density (skelcore.step) m_i is the summed area
  of those input points, in units of the mean input point's: an unevenly sampled input is balanced too.
Torn steps (not in LCWR): as in LBC (skelcore.stop_rules.torn), a step that widens many one-rings past twice their
  size (the rings it solved with) is discarded and the run ends ('torn').
Per-point contraction weights (semantic LBC, skelcore.labels; not in LCWR): a point's Laplacian row is scaled
  by the mean weight of the input points it stands for. The merge rule reads the unweighted Laplacian: it
  judges whether a neighbourhood has converged, not how hard it is pulled.
Termination (LCWR lines 145-151): e = (lambda_1 + lambda_2 + 2 lambda_3) / (2 sum lambda), lambda the
  eigenvalues (ascending) of the covariance of the present points, tends to 1 as the cloud becomes a line.
  From step COVARIANCE_FROM on, stop when |e_t - e_{t-1}| (1 - removed share of the input in step t)
  < gl_covariance ('covariance'). MATLAB keeps the factor of the last reducing step once reduction has
  stopped; we use the step's own share (0 once nothing merges). MATLAB tests the two states before its
  new solve and discards that solve; testing right after the reduction gives the same final state.
  Also as in LCWR: NaN, bounding-box growth past bbox_growth (lines 137-143), max_iterations; and LBC's
  collapse guard and solver failure. LCWR has no ring-ratio rule (its `tc` is read and unused), and a_t itself no longer
  falls monotonically (a merge removes a point's nearest neighbour, so its ring size jumps). We keep LBC's
  rule, as a safeguard, on what one step does to the rings it solved with: from step 2, stop ('ring_ratio',
  the step discarded as in LBC) when sum_i (s_i before - s_i after) / sum s^0 < termination, even where the
  covariance rule would end on its state: a step that no longer shrinks the rings only shortens curves (on an
  unevenly sampled plate with three holes, the state such a step left had lost one of them).
Curves first (not in LCWR): the covariance of a whole plate or block barely changes while it thins to its
  medial sheet, so the covariance rule alone stops there (a drilled plate: 3 steps, its hole lost). It stops
  only a cloud at least curve_share curve-like (skelcore.curveness); until then the ring-ratio rule ends the
  run, and, as in LBC, lets a cloud go on while each step makes it more curve-like.
The constants assume the normalised frame (bounding box 1.6), as the MATLAB does.
"""
from __future__ import annotations

import time
from typing import Generator

import numpy as np

from .curveness import curve_like_points
from .laplacian import LaplacianSystem
from .neighbours import OneRings
from .params import ContractionParams
from .ring_merge import greedy_matching, merge_rings
from .skeleton import SkeletonParams
from .solver import CholeskySolver
from .step import (TERMINATION_MESSAGES, IterationState, Redo, anchored, contraction_rows, free_points, grown,
                   hold_curves, rejected, represented, retune, schedule, shown, solve_stages, stall_ratios, start_run,
                   stopped, wl_growth)
from .stop_rules import curve_like, rings_stalled, torn

CONTROL = 1.2  # LCWR `Controled_ratio` factor
S_FLOOR = 1e-4  # LCWR `S(S<0)=0.0001`
SMOOTH = 3.0  # weight of the Laplacian-difference term (Remove_points_in_rings.m line 15)
COVARIANCE_FROM = 3  # LCWR `t>=3`: the covariance rule is tested from the third step on
PRIORITY_SEED = 0


def contract_with_reduction(points: np.ndarray, params: ContractionParams, weights: np.ndarray | None = None, *,
                            stages: bool = False) -> Generator[IterationState | None, ContractionParams | Redo | None, None]:
    """GLSkeleton as a generator with the same protocol as skelcore.contraction.contract. `weights`: (n,)
    per-point contraction weights of the input points, checked; a merged point carries their mean over the
    input points it stands for."""
    run = start_run(points, params)
    state, rings, builder, auto_wl0 = run.state, run.rings, run.builder, run.auto_wl0
    unit, sizes0 = run.unit, run.sizes0
    n = len(unit)
    ids = owner = state.point_ids
    priority = np.random.default_rng(PRIORITY_SEED).permutation(n)  # merge order, by input id
    current, sizes, start_sizes, ratio = unit, sizes0, sizes0, 1.0
    score, reducing = _covariance_score(unit), True
    solver = CholeskySolver()
    held = np.full(n, np.inf)  # W_L held on thin parts' axes (step.hold_curves)
    iteration, earlier, first_ratio = 0, None, 1.0  # earlier: the accepted state before `state`; a_t after step 1

    def carried():  # what the loop carries from step to step: a Redo restores it
        return (iteration, state, earlier, rings, builder, current, sizes, sizes0, start_sizes, ratio, score, reducing,
                held, ids, owner, first_ratio)

    before = carried()
    while True:
        sent = yield state
        if isinstance(sent, Redo):
            (iteration, state, earlier, rings, builder, current, sizes, sizes0, start_sizes, ratio, score, reducing,
             held, ids, owner, first_ratio), sent = before, sent.params
        elif state.termination:
            return
        params, notes = retune(params, sent)
        before = carried()
        iteration += 1
        step_start = time.perf_counter()
        growth = wl_growth(state, params)
        wl, wh = schedule(params, auto_wl0, growth, sizes0, sizes)
        # A point standing for m input points carries m times their Laplacian (cot rows scale with the area
        # per point), so its attraction row is weighted by their area (their count without balance_density)
        # to keep eq. 2's balance of the input cloud.
        wh = np.minimum(wh * represented(owner, run.areas, len(ids), params), params.wh_max)
        wh = anchored(wh, run, ids, params)
        # Per-point contraction weights: the mean over the input points a point stands for, so a point of
        # one label keeps its label's weight and a merge across labels blends them by point count.
        row_weights = None if weights is None else (np.bincount(owner, weights=weights, minlength=len(ids))
                                                     / np.bincount(owner, minlength=len(ids)))
        row_weights = contraction_rows(held, wl, row_weights, params)
        laplacian_start = time.perf_counter()
        values = builder.laplacian_values(current)  # L(x_{t-1}): the solve's and the merge rule's (G_i)
        laplacian_time = time.perf_counter() - laplacian_start
        candidate, failure, timings = yield from solve_stages(builder, solver, current, wl, wh, params, run,
                                                              first_step=iteration == 1, stages=stages,
                                                              row_weights=row_weights, laplacian_values=values)
        timings["laplacian"] += laplacian_time
        if stages:
            yield None
        if failure is not None:
            state = rejected(state, earlier, run, *failure, notes)
            continue
        new_sizes, nearest = _nearest_in_ring(rings, candidate)
        free = free_points(run, ids, params)
        new_ratio = float(new_sizes[free].sum() / sizes0[free].sum())
        # LBC's rule, on the rings of this solve: stop once the step shrinks them by less than `termination`
        drop = float((start_sizes[free].sum() - new_sizes[free].sum()) / sizes0[free].sum())
        # as in LBC (skelcore.contraction): a cloud not yet curve-like goes on while each step makes it more so
        ratios = stall_ratios(first_ratio, earlier, state)
        if rings_stalled(iteration, drop, current, candidate, params, run.diagonal, ratios):
            moved = (f"shrank the rings by {drop:.4f} < {params.termination:g}" if drop >= 0
                     else f"widened the rings by {-drop:.4f}")
            state = stopped(state, "ring_ratio", f"the step {moved}", notes)
            continue
        tear = torn(iteration, start_sizes, new_sizes)
        if tear is not None:
            state = stopped(state, *tear, notes)
            continue

        keep, new_row = np.ones(len(ids), dtype=bool), np.arange(len(ids))
        reduce_start = time.perf_counter()
        if reducing:
            gamma = builder.laplacian(current, values) @ current
            control = CONTROL * (new_ratio if iteration == 1 else ratio - new_ratio)
            force = grown((params.wl0 or auto_wl0) * growth, params.sl, 2)  # W_L two steps on
            qualified = np.flatnonzero(merge_rule(gamma, rings, new_sizes, sizes0, unit[ids] - candidate, control,
                                                  force, params.gl_merge, params.gl_merge_share))
            absorbers = qualified[curve_like_points(candidate, SkeletonParams.sample_radius * run.diagonal,
                                                    at=qualified)] if len(qualified) else qualified
            if len(absorbers) or not len(qualified):  # else the qualified points wait for curve-like parts
                pairs = greedy_matching(absorbers, nearest[absorbers], priority[ids[absorbers]], len(ids))
                merged = merge_rings(rings, absorbers[pairs], nearest[absorbers[pairs]], gamma, unit[ids])
                if merged is None:
                    reducing = False
                    notes.append("point reduction stopped: no point met the merge rule")
                else:
                    rings, keep, new_row = merged
                    pattern_start = time.perf_counter()
                    builder = LaplacianSystem(rings)
                    timings["pattern"] = time.perf_counter() - pattern_start
        timings["rings"] = time.perf_counter() - reduce_start - timings.get("pattern", 0.0)

        current, sizes, sizes0, wh = candidate[keep], new_sizes[keep], sizes0[keep], wh[keep]
        held = hold_curves(wl, current, run) if iteration == 1 else held[keep]
        first_ratio = new_ratio if iteration == 1 else first_ratio
        start_sizes = rings.sizes(current) if len(current) < len(keep) else sizes
        share_removed = (len(ids) - len(current)) / n
        ids, owner, ratio = ids[keep], new_row[owner], new_ratio
        previous, score = score, _covariance_score(current)
        change = abs(score - previous) * (1.0 - share_removed)
        termination, detail = None, ""
        if covariance_settled(iteration, change, current, params, run.diagonal):
            termination, detail = "covariance", f"score changed by {change:.4f} < {params.gl_covariance:g}"
        elif iteration >= params.max_iterations:
            termination = "max_iterations"
        message = "; ".join(filter(None, [TERMINATION_MESSAGES.get(termination, ""), detail, *notes]))
        timings["rest"] = time.perf_counter() - step_start - sum(timings.values())
        shown_points, anchored_count = shown(current, run, ids, params)
        earlier, state = state, IterationState(iteration=iteration, points=shown_points, point_ids=ids, owner=owner,
                                               rings=rings, wl=wl, wh=wh, ring_ratio=ratio, params=params,
                                               timings=timings, termination=termination, message=message,
                                               anchored=anchored_count, wl_growth=growth)


def covariance_settled(iteration: int, change: float, points: np.ndarray, params: ContractionParams,
                       diagonal: float) -> bool:
    """LCWR's stop rule (module docstring, termination) after a step that changed the covariance score by `change`
    (weighted by the share of the input it kept) and left `points`. The covariance of the whole cloud barely
    changes while a plate or a block thins to its medial sheet, so the rule alone stops on a sheet: it waits until
    the cloud is curve-like (till then the ring-ratio rule tells when the contraction has stalled)."""
    return (iteration >= COVARIANCE_FROM and change < params.gl_covariance
            and curve_like(points, params, diagonal))


def merge_rule(gamma: np.ndarray, rings: OneRings, sizes: np.ndarray, sizes0: np.ndarray, moved: np.ndarray,
               control: float, force: float, threshold: float, share: float = 1.0) -> np.ndarray:
    """Which points qualify to absorb their nearest ring neighbour by LCWR's score (module docstring, merge rule;
    the curve test is the caller's); `moved` = p^0 - x^t. At most `share` of the points qualify: those furthest
    below the threshold."""
    rho = np.where(sizes - control * sizes0 > 0, sizes - control * sizes0, S_FLOOR) / sizes0
    counts = np.diff(rings.indptr)
    ring_mean = np.add.reduceat(gamma[rings.indices], rings.indptr[:-1]) / counts[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):  # a ring that has not shrunk: infinite push
        push = (control * sizes0 / (sizes0 - sizes) / rho)[:, None] * moved
        score = (_square(force * rho[:, None] * gamma) - _square(push)
                 + SMOOTH * _square(gamma - ring_mean))
        margin = np.where(np.isnan(score), np.inf, score - threshold * sizes**2)
    merging = margin < 0
    most = int(share * len(margin))
    if merging.sum() > most:
        merging[:] = False
        merging[np.argsort(margin, kind="stable")[:most]] = True
    return merging


def _nearest_in_ring(rings: OneRings, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ring size s_i (smallest distance to the ring) and the row of that nearest ring neighbour (get_ring_size.m)."""
    centres = rings.centres()
    lengths = np.linalg.norm(points[rings.indices] - points[centres], axis=1)
    sizes = np.minimum.reduceat(lengths, rings.indptr[:-1])
    hits = np.flatnonzero(lengths == sizes[centres])  # in entry order, so grouped by centre
    first = np.ones(len(hits), dtype=bool)
    first[1:] = centres[hits[1:]] != centres[hits[:-1]]
    return sizes, rings.indices[hits[first]]


def _covariance_score(points: np.ndarray) -> float:
    """(lambda_1 + lambda_2 + 2 lambda_3) / (2 sum lambda) of the covariance (LCWR lines 146-148)."""
    eigenvalues = np.linalg.eigvalsh(np.cov(points.T))
    return float((eigenvalues.sum() + eigenvalues[-1]) / (2.0 * eigenvalues.sum()))


def _square(vectors: np.ndarray) -> np.ndarray:
    return (vectors * vectors).sum(axis=1)
