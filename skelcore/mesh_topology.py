"""The topology of a triangle mesh's surface: its pieces, Euler characteristic, boundary loops and genus.

A closed mesh bounds a solid, and the loops through that solid (the holes a curve skeleton must keep) number its
surface's genus, summed over its pieces: the Euler-Poincare formula chi = V - E + F = 2 C - 2 g - b for an
orientable surface of C pieces with b boundary loops. Read from the file's own faces, before any resampling,
this is exact, where a count from sampled points depends on the scale it is read at.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components



def mesh_topology(faces: np.ndarray, vertex_count: int) -> dict:
    """{"components", "euler", "boundary_loops", "genus", "closed"} of the surface of (f,3) triangles `faces`
    over `vertex_count` vertices (those no face uses are not counted). Closed: every edge has exactly two
    faces. Vertices at one position must have been merged (a triangle soup counts as separate triangles)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    used = np.flatnonzero(np.bincount(faces.ravel(), minlength=vertex_count))
    sides = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    # one sort of one key per side (low * count + high) finds the edges and how many faces each has
    keys = np.sort(sides[:, 0] * vertex_count + sides[:, 1])
    starts = np.r_[True, keys[1:] != keys[:-1]] if len(keys) else np.zeros(0, dtype=bool)
    uses = np.diff(np.flatnonzero(np.r_[starts, True]))
    edges = np.stack(np.divmod(keys[starts], vertex_count), axis=1)
    chi = len(used) - len(edges) + len(faces)
    components = _pieces(edges, used, vertex_count)
    border = edges[uses == 1]
    boundary_loops = _pieces(border, np.unique(border), vertex_count)
    return {"components": components, "euler": int(chi), "boundary_loops": boundary_loops,
            "genus": (2 * components - boundary_loops - chi) // 2, "closed": bool(len(faces) and (uses == 2).all())}


def solid_loops(faces: np.ndarray, vertex_count: int) -> int | None:
    """The loops through the solid a closed mesh bounds (its total genus); None when the surface is not closed
    (a scan's open mesh, a sheet), which bounds no solid."""
    if faces is None or len(faces) == 0:
        return None
    topology = mesh_topology(faces, vertex_count)
    return topology["genus"] if topology["closed"] else None


def _pieces(edges: np.ndarray, vertices: np.ndarray, vertex_count: int) -> int:
    """Connected pieces of the graph of `edges` among `vertices` (every vertex an edge touches)."""
    if len(vertices) == 0:
        return 0
    graph = sp.csr_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(vertex_count, vertex_count))
    labels = connected_components(graph, directed=False)[1]
    return len(np.unique(labels[vertices]))
