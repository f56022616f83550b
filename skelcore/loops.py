"""Which cycles of the skeleton graph are loops of the shape, and how a false one is removed: by a cut.

The collapse keeps every loop of the complex the surface maps onto; a few of them can still be false: a
plate or a blob whose contraction stopped at a hollow outline, where a gap between neighbouring fans
stretches into a long loop. The rule tells them apart with the ORIGINAL surface and no length threshold:

    a cycle is a loop of the shape when the original surface crosses a disk spanning it.

The disk is the fan from the cycle's centroid to its edges. Around a real loop, the disk must leave the
solid through the hole, so the surface crosses it along a curve, and there the surface normal lies in the
disk's plane (a torus's inner wall, a drilled hole's wall, a linked ring's tube). A false loop's disk is
sandwiched inside the solid: the faces of the plate it lies in run parallel to it, or no surface is near.
A crossing is an original point within one point spacing of the disk whose PCA normal makes more than
CROSSING_ANGLE degrees with the disk's normal; a loop needs CROSSING_POINTS of them, so that one noisy
point does not make a loop. A plate thinner than the normals' neighbourhood (a crate's side, a bracket of
sheet metal) reads as one sheet, and the wall of a hole through it, a spacing or two high, has no normal of its
own: its points take the faces'. There the surface crosses the disk where the sheet ends, so a point on the
sheet's edge crosses too when the direction off that edge lies across the disk as a wall's normal would: a point
is on the edge when its neighbours leave at least half of its tangent plane empty (EDGE_GAP), the edge's
direction the middle of that empty sector. Inside a sheet, 15 neighbours all on one side of a line through
the point are rare: none of a clean benchmark torus's or pretzel's points, 0.02-0.04% of them with 0.5% noise,
0.4-0.7% with 1% (where the noisy normals already cross a disk here and there).

The hole itself is the second half of the rule: the disk of a real loop spans it, so part of the disk lies
outside the solid (the original cloud's inside test, skelcore.inside), while a cycle drawn through a bulky
part can have a disk wholly inside it whose rim runs along the walls, crossed by them as a hole's would be (a
bulky scan whose contraction left shards, a handle's foot). A loop needs OPEN_SHARE of its disk's area
outside. It is small on purpose: a real loop's disk also covers the material around the hole (a drilled
plate's skeleton runs midway between the holes, and the false pieces of the graph next to a loop are merged
into its cycle as they are cut), so measured shares of real loops run down to 5%, and the rule only
separates disks that do not reach outside at all. Where a scan is open (a single view), the space behind
its surface joins the outside, so disks there mostly count as outside and the crossings decide.

Only outside space that goes through counts. A real loop links with the outside: a curve through its hole
closes up outside the object. A false cycle bounds some disk within the solid, and no curve outside crosses
any disk spanning it an odd number of times; where its fan disk reads as outside, the space on one side is a
pocket that the disk and the surface close (the lid of a bowl whose rim the cycle follows), or the reading is
wrong (on a noisy scan of a bulky part, cells deep inside whose nearest sample's normal points the wrong way).
So a disk point outside counts only when the open space next to the first grid cell past the disk along its
normal reaches the inside test's grid border without crossing the disk (the disk a wall of grid cells) on one
side, and on the other too, or that cell is solid where the inside test only guesses: behind an open scan,
whose far side was never seen, the space reads as solid. On a duck scan with 0.5% noise that took a false
cycle's outside share from 7.5% to 0.4%.

Nor does outside space along the cycle itself. A loop's hole lies within its cycle, which runs inside the
material around it, so the disk next to its rim is solid whatever the hole's size; outside space only there
means the cycle wanders out of the solid past an opening it does not go round (a flat bar of a chair's back
contracts into two strands that bulge into the openings above and below it, a sliver cycle whose disk read
2.8% outside, 15 of its 18 outside samples in the outer band). The disk's outermost band, the outer row of
each fan triangle's lattice (an eighth of the way in from the rim), does not count; the loops of the ball
with thin handles, the mug and the chair read the same share with the band left out, or nearly (the mug's
25% -> 20%).

Before the disk, a cycle must be joined by the surface all round. A surface edge whose middle has no
original point within the skeleton's sample radius r crosses empty space that the skeleton resolves (its
ends lie more than r from that middle too): it is a jump across a gap of the scan, where the k-nearest
one-rings reach over nothing (a twig's tip beside another branch, a partial scan's shadow), not surface. In a
cloud sparser than the skeleton's balls r is the points' spacing (the median surface edge) instead: there
most edges have no point within a ball of their middle, over surface that is there. An edge whose middle lies
outside the solid (the inside test's, within a spacing of the surface counting as inside) is a jump too, over
a gap narrower than 2r: the slot under a stapler's arm, 1.2-2.6 r wide and open at three sides, which the
one-rings bridged where it is 1.6-2.3 r wide, 3.5 spacings long, their middles 0.9-1.0 r from both walls. An
edge up to two spacings long has its middle within a spacing of its ends, so only longer ones are asked.
A cycle with an edge whose shortest supporting surface edge is such a jump is no loop of the shape,
whatever its disk says: the walls of the branches it runs along cross it. A long edge over surface that is
there (a sparse patch, the merged rings of GLSkeleton's reduction, a chord over points that went to another
node) is no jump: its middle lies on that surface.

A false cycle is cut at its weakest edge, never merged to a point: its widest jump, else the edge fewest
surface edges support (ties: the longest). The curve keeps its length, and its points keep their nodes.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import networkx as nx
import numpy as np
from scipy.spatial import cKDTree

from .distances import triangle_distance
from .inside import InsideTest
from .neighbours import local_frames, widest_gap
from .normalise import object_diagonal
from .normals import COLLAPSED
from .regions import border_labels, dilated, label_regions

CROSSING_ANGLE = 60.0  # degrees between a crossing point's normal and the disk's normal, at least
CROSSING_POINTS = 4  # crossing points a loop needs
NORMAL_K = 16  # neighbours for a point's PCA normal
EDGE_GAP = 180.0  # degrees of a point's tangent plane its neighbours leave empty, at least, on a sheet's edge
OPEN_SHARE = 0.02  # share of a loop's disk that lies outside the solid, at least
DISK_LATTICE = 8  # each fan triangle of a disk is sampled at the centres of DISK_LATTICE^2 equal triangles
THROUGH_REACH = 3  # cells along the normal on each side of an outside disk sample searched for the open space past it
# cycle rank x nodes up to this get networkx's minimum cycle basis, one false cycle cut at a time (about a second
# here at most); above it short_cycle_basis, as networkx's takes minutes (rank 141 of 574 nodes: 64 s per basis)
MINIMUM_BASIS_WORK = 2000


def cloud_inside(points: np.ndarray, band: float, tree: cKDTree | None = None) -> InsideTest:
    """The inside test a SurfaceProbe over `points` reads, within `band` of the surface counting as inside: the
    points as their own surface sample. A run can make it ahead on its second core and hand it to the probe as
    `shared` (the probe takes its oriented normals, and its grid unless its own band sizes the cells: made with
    band 0, it sizes them by the samples' spacing alone). tree: a cKDTree over `points`."""
    return InsideTest.of_cloud(points, band, COLLAPSED * object_diagonal(points), tree)


class SurfaceProbe:
    """The original surface, for asking whether it crosses a disk."""

    def __init__(self, original: np.ndarray, spacing: float, shared: InsideTest | None = None,
                 samples: np.ndarray | None = None) -> None:
        """shared: an inside test made ahead (the run's metrics', or cloud_inside of `original`), whose oriented
        normals `inside` takes when it samples these very points. samples: what `inside` samples in place of
        `original`: the same points with a thin wall's two faces kept apart, where cleaning's denoising pulled
        them into one sheet (io.Cloud.surface)."""
        self.points = original
        self.tree = cKDTree(original)
        self.spacing = spacing
        self._scale = float(np.abs(original).max(initial=0.0)) + spacing  # of the rounding in crossings
        # (n, 2, 3) each point's PCA normal and its edge's direction (NaN: none), and whether it is computed yet
        self._across: np.ndarray | None = None
        self._known: np.ndarray | None = None
        self._inside: InsideTest | None = None
        self._exterior: np.ndarray | None = None
        self._shared = shared
        self._samples = original if samples is None else samples

    def across_directions(self, ids: np.ndarray) -> np.ndarray:
        """(len(ids), 2, 3) for those original points, each computed once: the PCA normal (unsigned), and the
        direction off the sheet's edge where the point lies on one (the module's rule), else NaN."""
        if self._across is None:
            self._across, self._known = np.full((len(self.points), 2, 3), np.nan), np.zeros(len(self.points), bool)
        missing = np.unique(ids[~self._known[ids]])
        if len(missing):
            k = min(NORMAL_K, len(self.points))
            _, neighbours = self.tree.query(self.points[missing], k=k)
            local = self.points[neighbours.reshape(len(missing), k)]  # the point itself first
            _, frames, _ = local_frames(local)
            normal, first, second = frames[:, :, 0], frames[:, :, 2], frames[:, :, 1]
            gap, edge = widest_gap(local[:, 1:] - local[:, :1], first, second)
            edge[gap < math.radians(EDGE_GAP)] = np.nan
            self._across[missing, 0], self._across[missing, 1] = normal, edge
            self._known[missing] = True
        return self._across[ids]

    def crossings(self, corners: np.ndarray) -> int:
        """Original points within one spacing of the fan disk over the closed polygon `corners`, whose
        normal lies within 90 - CROSSING_ANGLE degrees of the disk's plane."""
        centre = corners.mean(axis=0)
        normal = np.linalg.svd(corners - centre)[2][2]
        # the fan's triangles (centre, a, b), all at once; a flat one (area 0) is skipped
        a, b = corners, np.roll(corners, -1, axis=0)
        plane = np.cross(a - centre, b - centre)
        area2 = np.linalg.norm(plane, axis=1)
        flat = area2 == 0
        a, b, plane, area2 = a[~flat], b[~flat], plane[~flat], area2[~flat]
        triangles = np.stack([np.broadcast_to(centre, a.shape), a, b], axis=1)
        middles = triangles.mean(axis=1)
        reach = np.linalg.norm(triangles - middles[:, None], axis=2).max(axis=1) + self.spacing
        near = self.tree.query_ball_point(middles, reach, return_sorted=False, workers=-1)
        triangle = np.repeat(np.arange(len(near)), [len(ids) for ids in near])
        ids = np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64, count=len(triangle))
        # A point is at least as far from the triangle as from its plane: only those in a slab can be near.
        # The slack covers rounding, of the coordinates and of the plane of a thin triangle.
        slack = 1e-9 * (self._scale + reach * np.linalg.norm(a - centre, axis=1) * np.linalg.norm(b - centre, axis=1)
                        / area2)
        height = np.abs(np.einsum("ij,ij->i", self.points[ids] - centre, (plane / area2[:, None])[triangle]))
        in_slab = height <= self.spacing + slack[triangle]
        ids, triangle = ids[in_slab], triangle[in_slab]
        found = np.unique(ids[triangle_distance(self.points[ids], triangles[triangle]) <= self.spacing])
        if len(found) < CROSSING_POINTS:
            return 0
        # a normal or an edge's direction across the disk (NaN compares False)
        across = np.abs(self.across_directions(found) @ normal) < math.cos(math.radians(CROSSING_ANGLE))
        return int(across.any(axis=1).sum())

    def inside(self) -> InsideTest:
        """The solid the original points bound, within one spacing of the surface counting as inside; made once,
        when a loop is first judged. From the shared test of the same points only the grid is made again, to this
        probe's band: their oriented normals are the ones this would compute."""
        if self._inside is None:
            if self._shared is not None and np.array_equal(self._shared.samples, self._samples):
                self._inside = self._shared.with_band(self.spacing)
            else:
                self._inside = cloud_inside(self._samples, self.spacing,
                                            self.tree if self._samples is self.points else None)
        return self._inside

    def open_share(self, corners: np.ndarray) -> float:
        """The share of the area of the fan disk over the closed polygon `corners` that lies outside the solid the
        original points bound (within one spacing of the surface counts as inside), away from the rim, and goes
        through: open space past the disk reaches beyond the object without crossing it (`_through`)."""
        centre = corners.mean(axis=0)
        spokes = corners - centre
        spokes_next = np.roll(spokes, -1, axis=0)
        planes = np.cross(spokes, spokes_next)
        areas = np.linalg.norm(planes, axis=1)
        if areas.sum() == 0:
            return 0.0
        samples = centre + _LATTICE[:, :1, None] * spokes + _LATTICE[:, 1:, None] * spokes_next  # (m^2, k, 3)
        outside = ~self.inside().contains(samples.reshape(-1, 3)).reshape(len(_LATTICE), len(corners))
        outside &= areas > 0  # a flat fan triangle weighs nothing and has no normal to look along
        outside &= _AWAY_FROM_RIM[:, None]  # module docstring: outside space along the cycle is no hole
        if outside.mean(axis=0) @ areas >= OPEN_SHARE * areas.sum():  # else no point of it can make it a loop
            where = np.nonzero(outside)
            outside[where] = self._through(samples[where], planes[where[1]], centre, spokes, spokes_next)
        return float(outside.mean(axis=0) @ areas / areas.sum())

    def exterior(self) -> np.ndarray:
        """The inside test's grid cells that lie outside the solid, each as its centre is judged (the cells near
        the surface, which the grid leaves to its points, too)."""
        if self._exterior is None:
            test = self.inside()
            centres = np.indices(test.cells.shape).reshape(3, -1).T
            self._exterior = ~test.contains(test.origin + (centres + 0.5) * test.size).reshape(test.cells.shape)
        return self._exterior

    def _through(self, points: np.ndarray, planes: np.ndarray, centre: np.ndarray, spokes: np.ndarray,
                 spokes_next: np.ndarray) -> np.ndarray:
        """Which of `points` (outside samples of the fan disk, each with its fan triangle's normal in `planes`)
        go through: past the disk, open space reaches the grid's border without crossing the disk on both sides
        (a curve through such a point from one side to the other closes up outside the object, so it links the
        cycle), or on one side while the other meets solid that the inside test only guesses (an open scan's
        far side). See the module's rules."""
        test = self.inside()
        shape = np.array(test.cells.shape)
        wall = _disk_wall(test, centre, spokes, spokes_next)
        open_space = self.exterior() & ~wall
        regions, _ = label_regions(open_space)
        far = np.zeros(regions.max() + 1, bool)
        far[border_labels(regions)] = True
        far[0] = False  # label 0: the solid and the wall
        # Each side's open space is that next to the first cell past the wall along the disk's normal (its 27
        # cells: the open space of a narrow hole, a few cells across, lies beside a point near its wall).
        normals = planes / np.linalg.norm(planes, axis=1, keepdims=True)
        steps = np.arange(2 * THROUGH_REACH + 1) * 0.5 * test.size
        around = np.stack(np.meshgrid(*[np.arange(-1, 2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        reaches_far, closed = np.zeros(len(points), bool), np.zeros(len(points), bool)
        for sign in (1.0, -1.0):
            cells = test.cell_of(points[:, None] + sign * steps[:, None] * normals[:, None])  # (m, steps, 3)
            past = ~wall[tuple(cells.transpose(2, 0, 1))]
            first = cells[np.arange(len(points)), past.argmax(axis=1)]
            beside = regions[tuple(np.clip(first[:, None] + around, 0, shape - 1).transpose(2, 0, 1))]  # (m, 27)
            side_far = far[beside].any(axis=1)
            reaches_far |= side_far
            # else the side is closed, unless its first cell is solid where the inside test only guesses (an open
            # scan's far side, read by centres)
            guessed = (regions[tuple(first.T)] == 0) & test.undecided[tuple(first.T)]
            closed |= ~past.any(axis=1) | ~(side_far | guessed)
        return reaches_far & ~closed


def _disk_wall(test: InsideTest, centre: np.ndarray, spokes: np.ndarray, spokes_next: np.ndarray) -> np.ndarray:
    """The fan disk as a wall of the inside test's grid cells: samples closer than a cell, the cells holding them
    grown by one, so that no face-connected path of cells crosses it (a path crossing the disk passes within a
    cell of a sample)."""
    lengths = np.linalg.norm(np.stack([spokes, spokes_next, spokes_next - spokes]), axis=2).max(axis=0)
    wall = np.zeros(test.cells.shape, bool)
    for spoke, spoke_next, length in zip(spokes, spokes_next, lengths):
        steps = int(np.ceil(2.0 * length / test.size)) + 1
        i, j = np.nonzero(np.add.outer(np.arange(steps + 1), np.arange(steps + 1)) <= steps)
        wall[tuple(test.cell_of(centre + np.outer(i / steps, spoke) + np.outer(j / steps, spoke_next)).T)] = True
    return dilated(wall)


def _lattice(m: int) -> np.ndarray:
    """(m^2, 2) barycentric centres of the m^2 equal triangles that split a triangle m times along each side."""
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    up = (i + j <= m - 1)
    down = (i + j <= m - 2)
    return np.concatenate([np.c_[i[up] + 1 / 3, j[up] + 1 / 3], np.c_[i[down] + 2 / 3, j[down] + 2 / 3]]) / m


_LATTICE = _lattice(DISK_LATTICE)
_AWAY_FROM_RIM = _LATTICE.sum(axis=1) < 1 - 1 / DISK_LATTICE  # lattice points off the outer row, next to the rim


def cut_false_loops(adj: dict[int, set[int]], xyz: list, node_of_point: np.ndarray, edges: np.ndarray,
                    probe: SurfaceProbe, radius: float = 0.0,
                    disk_probe: Callable[[int], SurfaceProbe] | None = None,
                    most_loops: Callable[[int], int | None] | None = None) -> tuple[int, int]:
    """Cut every cycle of `adj` that is no loop of the shape (see the module's rules) at its weakest edge,
    shortest cycles first, until every cycle left is a loop. `radius`: the skeleton's sample radius, the
    empty space a jump crosses (0: no jumps). disk_probe: the probe that judges the disk of a cycle through a
    given node (OriginalSurface.probe_of_piece of its piece; None: `probe`). most_loops: the most loops the
    solid has (OriginalSurface.loops_at_most), asked with the number of cycles left once they pass the rules
    (it may stop counting at that many): while more are left, the one whose disk is least open is cut too (a
    curve skeleton has as many loops as its solid). Returns the number of cuts of false loops and of loops
    beyond the solid's."""
    ends = node_of_point[edges].reshape(-1, 2)
    low, high = ends.min(axis=1), ends.max(axis=1)
    m = len(xyz)
    between = low != high
    codes, inverse, counts = np.unique(low[between] * m + high[between], return_inverse=True, return_counts=True)
    pairs = list(zip((codes // m).tolist(), (codes % m).tolist()))
    support = dict(zip(pairs, counts.tolist()))
    jump: dict | None = None  # found once there is a cycle to judge (its inside test is made then)
    open_shares: dict[frozenset, float] = {}  # -1: too few crossings
    cuts = beyond = 0
    limit: int | None = None  # most_loops(), once asked
    while True:
        graph = nx.Graph((u, v, {"length": math.dist(xyz[u], xyz[v])}) for u in adj for v in adj[u] if u < v)
        basis, minimum = short_cycle_basis(graph)
        if basis and jump is None:
            jump = _jumps(probe, edges[between], inverse.ravel(), pairs, radius) if radius > 0 else {}
        false_cycles = []
        for cycle in sorted(basis, key=len):
            ordered = _ordered(graph, cycle)
            if any((min(e), max(e)) in jump for e in zip(ordered, ordered[1:] + ordered[:1])):
                false_cycles.append(ordered)
            else:
                key = frozenset(cycle)
                if key not in open_shares:
                    corners = np.array([xyz[node] for node in ordered])
                    disk = probe if disk_probe is None else disk_probe(ordered[0])
                    open_shares[key] = disk.open_share(corners) if disk.crossings(corners) >= CROSSING_POINTS else -1.0
                if open_shares[key] < OPEN_SHARE:
                    false_cycles.append(ordered)
            if false_cycles and minimum:  # one cut at a time, the basis found again: the shortest false cycle first
                break
        if not false_cycles:
            if basis and most_loops is not None and limit is None:
                limit = most_loops(len(basis))
            if limit is None or len(basis) <= limit:
                return cuts - beyond, beyond
            # loops beyond the solid's: the least open disk goes first, as the one least like a hole's
            false_cycles = [_ordered(graph, min(basis, key=lambda cycle: open_shares[frozenset(cycle)]))]
            beyond += 1
        for false in false_cycles:
            ring = [(min(e), max(e)) for e in zip(false, false[1:] + false[:1]) if e[1] in adj[e[0]]]
            if len(ring) < len(false):
                continue  # an edge of it was cut already: it is no cycle any more
            u, v = min(ring, key=lambda e: (-jump.get(e, 0.0), support.get(e, 0), -math.dist(xyz[e[0]], xyz[e[1]])))
            adj[u].discard(v)
            adj[v].discard(u)
            cuts += 1


def short_cycle_basis(graph: nx.Graph) -> tuple[list[list[int]], bool]:
    """A basis of the graph's cycles (node lists) and whether it is a minimum one. Up to MINIMUM_BASIS_WORK,
    networkx's minimum-weight basis ("length"); above (a skeleton meshed with false cycles: k far below its
    default, heavy noise) that takes minutes, so the shortest cycle through each edge is taken
    instead, shortest first while independent over GF(2) (a superset of the fundamental cycles completes it)."""
    rank = graph.number_of_edges() - graph.number_of_nodes() + nx.number_connected_components(graph)
    if rank <= 1:  # no cycle, or the only one: that is the basis, and a minimum one (networkx's search: 0.06 s)
        return nx.cycle_basis(graph), True
    if rank * graph.number_of_nodes() <= MINIMUM_BASIS_WORK:
        return nx.minimum_cycle_basis(graph, weight="length"), True
    index = {frozenset(edge): i for i, edge in enumerate(graph.edges)}
    candidates = []
    for u, v, length in list(graph.edges(data="length")):
        graph.remove_edge(u, v)
        try:
            around, path = nx.bidirectional_dijkstra(graph, u, v, weight="length")
            candidates.append((around + length, path))
        except nx.NetworkXNoPath:
            pass  # a bridge: on no cycle
        graph.add_edge(u, v, length=length)
    candidates.sort(key=lambda candidate: candidate[0])
    candidates += [(math.inf, cycle) for cycle in nx.cycle_basis(graph)]
    pivots: dict[int, int] = {}  # leading bit -> reduced edge set (bits: edge indices), a GF(2) echelon form
    basis = []
    for _, nodes in candidates:
        bits = 0
        for a, b in zip(nodes, nodes[1:] + nodes[:1]):
            bits ^= 1 << index[frozenset((a, b))]
        reduced = bits
        while reduced and reduced.bit_length() - 1 in pivots:
            reduced ^= pivots[reduced.bit_length() - 1]
        if reduced:
            pivots[reduced.bit_length() - 1] = reduced
            basis.append(list(nodes))
            if len(basis) == rank:
                break
    return basis, False


def _jumps(probe: SurfaceProbe, edges: np.ndarray, pair_of_edge: np.ndarray, pairs: list, radius: float) -> dict:
    """The node pairs (of `pairs`, each edge's in `pair_of_edge`) that only a jump joins (the module's jump
    rules: no point within `radius` of its middle, or its middle outside the solid), each with the width of its
    gap. The gap is as wide as the shortest edge across it: when even that edge is a jump, the longer ones run
    across the same gap (or slant over surface beside it)."""
    lengths = np.linalg.norm(probe.points[edges[:, 0]] - probe.points[edges[:, 1]], axis=1)
    order = np.lexsort((lengths, pair_of_edge))
    first = order[np.searchsorted(pair_of_edge[order], np.arange(len(pairs)))]  # each pair's shortest edge
    long = first[lengths[first] > 2 * probe.spacing]  # a shorter edge's middle lies within a spacing of its ends
    if not len(long):
        return {}
    middles = (probe.points[edges[long, 0]] + probe.points[edges[long, 1]]) / 2
    gaps = long[(probe.tree.query(middles, workers=-1)[0] > radius) | ~probe.inside().contains(middles)]
    return {pairs[pair_of_edge[i]]: float(lengths[i]) for i in gaps.tolist()}


def _ordered(graph: nx.Graph, cycle: list[int]) -> list[int]:
    """The nodes of a cycle (given as a set) in their order round it."""
    return [u for u, _ in nx.find_cycle(graph.subgraph(cycle))]
