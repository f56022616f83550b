"""Keeping a contraction inside the original solid: its medial surface, and points held on it.

Laplacian contraction is a mean-curvature flow, and that flow closes a loop through a solid whose hole is long
beside its width: a bore's wall curves only around the bore, so each step pulls it towards the bore's axis, out of
the material, until wall and outer faces meet on the axis (a pipe taller than wide, a drilled block). Mean
curvature skeletons (Tagliasacchi et al. 2012, eq. 4) keep their flow centred by attracting each point to its
medial pole; here the pole is a constraint on the points a step takes out of the solid: such a point goes to the
nearest point of the original's medial surface instead (`MedialHold`), inside the material, and the rest of the
cloud contracts as before. Switched on by ContractionParams.hold_inside; a run whose skeleton
keeps fewer loops than its solid has (a closed mesh's genus, or those a closed point cloud's inside test reads:
skelcore.cloud_topology) tries it (skelcore.pipeline).

The medial surface is sampled by the centres of the shrinking balls (Ma et al. 2012): the largest ball touching a
sample on the inward side of its normal and holding no other sample. A ball that never closes (the open side of a
scan) has no centre.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .inside import InsideTest
from .loops import cloud_inside
from .verdict import StabilityThresholds

MAX_SHRINKS = 40  # shrinking steps at most; each sets a ball through its nearest sample, most settle in under 10


def shrinking_ball_centres(samples: np.ndarray, outward: np.ndarray, tree: cKDTree | None = None
                           ) -> tuple[np.ndarray, np.ndarray]:
    """(centres (n,3), radii (n,)) of the largest ball tangent at each sample to its plane, on the side opposite
    its outward normal, that holds no other sample; NaN where the ball never closes (it would reach past the
    samples' extent) or the sample has no normal. Each step centres the ball at p - r n and, while a sample q
    other than p lies inside it, sets r to that of the ball through p and q: |p - q|^2 / (2 n.(p - q))."""
    tree = cKDTree(samples) if tree is None else tree
    reach = float(np.linalg.norm(np.ptp(samples, axis=0)))
    radii = np.full(len(samples), reach)
    active = np.flatnonzero(np.linalg.norm(np.nan_to_num(outward), axis=1) > 0.5)
    for _ in range(MAX_SHRINKS):
        if len(active) == 0:
            break
        p, n = samples[active], outward[active]
        distance, nearest = tree.query(p - radii[active, None] * n, k=2, workers=-1)
        other = nearest[:, 0] == active  # the ball's nearest sample is p itself: the next one is the other
        q = samples[np.where(other, nearest[:, 1], nearest[:, 0])]
        gap = np.where(other, distance[:, 1], distance[:, 0])
        offset = p - q
        along = 2.0 * np.einsum("ij,ij->i", n, offset)
        through = np.where(along > 0, np.einsum("ij,ij->i", offset, offset) / np.where(along > 0, along, 1.0), np.inf)
        shrinks = (gap < radii[active] * (1 - 1e-9)) & (through < radii[active] * (1 - 1e-9))
        radii[active[shrinks]] = through[shrinks]
        active = active[shrinks]
    centres = samples - radii[:, None] * np.nan_to_num(outward)
    open_ball = (radii >= reach) | (np.linalg.norm(np.nan_to_num(outward), axis=1) <= 0.5)
    centres[open_ball], radii[open_ball] = np.nan, np.nan
    return centres, radii


@dataclass(frozen=True)
class MedialHold:
    """The original solid of a cloud (its inside test) and samples of its medial surface (shrinking-ball centres)."""
    inside: InsideTest
    centres: np.ndarray  # (m,3) the medial samples, balls that closed only
    tree: cKDTree

    @classmethod
    def of_cloud(cls, points: np.ndarray, diagonal: float) -> "MedialHold":
        """From the original points themselves (outward normals oriented along the cloud, skelcore.inside), within
        the verdict's band of the surface (a share of `diagonal`) counting as inside, as the paper's boundedness
        criterion reads it."""
        inside = cloud_inside(points, StabilityThresholds.surface_tolerance * diagonal)
        centres = shrinking_ball_centres(inside.samples, inside.normals, inside.tree)[0]
        centres = centres[np.isfinite(centres).all(axis=1)]
        return cls(inside, centres, cKDTree(centres if len(centres) else np.zeros((1, 3))))

    def hold(self, points: np.ndarray) -> tuple[np.ndarray, int]:
        """`points` with those outside the solid moved to the nearest medial sample; and how many moved (none
        without medial samples: a surface that bounds nothing)."""
        outside = np.flatnonzero(~self.inside.contains(points))
        if len(outside) == 0 or len(self.centres) == 0:
            return points, 0
        held = points.copy()
        held[outside] = self.centres[self.tree.query(points[outside], workers=-1)[1]]
        return held, len(outside)
