"""Curve skeleton: the contracted points (a surface skeleton) to a graph that keeps the shape's loops.

After cloudcontr's `rosa_lineextract` (Cao et al. 2010, section 4), with a topological core:
0. contracted points a degenerate ring flung out of the shape take their neighbours' place (skelcore.flung);
1. ball-cover farthest point sampling of the contracted points, radius r = sample_radius * diagonal of the
   ORIGINAL points' object box (skelcore.normalise.object_box: far strays left out), within each connected
   piece of the original surface; every point maps to its nearest sample of its piece (skelcore.sampling);
2. the ORIGINAL surface (its ring edges and the triangles among them) mapped through that map is a
   2-complex on the samples with the loops of the shape; it is reduced to a graph by elementary collapses
   and link-condition edge contractions, which keep its loops exactly (skelcore.collapse);
3. refinements, each switchable, in this order: merge junctions joined by a short path, prune short spurs,
   split edges longer than the cover's spacing (two radii), recentre degree-2 nodes on the cross-section of
   their ORIGINAL points, give components of less than the cleaning's stray share of the points to the
   nearest node of the rest, drop nearly collinear degree-2 nodes (skelcore.refine, skelcore.recentre). Their
   lengths are in units of r, so they follow the sampling.

Invariants: every loop of the sample complex is a loop of the skeleton and the skeleton has no other; no
curve is merged to a point (only triangles are ever contracted, and a refinement shortens a branch by at
most its stated length).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import networkx as nx
import numpy as np

from .collapse import SampleComplex, collapse_to_graph
from .errors import ParameterError
from .flung import put_back
from .loops import cut_false_loops
from .normalise import SAMPLE_RADIUS
from .params import CleaningParams, check_flags, is_real
from .recentre import recentre
from .refine import absorb_specks, drop_collinear, merge_junctions, prune_spurs, split_long_edges
from .sampling import ball_cover_by_piece
from .surface import OriginalSurface


# Below this the balls are smaller than the point spacing of a million-point scan (about 1e-3 of the diagonal):
# every point would be a node, and the edges split into millions of pieces
MIN_SAMPLE_RADIUS = 1e-3


@dataclass(frozen=True)
class SkeletonParams:
    """Parameters of the curve skeleton extraction."""
    sample_radius: float = SAMPLE_RADIUS  # ball radius, fraction of the ORIGINAL points' object diagonal
    # contracted points flung out of the shape take their neighbours' place first (skelcore.flung)
    put_back_flung: bool = True
    cut_false_loops: bool = True  # cut cycles whose spanning disk the original surface does not cross
    # ... and cycles that jump a gap of the scan: an edge whose shortest surface edge has no original point
    # within the sample radius of its middle, or the points' spacing where larger (skelcore.loops)
    cut_jumps: bool = True
    # ... and while more cycles are left than the solid has loops (a one-piece closed mesh's genus, or the most a
    # closed cloud's inside test reads: OriginalSurface.loops_at_most), the one whose disk is least open
    cut_beyond_solid: bool = True
    merge_junctions: bool = True
    junction_distance: float = 2.0  # in sample radii: junctions joined by a shorter path become one
    prune_spurs: bool = True
    spur_length: float = 3.0  # in sample radii: end branches shorter than this are removed
    split_long_edges: bool = True
    # in sample radii: longer edges are split into equal pieces (the ball cover puts its samples 1-2 radii apart)
    edge_length: float = 2.0
    # components holding less than the cleaning's stray share of the points join the nearest larger one
    absorb_specks: bool = True
    drop_collinear: bool = False
    collinear_angle: float = 10.0  # degrees: a degree-2 node turning less than this is dropped
    # degree-2 nodes move across the curve onto the centre of their original points' cross-section
    recentre: bool = True

    def validated(self) -> "SkeletonParams":
        """These parameters, or a ParameterError naming the first that is out of range or of the wrong type."""
        check_flags(self)
        for name in ("sample_radius", "junction_distance", "spur_length", "edge_length"):
            value = getattr(self, name)
            if not is_real(value) or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"parameter {name}={value!r}: must be a positive finite number")
        if not MIN_SAMPLE_RADIUS <= self.sample_radius <= 1:
            raise ParameterError(f"parameter sample_radius={self.sample_radius!r}: must be between "
                                 f"{MIN_SAMPLE_RADIUS:g} and 1 (a fraction of the diagonal)")
        angle = self.collinear_angle
        if not is_real(angle) or not 0 <= angle < 180:
            raise ParameterError(f"parameter collinear_angle={angle!r}: must be a number of degrees in [0, 180)")
        return self

    def replace(self, **changes) -> "SkeletonParams":
        """A copy with `changes` applied, validated."""
        return dataclasses.replace(self, **changes).validated()

    def to_dict(self) -> dict:
        """The parameters as a plain dict (for params.json)."""
        return dataclasses.asdict(self)


@dataclass
class Skeleton:
    """A curve skeleton: the graph, the node of every input point, the sample radius."""
    graph: nx.Graph  # nodes 0..m-1 with 'pos' (3,) and 'point_count'; edges with 'length'
    correspondence: np.ndarray  # (n,) node of every input point
    radius: float  # the sample radius in the user's units
    # the narrowest gap of the input told from its surface: the radius, or a sparse cloud's larger point spacing
    # (OriginalSurface.gap_unit); the unit in which the verdict reads the input's pieces
    gap: float
    dropped: int = 0  # degree-2 nodes GLSkeleton's light graph left out (skelcore.refine.drop_collinear)
    beyond_solid: int = 0  # loops cut as more than the solid has (SkeletonParams.cut_beyond_solid)

    def nodes_array(self) -> np.ndarray:
        """(m,3) node positions, in node order."""
        if self.graph.number_of_nodes() == 0:
            return np.zeros((0, 3))
        return np.array([self.graph.nodes[i]["pos"] for i in range(self.graph.number_of_nodes())], dtype=float)

    def edges_array(self) -> np.ndarray:
        """(e,2) edges as sorted node pairs, in sorted order."""
        edges = np.array(sorted(tuple(sorted(e)) for e in self.graph.edges()), dtype=np.int64)
        return edges.reshape(-1, 2)

    def degrees(self) -> np.ndarray:
        """(m,) the degree of every node."""
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


def extract_skeleton(contracted, original, surface, params: SkeletonParams | None = None) -> Skeleton:
    """Curve skeleton graph of `contracted` (n,3); `original` (n,3) the same points before contraction;
    `surface` the original surface as point ids: (t,3) ring triangles (OneRings.triangles, preferred: the
    fans cover the surface without gaps) or (e,2) ring edges, whose 3-cliques are then its triangles; or an
    OriginalSurface of `original` made before (skelcore.surface: the skeletons of one run share it)."""
    params = (params or SkeletonParams()).validated()
    known = surface if isinstance(surface, OriginalSurface) else OriginalSurface.of(original, surface)
    contracted = known.checked(contracted)
    original, edges, triangles = known.points, known.edges, known.triangles
    radius = params.sample_radius * known.diagonal
    gap = known.gap_unit(radius)
    if params.put_back_flung:
        contracted = put_back(contracted, known)

    samples, owner = ball_cover_by_piece(contracted, radius, edges, known.pieces)
    xyz = [tuple(p) for p in contracted[samples].tolist()]
    complex_ = SampleComplex.from_surface(xyz, owner, edges, triangles)
    collapse_to_graph(complex_)
    adj, parent = complex_.nbr, complex_.parent
    beyond_solid = 0
    if params.cut_false_loops and len(edges):
        node_of_point = _roots(parent)[owner]
        node_piece = np.zeros(len(xyz), dtype=np.int64)
        node_piece[node_of_point] = known.pieces[1]  # a node's points lie on one piece (ball_cover_by_piece)
        beyond_solid = cut_false_loops(adj, xyz, node_of_point, edges, known.probe, gap if params.cut_jumps else 0.0,
                                       lambda node: known.probe_of_piece(int(node_piece[node])),
                                       known.loops_at_most if params.cut_beyond_solid else None)[1]
    if params.merge_junctions:
        merge_junctions(adj, xyz, parent, params.junction_distance * radius)
    if params.prune_spurs:
        prune_spurs(adj, xyz, parent, params.spur_length * radius)
    node_of_point = _roots(parent)[owner]
    if params.split_long_edges:
        node_of_point = split_long_edges(adj, xyz, node_of_point, contracted, params.edge_length * radius,
                                         known.diagonal)
        parent = np.r_[parent, np.arange(len(parent), len(xyz))]
    if params.recentre:
        recentre(adj, xyz, node_of_point, original)
    if params.absorb_specks:  # after recentring: a speck's far points would pull its new node's centre
        absorb_specks(adj, xyz, parent, node_of_point, CleaningParams.min_piece_share)
        node_of_point = _roots(parent)[node_of_point]
    if params.drop_collinear:
        # a node turning collinear_angle one sample radius from its neighbour lies this far off their chord:
        # the offset that angle allows at the skeleton's own spacing; a chord farther out cuts a resolved bend
        offset = radius * math.sin(math.radians(params.collinear_angle))
        drawn = len(adj)
        node_of_point = drop_collinear(adj, xyz, node_of_point, contracted, params.collinear_angle, offset)
        return _finish(adj, xyz, node_of_point, radius, gap, beyond_solid, dropped=drawn - len(adj))
    return _finish(adj, xyz, node_of_point, radius, gap, beyond_solid)


def beyond_solid_notes(skeleton: Skeleton, genus: bool) -> list[str]:
    """In words, the loops `skeleton` cut as more than its solid has (SkeletonParams.cut_beyond_solid; empty when
    none). genus: the solid's loops were a closed mesh's genus (io.Cloud.loops_at_most), not a cloud's read."""
    cut = skeleton.beyond_solid
    if not cut:
        return []
    which = "the loop whose disk lay least in open space was" if cut == 1 else \
        f"the {cut} whose disks lay least in open space were"
    solid = ("the mesh's solid has (its genus)" if genus
             else "the solid the cloud bounds has (as its inside test reads it)")
    return [f"the skeleton drew {'one loop' if cut == 1 else f'{cut} loops'} more than {solid}: {which} cut"]


def _roots(parent: np.ndarray) -> np.ndarray:
    """Resolve the merge forest: every sample to the node that absorbed it (pointer jumping)."""
    root = parent.copy()
    while not np.array_equal(nxt := root[root], root):
        root = nxt
    return root


def _finish(adj: dict[int, set[int]], xyz: list, node_of_point: np.ndarray, radius: float, gap: float,
            beyond_solid: int, dropped: int = 0) -> Skeleton:
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
    return Skeleton(graph=graph, correspondence=correspondence, radius=radius, gap=gap, dropped=dropped,
                    beyond_solid=beyond_solid)
