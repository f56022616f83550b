"""Parameters of the contraction, one validated dataclass (cloudcontr's defaults)."""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass

from .errors import ParameterError

METHODS = ("lbc", "glskeleton")
SEED = 0  # a run's seed for every random choice (RunOptions.seed, --seed)
# Accepted values of the numeric parameters: name -> (low, high, low included); `validated` checks them
# and the inspector's widgets take their ranges from here, so every valid value can be entered.
# Weights enter eq. 2's normal equations squared (W_L^2 L^T L + W_H^2): past WEIGHT_MAX their squares leave float range.
WEIGHT_MAX = 1e100
LIMITS = {
    "k": (3, 200, True), "wl0": (0.0, WEIGHT_MAX, False), "wh0": (0.0, WEIGHT_MAX, False), "sl": (1.0, math.inf, True),
    "wl_max": (0.0, WEIGHT_MAX, False), "wh_max": (0.0, WEIGHT_MAX, False), "max_iterations": (1, 1000, True),
    "termination": (0.0, math.inf, False), "bbox_growth": (1.0, math.inf, False), "collapse": (0.0, 0.99, True),
    "curve_share": (0.0, 1.0, True),
    "gl_merge": (0.0, math.inf, False), "gl_covariance": (0.0, math.inf, False), "gl_merge_share": (0.0, 1.0, False),
}
INTEGERS = ("k", "max_iterations")
AUTOMATIC = ("k", "wl0")  # None: the engine chooses (default_k, and W_L0 from the one-rings)


K_SHARE, K_MIN, K_MAX = 0.012, 8, 30  # cloudcontr GS.compute_k_knn: k = clamp(round(K_SHARE n), K_MIN, K_MAX)
DEFAULT_K_RULE = f"clamp(round({K_SHARE} n), {K_MIN}, {K_MAX})"


def default_k(n_points: int) -> int:
    """The one-rings' neighbours for n points: DEFAULT_K_RULE."""
    return int(min(K_MAX, max(K_MIN, round(K_SHARE * n_points))))


@dataclass(frozen=True)
class ContractionParams:
    """Parameters of a contraction (LBC and GLSkeleton); defaults are cloudcontr's."""
    method: str = "lbc"
    k: int | None = None  # neighbours for the one-rings; None: default_k(n)
    wl0: float | None = None  # initial contraction weight; None: 1 / (5 * mean one-ring edge length)
    wh0: float = 1.0  # initial attraction weight
    sl: float = 3.0  # W_L amplification per iteration
    wl_max: float = 2048.0  # cap on W_L (Au et al. 2008)
    wh_max: float = 1e4  # cap on W_H
    max_iterations: int = 20
    termination: float = 0.01  # stop when the ring-size ratio falls by less than this ...
    curve_share: float = 0.5  # ... and this share of the cloud is curve-like (0: cloudcontr's rule alone)
    # points that the first step brought to a thin part's axis keep that step's W_L (skelcore.step.hold_curves), and
    # the input's handles thinner than a skeleton ball stay in place (skelcore.step.anchored; neither in cloudcontr):
    # small handles and limbs' ends are not shortened away while the bulk still contracts
    hold_curves: bool = True
    # each point's attraction W_H is weighted by the input surface area it stands for (skelcore.step.represented;
    # not in cloudcontr), so a sparsely sampled part contracts at the pace of a densely sampled one; off by
    # default: it also moves when thin handles are held (the hold decides after the first step)
    balance_density: bool = False
    # one-ring edges whose middle lies off the sampled surface are dropped before the contraction
    # (skelcore.ring_jumps; not in cloudcontr): a coarse sampling's rings do not join parts across empty space
    drop_jumps: bool = True
    # points a step would take out of the original solid go to the nearest point of its medial surface instead
    # (skelcore.medial; not in cloudcontr): loops through a solid that contraction closes (a bore longer than
    # wide) are kept, at the price of spurs; off by default, tried on a closed mesh or cloud that lost loops
    hold_inside: bool = False
    bbox_growth: float = 1.2  # stop when the bounding box grows past this factor of the original
    collapse: float = 0.5  # stop when one step shrinks the longest extent, or a second one spanned at least this share
    # of the longest, below this share (not in cloudcontr)
    normalise: bool = True  # centre the bounding box and scale its largest extent to 1.6
    # GLSkeleton only (skelcore.glskeleton; defaults from the authors' MATLAB):
    # a point absorbs its nearest ring neighbour when its merge score < gl_merge * s_i^2 and the cloud is curve-like there
    gl_merge: float = 1e5
    gl_covariance: float = 0.02  # stop when the covariance score changes by less than this (from iteration 3)
    gl_merge_share: float = 0.3  # at most this share of the points qualify per step, the best scores (1: no cap)

    def validated(self) -> "ContractionParams":
        """These parameters, or a ParameterError naming the first that is out of range or of the wrong type."""
        if self.method not in METHODS:
            raise ParameterError(f"parameter method={self.method!r}: must be one of {', '.join(METHODS)}")
        check_flags(self)
        for name, (low, high, closed) in LIMITS.items():
            value = getattr(self, name)
            if value is None and name in AUTOMATIC:
                continue
            if name in INTEGERS and not is_integer(value):
                raise ParameterError(f"parameter {name}={value!r}: must be an integer between {low} and {high}")
            if not is_real(value) or not _within(value, low, high, closed):
                raise ParameterError(f"parameter {name}={value!r}: must be {_describe_range(low, high, closed)}")
        return self

    def starts_above_caps(self) -> list[tuple[str, str]]:
        """The starting weights given above their caps, as (start, cap) names: W_L and W_H never exceed wl_max and
        wh_max (skelcore.step.schedule), so such a run starts at the cap, where a larger start changes nothing."""
        return [(start, cap) for start, cap in (("wl0", "wl_max"), ("wh0", "wh_max"))
                if getattr(self, start) is not None and getattr(self, start) > getattr(self, cap)]

    def replace(self, **changes) -> "ContractionParams":
        """A copy with `changes` applied, validated."""
        return dataclasses.replace(self, **changes).validated()

    def to_dict(self) -> dict:
        """The parameters as a plain dict (for params.json)."""
        return dataclasses.asdict(self)


def is_real(value) -> bool:
    """A real number (numpy's too), not a bool nor a string that would read as one."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value) -> bool:
    """An integer (numpy's too), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def check_flag(name: str, value) -> None:
    """`value` a bool, numpy's included, or a ParameterError naming the parameter (the string "no" reads as true)."""
    if not (isinstance(value, bool) or getattr(value, "dtype", None) == bool and getattr(value, "shape", None) == ()):
        raise ParameterError(f"parameter {name}={value!r}: must be True or False")


def check_flags(params) -> None:
    """check_flag on every switch of the parameter dataclass `params` (each field whose default is a bool)."""
    for field in dataclasses.fields(params):
        if isinstance(field.default, bool):
            check_flag(field.name, getattr(params, field.name))


def _within(value, low: float, high: float, closed: bool) -> bool:
    value = float(value)
    if not math.isfinite(value) or value > high:
        return False
    return value >= low if closed else value > low


def _describe_range(low: float, high: float, closed: bool) -> str:
    if math.isinf(high):
        return f"a finite number {'>=' if closed else '>'} {low:g}"
    return f"a number in {'[' if closed else '('}{low:g}, {high:g}]"


@dataclass(frozen=True)
class CleaningParams:
    """Parameters of the cleaning before contraction (skelcore.clean's docstring gives the rules)."""
    remove_outliers: bool = True
    neighbours: int = 16  # for the spacing of each point
    outlier_ratio: float = 1.5  # times the spacing of its own neighbours
    outlier_spread: float = 3.0  # robust standard deviations above the cloud's median spacing (the 3-sigma rule)
    remove_stray: bool = True
    denoise: bool = True  # project every point onto the PCA plane of its neighbours, once (where they have one)
    piece_gap: float = 3.0  # a chain of neighbours joins two points when each step is at most this many spacings
    min_piece_share: float = 0.01  # pieces with fewer points than this share are stray

    @property
    def denoise_neighbours(self) -> int:
        """The neighbours of the denoising projection, 0 when it is off."""
        return self.neighbours if self.denoise else 0

    def validated(self) -> "CleaningParams":
        """These parameters, or a ParameterError naming the first that is out of range or of the wrong type."""
        check_flags(self)
        if not is_integer(self.neighbours) or not 2 <= self.neighbours <= 200:
            raise ParameterError(f"parameter neighbours={self.neighbours!r}: must be an integer between 2 and 200")
        for name in ("outlier_ratio", "outlier_spread", "piece_gap"):
            value = getattr(self, name)
            if not is_real(value) or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"parameter {name}={value!r}: must be a positive finite number")
        if not is_real(self.min_piece_share) or not 0 <= self.min_piece_share < 0.5:
            raise ParameterError(f"parameter min_piece_share={self.min_piece_share!r}: must be a number in [0, 0.5)")
        return self

    def to_dict(self) -> dict:
        """The parameters as a plain dict (for params.json)."""
        return dataclasses.asdict(self)
