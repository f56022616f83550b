"""The ORIGINAL points and surface as curve-skeleton extraction reads them (skelcore.skeleton).

Everything here depends on the input and its one-rings only, not on where the contraction has moved the
points: for a run on one set of rings (LBC's, or GLSkeleton's between two reductions) it is the same at every
iteration. Made once with `OriginalSurface.of` and passed to extract_skeleton, it is not worked out again for
each iteration's skeleton (the inspector draws one per step): the validated edges and triangles, the surface's
connected pieces, the object diagonal, the median edge length (the points' spacing), the probe of false loops
with the normals it has computed (and a piece's own, where it is sampled far more finely than the cloud), and the
convex hull and symmetric adjacency that finding flung points reads (skelcore.flung).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, QhullError

from . import cloud_topology
from .collapse import surface_triangles
from .errors import InputError
from .inside import InsideTest
from .io import MIN_POINTS, as_points
from .loops import SurfaceProbe
from .normalise import object_diagonal

FINER = 2.0  # a piece sampled more finely than the cloud by this factor has its loops judged at its own spacing
# A separate piece less than this many sample radii across is resolved by a few balls, a hole of it by fewer (of
# tori beside one 10-20 times their size, those 2.1-2.6 radii across lost their loop, those 3.0-4.3 kept it)
SMALL_PIECE = 4.0
HULL_DIRECTIONS = 128  # directions whose extreme original points span a hull within theirs (hull_planes)


@dataclass(eq=False)
class OriginalSurface:
    """The original points, their surface as point ids, and what is derived from them once."""
    points: np.ndarray  # (n,3) the original points
    edges: np.ndarray  # (e,2) surface edges (the triangles' sides, as many times as triangles have them)
    triangles: np.ndarray  # (t,3) surface triangles
    diagonal: float  # object diagonal of the original points (skelcore.normalise.object_diagonal)
    pieces: tuple[int, np.ndarray]  # connected pieces of the graph of `edges`: (count, piece of every point)
    shared_inside: InsideTest | None = field(default=None, repr=False)  # for the probe (SurfaceProbe's `shared`)
    inside_samples: np.ndarray | None = field(default=None, repr=False)  # ... and what its inside test samples
    # the most loops a skeleton of the surface keeps, where known exactly: a one-piece closed mesh's genus
    # (io.Cloud.loops_at_most)
    genus: int | None = None
    _probe: SurfaceProbe | None = field(default=None, repr=False)
    _hulls: dict = field(default_factory=dict, repr=False)  # "inner", "whole": face planes (None: flat)
    _adjacency: sp.csr_matrix | None = field(default=None, repr=False)
    _piece_probes: dict = field(default_factory=dict, repr=False)  # piece -> the probe its loops are judged by
    _most_loops: dict = field(default_factory=dict, repr=False)  # enough -> loops_at_most(enough); None: all

    @classmethod
    def of(cls, original, surface, shared_inside: InsideTest | None = None,
           inside_samples: np.ndarray | None = None, genus: int | None = None) -> "OriginalSurface":
        """From `original` (n,3) and `surface`: (t,3) ring triangles (OneRings.triangles, preferred: the fans
        cover the surface without gaps) or (e,2) ring edges, whose 3-cliques are then its triangles.
        shared_inside: the run's metrics' inside test, which the probe takes the oriented normals of;
        inside_samples: the points the probe's inside test samples in place of `original` (io.Cloud.surface);
        genus: the loops through the solid, where known exactly (io.Cloud.loops_at_most)."""
        original = as_points(original, "original points")
        cells = np.asarray(surface)
        if cells.size == 0:
            cells = np.zeros((0, 2), dtype=np.int64)
        if cells.ndim != 2 or cells.shape[1] not in (2, 3) or not np.issubdtype(cells.dtype, np.integer):
            raise InputError(f"surface: expected (t, 3) triangles or (e, 2) edges of point ids, got shape "
                             f"{cells.shape} of {cells.dtype}")
        n = len(original)
        if len(cells) and (cells.min() < 0 or cells.max() >= n):
            raise InputError(f"surface: point ids must lie in [0, {n})")
        cells = cells.astype(np.int64)
        if cells.shape[1] == 2:
            edges, triangles = cells, surface_triangles(cells, n)
        else:
            edges, triangles = np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [0, 2]]]), cells
        graph = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)) if len(edges) else \
            sp.coo_matrix((n, n))
        return cls(original, edges, triangles, object_diagonal(original), connected_components(graph, directed=False),
                   shared_inside, inside_samples, genus)

    def checked(self, contracted) -> np.ndarray:
        """The contracted positions of the original points, validated against them."""
        contracted = as_points(contracted, "contracted points")
        if len(contracted) != len(self.points):
            raise InputError(f"contracted and original points differ in number ({len(contracted)} vs "
                             f"{len(self.points)})")
        return contracted

    @functools.cached_property
    def spacing(self) -> float:
        """The median length of the surface's edges: the points' spacing along it (0 without edges)."""
        return _median_edge(self.points, self.edges)

    def gap_unit(self, radius: float) -> float:
        """The narrowest gap of the input a skeleton of ball radius `radius` tells from its surface: the radius,
        or the points' spacing where a cloud sparser than the balls has a larger one (there most surface edges
        have no point within a ball of their middle, over surface that is there)."""
        return max(radius, self.spacing)

    def scale_notes(self, sample_radius: float) -> list[str]:
        """What a skeleton of ball radius `sample_radius` (a fraction of the diagonal) cannot resolve, in words: a
        cloud sparser than its balls, and separate pieces less than SMALL_PIECE balls across (a small object
        beside a large one: the radius is a fraction of the whole cloud's diagonal). Empty when neither."""
        radius = sample_radius * self.diagonal
        notes = []
        if self.gap_unit(radius) > radius:
            share = self.spacing / self.diagonal  # one more digit where one does not tell it from the radius
            apart = f"{share:.1%}" if f"{share:.1%}" != f"{sample_radius:.1%}" else f"{share:.2%}"
            notes.append(f"a sparse cloud: its points lie {apart} of the diagonal apart, more than the skeleton's "
                         f"sample radius ({sample_radius:.1%}); gaps and holes narrower than that spacing are not "
                         f"told from surface")
        count, labels = self.pieces
        if count > 1:
            low, high = np.full((count, 3), np.inf), np.full((count, 3), -np.inf)
            np.minimum.at(low, labels, self.points)
            np.maximum.at(high, labels, self.points)
            across = np.linalg.norm(high - low, axis=1) / radius
            small = across[(np.bincount(labels, minlength=count) >= MIN_POINTS) & (across < SMALL_PIECE)]
            if len(small):
                pieces = (f"a separate piece is {small[0]:.1f} of the skeleton's sample radii across" if len(small) == 1
                          else f"{len(small)} separate pieces are {small.min():.1f}-{small.max():.1f} of the "
                               f"skeleton's sample radii across")
                notes.append(f"{pieces}, less than {SMALL_PIECE:g}: balls of {sample_radius:.1%} of the whole "
                             f"cloud's diagonal resolve little of such a piece, and a loop of it may be lost; "
                             f"skeletonise it alone, or lower the sample radius")
        return notes

    def loops_at_most(self, enough: int | None = None) -> int | None:
        """The most loops a skeleton of this surface keeps: a one-piece closed mesh's genus (`genus`); else the
        most the solid a closed cloud bounds has as the run's inside test reads it (or the probe's where the run
        has none yet; skelcore.cloud_topology.loops_at_most, counted only until a level reads `enough`). None: no
        solid to go by."""
        if self.genus is not None:
            return self.genus
        if None in self._most_loops:  # counted to the end (or read ahead): the answer to every ask
            return self._most_loops[None]
        if enough not in self._most_loops:  # the skeletons of a run mostly ask with the same count
            try:
                test = self.shared_inside if self.shared_inside is not None else self.probe.inside()
            except InputError:  # too few points to bound anything
                self._most_loops[enough] = None
            else:
                self._most_loops[enough] = cloud_topology.loops_at_most(test, enough)
        return self._most_loops[enough]

    def read_ahead(self, most: int | None) -> None:
        """Take `most` as loops_at_most's answer: cloud_topology.loops_at_most of `shared_inside` read on a helper
        thread while the contraction ran, or the bound a run was given (skelcore.pipeline: a run held inside)."""
        self._most_loops[None] = most

    @property
    def probe(self) -> SurfaceProbe:
        """The surface probe of false loops at the median edge length (its normals kept between skeletons)."""
        if self._probe is None:
            self._probe = SurfaceProbe(self.points, self.spacing, self.shared_inside, self.inside_samples)
        return self._probe

    def probe_of_piece(self, piece: int) -> SurfaceProbe:
        """The probe a loop on surface piece `piece` (of `pieces`) is judged by: `probe`, or where the piece is
        sampled more than FINER times as finely as the cloud (a small object beside a large one), one over the
        piece's own points at its own spacing. The cloud's probe reads open space within one of the cloud's
        spacings of the surface as solid, and a small object's hole can be narrower than that (a torus a tenth the
        size of the other in its cloud: its hole read 0% open, and its loop was cut)."""
        if piece not in self._piece_probes:
            count, labels = self.pieces
            probe = self.probe
            own = self.edges[labels[self.edges[:, 0]] == piece] if count > 1 else self.edges[:0]
            if len(own) and np.count_nonzero(labels == piece) >= MIN_POINTS:
                spacing = _median_edge(self.points, own)
                if FINER * spacing < self.spacing:
                    probe = SurfaceProbe(self.points[labels == piece], spacing)
            self._piece_probes[piece] = probe
        return self._piece_probes[piece]

    def hull_planes(self, inner: bool = False) -> np.ndarray | None:
        """(f, 4) face planes of the convex hull of the original points, rows (n, d) with n.x + d <= 0 inside and n a
        unit normal (None: the points span no volume); with `inner`, of the hull of the points extreme along
        HULL_DIRECTIONS directions, which lies within it and has few faces. Each made once."""
        key = "inner" if inner else "whole"
        if key not in self._hulls:
            points = self.points[np.unique((self.points @ _DIRECTIONS.T).argmax(axis=0))] if inner else self.points
            try:
                self._hulls[key] = ConvexHull(points).equations
            except QhullError:  # flat, or too few points
                self._hulls[key] = None
        return self._hulls[key]

    @property
    def adjacency(self) -> sp.csr_matrix:
        """(n, n) symmetric 0/1 adjacency of the original points along the surface's edges, made once."""
        if self._adjacency is None:
            n = len(self.points)
            edges = self.edges
            graph = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()
            self._adjacency = ((graph + graph.T) > 0).astype(float).tocsr()
        return self._adjacency


def _median_edge(points: np.ndarray, edges: np.ndarray) -> float:
    """The median length of `edges` (e, 2) between `points`: their spacing along the surface (0 without edges)."""
    if not len(edges):
        return 0.0
    return float(np.median(np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)))


def _fibonacci_sphere(count: int) -> np.ndarray:
    """(count, 3) unit vectors spread evenly over the sphere."""
    z = 1.0 - (2.0 * np.arange(count) + 1.0) / count
    angle = np.pi * (3.0 - np.sqrt(5.0)) * np.arange(count)
    ring = np.sqrt(1.0 - z * z)
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), z])


_DIRECTIONS = _fibonacci_sphere(HULL_DIRECTIONS)
