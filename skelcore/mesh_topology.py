"""The topology of a triangle mesh's surface: its pieces, Euler characteristic, boundary loops and genus.

A closed mesh bounds a solid, and the loops through that solid (the holes a curve skeleton must keep) number its
surface's genus, summed over its pieces: the Euler-Poincare formula chi = V - E + F = 2 C - 2 g - b for an
orientable surface of C pieces with b boundary loops. Read from the file's own faces, before any resampling,
this is exact, where a count from sampled points depends on the scale it is read at. It holds for a surface
that is a manifold: two solids touching at a corner share a vertex whose faces form two fans, and the formula
then counts one piece too few (a genus of -1 for two cubes).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .distinct import distinct_rows


def mesh_topology(faces: np.ndarray, vertex_count: int) -> dict:
    """{"components", "euler", "boundary_loops", "genus", "closed"} of the surface of (f,3) triangles `faces`
    over `vertex_count` vertices (those no face uses are not counted; a face repeated, or naming a vertex twice,
    counts once or not at all). Closed: a manifold without border, every edge on exactly two faces and every
    vertex's faces one fan. Vertices at one position must have been merged (a triangle soup counts as separate
    triangles)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    if len(faces):
        faces = distinct_rows(np.sort(faces, axis=1))  # one face per vertex triple (the order is no topology)
    used = np.flatnonzero(np.bincount(faces.ravel(), minlength=vertex_count))
    ends = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    low, high = ends.min(axis=1), ends.max(axis=1)
    # one sort of one key per side (low * count + high) finds the edges and how many faces each has
    keys = low * vertex_count + high
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    starts = np.r_[True, ordered[1:] != ordered[:-1]] if len(keys) else np.zeros(0, dtype=bool)
    uses = np.diff(np.flatnonzero(np.r_[starts, True]))
    edges = np.stack(np.divmod(ordered[starts], vertex_count), axis=1)
    chi = len(used) - len(edges) + len(faces)
    components = _pieces(edges, used, vertex_count)
    border = edges[uses == 1]
    boundary_loops = _pieces(border, np.unique(border), vertex_count)
    two_sided = bool(len(faces)) and bool((uses == 2).all())
    return {"components": components, "euler": int(chi), "boundary_loops": boundary_loops,
            "genus": (2 * components - boundary_loops - chi) // 2,
            "closed": two_sided and _fans(ends, order, len(faces)) == len(used)}


def closed_solid(faces: np.ndarray | None, vertex_count: int) -> tuple[int | None, int | None, str]:
    """(loops, pieces, ""): the loops through the solid a closed mesh bounds (its total genus) and the pieces of
    its surface; or (None, None, why in words) when the surface bounds no solid (a scan's open mesh, a sheet, two
    solids touching at an edge or a corner). (None, None, "") without faces."""
    if faces is None or len(faces) == 0:
        return None, None, ""
    topology = mesh_topology(faces, vertex_count)
    if topology["closed"]:
        return topology["genus"], topology["components"], ""
    why = (f"it has {topology['boundary_loops']} boundary loop{'' if topology['boundary_loops'] == 1 else 's'}"
           if topology["boundary_loops"] else "edges or corners where separate sheets meet")
    return None, None, (f"the mesh's faces close no solid ({why}), so its skeleton's loops are not checked against "
                        f"a genus")


def _fans(ends: np.ndarray, order: np.ndarray, face_count: int) -> int:
    """The fans of faces round the vertices of a surface whose every edge has two faces: the pieces of the graph
    of face corners joined across the edges they share (corner 3 f + j is face f's j-th vertex; side s = 3 f + j
    runs from that corner to the next, `ends` its two vertices, `order` the sides sorted by edge)."""
    side = np.arange(len(ends))
    corner = 3 * (side // 3)
    at_low = np.where(ends[:, 0] <= ends[:, 1], side, corner + (side % 3 + 1) % 3)  # the corner at the lower end
    at_high = np.where(ends[:, 0] <= ends[:, 1], corner + (side % 3 + 1) % 3, side)
    first, second = order[0::2], order[1::2]  # each edge's two sides, next to each other in edge order
    rows = np.r_[at_low[first], at_high[first]]
    cols = np.r_[at_low[second], at_high[second]]
    graph = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * face_count,) * 2)
    return connected_components(graph, directed=False)[0]


def _pieces(edges: np.ndarray, vertices: np.ndarray, vertex_count: int) -> int:
    """Connected pieces of the graph of `edges` among `vertices` (every vertex an edge touches)."""
    if len(vertices) == 0:
        return 0
    graph = sp.csr_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(vertex_count, vertex_count))
    labels = connected_components(graph, directed=False)[1]
    return len(np.unique(labels[vertices]))
