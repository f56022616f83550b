"""Whether a mesh's vertices stand for its surface, and drawing points evenly over it when they do not.

Everything downstream reads a cloud of points, and a mesh file gives its vertices. A remeshed scan's vertices
spread evenly over its surface, but a CAD model's or a modelling primitive's do not: a plate's flat face is two
triangles whose four corners are all the points it has, and trimesh's default torus has its rings of 32
vertices 2.6 skeleton sample radii apart. Contracted as they are, such vertices leave holes the size of their
faces: a block with two drilled holes (264 vertices) came out as a 4-node skeleton without its loops, a chair
without its loops, and the torus's rings contracted to 32 separate clusters.

So a mesh is judged three times. First by the share of its surface that lies farther than the skeleton's default
sample radius (skelcore.normalise.SAMPLE_RADIUS of its diagonal) from every vertex, estimated at COVERAGE_PROBES
random points of the surface. Then by the share of its vertices (at most STRAY_PROBES of them, drawn at random)
that cleaning's stray rule (skelcore.clean, default parameters) would cut away, where it would keep all but
MAX_UNCOVERED of points drawn evenly over the surface (else the pieces are small separate parts, which an even
sample loses as well): a CSG union keeps each solid's own tessellation, and a ball of 64 segments carrying three
finely meshed ring handles has 90% of its vertices on the handles, the ball's 14 times sparser, so cleaning cut
the ball into stray shards and the skeleton came out in 3 pieces without a loop. Up to MAX_UNCOVERED on each,
the vertices are the cloud (Cao's cloudcontr contracts a mesh's vertices, and its remeshed models are what it
was made for); above, the surface is sampled evenly instead, with as many points as it has vertices and at
least SURFACE_POINTS. Measured: every remeshed model at hand lies within the radius of a vertex but 0.55% or
less of its surface, and cleaning keeps all but 0.1% of its vertices (11 of cloudcontr's 12 meshes, the
reference folder's elephant, hand, bunny and horse), while CAD solids (manifold3d's blocks, gear, chair, mug,
stool), trimesh's primitives (torus, capsule, icosphere, annulus, box) and cloudcontr's 919-vertex test figure
leave 22-99% of it farther, and the handled balls lose 9% and more of their vertices to cleaning. A file whose
faces leave more than MAX_UNCOVERED of its vertices out is a cloud with a few faces among its points, and one
whose faces have no area is points stored as a mesh: both keep their vertices.

Third, by the share of its vertices that read as curves at the skeleton's scale before any contraction
(skelcore.curveness), over IN_ROWS where points drawn evenly over it read so at most MAX_UNCOVERED: a low-poly
model's vertices can lie in rows along its long facets, every one of them within the radius of the surface's
points, and the contraction takes such rows for curves already finished. pyvista's airplane (1,335 vertices: rings
round the fuselage, spars along the wings) has 22% of its vertices in rows, an even sample none, and its vertices
came out with 3-4 false loops where the rows meet at the wing roots (sampled: none); every other mesh at hand (63
files: cloudcontr's, the reference folder's, meshes shipped with pyvista, pymeshlab, pymeshfix and on npm) reads at
most 2% (cloudcontr's corn and 9-handle torus), most of them under 0.1%.
"""
from __future__ import annotations

import functools

import numpy as np

from .distinct import distinct
from .errors import InputError
from .normalise import SAMPLE_RADIUS, binary_unit, half_extent, object_diagonal
from .params import CleaningParams
from .readers import quiet_trimesh

COVERAGE_PROBES = 10_000  # random surface points that measure the uncovered share (its standard error at 1%: 0.1%)
STRAY_PROBES = 200_000  # vertices the stray rule is run on, at most (a million take 3 s)
MAX_UNCOVERED = 0.01  # share of the surface farther than the sample radius from every vertex, and of the vertices
# cleaning would cut away as stray pieces (or of points drawn evenly that read as curves), at most
IN_ROWS = 0.1  # share of the vertices that read as curves, at most: the meshes at hand read 0-2% (with the scatter
# of the curve-likeness probes), pyvista's airplane, whose rows closed false loops, 22%
SURFACE_POINTS = 10_000  # points drawn over a surface its vertices do not cover, at least (the real-shape
# benchmark samples its solids at this density: skelcore.solids)


def _unit_mesh(vertices: np.ndarray, faces: np.ndarray):
    """(trimesh mesh of the vertices over `unit`, unit): at an extent of about 1, areas neither overflow nor vanish."""
    unit = binary_unit(half_extent(vertices))
    return quiet_trimesh().Trimesh(vertices=vertices / unit, faces=faces, process=False), unit


def uncovered_share(vertices: np.ndarray, faces: np.ndarray, seed: int = 0) -> float:
    """The share of the mesh's surface (by area, which must be > 0) farther than SAMPLE_RADIUS of the diagonal
    from every vertex."""
    from scipy.spatial import cKDTree

    mesh, _ = _unit_mesh(vertices, faces)
    probes, _ = quiet_trimesh().sample.sample_surface(mesh, COVERAGE_PROBES, seed=seed)
    radius = SAMPLE_RADIUS * object_diagonal(mesh.vertices)  # at the unit scale: 1e300 coordinates' would overflow
    distance, _ = cKDTree(mesh.vertices).query(probes, workers=-1)
    return float(np.mean(distance > radius))


def stray_share(points: np.ndarray, seed: int = 0) -> float:
    """The share of `points` (distinct) that cleaning's stray rule, with its default parameters, would cut away,
    judged on STRAY_PROBES of them drawn at random when there are more (thinning every part alike scales every
    spacing alike, and with them the rule's gap)."""
    from scipy.spatial import cKDTree

    from .neighbours import leaf_knn, stray_pieces  # scipy: loaded when a mesh is judged, not when io is imported

    if len(points) > STRAY_PROBES:
        points = points[np.random.default_rng(seed).choice(len(points), STRAY_PROBES, replace=False)]
    cleaning = CleaningParams()
    if len(points) <= cleaning.neighbours + 1:
        return 0.0
    distance, index = leaf_knn(cKDTree(points), cleaning.neighbours + 1)
    stray = stray_pieces(distance, index, distance[:, 1:].mean(axis=1), np.ones(len(points), bool),
                         cleaning.piece_gap, cleaning.min_piece_share)
    return float(stray.mean())


def curve_like_share(points: np.ndarray, seed: int = 0) -> float:
    """The share of `points` (at most STRAY_PROBES of them, drawn at random) that read as curves at the skeleton's
    default sample radius (skelcore.curveness.skeleton_scale_share), at the unit scale (binary_unit)."""
    from .curveness import skeleton_scale_share  # scipy: loaded when a mesh is judged, not when io is imported

    if len(points) > STRAY_PROBES:
        points = points[np.random.default_rng(seed).choice(len(points), STRAY_PROBES, replace=False)]
    points = points / binary_unit(half_extent(points))
    return skeleton_scale_share(points, object_diagonal(points), seed)


def sample_surface(vertices: np.ndarray, faces: np.ndarray, count: int, seed: int, name: str = "mesh"
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(`count` points spread evenly over the mesh's surface, in its coordinates; the face of each). Poisson-disk
    rejection, topped up uniformly by area where it leaves fewer (a surface of long slivers)."""
    mesh, unit = _unit_mesh(vertices, faces)
    if not mesh.area > 0:
        raise InputError(f"{name}: the mesh has no surface to sample (its triangles have no area)")
    sample = quiet_trimesh().sample
    points, face_index = sample.sample_surface_even(mesh, count, seed=seed)
    if len(points) < count:
        extra, extra_faces = sample.sample_surface(mesh, count - len(points), seed=seed + 1)
        points, face_index = np.vstack([points, extra]), np.concatenate([face_index, extra_faces])
    return np.asarray(points[:count], dtype=np.float64) * unit, np.asarray(face_index[:count])


def points_to_draw(vertices: np.ndarray, faces: np.ndarray, labelled: bool, cap: int, seed: int = 0
                   ) -> tuple[int | None, str | None]:
    """(how many points to draw over the mesh instead of taking its vertices, or None to take them; a note saying
    why, or None where the vertices stand for the surface). vertices: no two equal; labelled vertices are kept:
    their labels belong to them. cap: the most points the run may hold."""
    if distinct(faces).size < (1 - MAX_UNCOVERED) * len(vertices):
        return None, None  # a cloud with a few faces among its points: they are not its surface
    if not _unit_mesh(vertices, faces)[0].area > 0:
        return None, None  # faces without area: points stored as a mesh, with no surface to draw from
    # the even sample both comparisons below read, drawn once and only when one of them needs it
    drawn = functools.cache(lambda: sample_surface(vertices, faces, SURFACE_POINTS, seed)[0])
    uncovered = uncovered_share(vertices, faces, seed)
    if uncovered > MAX_UNCOVERED:
        why = f"leave {uncovered:.0%} of its surface farther than the skeleton's sample radius from any vertex"
    elif ((stray := stray_share(vertices, seed)) > MAX_UNCOVERED
          and (even := stray_share(drawn())) <= MAX_UNCOVERED):
        # an even sample keeping what the vertices lose: their spread is to blame, not small separate parts
        why = (f"are spread so unevenly that cleaning would cut {stray:.0%} of them away as stray pieces (of "
               f"points drawn evenly over it, {even:.0%})")
    elif ((rows := curve_like_share(vertices, seed)) > IN_ROWS
          and (even := curve_like_share(drawn())) <= MAX_UNCOVERED):
        why = (f"lie in rows: {rows:.0%} of them read as curves at the skeleton's scale before any contraction (of "
               f"points drawn evenly over it, {even:.0%})")
    else:
        return None, None
    gap = f"mesh: its {len(vertices):,} vertices {why}"
    if labelled:
        return None, f"{gap}; they are kept for their labels (--sample N draws N points over it instead)"
    count = min(max(SURFACE_POINTS, len(vertices)), cap)
    return count, f"{gap}, so {count:,} points are drawn evenly over it instead (--sample 0 keeps the vertices)"
