"""cloudcontr's normalisation (GS.normalize): centre the bounding box, largest extent 1.6."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNIT_EXTENT = 1.6


@dataclass(frozen=True)
class Normalisation:
    """The similarity to the working frame: bounding box centred, largest extent scaled to UNIT_EXTENT."""
    centre: np.ndarray
    scale: float

    @classmethod
    def fit(cls, points: np.ndarray) -> "Normalisation":
        low, high = points.min(axis=0), points.max(axis=0)
        return cls(centre=(low + high) / 2, scale=UNIT_EXTENT / float((high - low).max()))

    @classmethod
    def identity(cls) -> "Normalisation":
        return cls(centre=np.zeros(3), scale=1.0)

    def forward(self, points: np.ndarray) -> np.ndarray:
        """Points in the working frame."""
        return (points - self.centre) * self.scale

    def inverse(self, points: np.ndarray) -> np.ndarray:
        """Points back in the user's frame."""
        return points / self.scale + self.centre


ROBUST_SHARE = 0.01  # the share of points each side that a robust extent ignores


def robust_extent(points: np.ndarray) -> np.ndarray:
    """(3,) the extent of the middle 98% of the points along each axis: a few points flung far by a
    degenerate ring, or stray points a scan left, do not change it."""
    low, high = np.quantile(points, [ROBUST_SHARE, 1.0 - ROBUST_SHARE], axis=0)
    return high - low
