"""The shape's surface carried onto the skeleton samples, then collapsed to a graph without changing its loops.

Every input point maps to a skeleton sample (the ball-cover owner of its contracted position). The ring
triangles of the ORIGINAL surface, mapped through that owner, form a 2-complex on the samples: its edges
join samples whose points are ring neighbours, its triangles are the surface triangles whose three corners
went to three different samples, plus every 3-cycle of its graph (a loop must pass at least four samples
to be resolved). The contraction is a deformation of the shape onto its skeleton, so this complex has the
loops of the shape, however the contracted points lie: a loop's hole is crossed by no surface triangle,
and a sheet or a blob that did not contract to a curve is filled by the triangles of its sides. No
distance, angle or length threshold decides what a loop is here (skelcore.loops then vetoes the few false
ones that gaps between disagreeing fans leave).

The complex is then reduced to a graph by operations that keep its homotopy type, so no loop is ever lost
or made:
- elementary collapse: an edge in exactly one triangle (a free edge) goes with its triangle. Taken first
  where the edge jumps over its apex (obtuse angle there, the Gabriel test), longest first: along a curve,
  samples i and i+2 are often joined over i+1;
- edge contraction under the link condition (Dey et al. 1999, Lk(a) & Lk(b) == Lk(ab)): a and b merge at
  their midpoint, lowest mean endpoint degree first, then shortest. The condition forbids contracting an
  edge of a triangle-free 3-cycle (a short loop) and folding two triangles onto each other.
Triangles that close a cavity (a blob that kept its volume: its two sides enclose it) are removed first,
one per cavity, chosen by the persistence pairing (gudhi): that changes no loop.
"""
from __future__ import annotations

import heapq
import math

import numpy as np

from .distinct import distinct, distinct_rows


def surface_triangles(edges: np.ndarray, n_points: int) -> np.ndarray:
    """(t,3) the triangles (3-cliques) of the graph of `edges` on n_points, each once, corners ascending."""
    edges = distinct_rows(np.sort(edges, axis=1)) if len(edges) else np.zeros((0, 2), dtype=np.int64)
    directed = np.concatenate([edges, edges[:, ::-1]])
    directed = directed[np.lexsort((directed[:, 1], directed[:, 0]))]
    keys = directed[:, 0] * n_points + directed[:, 1]
    starts = np.searchsorted(directed[:, 0], np.arange(n_points + 1))
    a, b = edges[:, 0], edges[:, 1]
    degree = starts[a + 1] - starts[a]
    row = np.repeat(np.arange(len(edges)), degree)
    offset = np.arange(len(row)) - np.repeat(np.cumsum(degree) - degree, degree)
    c = directed[starts[a[row]] + offset, 1]
    above = c > b[row]
    row, c = row[above], c[above]
    wanted = b[row] * n_points + c
    found = np.searchsorted(keys, wanted)
    found = (found < len(keys)) & (keys[np.minimum(found, len(keys) - 1)] == wanted)
    return np.column_stack([a[row], b[row], c])[found]


def _edge(u: int, v: int) -> tuple[int, int]:
    return (u, v) if u < v else (v, u)


class SampleComplex:
    """A 2-complex on skeleton samples: `nbr` node -> neighbours, `apex` edge -> third corners of its
    triangles, `xyz` node positions, `parent` the merge forest (a merged node points at its survivor)."""

    def __init__(self, xyz: list, edges: np.ndarray, triangles: np.ndarray) -> None:
        self.xyz = xyz
        self.parent = np.arange(len(xyz))
        self.nbr: dict[int, set[int]] = {i: set() for i in range(len(xyz))}
        self.apex: dict[tuple[int, int], set[int]] = {}
        for u, v in edges.tolist():
            self.nbr[u].add(v)
            self.nbr[v].add(u)
        for a, b, c in triangles.tolist():
            for u, v, w in ((a, b, c), (a, c, b), (b, c, a)):
                self.nbr[u].add(v)
                self.nbr[v].add(u)
                self.apex.setdefault(_edge(u, v), set()).add(w)

    @classmethod
    def from_surface(cls, xyz: list, owner: np.ndarray, edges: np.ndarray, triangles: np.ndarray) -> "SampleComplex":
        """The complex of the surface `edges`/`triangles` (point ids) mapped through `owner` (point -> node),
        with every 3-cycle of its graph filled: a loop must pass at least four samples to be resolved (the
        fans of a surface leave tiny gaps where neighbouring fans disagree, which a stretched part of the
        contraction can spread over three samples)."""
        m = len(xyz)
        ends = owner[edges].reshape(-1, 2)
        low, high = ends.min(axis=1), ends.max(axis=1)
        codes = distinct(low[low != high] * m + high[low != high])  # in the order of (low, high)
        pairs = np.column_stack([codes // m, codes % m])
        corners = owner[triangles].reshape(-1, 3)
        first, last = corners.min(axis=1), corners.max(axis=1)
        middle = corners.sum(axis=1) - first - last
        three_nodes = (first != middle) & (middle != last)
        corners = np.concatenate([np.column_stack([first, middle, last])[three_nodes], surface_triangles(pairs, m)])
        return cls(xyz, pairs, distinct_rows(corners))

    def triangles(self) -> list[tuple[int, int, int]]:
        """Every triangle once, as (u, v, w) with u < v < w."""
        return [(u, v, w) for (u, v), apexes in self.apex.items() for w in apexes if w > v]

    def drop_cavity_triangles(self) -> None:
        """Remove the triangles that close cavities (the positive 2-simplices of the persistence pairing, one
        per independent 2-cycle): the boundaries the other triangles span are unchanged, so the loops are
        too, and no closed surface is left to stop the collapse."""
        import gudhi

        tree = gudhi.SimplexTree()
        for u, nbrs in self.nbr.items():
            tree.insert([u], 0.0)
            for v in nbrs:
                if u < v:
                    tree.insert([u, v], 0.0)
        for triangle in self.triangles():
            tree.insert(list(triangle), 1.0)
        tree.compute_persistence(persistence_dim_max=True)
        for birth, _ in tree.persistence_pairs():
            if len(birth) == 3:
                self.remove_triangle(*sorted(birth))

    def link_condition(self, u: int, v: int) -> bool:
        """Lk(u) & Lk(v) == Lk(uv) in a 2-complex: the common neighbours are exactly the apexes of uv, and no
        edge cw joins two of them with triangles ucw and vcw both present."""
        apexes = self.apex.get(_edge(u, v), set())
        if self.nbr[u] & self.nbr[v] != apexes:
            return False
        return len(apexes) < 2 or not any(
            w in self.apex.get(_edge(u, c), ()) and w in self.apex.get(_edge(v, c), ())
            for c in apexes for w in apexes if c < w)

    def contract(self, keep: int, gone: int, at) -> None:
        """Merge `gone` into `keep` at `at`: triangles on the edge vanish, the others follow `gone`."""
        for c in self.apex.pop(_edge(keep, gone), ()):
            self.apex[_edge(keep, c)].discard(gone)
            self.apex[_edge(gone, c)].discard(keep)
        for x in self.nbr.pop(gone) - {keep}:
            apexes = self.apex.pop(_edge(gone, x), set())
            for y in apexes:
                across = self.apex[_edge(x, y)]
                across.discard(gone)
                across.add(keep)
            self.apex.setdefault(_edge(keep, x), set()).update(apexes)
            self.nbr[x].discard(gone)
            self.nbr[x].add(keep)
            self.nbr[keep].add(x)
        self.nbr[keep].discard(gone)
        self.parent[gone] = keep
        self.xyz[keep] = tuple(float(c) for c in at)

    def remove_triangle(self, u: int, v: int, w: int) -> None:
        """Remove the triangle (u, v, w) from its three edges."""
        for a, b, c in ((u, v, w), (u, w, v), (v, w, u)):
            self.apex[_edge(a, b)].discard(c)

    def remove_edge(self, u: int, v: int) -> None:
        """Remove a triangle-free edge."""
        self.apex.pop(_edge(u, v), None)
        self.nbr[u].discard(v)
        self.nbr[v].discard(u)


def collapse_to_graph(cx: SampleComplex) -> None:
    """Reduce `cx` to a graph (no triangle left) by elementary collapses and link-condition contractions.

    A lazy heap of (key, u, v) entries, smallest first. After a change, the edges (u, v), u < v, whose end u
    is a changed node or one of its neighbours are pushed with their current key (an edge whose key changed
    at its larger end only keeps its old entry until it is pushed again); an entry whose key is no longer
    its edge's is stale and skipped. `keys` holds every edge's current key: after a change only the edges
    whose key it can change are recomputed (_incident, _touched_by_contraction). The heap holds each entry
    once: a second copy of an entry would pop right after the first and find its edge gone."""
    xyz, nbr, apex, dist = cx.xyz, cx.nbr, cx.apex, math.dist

    def key(u: int, v: int) -> tuple | None:
        apexes = apex.get((u, v))
        if not apexes:
            return None
        span = dist(xyz[u], xyz[v])
        if len(apexes) == 1:
            (c,) = apexes
            if dist(xyz[u], xyz[c]) ** 2 + dist(xyz[c], xyz[v]) ** 2 < span ** 2:
                return 0, -span, 0.0
        if cx.link_condition(u, v):
            return 1, (len(nbr[u]) + len(nbr[v])) / 2, span
        return None

    def recompute(edges) -> None:
        for edge in edges:
            keys[edge] = key(*edge)

    def push_around(nodes) -> None:
        near = set(nodes)
        for node in nodes:
            near.update(cx.nbr[node])
        for u in near:
            for v in cx.nbr[u]:
                if u < v and (k := keys[(u, v)]) is not None and (entry := (*k, u, v)) not in queued:
                    queued.add(entry)
                    heapq.heappush(heap, entry)

    cx.drop_cavity_triangles()
    heap: list = []
    queued: set[tuple] = set()  # the entries in the heap
    keys: dict[tuple[int, int], tuple | None] = {}
    recompute(_incident(cx, cx.nbr))
    push_around(list(cx.nbr))
    while True:
        while heap:
            entry = heapq.heappop(heap)
            queued.discard(entry)
            *stored, u, v = entry
            if keys.get((u, v)) != tuple(stored):
                continue
            if stored[0] == 0:
                (c,) = cx.apex[(u, v)]
                cx.remove_triangle(u, v, c)
                cx.remove_edge(u, v)
                del keys[(u, v)]
                recompute(_incident(cx, (u, v, c)))
                push_around((u, v, c))
            else:
                common = nbr[u] & nbr[v]
                for x in nbr[v]:
                    del keys[_edge(v, x)]
                cx.contract(u, v, [(a + b) / 2 for a, b in zip(xyz[u], xyz[v])])
                recompute(_touched_by_contraction(cx, u, common))
                push_around((u,))
        if not _open_stuck_cavity(cx):
            return
        keys.clear()
        recompute(_incident(cx, cx.nbr))
        push_around(list(cx.nbr))


def _incident(cx: SampleComplex, nodes) -> set[tuple[int, int]]:
    """The edges at `nodes`. An elementary collapse of triangle uvc changes the neighbours of u and v and the
    triangles on uv, uc and vc: the keys of the edges at u, v and c only (a key reads the neighbours of its
    ends, the triangles on its edge and those on the edges from its ends to its apexes)."""
    return {_edge(x, y) for x in nodes for y in cx.nbr[x]}


def _touched_by_contraction(cx: SampleComplex, keep: int, common: set[int]) -> set[tuple[int, int]]:
    """The edges whose key a contraction into `keep` can change: those at `keep` and at the `common`
    neighbours of the two merged nodes (their degree fell), and those between two neighbours of `keep` (their
    common neighbours and the triangles at their ends changed, and `keep`, which moved, can be their apex).
    A neighbour that moved from the merged node to `keep` keeps its degree and, towards the rest of the
    complex, its triangles."""
    around = cx.nbr[keep]
    edges = _incident(cx, (keep, *common))
    edges.update(_edge(x, y) for x in around for y in cx.nbr[x] & around)
    return edges


def _open_stuck_cavity(cx: SampleComplex) -> bool:
    """When triangles remain that no collapse or contraction may touch: a free edge goes first (an
    elementary collapse, whatever its angle), the longest. With none, the complex is contractible but not
    collapsible here (a "dunce hat" knot of triangles, rare): the largest triangle is removed, which can
    open one small loop. Returns whether anything changed."""
    triangles = [(edge, w) for edge, apexes in cx.apex.items() for w in apexes]
    if not triangles:
        return False
    free = [(math.dist(cx.xyz[u], cx.xyz[v]), (u, v)) for (u, v), w in triangles if len(cx.apex[(u, v)]) == 1]
    if free:
        _, (u, v) = max(free)
        (c,) = cx.apex[(u, v)]
        cx.remove_triangle(u, v, c)
        cx.remove_edge(u, v)
        return True

    def area(u: int, v: int, w: int) -> float:
        return float(np.linalg.norm(np.cross(np.subtract(cx.xyz[v], cx.xyz[u]), np.subtract(cx.xyz[w], cx.xyz[u]))))

    cx.remove_triangle(*max(((u, v, w) for (u, v), w in triangles if w > v), key=lambda t: area(*t)))
    return True
