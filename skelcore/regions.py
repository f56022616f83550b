"""Regions of boolean voxel grids: dilation by a cell, face-connected (or corner-connected) labelling and the labels
on the grid's border, for the inside test's shell and regions (skelcore.inside), the open space the loop rule looks
through (skelcore.loops), the coarse grid that finds pieces far apart (skelcore.normalise) and the loops of a closed
cloud's solid (skelcore.cloud_topology)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components


def dilated(cells: np.ndarray) -> np.ndarray:
    """The boolean grid `cells` dilated by its full 3x3x3 neighbourhood (outside the grid counts as empty):
    the cube is the product of three 3-cell segments, so one pass along each axis gives it. Done here with
    numpy because scipy.ndimage costs 0.04-0.1 s to import (it rewrites its docstrings as it loads), more than
    the grids of a run take (at most a few hundred thousand cells)."""
    grown = cells.copy()
    for axis in range(cells.ndim):
        before = grown.copy()
        low = [slice(None)] * cells.ndim
        high = [slice(None)] * cells.ndim
        low[axis], high[axis] = slice(None, -1), slice(1, None)
        grown[tuple(low)] |= before[tuple(high)]
        grown[tuple(high)] |= before[tuple(low)]
    return grown


FACE_STEPS = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
# the 13 steps to a cell sharing a face, an edge or a corner, one of each opposite pair
TOUCHING_STEPS = tuple(step for step in np.ndindex(3, 3, 3) if step > (1, 1, 1))


def label_regions(cells: np.ndarray, touching: bool = False) -> tuple[np.ndarray, int]:
    """(label of each cell, count) of the face-connected regions of the True cells of a 3D grid: labels 1..count
    in the order of each region's first cell in C order, 0 for False cells (scipy.ndimage.label's numbering).
    touching: cells sharing only an edge or a corner are joined too (the pieces of a union of closed cubes)."""
    index = np.full(cells.shape, -1, np.int64)
    members = np.flatnonzero(cells)
    index.ravel()[members] = np.arange(len(members))
    pairs = []
    for step in (np.subtract(TOUCHING_STEPS, 1) if touching else FACE_STEPS):
        low = tuple(slice(max(-s, 0), cells.shape[d] - max(s, 0)) for d, s in enumerate(step))
        high = tuple(slice(max(s, 0), cells.shape[d] - max(-s, 0)) for d, s in enumerate(step))
        a, b = index[low].ravel(), index[high].ravel()
        both = (a >= 0) & (b >= 0)
        pairs.append(np.stack([a[both], b[both]]))
    edges = np.concatenate(pairs, axis=1)
    graph = sp.csr_matrix((np.ones(edges.shape[1], np.int8), (edges[0], edges[1])), shape=(len(members),) * 2)
    count, piece = connected_components(graph, directed=False)
    labels = np.zeros(cells.shape, np.int32)
    labels.ravel()[members] = piece + 1
    return labels, count


def border_labels(labels: np.ndarray) -> np.ndarray:
    """The distinct labels on the six faces of a 3D grid of labels (0 among them where a face holds it)."""
    return np.unique(np.concatenate([labels[[0, -1]].ravel(), labels[:, [0, -1]].ravel(),
                                     labels[:, :, [0, -1]].ravel()]))
