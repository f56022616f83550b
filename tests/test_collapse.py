"""skelcore.collapse: the incremental bookkeeping of collapse_to_graph gives the complex that recomputing every
key around every change gives, and the sample complex is built as by plain numpy unique."""
import heapq
import math

import numpy as np
import pytest

from skelcore import collapse
from skelcore.collapse import SampleComplex, collapse_to_graph, surface_triangles
from skelcore.neighbours import one_rings
from skelcore.sampling import ball_cover_sampling
from skelcore.shapes import make_shape


def recomputing_collapse(cx: SampleComplex) -> None:
    """collapse_to_graph as first written: every key around a change is computed afresh and pushed, and an
    entry is checked against its edge's key when it is popped. The reference of the fast version."""
    def key(u, v):
        apexes = cx.apex.get((u, v))
        if not apexes:
            return None
        span = math.dist(cx.xyz[u], cx.xyz[v])
        if len(apexes) == 1:
            (c,) = apexes
            if math.dist(cx.xyz[u], cx.xyz[c]) ** 2 + math.dist(cx.xyz[c], cx.xyz[v]) ** 2 < span ** 2:
                return 0, -span, 0.0
        if cx.link_condition(u, v):
            return 1, (len(cx.nbr[u]) + len(cx.nbr[v])) / 2, span
        return None

    def push_around(nodes):
        near = set()
        for node in nodes:
            near.add(node)
            near.update(cx.nbr[node])
        for u in near:
            for v in cx.nbr[u]:
                if u < v and (k := key(u, v)) is not None:
                    heapq.heappush(heap, (k, u, v))

    cx.drop_cavity_triangles()
    heap = []
    push_around(list(cx.nbr))
    while True:
        while heap:
            stored, u, v = heapq.heappop(heap)
            if u not in cx.nbr or v not in cx.nbr[u] or key(u, v) != stored:
                continue
            if stored[0] == 0:
                (c,) = cx.apex[(u, v)]
                cx.remove_triangle(u, v, c)
                cx.remove_edge(u, v)
                push_around((u, v, c))
            else:
                cx.contract(u, v, [(a + b) / 2 for a, b in zip(cx.xyz[u], cx.xyz[v])])
                push_around((u,))
        if not collapse._open_stuck_cavity(cx):
            return
        push_around(list(cx.nbr))


def sample_complex(name: str, shrink: float, n: int = 2000) -> SampleComplex:
    """The sample complex of a shape whose points moved `shrink` of the way to their centreline."""
    shape = make_shape(name, n)
    points = shape.points
    rings = one_rings(points, 12)
    centre = points.mean(axis=0)
    contracted = points + shrink * (centre - points) * np.array([1.0, 1.0, 0.2])
    radius = 0.03 * float(np.linalg.norm(np.ptp(points, axis=0)))
    samples, owner = ball_cover_sampling(contracted, radius)
    triangles = rings.triangles
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [0, 2]]])
    return SampleComplex.from_surface([tuple(p) for p in contracted[samples].tolist()], owner, edges, triangles)


@pytest.mark.parametrize("name,shrink", [("torus", 0.0), ("torus", 0.5), ("y_branch", 0.3), ("two_hole", 0.6),
                                         ("animal", 0.2)])
def test_collapse_matches_the_recomputing_reference(name, shrink):
    fast, reference = sample_complex(name, shrink), sample_complex(name, shrink)
    collapse_to_graph(fast)
    recomputing_collapse(reference)
    assert fast.nbr == reference.nbr
    assert fast.xyz == reference.xyz
    assert np.array_equal(fast.parent, reference.parent)
    assert not fast.triangles()


def test_sample_complex_edges_and_triangles_are_the_unique_mapped_ones():
    rng = np.random.default_rng(1)
    triangles = rng.integers(0, 300, (2000, 3))
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [0, 2]]])
    owner = rng.integers(0, 40, 300)
    cx = SampleComplex.from_surface([(0.0, 0.0, 0.0)] * 40, owner, edges, triangles)
    pairs = np.sort(owner[edges], axis=1)
    pairs = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0)
    corners = np.sort(owner[triangles], axis=1)
    corners = corners[(corners[:, 0] != corners[:, 1]) & (corners[:, 1] != corners[:, 2])]
    expected = np.unique(np.concatenate([corners, surface_triangles(pairs, 40)]), axis=0)
    assert {(u, v) for u in cx.nbr for v in cx.nbr[u] if u < v} == set(map(tuple, pairs.tolist()))
    assert sorted(cx.triangles()) == sorted(map(tuple, expected.tolist()))
