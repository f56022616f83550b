"""Refinements of the curve skeleton graph, each switchable: merge junctions joined by a short path, prune
short spurs, split edges longer than the sampling's spacing, drop nearly collinear degree-2 nodes, give stray
specks to the skeleton beside them. None of them can remove a loop of the object or shrink a curve by more than
its stated length: a merge is refused when it would fold a loop away, and only end branches shorter than the
spur length are pruned.

The graph is a dict node -> neighbours with positions `xyz` (list of tuples); `parent` is the merge forest
(a merged node points at the node that absorbed it).
"""
from __future__ import annotations

import heapq
import math

import networkx as nx
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from .distances import segment_distance

Adjacency = dict[int, set[int]]


def merge_nodes(adj: Adjacency, xyz: list, parent: np.ndarray, keep: int, gone: list[int], at) -> None:
    """Contract the nodes `gone` into `keep`, placed at `at`."""
    for node in gone:
        for w in adj.pop(node):
            adj[w].discard(node)
            if w != keep:
                adj[w].add(keep)
                adj[keep].add(w)
        parent[node] = keep
    xyz[keep] = tuple(float(c) for c in at)


def _branch(adj: Adjacency, start: int, first: int) -> list[int]:
    """Walk from `start` through `first` along degree-2 nodes; the path ends at the next other node."""
    path = [start, first]
    while len(adj[path[-1]]) == 2 and path[-1] != start:
        a, b = adj[path[-1]]
        path.append(a if a != path[-2] else b)
    return path


def _arclength(xyz: list, path: list[int]) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum([math.dist(xyz[a], xyz[b]) for a, b in zip(path, path[1:])])])


def merge_junctions(adj: Adjacency, xyz: list, parent: np.ndarray, limit: float) -> None:
    """Contract a path joining two junctions into one node at the path's mean, shortest path first.

    Refused where it would fold a loop away: when two path nodes share an outside neighbour, or the path's
    ends are also joined another way by a direct edge."""
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
        chords = sum(len(adj[node] & set(path)) for node in path) // 2 - (len(path) - 1)
        if len(outside) != len(set(outside)) or chords:
            blocked.add(frozenset(path))
            continue
        merge_nodes(adj, xyz, parent, path[0], path[1:], np.mean([xyz[node] for node in path], axis=0))


def _end_branches(adj: Adjacency, xyz: list, limit: float) -> list[tuple[float, list[int]]]:
    """(length, path from the junction to the end) of every end branch at a junction shorter than `limit`."""
    branches = []
    for end in [n for n in adj if len(adj[n]) == 1]:
        path = _branch(adj, end, next(iter(adj[end])))[::-1]
        if len(adj[path[0]]) >= 3 and (length := _arclength(xyz, path)[-1]) < limit:
            branches.append((length, path))
    return branches


def prune_spurs(adj: Adjacency, xyz: list, parent: np.ndarray, limit: float) -> None:
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


def split_long_edges(adj: Adjacency, xyz: list, node_of_point: np.ndarray, contracted: np.ndarray,
                     max_length: float, longest: float) -> np.ndarray:
    """Split every edge longer than `max_length` into equal pieces with new degree-2 nodes (appended to `xyz`
    and `adj`), and return the points' nodes with each point of a split edge's end moved to the nearest of
    that end and the new nodes on its edges (by its contracted position); a new node that no point chose is
    taken out again. Edges longer than `longest` (the object's diagonal) stay whole: no chord of the object is
    that long, so one reaches a stray the cleaning was told to keep, across empty space (split, a stray far
    out would make billions of nodes).

    Why: contracting the sample complex merges runs of samples where the contracted points stayed thick
    (noise, a sheet), so one edge can span many ball radii and cut across a bending curve as a chord. Split
    to the ball cover's spacing, the curve has the same resolution however thick its points stayed, and the
    new nodes, given their points, are recentred like any other."""
    long_edges = [(u, v) for u in adj for v in adj[u] if u < v and max_length < math.dist(xyz[u], xyz[v]) <= longest]
    if not long_edges:
        return node_of_point
    pos = np.asarray(xyz, dtype=float)
    candidates: dict[int, list[int]] = {}  # old node -> the new nodes on its split edges
    for u, v in long_edges:
        pieces = math.ceil(math.dist(xyz[u], xyz[v]) / max_length)
        new = list(range(len(xyz), len(xyz) + pieces - 1))
        xyz.extend(tuple(p) for p in (pos[u] + np.outer(np.arange(1, pieces) / pieces, pos[v] - pos[u])).tolist())
        chain = [u, *new, v]
        adj[u].discard(v)
        adj[v].discard(u)
        for node in new:
            adj[node] = set()
        for a, b in zip(chain, chain[1:]):
            adj[a].add(b)
            adj[b].add(a)
        candidates.setdefault(u, []).extend(new)
        candidates.setdefault(v, []).extend(new)
    node_of_point = node_of_point.copy()
    order = np.argsort(node_of_point, kind="stable")
    starts = np.searchsorted(node_of_point[order], np.arange(len(pos) + 1))
    everywhere = np.asarray(xyz, dtype=float)
    for node, new in candidates.items():
        points = order[starts[node]:starts[node + 1]]
        choice = np.array([node, *new])
        gaps = np.linalg.norm(contracted[points, None, :] - everywhere[choice][None, :, :], axis=2)
        node_of_point[points] = choice[gaps.argmin(axis=1)]
    # A new node no point chose lies over a gap of the contracted points: it goes, so every node holds points.
    held = np.bincount(node_of_point, minlength=len(xyz)) > 0
    for node in range(len(pos), len(xyz)):
        if not held[node]:
            a, b = adj.pop(node)
            adj[a].discard(node)
            adj[b].discard(node)
            adj[a].add(b)
            adj[b].add(a)
    return node_of_point


def absorb_specks(adj: Adjacency, xyz: list, parent: np.ndarray, node_of_point: np.ndarray, share: float) -> None:
    """Give every component holding less than `share` of the points, beside a component that holds more, to the
    nearest node of the larger ones: the cleaning's rule for stray pieces (skelcore.clean), applied to what
    reaches the skeleton as its own piece of surface although the cleaning kept it, such as a point whose one-ring
    joins no other (a lone node, counted as a component of its own)."""
    counts = np.bincount(node_of_point, minlength=len(xyz))
    graph = nx.Graph((u, v) for u in adj for v in adj[u])
    graph.add_nodes_from(adj)
    pieces = [list(piece) for piece in nx.connected_components(graph)]
    specks = [node for piece in pieces if counts[piece].sum() < share * len(node_of_point) for node in piece]
    large = [node for piece in pieces if counts[piece].sum() >= share * len(node_of_point) for node in piece]
    if not specks or not large:
        return
    _, nearest = cKDTree(np.array([xyz[node] for node in large])).query(np.array([xyz[node] for node in specks]))
    for node, target in zip(specks, nearest.tolist()):
        del adj[node]
        parent[node] = large[target]


def _pair(a: int, b: int) -> tuple[int, int]:
    return (a, b) if a < b else (b, a)


def _turn(xyz: list, a: int, x: int, b: int) -> float:
    """Turning angle in degrees at x on the polyline a-x-b."""
    u, v = np.subtract(xyz[x], xyz[a]), np.subtract(xyz[b], xyz[x])
    norms = np.linalg.norm(u) * np.linalg.norm(v)
    return 0.0 if norms == 0 else math.degrees(math.acos(np.clip(np.dot(u, v) / norms, -1.0, 1.0)))


def drop_collinear(adj: Adjacency, xyz: list, node_of_point: np.ndarray, points: np.ndarray,
                   max_angle: float, max_offset: float) -> np.ndarray:
    """Drop degree-2 nodes turning less than `max_angle`, straightest first, unless their neighbours are
    already joined or the edge that would span it would pass farther than `max_offset` from it or from a node
    dropped into it before (a gentle bend would otherwise go node by node, each turning little, until one
    chord cut it); then place the kept degree-2 nodes where the polyline through them fits the nodes dropped
    from it best (`_refit`). The points of a dropped node go to the nearer end of the edge that now spans it."""
    spans: dict[tuple[int, int], list[int]] = {}  # edge (a < b) -> the nodes dropped from it, in order from a
    pos = np.asarray(xyz, dtype=float)

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
        spanned = _along(spans, a, x) + [x] + _along(spans, x, b)
        if segment_distance(pos[spanned], pos[a], pos[b]).max() > max_offset:
            continue
        spans.pop(_pair(a, x), None)
        spans.pop(_pair(x, b), None)
        spans[_pair(a, b)] = spanned if a < b else spanned[::-1]
        del adj[x]
        adj[a].discard(x)
        adj[b].discard(x)
        adj[a].add(b)
        adj[b].add(a)
        push(a)
        push(b)
    _refit(adj, xyz, spans)
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


def _along(spans: dict[tuple[int, int], list[int]], a: int, b: int) -> list[int]:
    """The nodes dropped from edge a-b, in order from a."""
    dropped = spans.get(_pair(a, b), [])
    return dropped if a < b else dropped[::-1]


def _refit(adj: Adjacency, xyz: list, spans: dict[tuple[int, int], list[int]]) -> None:
    """Move the kept degree-2 nodes next to dropped ones to where the polyline through them fits, in least
    squares, those dropped nodes (each at its share of the arc length of the stretch it lay on) and the kept
    nodes' own places. Kept where they were, the nodes that outlive the drop are the ones that turn most:
    on a straight stretch, those that noise or a cap's pull put off the axis, and each would swing a long chord
    with it. Ends and junctions stay, as recentring leaves them."""
    pos = np.asarray(xyz, dtype=float)
    free = np.array(sorted(x for x in adj if len(adj[x]) == 2 and any(_pair(x, y) in spans for y in adj[x])),
                    dtype=np.int64)
    if not len(free):
        return
    column = np.full(len(pos), -1, dtype=np.int64)
    column[free] = np.arange(len(free))
    rows, cols, weights, target = [np.arange(len(free))], [np.arange(len(free))], [np.ones(len(free))], [pos[free]]
    start = len(free)
    for (a, b), dropped in spans.items():
        stretch = pos[[a, *dropped, b]]
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(stretch, axis=0), axis=1))])
        share = arc[1:-1] / arc[-1] if arc[-1] > 0 else np.full(len(dropped), 0.5)
        goal = pos[dropped].copy()
        row = np.arange(start, start + len(dropped))
        for end, weight in ((a, 1.0 - share), (b, share)):
            if column[end] >= 0:
                rows.append(row)
                cols.append(np.full(len(row), column[end]))
                weights.append(weight)
            else:
                goal -= weight[:, None] * pos[end]
        target.append(goal)
        start += len(dropped)
    design = sp.csr_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(start, len(free)))
    fitted = spla.spsolve((design.T @ design).tocsc(), design.T @ np.concatenate(target))
    for node, place in zip(free.tolist(), np.atleast_2d(fitted).tolist()):
        xyz[node] = tuple(place)
