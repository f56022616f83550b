"""Parameters of the contraction, one validated dataclass (cloudcontr defaults, DESIGN.md section 3)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .errors import ParameterError

METHODS = ("lbc", "glskeleton")


def default_k(n_points: int) -> int:
    """cloudcontr GS.compute_k_knn: clamp(round(0.012 n), 8, 30)."""
    return int(min(30, max(8, round(0.012 * n_points))))


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
    bbox_growth: float = 1.2  # stop when the bounding box grows past this factor of the original
    collapse: float = 0.5  # stop when one step shrinks the longest extent below this share (not in cloudcontr)
    normalise: bool = True  # centre the bounding box and scale its largest extent to 1.6
    # GLSkeleton only (skelcore.glskeleton; defaults from the authors' MATLAB):
    gl_merge: float = 1e5  # a point absorbs its nearest ring neighbour when its merge score < gl_merge * s_i^2
    gl_covariance: float = 0.02  # stop when the covariance score changes by less than this (from iteration 3)
    gl_merge_share: float = 0.3  # at most this share of the points may absorb a neighbour per step (1: no cap, as LCWR)

    def validated(self) -> "ContractionParams":
        """These parameters, or a ParameterError naming the first out of range."""
        def positive(name: str, value: float | None, allow_none: bool = False) -> None:
            if value is None and allow_none:
                return
            if value is None or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"parameter {name}={value!r}: must be a positive finite number")

        if self.method not in METHODS:
            raise ParameterError(f"parameter method={self.method!r}: must be one of {', '.join(METHODS)}")
        if self.k is not None and (int(self.k) != self.k or not 3 <= self.k <= 200):
            raise ParameterError(f"parameter k={self.k!r}: must be an integer between 3 and 200")
        positive("wl0", self.wl0, allow_none=True)
        for name in ("wh0", "wl_max", "wh_max", "termination", "gl_merge", "gl_covariance"):
            positive(name, getattr(self, name))
        if not math.isfinite(self.gl_merge_share) or not 0 < self.gl_merge_share <= 1:
            raise ParameterError(f"parameter gl_merge_share={self.gl_merge_share!r}: must be a number in (0, 1]")
        if not math.isfinite(self.sl) or self.sl < 1:
            raise ParameterError(f"parameter sl={self.sl!r}: must be a finite number >= 1")
        if int(self.max_iterations) != self.max_iterations or not 1 <= self.max_iterations <= 1000:
            raise ParameterError(f"parameter max_iterations={self.max_iterations!r}: must be an integer between 1 and 1000")
        if not math.isfinite(self.curve_share) or not 0 <= self.curve_share <= 1:
            raise ParameterError(f"parameter curve_share={self.curve_share!r}: must be a number in [0, 1]")
        if not math.isfinite(self.collapse) or not 0 <= self.collapse < 1:
            raise ParameterError(f"parameter collapse={self.collapse!r}: must be a number in [0, 1)")
        if not math.isfinite(self.bbox_growth) or self.bbox_growth <= 1:
            raise ParameterError(f"parameter bbox_growth={self.bbox_growth!r}: must be a finite number > 1")
        return self

    def replace(self, **changes) -> "ContractionParams":
        """A copy with `changes` applied, validated."""
        return dataclasses.replace(self, **changes).validated()

    def to_dict(self) -> dict:
        """The parameters as a plain dict (for params.json)."""
        return dataclasses.asdict(self)
