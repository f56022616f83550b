"""Contracted points flung out of the shape: put back where their neighbours went before the skeleton reads them.

A contraction moves points inward: eq. 2 of Cao et al. 2010 pulls each point towards its one-ring. Where a ring
is degenerate its cotangent weights can turn negative and throw the point out of the shape, further at every
step (a mesh's vertices along a seam, whose nearest neighbours lie in a plane across the surface: the tips of
cloudcontr's 9-handle torus went 1.3 units out of a solid 2 thick). The run's checks let a few such points
through, as they should (they read the middle 98% of the cloud, and a handful of points is no failed step), but
the skeleton drew them: a spur out of the shape, or a small false loop between the spur and the curve (on that
torus LBC had four spurs, GLSkeleton two false loops and two spurs).

A contracted point is flung when it lies beyond the convex hull of a closed original surface, by more than a
point spacing and as far from every original point (nearer, noise can put it there): no part of the shape is
there, and so no part of its skeleton. Inside the hull a skeleton can run through space outside the solid (the
axis of a cup, of a pipe), so nothing there is flung. The surface is closed when the original cloud's inside
test (skelcore.inside) decides the region of empty cells round the object as a whole: outside. Through an open
surface (a single-view scan) the space behind it joins that region and splits its votes; the object then goes on
beyond what was seen, a part seen from one side has its axis beyond the scan's hull, and no point is flung.

A flung point takes the harmonic interpolation of its surface neighbours' contracted positions: the discrete
Laplace equation over the original surface's edges, the points not flung held where they are. A flung group
thus carries on as the material round it went. A group with no neighbour that stayed is left where it is.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from .errors import InputError
from .surface import OriginalSurface


def flung_points(contracted: np.ndarray, surface: OriginalSurface) -> np.ndarray:
    """(n,) which contracted points lie more than a point spacing beyond the convex hull of a closed original
    surface and from every original point (none when the surface is open)."""
    probe = surface.probe
    # the run's own test of the object when it made one (its metrics', of the input before cleaning or of a mesh's
    # faces), else the probe's: only cells decided with their region are read, which another thread resolving
    # split cells of the shared one leaves alone
    test = surface.shared_inside
    if test is None:
        try:
            test = probe.inside()
        except InputError:  # no part with a surface normal: no side of it is certain
            return np.zeros(len(contracted), bool)
    # the region round the object, which the grid's corner cell lies in: decided outside as a whole, or split
    if test.cells[0, 0, 0] != 0 or test.undecided[0, 0, 0]:
        return np.zeros(len(contracted), bool)
    flung = np.isinf(probe.tree.query(contracted, distance_upper_bound=probe.spacing, workers=-1)[0])
    if flung.any():  # a cell decided inside is within the hull: most points, passed over at one lookup each
        cell = tuple(test.cell_of(contracted[flung]).T)
        flung[flung] = (test.cells[cell] != 1) | test.undecided[cell]
    if flung.any():
        flung[flung] = _beyond_hull(contracted[flung], surface, probe.spacing)
    return flung


def _beyond_hull(points: np.ndarray, surface: OriginalSurface, margin: float) -> np.ndarray:
    """Which of `points` lie more than `margin` beyond a face plane of the convex hull of the original points (none
    when they span no volume). The points inside the small hull within it (OriginalSurface.hull_planes), most of
    them, are passed over, and only the others meet every face."""
    inner = surface.hull_planes(inner=True)
    if inner is None:
        return np.zeros(len(points), bool)
    beyond = (points @ inner[:, :3].T + inner[:, 3]).max(axis=1) > 0
    if beyond.any():
        planes = surface.hull_planes()
        beyond[beyond] = (points[beyond] @ planes[:, :3].T + planes[:, 3]).max(axis=1) > margin
    return beyond


def put_back(contracted: np.ndarray, surface: OriginalSurface) -> np.ndarray:
    """`contracted` with its flung points (flung_points) at the harmonic interpolation of their neighbours' places
    over the original surface's edges; the array itself when none is flung."""
    if not len(surface.edges):  # no neighbours to go with
        return contracted
    flung = flung_points(contracted, surface)
    if not flung.any():
        return contracted
    adjacency = surface.adjacency
    group = np.flatnonzero(flung)
    rows = adjacency[group]
    count, label = connected_components(rows[:, group], directed=False)
    anchored = np.zeros(count, bool)
    anchored[label[np.asarray(rows[:, ~flung].sum(axis=1)).ravel() > 0]] = True
    moved = group[anchored[label]]
    if not len(moved):
        return contracted
    rows = adjacency[moved]
    # L_FF x_F = A_FK x_K: each moved point the mean of its neighbours (its group's are moved too, or none is)
    laplacian = sp.diags(np.asarray(rows.sum(axis=1)).ravel()) - rows[:, moved]
    result = contracted.copy()
    result[moved] = np.asarray(spsolve(laplacian.tocsc(), rows[:, ~flung] @ contracted[~flung])).reshape(-1, 3)
    return result
