"""Laplacian-based contraction (Cao et al. 2010) as a generator of per-iteration states.

`contract()` is the entry for both methods: LBC's loop is here, GLSkeleton's (with in-loop point reduction)
in skelcore.glskeleton; both take their steps from skelcore.step (the solve of eq. 2, the weight schedule, the
checks, retuning). LBC keeps every point and one set of rings, so the sparsity pattern and CHOLMOD's symbolic
analysis are made once per run.
"""
from __future__ import annotations

import time
from typing import Generator

import numpy as np

from . import glskeleton
from .labels import check_weights
from .params import ContractionParams
from .solver import CholeskySolver
from .step import (RESTART_FIELDS, TERMINATION_MESSAGES, IterationState, Redo, anchored, contraction_rows,
                   free_points, hold_curves, record, rejected, retune, schedule, shown, solve_stages, stall_ratios,
                   start_run, wl_growth)
from .stop_rules import goes_on, rings_stalled, torn

__all__ = ["RESTART_FIELDS", "TERMINATION_MESSAGES", "IterationState", "Redo", "contract", "goes_on", "record",
           "retune", "run_contraction"]


def contract(points: np.ndarray, params: ContractionParams = ContractionParams(), weights=None, *,
             stages: bool = False) -> Generator[IterationState | None, ContractionParams | Redo | None, None]:
    """Yield the input state, then one state per solve; `send(params)` retunes the following steps, and
    `send(Redo(params))` forgets the state just yielded and computes that step again (with `params`).

    The last state yielded carries `termination`. When a rule rejects the candidate of a step (NaN,
    solver failure, bounding-box growth, ring ratio no longer falling: cloudcontr discards that step),
    the last accepted state is yielded again with the reason set, or after a bounding-box growth that began
    in it, the one before it (skelcore.step.rejected; `record` then drops the last).
    weights: optional (n,) positive per-point contraction weights; point i's Laplacian row of eq. 2 is
    W_L w_i L_i (see skelcore.labels). None: every weight is 1.
    stages: also yield None between the stages of a step (Laplacian, solve, checks), so that a caller
    can stop within a step and resume it later with next() (the inspector's Pause).
    """
    params = params.validated()
    points = np.asarray(points, dtype=np.float64)
    weights = None if weights is None else check_weights(weights, len(points))
    if params.method == "glskeleton":
        yield from glskeleton.contract_with_reduction(points, params, weights, stages=stages)
    else:
        yield from _contract_lbc(points, params, weights, stages)


def _contract_lbc(points: np.ndarray, params: ContractionParams, weights: np.ndarray | None, stages: bool
                  ) -> Generator[IterationState | None, ContractionParams | Redo | None, None]:
    run = start_run(points, params)
    state, ids, sizes0 = run.state, run.state.point_ids, run.sizes0
    current, sizes, ratio = run.unit, sizes0, 1.0
    solver = CholeskySolver()
    held = np.full(len(points), np.inf)  # W_L held on thin parts' axes (step.hold_curves)
    iteration, earlier, first_ratio = 0, None, 1.0  # earlier: the accepted state before `state`; a_t after step 1
    before = (iteration, state, earlier, current, sizes, ratio, held, first_ratio)  # what the last step started from
    while True:
        sent = yield state
        if isinstance(sent, Redo):
            (iteration, state, earlier, current, sizes, ratio, held, first_ratio), sent = before, sent.params
        elif state.termination:
            return
        params, notes = retune(params, sent)
        before = (iteration, state, earlier, current, sizes, ratio, held, first_ratio)
        iteration += 1
        step_start = time.perf_counter()
        growth = wl_growth(state, params)
        wl, wh = schedule(params, run.auto_wl0, growth, sizes0, sizes)
        if params.balance_density:  # every input point stands for itself: its own area (skelcore.step.represented)
            wh = np.minimum(wh * run.areas, params.wh_max)
        wh = anchored(wh, run, ids, params)
        candidate, failure, timings = yield from solve_stages(run.builder, solver, current, wl, wh, params,
                                                              run, first_step=iteration == 1, stages=stages,
                                                              row_weights=contraction_rows(held, wl, weights, params))
        if stages:
            yield None
        if failure is None:
            new_sizes = run.rings.sizes(candidate)
            free = free_points(run, ids, params)
            new_ratio = float(new_sizes[free].sum() / sizes0[free].sum())
            # cloudcontr: stop once a_{t-1} - a_t < threshold; while the rings still shrink, a cloud not yet
            # curve-like (a sheet) goes on contracting, as long as each such step leaves it more curve-like
            # (thin parts pulled into a blob would not)
            drop = ratio - new_ratio
            ratios = stall_ratios(first_ratio, earlier, state)
            if rings_stalled(iteration, drop, current, candidate, params, run.diagonal, ratios):
                moved = f"fell by {drop:.4f} < {params.termination:g}" if drop >= 0 else f"rose by {-drop:.4f}"
                failure = ("ring_ratio", f"a_t {moved}")
            else:
                failure = torn(iteration, sizes, new_sizes)
        if failure is not None:
            state = rejected(state, earlier, run, *failure, notes)
            continue
        current, sizes, ratio = candidate, new_sizes, new_ratio
        if iteration == 1:
            held, first_ratio = hold_curves(wl, current, run), ratio
        termination = "max_iterations" if iteration >= params.max_iterations else None
        message = "; ".join(filter(None, [TERMINATION_MESSAGES.get(termination, ""), *notes]))
        timings["rest"] = time.perf_counter() - step_start - timings["laplacian"] - timings["solve"]
        shown_points, anchored_count = shown(current, run, ids, params)
        earlier, state = state, IterationState(iteration=iteration, points=shown_points, point_ids=ids, owner=ids,
                                               rings=run.rings, wl=wl, wh=wh, ring_ratio=ratio, params=params,
                                               timings=timings, termination=termination, message=message,
                                               anchored=anchored_count, wl_growth=growth)


def run_contraction(points: np.ndarray, params: ContractionParams = ContractionParams(),
                    weights=None) -> list[IterationState]:
    """Run to the end; the last state carries the termination reason."""
    history: list[IterationState] = []
    for state in contract(points, params, weights):
        record(history, state)
    return history
