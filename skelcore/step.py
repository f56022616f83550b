"""What every contraction step shares, for LBC (skelcore.contraction) and GLSkeleton (skelcore.glskeleton).

A step solves Cao et al. 2010, eq. 2, [W_L L; W_H] P' = [0; W_H P], in the least-squares sense through its
normal equations (W_L^2 L^T L + W_H^2) P' = W_H^2 P with one sparse Cholesky factorisation for all three
coordinates. W_L grows by s_L per step up to a cap; W_H,i = W_H0 s_i^0 / s_i^t follows how far each one-ring
has shrunk (cloudcontr: s_i is the smallest distance from point i to its ring). This module holds the state a
step yields, the run's set-up, the weight schedule, the solve with the checks that reject its candidate, and
live retuning (when a step is torn or a run has stalled: skelcore.stop_rules); the method modules hold only
their loops.

Uneven sampling (not in cloudcontr): a cot Laplacian row is about 2 A_i H_i n_i, A_i the surface area point i
stands for, while its attraction row is W_H,i whatever that area. So where the input is sampled k times
sparser, eq. 2 pulls k times harder: with 30% of the points kept on one half of a drilled plate, that half is
more than one s_L step ahead, and it is shortened to a tangle while the dense half is still a sheet.
`represented` weights W_H,i by the area (params.balance_density), which keeps one balance over the surface.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass, field
from typing import Generator

import numpy as np

from .errors import ParameterError, SolverError
from .laplacian import LaplacianSystem
from .neighbours import OneRings, one_rings
from .curveness import thin_parts, thin_tubes
from .normalise import ROBUST_SHARE, Normalisation, object_core, object_diagonal, robust_extent
from .params import ContractionParams, default_k
from .skeleton import SkeletonParams
from .solver import CholeskySolver

# A step rejected for these ends the run on the state before it (or, see `rejected`, the one before that); the
# words name the rejected step (`it`), so that a verdict of the state kept does not read as contradicting them
REJECTION_CAUSES = {
    "nan": "its solve produced NaN",
    "solver_failure": "the sparse solver failed",
    "bbox_growth": "it grew the bounding box past its limit",
    "collapse": "it pulled the cloud together past its limit (a curve or a loop collapsing)",
    "torn": "it tore the cloud apart (many one-rings widened)",
    "flung": "it flung points out of the input's bounding box",
}
TERMINATION_MESSAGES = {
    "ring_ratio": "the one-ring size ratio stopped falling",
    "max_iterations": "the maximum number of iterations was reached",
    "covariance": "the cloud's covariance shows a converged curve",
    **{reason: f"the next step was discarded, as {cause}" for reason, cause in REJECTION_CAUSES.items()},
}
RESTART_FIELDS = ("method", "k", "normalise", "balance_density", "drop_jumps")


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
    timings: dict = field(default_factory=dict)  # seconds: rings, pattern (L's sparsity), laplacian, solve, rest
    termination: str | None = None  # set on the last state of a run (see TERMINATION_MESSAGES)
    anchored: int = 0  # present points anchored on a thin handle's axis (skelcore.step.anchored)
    message: str = ""
    detail: str = ""  # of a stop or rejection: its figures and notes, without its words (TERMINATION_MESSAGES)
    wl_growth: float = 1.0  # W_L's growth since the first step, W_L / W_L0 before the cap (wl_growth)

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


@dataclass(frozen=True)
class Redo:
    """Sent into a contraction instead of parameters: forget the state just yielded and compute that step again
    from the state before it, with `params` (None: the same). A caller that computes a step before it is asked
    for (the inspector) redoes it when the parameters changed meanwhile. At the input state it is a plain send."""
    params: ContractionParams | None = None


@dataclass(frozen=True)
class RunStart:
    """A run's fixed set-up: the frame, the input's one-rings and the figures every step compares with."""
    normalisation: Normalisation
    unit: np.ndarray  # the input in the run's frame
    rings: OneRings
    builder: LaplacianSystem
    sizes0: np.ndarray  # s^0, the input's ring sizes
    auto_wl0: float  # 1 / (5 * mean one-ring edge length), cloudcontr's W_L0
    areas: np.ndarray  # (n,) the surface area each input point stands for, over their mean (density_weights;
    # ones without params.balance_density, which is fixed for a run)
    extent0: np.ndarray  # robust extent of the input, for the growth check
    diagonal: float  # the input's object diagonal (normalise.object_box), run's frame: the scale of curve-likeness
    state: IterationState  # iteration 0, the input
    # (n,) the input points of the object without strays far out (normalise.object_core; None: every point, as
    # after cleaning): a stray's ring spans empty space, so W_L0's spacing and a_t are measured without it
    core: np.ndarray | None = None

    @functools.cached_property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """The input's bounding box, run's frame, widened by the skeleton's sample radius: a point beyond it has
        left the shape at the skeleton's own scale (early steps of a block push its faces out by about one
        sampling spacing, which is no fling)."""
        margin = SkeletonParams.sample_radius * self.diagonal
        return self.unit.min(axis=0) - margin, self.unit.max(axis=0) + margin

    def outside_share(self, points: np.ndarray) -> float:
        """The share of `points` (run's frame) outside `box`."""
        return _outside_share(points, *self.box)

    @functools.cached_property
    def medial(self):
        """The input's solid and medial surface (skelcore.medial.MedialHold), run's frame; made when a step first
        asks (params.hold_inside)."""
        from .medial import MedialHold  # its loop probe imports networkx: only runs that hold points pay for it

        return MedialHold.of_cloud(self.unit, self.diagonal)

    @functools.cached_property
    def anchors(self) -> np.ndarray:
        """(n, 3) the axis point of each input point on a handle thinner than the skeleton resolves (NaN: free;
        curveness.thin_tubes), in the run's frame; found when a step first asks (params.hold_curves)."""
        return thin_tubes(self.unit, SkeletonParams.sample_radius * self.diagonal, self.rings.edges(),
                          self.state.params.k or default_k(len(self.unit)))


def start_run(points: np.ndarray, params: ContractionParams) -> RunStart:
    """Normalise, build the one-rings and their Laplacian pattern, and the input state."""
    points = np.asarray(points, dtype=np.float64)
    normalisation = Normalisation.fit(points) if params.normalise else Normalisation.identity()
    unit = normalisation.forward(points)
    started = time.perf_counter()
    rings = one_rings(unit, params.k or default_k(len(points)), params.drop_jumps)
    rings_end = time.perf_counter()
    builder = LaplacianSystem(rings)
    timings = {"rings": rings_end - started, "pattern": time.perf_counter() - rings_end}
    core = object_core(unit)
    spacing = rings.mean_edge_length(unit, core)
    auto_wl0 = 1.0 / (5.0 * spacing)
    ids = np.arange(len(points))
    state = IterationState(iteration=0, points=points, point_ids=ids, owner=ids, rings=rings,
                           wl=params.wl0 or auto_wl0, wh=np.full(len(points), params.wh0), ring_ratio=1.0,
                           params=params, timings=timings)
    diagonal = object_diagonal(unit)
    # density at the scale the skeleton resolves: averaged over about one sample radius (a random walk of
    # `passes` ring steps spreads over sqrt(passes) ring spacings), in no more passes than there are points (a walk
    # that long reaches every point it can; clumps 1e-12 across asked for 1e20 passes)
    passes = int(min(np.ceil((SkeletonParams.sample_radius * diagonal / max(spacing, 1e-300)) ** 2), len(points)))
    areas = density_weights(rings, unit, passes) if params.balance_density else np.ones(len(unit))
    return RunStart(normalisation, unit, rings, builder, rings.sizes(unit), auto_wl0, areas, robust_extent(unit),
                    diagonal, state, core)


def density_weights(rings: OneRings, points: np.ndarray, passes: int) -> np.ndarray:
    """(n,) the surface area each point stands for, over their mean: a third of the area of its ring's fan
    triangles (the barycentric cell), averaged with its ring neighbours' `passes` times, so that the sampling's
    random jitter evens out and what remains is the density of the sampling."""
    i, j, l = rings.triangles.T
    fan = 0.5 * np.linalg.norm(np.cross(points[j] - points[i], points[l] - points[i]), axis=1)
    area = np.bincount(i, weights=fan, minlength=rings.n_points) / 3.0
    centres, members = rings.centres(), np.diff(rings.indptr) + 1
    for _ in range(passes):
        area = (np.bincount(centres, weights=area[rings.indices], minlength=rings.n_points) + area) / members
    mean = area.mean()
    return area / mean if mean > 0 else np.ones(rings.n_points)


def represented(owner: np.ndarray, areas: np.ndarray, m: int, params: ContractionParams) -> np.ndarray:
    """(m,) how much of the input each of the m present points stands for, the factor on its attraction W_H,i:
    the summed areas of the input points it represents (params.balance_density, module docstring), else their
    count. `owner`: for each input point, the row of the point that represents it."""
    return np.bincount(owner, weights=areas if params.balance_density else None, minlength=m)


def grown(start: float, factor: float, steps: int) -> float:
    """start * factor^steps, inf past the float range (where Python's ** raises): a large s_L after many steps."""
    try:
        return start * factor ** steps
    except OverflowError:
        return math.inf


def wl_growth(before: IterationState, params: ContractionParams) -> float:
    """W_L's growth at the step after `before`: 1 at the first, else before's times s_L (W_L^{t+1} = s_L W_L^t,
    Cao et al. 2010): an s_L changed during a run applies from the next step on."""
    return 1.0 if before.iteration == 0 else before.wl_growth * params.sl


def schedule(params: ContractionParams, auto_wl0: float, growth: float, sizes0: np.ndarray,
             sizes: np.ndarray) -> tuple[float, np.ndarray]:
    """W_L = W_L0 growth (s_L^(t-1) while s_L stays), capped; W_H,i = W_H0 s_i^0 / s_i^t, capped (cloudcontr's
    schedule)."""
    wl = min((params.wl0 or auto_wl0) * growth, params.wl_max)
    return wl, np.minimum(params.wh0 * sizes0 / np.maximum(sizes, 1e-300), params.wh_max)


def solve_stages(system_builder: LaplacianSystem, solver: CholeskySolver, current: np.ndarray, wl: float,
                 wh: np.ndarray, params: ContractionParams, run: RunStart, first_step: bool,
                 stages: bool = False, row_weights: np.ndarray | None = None,
                 laplacian_values: np.ndarray | None = None
                 ) -> Generator[None, None, tuple[np.ndarray | None, tuple[str, str] | None, dict]]:
    """One solve of eq. 2 and the checks that reject its candidate: solver failure, NaN, bounding-box growth
    past params.bbox_growth of the input's (run.extent0; robust extents: a few points flung out by degenerate
    rings do not end the contraction of the rest), collapse: once a cloud is a thin curve its rings
    degenerate and a step can pull the whole curve together; the longest extent falling below
    params.collapse of the current one in a single step is that, never a contraction onto the skeleton, and so
    is the second principal extent falling so, where the cloud spans it at least params.collapse as far as the
    longest (a loop pulled together across itself: GLSkeleton's merges thin a ring's points and the Laplacian
    then shortens it, until one step flattens a thick torus's ring into a bar);
    and a fling: more than ROBUST_SHARE of the points newly outside the input's box (RunStart.box).
    The first step solves on the input's own rings, so it is exempt from the last two: an over-strong first
    step is a contraction to show (and judge), not a degenerate one. With params.hold_inside the candidate's
    points outside the input's solid are put on its medial surface first (RunStart.medial), and checked so.

    row_weights: per-point contraction weights of the present points (None: all 1). laplacian_values: the
    values of L at `current` (LaplacianSystem.laplacian_values), when the caller has them already.

    A generator for `yield from`: with `stages` it yields None between the Laplacian and the solve; its
    value is (candidate, failure as (reason, detail) or None, timings of 'laplacian' and 'solve')."""
    laplacian_start = time.perf_counter()
    system = system_builder.normal_matrix(current, wl, wh, row_weights, laplacian_values)
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
    if failure is None and params.hold_inside:
        candidate = run.medial.hold(candidate)[0]
    if failure is None and (robust_extent(candidate) > params.bbox_growth * run.extent0).any():
        failure = ("bbox_growth", "")
    if failure is None and not first_step:
        longest, before = np.ptp(candidate, axis=0).max(), np.ptp(current, axis=0).max()
        if longest < params.collapse * before:
            failure = ("collapse", f"longest extent {longest / before:.0%} of the step before")
    if failure is None and not first_step:
        spans, after = principal_extents(current), principal_extents(candidate)
        if spans[1] >= params.collapse * spans[2] and after[1] < params.collapse * spans[1]:
            failure = ("collapse", f"second extent {after[1] / spans[1]:.0%} of the step before")
    if failure is None and not first_step:
        # A contraction moves points inward; the growth check reads the middle 98%, so it lets a fling of up to
        # ROBUST_SHARE of the points through: this catches that (a folding sheet throws its corners out).
        outside, before = run.outside_share(candidate), run.outside_share(current)
        if outside - before > ROBUST_SHARE:
            failure = ("flung", f"{outside:.1%} of the points left the input's box, against {before:.1%}")
    return candidate, failure, timings


def hold_curves(wl: float, points: np.ndarray, run: RunStart) -> np.ndarray:
    """W_L that each point keeps (inf: none) when params.hold_curves is on, from the first step, which used
    `wl` and left the points at `points`. A point on a thin part's axis (curveness.thin_parts) has reached the
    skeleton; more contraction there only shortens the curve (curve-shortening flow), which pulls limbs' ends in
    and shrinks small handles to points while a bulky part beside them is still contracting. Only the first
    step decides: what becomes curve-like later was bulky at the input's scale and contracts with the rest."""
    return np.where(thin_parts(points, run.unit, SkeletonParams.sample_radius * run.diagonal), wl, np.inf)


def anchored(wh: np.ndarray, run: RunStart, ids: np.ndarray, params: ContractionParams) -> np.ndarray:
    """W_H of the present points (input ids `ids`) with those on handles thinner than the skeleton resolves
    (RunStart.anchors) at the cap W_H,max while params.hold_curves is on. The skeleton draws such a part as the
    curve of its cross-sections' centroids whatever the contraction does, so it stays where it is; contracted, it
    would be shortened shut or dragged into the bulk beside it (skelcore.curveness). It is not pulled onto its
    axis in the solve: collapsed, its rings would turn its neighbours' cotangent weights negative and fling them
    out; the states show it there (`shown`)."""
    return np.where(_fixed(run, ids, params), params.wh_max, wh)


def free_points(run: RunStart, ids: np.ndarray, params: ContractionParams) -> np.ndarray:
    """(m,) which present points (input ids `ids`) the contraction's progress, the rings' shrinking a_t, is
    measured on: those not anchored (`anchored`), whose rings never shrink, nor strays (RunStart.core), whose
    rings would swamp the sums; all when none is free."""
    free = ~_fixed(run, ids, params)
    if run.core is not None:
        free &= run.core[ids]
    return free if free.any() else np.ones(len(ids), dtype=bool)


def shown(current: np.ndarray, run: RunStart, ids: np.ndarray, params: ContractionParams) -> tuple[np.ndarray, int]:
    """The positions a state shows, in the user's coordinates, for the solve's `current` (present points of input
    ids `ids`): the anchored points (`anchored`) on their axis; and how many those are."""
    fixed = _fixed(run, ids, params)
    if fixed.any():
        current = np.where(fixed[:, None], run.anchors[ids], current)
    return run.normalisation.inverse(current), int(fixed.sum())


def _fixed(run: RunStart, ids: np.ndarray, params: ContractionParams) -> np.ndarray:
    """(m,) which present points (input ids `ids`) are anchored: none while params.hold_curves is off."""
    if not params.hold_curves:
        return np.zeros(len(ids), dtype=bool)
    return np.isfinite(run.anchors[ids, 0])


def contraction_rows(held: np.ndarray, wl: float, weights: np.ndarray | None, params: ContractionParams
                     ) -> np.ndarray | None:
    """Per-point factors on the Laplacian rows of eq. 2: the per-point contraction weights times W_L held / W_L
    (hold_curves, while params.hold_curves is on); None when all are 1."""
    if not params.hold_curves or not np.isfinite(held).any():
        return weights
    factors = np.minimum(wl, held) / wl
    return factors if weights is None else weights * factors


def stall_ratios(first_ratio: float, earlier: IterationState | None, state: IterationState
                 ) -> tuple[float, float | None, float] | None:
    """`under_way`'s ratios before the step after `state` (preceded by `earlier`; None: `state` is the input),
    `first_ratio` being a_t after the first step."""
    if earlier is None:
        return None
    return first_ratio, (earlier.ring_ratio if earlier.iteration else None), state.ring_ratio


def principal_extents(points: np.ndarray) -> np.ndarray:
    """(3,) the extents of the middle 98% of the points along their principal axes, ascending; the axes are those
    of the 98% nearest the median, so a few points flung far do not turn them."""
    offset = points - np.median(points, axis=0)
    distance2 = np.einsum("ij,ij->i", offset, offset)
    axes = np.linalg.eigh(np.cov(points[distance2 <= np.quantile(distance2, 1 - ROBUST_SHARE)].T))[1]
    return np.sort(robust_extent(points @ axes))


def stopped(state: IterationState, reason: str, detail: str, notes: list[str]) -> IterationState:
    """The last good state again, carrying the reason its successor was rejected."""
    detail = "; ".join(filter(None, [detail, *notes]))
    message = "; ".join(filter(None, [TERMINATION_MESSAGES[reason], detail]))
    return dataclasses.replace(state, termination=reason, message=message, detail=detail)


def rejected(state: IterationState, earlier: IterationState | None, run: RunStart, reason: str, detail: str,
             notes: list[str]) -> IterationState:
    """The state a run ends on when the candidate of its next step is rejected: the last good state, carrying
    the reason. When the bounding box grew, and the last good state had sent more of its points out of the
    input's bounding box than the state before it, by more than the share the growth check trims
    (normalise.ROBUST_SHARE: it reads the middle 98%, so such a state passes it), that earlier state: the
    fling that blew the box up had begun there, and a point outside the input's box is outside the shape.
    Never the input itself."""
    if reason == "bbox_growth" and earlier is not None and earlier.iteration >= 1:
        low, high = run.state.points.min(axis=0), run.state.points.max(axis=0)
        now, then = _outside_share(state.points, low, high), _outside_share(earlier.points, low, high)
        if now - then > ROBUST_SHARE:
            detail = (f"iteration {state.iteration} is dropped too: {now:.1%} of its points had left the input's "
                      f"box, against {then:.1%} at iteration {earlier.iteration}")
            state = earlier
    return stopped(state, reason, detail, notes)


def _outside_share(points: np.ndarray, low: np.ndarray, high: np.ndarray) -> float:
    return float(np.mean(np.any((points < low) | (points > high), axis=1)))


def record(history: list[IterationState], state: IterationState) -> bool:
    """Add a yielded state to a run's history; False when it repeats one already there (a rejected step: the
    last good state again, now with the reason, or the one before it, see `rejected`), which then replaces
    that state and ends the history."""
    at = next((i for i, kept in enumerate(history) if kept.iteration == state.iteration), len(history))
    new = at == len(history)
    del history[at:]
    history.append(state)
    return new


def retune(current: ContractionParams, sent: ContractionParams | None) -> tuple[ContractionParams, list[str]]:
    """The parameters of the next step: those sent into the generator (None: unchanged), checked against
    the run's, with a note naming what changed."""
    if sent is None:
        return current, []
    if not isinstance(sent, ContractionParams):
        raise ParameterError(f"sent {sent!r}: send a ContractionParams (or Redo of one, or None)")
    sent = sent.validated()
    changed = [name for name in current.to_dict() if getattr(sent, name) != getattr(current, name)]
    blocked = [name for name in changed if name in RESTART_FIELDS]
    if blocked:
        raise ParameterError(f"parameter {', '.join(blocked)} can only change on restart")
    # a number as short as it reads ("wh0=1e+09", not 1000000000.0)
    note = ", ".join(f"{name}={_short(getattr(sent, name))}" for name in changed)
    return sent, [f"retuned {note}"] if note else []


def _short(value) -> str:
    """A parameter's value in a note: a float as %g, anything else as it prints."""
    return f"{value:g}" if isinstance(value, float) else f"{value}"
