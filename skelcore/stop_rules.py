"""When a contraction step is taken and when a run stops, for LBC (skelcore.contraction) and GLSkeleton
(skelcore.glskeleton): cloudcontr's ring-ratio rule with the exceptions a bulky or sheet-like cloud needs, and
the rejection of torn steps.

Torn steps (not in cloudcontr): a Laplacian step pulls every point towards its neighbours, so its one-rings
shrink or stay. Once a cloud has thinned to ribbons, the rings of the input degenerate and a strong W_L can
fling neighbours apart: loops fold across each other and a curve's ends are pulled in, while the rings'
TOTAL still shrinks (others collapse), so the ring-ratio rule lets it pass. `torn` rejects a step that widens
more than TEAR_SHARE of the one-rings past TEAR_GROWTH times their width before it.
"""
from __future__ import annotations

import numpy as np

from .curveness import skeleton_scale_share
from .params import ContractionParams

TEAR_GROWTH = 2.0  # a one-ring this many times wider after a step than before it has been torn open ...
TEAR_SHARE = 0.15  # ... and a step that does so to more than this share of the points is rejected


def rings_stalled(iteration: int, drop: float, current: np.ndarray, candidate: np.ndarray, params: ContractionParams,
                  diagonal: float, ratios: tuple[float, float | None, float] | None = None) -> bool:
    """cloudcontr's stop rule, from the second step on: the step shrank the rings' total size by `drop` (a
    share of the input's), less than params.termination; except that while the rings still shrink, a step
    that goes_on is taken, and so is one that speeds up a contraction not yet under way (`under_way`)."""
    return iteration > 1 and drop < params.termination and not (
        drop >= 0 and (not under_way(drop, ratios, params) or goes_on(current, candidate, params, diagonal)))


def under_way(drop: float, ratios: tuple[float, float | None, float] | None, params: ContractionParams) -> bool:
    """Whether the contraction is under way for the stop rule, given `ratios`: a_t after the first step, of the
    state before the last (None when that is the input) and of the last (None: it is under way). It is once the
    rings have shrunk by params.termination since the first step, or once a step shrinks them no more than the
    step before. cloudcontr's rule tells a contraction that has slowed down; a bulky ball's first steps barely
    shrink it while W_L triples a step, each shrinking it more than the last. The first step does not count: it
    takes a scan's noise out of the rings, or pulls thin parts onto their axes, at once, while the bulk has not
    started (a ball with thin handles and 1% noise: 0.175, then 0.0065, and a run that stopped one step in)."""
    if ratios is None:
        return True
    first, earlier, last = ratios
    return first - last >= params.termination or (earlier is not None and drop <= earlier - last)


def goes_on(current: np.ndarray, candidate: np.ndarray, params: ContractionParams, diagonal: float) -> bool:
    """Whether a step past the ring-ratio stall is taken: the candidate is less than params.curve_share
    curve-like at the skeleton's scale of `diagonal` (RunStart.diagonal) and more so than the current."""
    if params.curve_share <= 0:
        return False
    after = skeleton_scale_share(candidate, diagonal)
    return after < params.curve_share and after > skeleton_scale_share(current, diagonal)


def curve_like(points: np.ndarray, params: ContractionParams, diagonal: float) -> bool:
    """Whether at least params.curve_share of the points are curve-like at the skeleton's scale of `diagonal`
    (skelcore.curveness.skeleton_scale_share; always, with share 0)."""
    return params.curve_share <= 0 or skeleton_scale_share(points, diagonal) >= params.curve_share


def torn(iteration: int, sizes: np.ndarray, new_sizes: np.ndarray) -> tuple[str, str] | None:
    """('torn', detail) when a step, from the second on, widened more than TEAR_SHARE of the one-rings past
    TEAR_GROWTH times their size before it (module docstring); else None. `sizes`, `new_sizes`: the ring sizes
    of the same rings before and after the step."""
    share = float(np.mean(new_sizes > TEAR_GROWTH * sizes)) if len(sizes) else 0.0
    if iteration > 1 and share > TEAR_SHARE:
        return "torn", f"{share:.0%} of the one-rings grew past {TEAR_GROWTH:g} times their size"
    return None
