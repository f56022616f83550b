"""Curve skeleton: the contracted points (a surface skeleton) to a graph that keeps the shape's loops.

cloudcontr `rosa_lineextract` (Cao et al. 2010, section 4), fixed where it is buggy:
1. ball-cover farthest point sampling of the contracted points, radius r = sample_radius * diagonal of the
   ORIGINAL points' bounding box; every point maps to its nearest sample;
2. two samples are joined when a ring edge joins points mapped to them;
3. no triangle is left. A triangle edge that jumps over a common neighbour (Gabriel test) is deleted when
   the common neighbours are connected, which keeps every hole of the graph (along a curve the samples i
   and i+2 are often joined, and contracting such a band, as cloudcontr does, shrinks a loop to nothing).
   The other triangle edges collapse to their midpoint, lowest mean endpoint degree first, then shortest;
4. RULE FOR CYCLES: a cycle is a loop of the shape when (a) it encloses a hole in the contracted points
   and (b) a passage through the ORIGINAL shape opens at that hole. (a) Each minimal cycle is projected
   on its best-fitting plane; inside the polygon, the largest circle free of the contracted points of its
   nodes and of their neighbours must be at least HOLE_RATIO times the largest inscribed circle, and
   HOLE_GAPS times the usual gap between those points: a face of a sheet that did not contract to a curve
   is filled by its own points. (b) From the cycle's centroid, on each side of its plane, at least
   PASSAGE_MIN of the rays within PASSAGE_ANGLE of its normal leave the original shape, passing no
   original point closer than that point's longest ring edge: a torus's hole is such a passage, while a
   bulky part that did not contract to a curve leaves a hollow ring inside the shape (or against a pocket
   of it). No length threshold: a long loop and a 4-node loop are judged alike. A cycle that fails is
   contracted to one node at the mean of its nodes (shrinking it edge by edge would judge it again at
   every step, and a hollow ring would end up passing somewhere), then step 3 runs again, until every
   cycle left is a loop;
5. refinements, each switchable, in this order: merge junctions joined by a short path, prune short spurs,
   recentre (move each degree-2 node across the curve onto the centre of the cross-section of the ORIGINAL
   points mapped to it and to its neighbours; see _recentre), drop nearly collinear degree-2 nodes.
Lengths of the refinements are in units of r, so they follow the sampling.
"""
from __future__ import annotations

import dataclasses
import heapq
import math
import numbers
from dataclasses import dataclass

import networkx as nx
import numpy as np
from scipy.spatial import cKDTree

from .errors import InputError, ParameterError
from .io import as_points

HOLE_RATIO = 0.5  # a cycle is a loop when its empty circle is at least this fraction of its inscribed circle
HOLE_GAPS = 2.0  # ... and at least this many times the usual gap between its points
HOLE_GRID = 32  # grid points per side on which a cycle's interior is probed
PASSAGE_ANGLE = 30.0  # ... and a passage through the shape opens there: of the rays from its centroid within
PASSAGE_MIN = 0.5  # this many degrees of its normal, at least this fraction leave the shape on either side

Adjacency = dict[int, set[int]]  # working graph: node -> neighbours; merged-away nodes are removed


@dataclass(frozen=True)
class SkeletonParams:
    sample_radius: float = 0.02  # ball radius, fraction of the ORIGINAL points' bounding-box diagonal
    merge_junctions: bool = True
    junction_distance: float = 2.0  # in sample radii: junctions joined by a shorter path become one
    prune_spurs: bool = True
    spur_length: float = 3.0  # in sample radii: end branches shorter than this are removed
    drop_collinear: bool = False
    collinear_angle: float = 10.0  # degrees: a degree-2 node turning less than this is dropped
    recentre: bool = True  # degree-2 nodes move across the curve onto the centre of their original points' cross-section

    def validated(self) -> "SkeletonParams":
        for name in ("sample_radius", "junction_distance", "spur_length"):
            value = getattr(self, name)
            if not _real(value) or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"parameter {name}={value!r}: must be a positive finite number")
        if self.sample_radius > 1:
            raise ParameterError(f"parameter sample_radius={self.sample_radius!r}: must be at most 1 "
                                 "(a fraction of the diagonal)")
        angle = self.collinear_angle
        if not _real(angle) or not 0 <= angle < 180:
            raise ParameterError(f"parameter collinear_angle={angle!r}: must be a number of degrees in [0, 180)")
        return self

    def replace(self, **changes) -> "SkeletonParams":
        return dataclasses.replace(self, **changes).validated()

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclass
class Skeleton:
    graph: nx.Graph  # nodes 0..m-1 with 'pos' (3,) and 'point_count'; edges with 'length'
    correspondence: np.ndarray  # (n,) node of every input point
    radius: float  # the sample radius in the user's units

    def nodes_array(self) -> np.ndarray:
        if self.graph.number_of_nodes() == 0:
            return np.zeros((0, 3))
        return np.array([self.graph.nodes[i]["pos"] for i in range(self.graph.number_of_nodes())], dtype=float)

    def edges_array(self) -> np.ndarray:
        edges = np.array(sorted(tuple(sorted(e)) for e in self.graph.edges()), dtype=np.int64)
        return edges.reshape(-1, 2)

    def degrees(self) -> np.ndarray:
        return np.array([self.graph.degree(i) for i in range(self.graph.number_of_nodes())], dtype=np.int64)

    def topology(self) -> dict:
        """components, cycles (independent loops = E - V + C), junctions (degree >= 3), ends (degree 1)."""
        degrees = self.degrees()
        components = nx.number_connected_components(self.graph)
        return {
            "components": components,
            "cycles": self.graph.number_of_edges() - self.graph.number_of_nodes() + components,
            "junctions": int((degrees >= 3).sum()),
            "ends": int((degrees == 1).sum()),
        }


def extract_skeleton(contracted, original, ring_edges, params: SkeletonParams | None = None) -> Skeleton:
    """Curve skeleton graph of `contracted` (n,3); `original` (n,3) the same points before contraction;
    `ring_edges` (e,2) pairs of ring neighbours (OneRings.edges())."""
    params = (params or SkeletonParams()).validated()
    contracted, original, ring_edges = _checked(contracted, original, ring_edges)
    radius = params.sample_radius * float(np.linalg.norm(original.max(axis=0) - original.min(axis=0)))

    samples, owner = ball_cover_sampling(contracted, radius)
    xyz = [tuple(p) for p in contracted[samples].tolist()]
    adj: Adjacency = {i: set() for i in range(len(samples))}
    pairs = owner[ring_edges]
    for a, b in np.unique(np.sort(pairs[pairs[:, 0] != pairs[:, 1]], axis=1), axis=0).tolist():
        adj[a].add(b)
        adj[b].add(a)
    parent = np.arange(len(samples))

    _collapse_triangles(adj, xyz, parent)
    _remove_false_loops(adj, xyz, parent, owner, contracted, original, ring_edges)
    if params.merge_junctions:
        _merge_junctions(adj, xyz, parent, params.junction_distance * radius)
    if params.prune_spurs:
        _prune_spurs(adj, xyz, parent, params.spur_length * radius)
    node_of_point = _roots(parent)[owner]
    if params.recentre:
        _recentre(adj, xyz, node_of_point, original)
    if params.drop_collinear:
        node_of_point = _drop_collinear(adj, xyz, node_of_point, contracted, params.collinear_angle)
    return _finish(adj, xyz, node_of_point, radius)


def ball_cover_sampling(points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Farthest point sampling until every point lies within `radius` of a sample.

    Returns (samples (s,) point ids, owner (n,) index into samples of each point's nearest sample). The loop
    runs over samples; a new sample at distance D from the others can only be nearest to points within D of
    it, so only that ball is updated. Starts at the point farthest from the centroid (deterministic).
    """
    tree = cKDTree(points)
    first = int(np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1)))
    nearest = np.linalg.norm(points - points[first], axis=1)
    owner = np.zeros(len(points), dtype=np.int64)
    samples = [first]
    while True:
        far = int(np.argmax(nearest))
        reach = nearest[far]
        if reach <= radius:
            break
        ball = np.asarray(tree.query_ball_point(points[far], reach), dtype=np.int64)
        dist = np.linalg.norm(points[ball] - points[far], axis=1)
        closer = dist < nearest[ball]
        nearest[ball[closer]] = dist[closer]
        owner[ball[closer]] = len(samples)
        nearest[far], owner[far] = 0.0, len(samples)
        samples.append(far)
    return np.asarray(samples, dtype=np.int64), owner


def _checked(contracted, original, ring_edges) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrays = [as_points(contracted, "contracted points"), as_points(original, "original points")]
    if len(arrays[0]) != len(arrays[1]):
        raise InputError(f"contracted and original points differ in number ({len(arrays[0])} vs {len(arrays[1])})")
    edges = np.asarray(ring_edges)
    if edges.size == 0:
        edges = np.zeros((0, 2), dtype=np.int64)
    if edges.ndim != 2 or edges.shape[1] != 2 or not np.issubdtype(edges.dtype, np.integer):
        raise InputError(f"ring edges: expected an (e, 2) integer array, got shape {edges.shape} of {edges.dtype}")
    if len(edges) and (edges.min() < 0 or edges.max() >= len(arrays[0])):
        raise InputError(f"ring edges: point ids must lie in [0, {len(arrays[0])})")
    return arrays[0], arrays[1], edges.astype(np.int64)


def _roots(parent: np.ndarray) -> np.ndarray:
    """Resolve the merge forest: every sample to the node that absorbed it."""
    root = parent.copy()
    while True:
        nxt = root[root]
        if np.array_equal(nxt, root):
            return root
        root = nxt


def _members(node_of_point: np.ndarray):
    """node -> ids of the points mapped to it, from one sort."""
    order = np.argsort(node_of_point, kind="stable")
    bounds = np.searchsorted(node_of_point[order], np.arange(node_of_point.max() + 2))
    return lambda node: order[bounds[node]:bounds[node + 1]]


def _inside(grid: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd rule: which 2-D grid points lie inside the closed polygon."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    y = grid[:, 1:2]
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (crosses & (grid[:, 0:1] < x_cross)).sum(axis=1) % 2 == 1


def _boundary_distance(grid: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    a, b = polygon, np.roll(polygon, -1, axis=0)
    edge = b - a
    t = np.clip(((grid[:, None, :] - a) * edge).sum(-1) / np.maximum((edge**2).sum(-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(grid[:, None, :] - (a + t[..., None] * edge), axis=-1).min(axis=1)


def _merge(adj: Adjacency, xyz: list, parent: np.ndarray, keep: int, gone: list[int], at) -> None:
    """Contract the nodes `gone` into `keep`, placed at `at`."""
    for node in gone:
        for w in adj.pop(node):
            adj[w].discard(node)
            if w != keep:
                adj[w].add(keep)
                adj[keep].add(w)
        parent[node] = keep
    xyz[keep] = tuple(float(c) for c in at)


def _midpoint(xyz: list, u: int, v: int) -> tuple:
    return tuple((a + b) / 2 for a, b in zip(xyz[u], xyz[v]))


def _shortcut(adj: Adjacency, xyz: list, u: int, v: int, common: set) -> bool:
    """u-v jumps over a common neighbour inside its diametral ball (Gabriel test), and the common
    neighbours are connected: deleting u-v then removes its triangles without opening a hole."""
    span = math.dist(xyz[u], xyz[v]) ** 2
    if not any(math.dist(xyz[u], xyz[c]) ** 2 + math.dist(xyz[c], xyz[v]) ** 2 < span for c in common):
        return False
    seen, todo = set(), [next(iter(common))]
    while todo:
        node = todo.pop()
        seen.add(node)
        todo.extend((adj[node] & common) - seen)
    return seen == common


def _collapse_triangles(adj: Adjacency, xyz: list, parent: np.ndarray) -> None:
    """Remove every triangle (step 3): shortcut edges are deleted, longest first; then the other triangle
    edges collapse to their midpoint, lowest mean endpoint degree first, then shortest.

    A lazy heap: after a change every edge whose key may have changed is pushed again; an entry whose key
    no longer matches is stale and skipped (its fresh copy is in the heap)."""
    def key(u: int, v: int) -> tuple[int, float, float] | None:
        common = adj[u] & adj[v]
        if not common:
            return None
        length = math.dist(xyz[u], xyz[v])
        if _shortcut(adj, xyz, u, v, common):
            return 0, -length, 0.0
        return 1, (len(adj[u]) + len(adj[v])) / 2, length

    def push(edges) -> None:
        for u, v in {(min(e), max(e)) for e in edges}:
            if (k := key(u, v)) is not None:
                heapq.heappush(heap, (k, u, v))

    heap: list = []
    push((u, v) for u in adj for v in adj[u])
    while heap:
        stored, u, v = heapq.heappop(heap)
        if u not in adj or v not in adj[u] or key(u, v) != stored:
            continue
        common = adj[u] & adj[v]
        if stored[0] == 0:  # degrees of u, v and the links of edges among the common neighbours change
            adj[u].discard(v)
            adj[v].discard(u)
            push([(u, w) for w in adj[u]] + [(v, w) for w in adj[v]]
                 + [(w, x) for w in common for x in adj[w] & common])
        else:  # u moves, the common neighbours lose a degree, edges among u's neighbours gain u
            _merge(adj, xyz, parent, u, [v], _midpoint(xyz, u, v))
            push([(u, w) for w in adj[u]] + [(c, x) for c in common for x in adj[c]]
                 + [(w, x) for w in adj[u] for x in adj[w] & adj[u]])


def _encloses_hole(adj: Adjacency, cycle: list[int], xyz: list, points: np.ndarray, members) -> bool:
    """Rule 4(a): inside the cycle (projected on its best-fitting plane), the largest circle free of the
    contracted points of its nodes and their neighbours is at least HOLE_RATIO times the largest inscribed
    circle, and HOLE_GAPS times the usual gap between those points (90th percentile of nearest-neighbour
    distances). A sheet fills its faces with points; a loop of the shape is empty in the middle, however
    bent; a gap no wider than the gaps of a sparse cloud is no loop."""
    corners = np.array([xyz[node] for node in cycle])
    centre = corners.mean(axis=0)
    plane = np.linalg.svd(corners - centre)[2][:2]
    polygon = (corners - centre) @ plane.T
    axes = [np.linspace(lo, hi, HOLE_GRID) for lo, hi in zip(polygon.min(axis=0), polygon.max(axis=0))]
    grid = np.stack(np.meshgrid(*axes), axis=-1).reshape(-1, 2)
    grid = grid[_inside(grid, polygon)]
    if len(grid) == 0:
        return False
    ids = np.concatenate([members(node) for node in set(cycle).union(*(adj[node] for node in cycle))])
    tree = cKDTree(points[ids])
    empty = tree.query(centre + grid @ plane)[0].max()
    gap = np.percentile(tree.query(points[ids], k=2)[0][:, -1], 90)
    return empty >= max(HOLE_RATIO * _boundary_distance(grid, polygon).max(), HOLE_GAPS * gap)


def _two_core(adj: Adjacency) -> Adjacency:
    """The nodes on cycles or on paths between cycles: peel nodes of degree < 2."""
    core = {u: set(nbrs) for u, nbrs in adj.items()}
    todo = [u for u, nbrs in core.items() if len(nbrs) < 2]
    while todo:
        u = todo.pop()
        for w in core.pop(u, ()):
            core[w].discard(u)
            if len(core[w]) == 1:
                todo.append(w)
    return core


def _shortest_path(adj: Adjacency, xyz: list, source: int, target: int) -> tuple[float, list[int]] | None:
    """Dijkstra that stops at `target`, ignoring the edge source-target."""
    best, previous, heap = {source: 0.0}, {}, [(0.0, source)]
    while heap:
        d, u = heapq.heappop(heap)
        if u == target:
            path = [u]
            while path[-1] != source:
                path.append(previous[path[-1]])
            return d, path[::-1]
        if d > best[u]:
            continue
        for w in adj[u]:
            if u == source and w == target:
                continue
            dw = d + math.dist(xyz[u], xyz[w])
            if dw < best.get(w, math.inf):
                best[w], previous[w] = dw, u
                heapq.heappush(heap, (dw, w))
    return None


def _minimal_cycles(adj: Adjacency, xyz: list) -> list[list[int]]:
    """The shortest cycle through each edge of the 2-core, shortest first, each once."""
    core = _two_core(adj)
    found: dict[frozenset, tuple[float, list[int]]] = {}
    for u in core:
        for v in core[u]:
            if u < v and (hit := _shortest_path(core, xyz, u, v)) is not None:
                found.setdefault(frozenset(hit[1]), (hit[0] + math.dist(xyz[u], xyz[v]), hit[1]))
    return [path for _, path in sorted(found.values())]


def _cone(count: int, half_angle: float) -> np.ndarray:
    """`count` nearly evenly spread unit vectors within `half_angle` degrees of +z (a Fibonacci cap)."""
    k = np.arange(count) + 0.5
    cos_polar = 1 - (1 - math.cos(math.radians(half_angle))) * k / count
    sin_polar, azimuth = np.sqrt(1 - cos_polar**2), np.pi * (1 + 5**0.5) * k
    return np.column_stack([np.cos(azimuth) * sin_polar, np.sin(azimuth) * sin_polar, cos_polar])


RAYS = _cone(32, PASSAGE_ANGLE)


def _passage(cycle: list[int], xyz: list, original: np.ndarray, reach: np.ndarray) -> float:
    """Rule 4(b): from the cycle's centroid, the fraction of rays within PASSAGE_ANGLE of the normal of its
    plane that leave the shape, on the side where fewer do. A ray is blocked when it passes an original
    point p closer than reach[p], p's longest ring edge: a ray through a ring triangle passes that close
    to one of its corners, so only a gap in the sampled surface lets a ray out."""
    corners = np.array([xyz[node] for node in cycle])
    centre = corners.mean(axis=0)
    frame = np.linalg.svd(corners - centre)[2]  # rows: the plane's two axes, then its normal
    rays = np.vstack([RAYS, RAYS * [1, 1, -1]]) @ frame
    blocked = np.zeros(len(rays), dtype=bool)
    for start in range(0, len(original), 8192):  # blocks of points keep the (points, rays) arrays small
        rel, r = original[start:start + 8192] - centre, reach[start:start + 8192, None]
        along = rel @ rays.T
        blocked |= ((along > 0) & ((rel**2).sum(axis=1)[:, None] - along**2 < r**2)).any(axis=0)
    return 1.0 - max(blocked[:len(RAYS)].mean(), blocked[len(RAYS):].mean())


def _remove_false_loops(adj: Adjacency, xyz: list, parent: np.ndarray, owner: np.ndarray, contracted: np.ndarray,
                        original: np.ndarray, ring_edges: np.ndarray) -> None:
    """Contract every cycle that is no loop (rule 4) to one node, then remove the triangles this makes,
    until every cycle left is a loop."""
    lengths = np.linalg.norm(original[ring_edges[:, 0]] - original[ring_edges[:, 1]], axis=1)
    reach = np.zeros(len(original))
    np.maximum.at(reach, ring_edges.ravel(), np.repeat(lengths, 2))
    passages: dict[tuple, float] = {}  # a loop is judged again at every round: by its corners
    while True:
        members = _members(_roots(parent)[owner])
        touched: set[int] = set()
        for cycle in _minimal_cycles(adj, xyz):
            if touched.intersection(cycle):
                continue
            if _encloses_hole(adj, cycle, xyz, contracted, members):
                corners = tuple(xyz[node] for node in cycle)
                if corners not in passages:
                    passages[corners] = _passage(cycle, xyz, original, reach)
                if passages[corners] >= PASSAGE_MIN:
                    continue
            touched.update(cycle)
            _merge(adj, xyz, parent, cycle[0], cycle[1:], np.mean([xyz[node] for node in cycle], axis=0))
        if not touched:
            return
        _collapse_triangles(adj, xyz, parent)


def _branch(adj: Adjacency, start: int, first: int) -> list[int]:
    """Walk from `start` through `first` along degree-2 nodes; the path ends at the next other node."""
    path = [start, first]
    while len(adj[path[-1]]) == 2 and path[-1] != start:
        a, b = adj[path[-1]]
        path.append(a if a != path[-2] else b)
    return path


def _arclength(xyz: list, path: list[int]) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum([math.dist(xyz[a], xyz[b]) for a, b in zip(path, path[1:])])])


def _merge_junctions(adj: Adjacency, xyz: list, parent: np.ndarray, limit: float) -> None:
    """Contract a path joining two junctions into one node at the path's mean, shortest path first.

    Skipped where two path nodes share an outside neighbour: the contraction would fold a loop away."""
    blocked: set[frozenset] = set()
    while True:
        candidates = []
        for j in [n for n in adj if len(adj[n]) >= 3]:
            for first in adj[j]:
                path = _branch(adj, j, first)
                if path[-1] != j and len(adj[path[-1]]) >= 3 and frozenset(path) not in blocked:
                    if (length := _arclength(xyz, path)[-1]) < limit:
                        candidates.append((length, path))
        if not candidates:
            return
        _, path = min(candidates)
        outside = [w for node in path for w in adj[node] if w not in path]
        if len(outside) != len(set(outside)):
            blocked.add(frozenset(path))
            continue
        _merge(adj, xyz, parent, path[0], path[1:], np.mean([xyz[node] for node in path], axis=0))


def _end_branches(adj: Adjacency, xyz: list, limit: float) -> list[tuple[float, list[int]]]:
    """(length, path from the junction to the end) of every end branch at a junction shorter than `limit`."""
    branches = []
    for end in [n for n in adj if len(adj[n]) == 1]:
        path = _branch(adj, end, next(iter(adj[end])))[::-1]
        if len(adj[path[0]]) >= 3 and (length := _arclength(xyz, path)[-1]) < limit:
            branches.append((length, path))
    return branches


def _prune_spurs(adj: Adjacency, xyz: list, parent: np.ndarray, limit: float) -> None:
    """Remove the shortest end branch (junction to end) while one is shorter than `limit`. Its points go
    to the junction, except at a split tip: when the junction is left with degree 2 and another end branch
    shorter than `limit`, the two were halves of one tip, and each pruned node's points go to the node of
    that branch at the nearest distance from the junction (else the surviving end sits on half the tip)."""
    while spurs := _end_branches(adj, xyz, limit):
        _, path = min(spurs)
        junction, pruned = path[0], path[1:]
        for node in pruned:
            for w in adj.pop(node):
                adj.get(w, set()).discard(node)
        parent[pruned] = junction
        if len(adj[junction]) == 2:
            tips = [p for n in adj[junction] if len(adj[(p := _branch(adj, junction, n))[-1]]) == 1]
            tips = [p for p in tips if _arclength(xyz, p)[-1] < limit]
            if tips:
                gaps = np.abs(_arclength(xyz, path)[1:, None] - _arclength(xyz, tips[0])[None, :])
                parent[pruned] = np.asarray(tips[0])[gaps.argmin(axis=1)]


def _pair(a: int, b: int) -> tuple[int, int]:
    return (a, b) if a < b else (b, a)


def _turn(xyz: list, a: int, x: int, b: int) -> float:
    """Turning angle in degrees at x on the polyline a-x-b."""
    u, v = np.subtract(xyz[x], xyz[a]), np.subtract(xyz[b], xyz[x])
    norms = np.linalg.norm(u) * np.linalg.norm(v)
    return 0.0 if norms == 0 else math.degrees(math.acos(np.clip(np.dot(u, v) / norms, -1.0, 1.0)))


def _drop_collinear(adj: Adjacency, xyz: list, node_of_point: np.ndarray, points: np.ndarray,
                    max_angle: float) -> np.ndarray:
    """Drop degree-2 nodes turning less than `max_angle`, straightest first, unless their neighbours are
    already joined; the points of a dropped node go to the nearer end of the edge that now spans it."""
    spans: dict[tuple[int, int], list[int]] = {}

    def push(x: int) -> None:
        if len(adj[x]) == 2:
            a, b = adj[x]
            heapq.heappush(heap, (_turn(xyz, a, x, b), x, a, b))

    heap: list = []
    for node in adj:
        push(node)
    while heap:
        turn, x, a, b = heapq.heappop(heap)
        if turn >= max_angle:
            break
        if x not in adj or adj[x] != {a, b} or b in adj[a]:
            continue
        spans[_pair(a, b)] = spans.pop(_pair(a, x), []) + [x] + spans.pop(_pair(x, b), [])
        del adj[x]
        adj[a].discard(x)
        adj[b].discard(x)
        adj[a].add(b)
        adj[b].add(a)
        push(a)
        push(b)
    ends = np.full((len(xyz), 2), -1, dtype=np.int64)  # dropped node -> the edge that spans it
    for edge, dropped in spans.items():
        ends[dropped] = edge
    ids = np.flatnonzero(ends[node_of_point, 0] >= 0)
    pos = np.asarray(xyz)
    a, b = ends[node_of_point[ids]].T
    nearer_b = np.linalg.norm(points[ids] - pos[b], axis=1) < np.linalg.norm(points[ids] - pos[a], axis=1)
    node_of_point = node_of_point.copy()
    node_of_point[ids] = np.where(nearer_b, b, a)
    return node_of_point


def _recentre(adj: Adjacency, xyz: list, node_of_point: np.ndarray, original: np.ndarray) -> None:
    """Move every degree-2 node, across the curve only, onto the centre of the cross-section of the ORIGINAL
    points mapped to it and to its two neighbours (three consecutive slabs make a balanced piece; one slab is
    often lopsided). The centre is a least-squares circle (Kasa fit) in the plane normal to the curve: exact
    for a tube however its points are spread, where a centroid follows the sampling density and, on a bent
    tube, the larger area of the outer side (by r^2 / 2R). Cross-sections that are not round, or whose points
    cover only one side, fall back to the centroid. Ends and junctions stay: the centroid of a tip is pulled
    towards its cap, that of a junction towards its heaviest branch."""
    middle = np.array([x for x in adj if len(adj[x]) == 2], dtype=np.int64)
    if len(middle) == 0:
        return
    pos = np.asarray(xyz, dtype=float)
    a, b = np.array([sorted(adj[x]) for x in middle]).T
    tangent = pos[b] - pos[a]
    norm = np.linalg.norm(tangent, axis=1, keepdims=True)
    tangent = np.divide(tangent, norm, out=np.zeros_like(tangent), where=norm > 0)
    u = np.cross(tangent, np.eye(3)[np.argmin(np.abs(tangent), axis=1)])
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    v = np.cross(tangent, u)

    # Every point of the three slabs of each middle node, as (middle row, point) pairs.
    order = np.argsort(node_of_point, kind="stable")
    starts = np.searchsorted(node_of_point[order], np.arange(len(xyz) + 1))
    slabs = np.concatenate([middle, a, b])
    counts = starts[slabs + 1] - starts[slabs]
    row = np.tile(np.arange(len(middle)), 3).repeat(counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    point = order[np.repeat(starts[slabs], counts) + offset]
    local = original[point] - pos[middle][row]
    x, y = (local * u[row]).sum(axis=1), (local * v[row]).sum(axis=1)
    z = x * x + y * y

    def total(values):
        return np.bincount(row, weights=values, minlength=len(middle))

    n = np.bincount(row, minlength=len(middle)).astype(float)
    sx, sy, sxx, sxy, syy = total(x), total(y), total(x * x), total(x * y), total(y * y)
    # Kasa: x^2 + y^2 = 2 cx x + 2 cy y + c in the least-squares sense, one 3x3 system per node.
    normal = np.stack([np.stack([sxx, sxy, sx], -1), np.stack([sxy, syy, sy], -1), np.stack([sx, sy, n], -1)], -2)
    rhs = np.stack([total(x * z), total(y * z), total(z)], -1)
    solvable = np.abs(np.linalg.det(normal)) > 1e-12 * np.maximum(np.abs(normal).max(axis=(1, 2)), 1e-300) ** 3
    solution = np.zeros((len(middle), 3))
    solution[solvable] = np.linalg.solve(normal[solvable], rhs[solvable][..., None])[..., 0]
    cx, cy = solution[:, 0] / 2, solution[:, 1] / 2
    radius = np.sqrt(np.maximum(solution[:, 2] + cx * cx + cy * cy, 0))
    dx, dy = x - cx[row], y - cy[row]
    distance = np.hypot(dx, dy)
    spread = np.sqrt(total((distance - radius[row]) ** 2) / np.maximum(n, 1)) / np.maximum(radius, 1e-300)
    around = np.hypot(total(dx / np.maximum(distance, 1e-300)), total(dy / np.maximum(distance, 1e-300))) / np.maximum(n, 1)
    round_section = solvable & (n >= 6) & (radius > 0) & (spread < 0.2) & (around < 0.5)
    cx, cy = np.where(round_section, cx, sx / np.maximum(n, 1)), np.where(round_section, cy, sy / np.maximum(n, 1))
    moved = pos[middle] + cx[:, None] * u + cy[:, None] * v
    for x_, p in zip(middle.tolist(), moved.tolist()):
        xyz[x_] = tuple(p)


def _finish(adj: Adjacency, xyz: list, node_of_point: np.ndarray, radius: float) -> Skeleton:
    """Relabel nodes 0..m-1 in order of their ids."""
    kept = np.array(sorted(adj), dtype=np.int64)
    label = np.full(len(xyz), -1, dtype=np.int64)
    label[kept] = np.arange(len(kept))
    correspondence = label[node_of_point]
    positions = np.asarray(xyz, dtype=float)[kept]
    counts = np.bincount(correspondence, minlength=len(kept))
    graph = nx.Graph()
    graph.add_nodes_from((i, {"pos": positions[i], "point_count": int(counts[i])}) for i in range(len(kept)))
    edges = [(int(label[u]), int(label[v])) for u in adj for v in adj[u] if u < v]
    graph.add_edges_from((a, b, {"length": float(np.linalg.norm(positions[a] - positions[b]))}) for a, b in edges)
    return Skeleton(graph=graph, correspondence=correspondence, radius=radius)
