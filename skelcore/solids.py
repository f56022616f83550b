"""Shapes of known genus beyond tubes, for the quality benchmark: CSG solids and the reference meshes and scans.

A solid's curve skeleton has one independent cycle per handle and one component per piece, so the truth
of each solid is read from its own closed mesh: cycles = total genus = (2 C - chi) / 2 with chi = V - E + F
(Euler-Poincare for C closed orientable surfaces). The solids are built with manifold3d, whose boolean
operations return closed 2-manifolds, so that count is exact. Every shape is sampled to the same number of
points evenly over its surface (seeded), with the mesh's face normals at the samples.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import InputError
from .mesh_topology import mesh_topology as surface_topology
from .household import HOUSEHOLD
from .parts import PARTS
from .solid_blocks import SEGMENTS, box, cone, cylinder, manifold3d, sphere, torus, union
from .surface_sampling import SURFACE_POINTS, sample_surface

DEFAULT_POINTS = SURFACE_POINTS


@dataclass(frozen=True)
class BenchmarkShape:
    """One benchmark shape: its surface samples and what a correct curve skeleton of it has."""

    name: str
    points: np.ndarray  # (n,3) float64 surface samples
    cycles: int  # independent loops of a correct curve skeleton (the genus)
    components: int  # connected pieces of a correct curve skeleton
    source: str  # how the shape was made, or the reference file it comes from
    normals: np.ndarray | None = None  # (n,3) outward unit normals at the samples, when a mesh gives them
    ends: int | None = None  # degree-1 nodes of a correct skeleton, where a rig or the construction fixes it
    note: str = ""  # why the truth is what it is
    mesh: tuple[np.ndarray, np.ndarray] | None = None  # (vertices, faces) when the shape is a closed mesh


# --- CSG solids ---------------------------------------------------------------------------------

def _stadium_link(half_straight: float, major: float, minor: float):
    """A chain link: two half rings joined by straight bars along x, in the xy plane."""
    right, left = torus(major, minor).split_by_plane((1.0, 0.0, 0.0), 0.0)
    bar = cylinder(2 * half_straight, minor, turn=(0.0, 90.0, 0.0))
    return union([right.translate((half_straight, 0.0, 0.0)), left.translate((-half_straight, 0.0, 0.0)),
                  bar.translate((0.0, major, 0.0)), bar.translate((0.0, -major, 0.0))])


def _upright(solid):
    """Turn a solid lying in the xy plane into the xz plane (a link threaded through its neighbour)."""
    return solid.rotate((90.0, 0.0, 0.0))


def drilled_block(holes: int):
    """A plate 0.6 thick with `holes` round holes drilled through it: in a row, or a 2x2 grid for 4."""
    pitch, radius = 1.0, 0.28
    if holes == 4:
        size, centres = (2.2, 2.2), [(x, y) for x in (-0.5, 0.5) for y in (-0.5, 0.5)]
    else:
        size, centres = (holes * pitch + 0.4, 1.2), [((i - (holes - 1) / 2) * pitch, 0.0) for i in range(holes)]
    # made first: a boolean's faces come in the order its solids were made, and the benchmark's samples follow them
    block = box((size[0], size[1], 0.6))
    drill = cylinder(1.0, radius)
    return block - union(drill.translate((x, y, 0.0)) for x, y in centres)


def mug():
    """A cup with an open cavity (walls 0.1 thick) and a ring handle on its side: genus 1."""
    body, cavity = cone(1.1, 0.5, 0.5), cone(1.1, 0.4, 0.4, lift=0.12)
    handle = _upright(torus(0.3, 0.08)).translate((0.5, 0.0, 0.55))
    # The handle's ends are cut inside the wall (not on its surface: coincident faces would leave slivers).
    return (body - cavity) + (handle - cone(1.1, 0.45, 0.45))


def pretzel():
    """Three rings in a row, each overlapping the next along a lens (no extra hole between them): genus 3."""
    ring = torus(1.0, 0.3)
    return union(ring.translate((x, 0.0, 0.0)) for x in (-1.7, 0.0, 1.7))


def linked_rings(count: int):
    """`count` rings of radius 1 in a chain, alternately in the xy and xz planes, so components = cycles =
    count. Two rings sit as a Hopf link (each centre on the other ring: their centrelines stay 1 apart
    everywhere); longer chains space the rings 4/3 apart, which puts both a ring's neighbours and the rings
    two along 2/3 away. The tube radius is 0.15 of that distance: the gap (0.7 of it) is over 8 standard
    deviations of the strongest benchmark noise, so noise never joins two rings."""
    pitch, closest = (1.0, 1.0) if count == 2 else (4.0 / 3.0, 2.0 / 3.0)
    ring = torus(1.0, 0.15 * closest)
    rings = [(ring if i % 2 == 0 else _upright(ring)).translate((pitch * i, 0.0, 0.0)) for i in range(count)]
    return union(rings) if count > 1 else rings[0]


def gear(teeth: int = 12, holes: int = 4):
    """A toothed disc 0.3 thick with a centre bore and `holes` lightening holes: genus holes + 1."""
    disc = cylinder(0.3, 1.0)  # made before the teeth (see drilled_block)
    tooth = box((0.3, 0.18, 0.3), (1.1, 0.0, 0.0))
    disc = union([disc] + [tooth.rotate((0.0, 0.0, 360.0 * i / teeth)) for i in range(teeth)])
    drill = cylinder(1.0, 0.18)
    bores = [drill.scale((1.2, 1.2, 1.0))]
    bores += [drill.translate((0.6 * np.cos(a), 0.6 * np.sin(a), 0.0))
              for a in 2 * np.pi * (np.arange(holes) + 0.5) / holes]
    return disc - union(bores)


def chain(links: int = 3):
    """`links` oval links, alternately in the xy and xz planes; each end loop threads its neighbour's with
    its centreline 0.5 (the end radius) from the neighbour's, and the links two along are as far apart.
    Tubes of radius 0.08 leave a gap of 0.34, over 8 standard deviations of the strongest benchmark noise."""
    half_straight, major, minor = 0.25, 0.5, 0.08
    pitch = 2 * half_straight + major  # a neighbour's end circle passes through this link's end-circle centre
    link = _stadium_link(half_straight, major, minor)
    parts = [(link if i % 2 == 0 else _upright(link)).translate((pitch * i, 0.0, 0.0)) for i in range(links)]
    return union(parts)


def table():
    """A top 2 x 1.2 x 0.08 on four round legs (radius 0.05, 1 long): genus 0, plates and rods at joints."""
    legs = [cylinder(1.0, 0.05, (x, y, 0.5)) for x in (-0.9, 0.9) for y in (-0.5, 0.5)]
    return union([box((2.0, 1.2, 0.08), (0.0, 0.0, 1.0)), *legs])


def chair():
    """A seat 1 x 1 x 0.08 on four legs (radius 0.04), a back of two uprights joined by a top rail and a middle
    rail: genus 2 (the two openings of the back)."""
    parts = [box((1.0, 1.0, 0.08), (0.0, 0.0, 0.5))]
    parts += [cylinder(0.5, 0.04, (x, y, 0.25)) for x in (-0.45, 0.45) for y in (-0.45, 0.45)]
    parts += [cylinder(1.0, 0.04, (x, 0.45, 1.0)) for x in (-0.45, 0.45)]
    parts += [cylinder(0.94, radius, (0.0, 0.45, z), (0.0, 90.0, 0.0)) for z, radius in ((1.47, 0.04), (1.0, 0.03))]
    return union(parts)


def stool():
    """A round seat (radius 0.5, 0.06 thick) on three legs joined by a ring below it: genus 3 (the ring, and two
    independent loops through the seat between the legs)."""
    parts = [cylinder(0.06, 0.5, (0.0, 0.0, 1.0))]
    parts += [cylinder(1.0, 0.04, (0.4 * np.cos(a), 0.4 * np.sin(a), 0.5)) for a in 2 * np.pi * np.arange(3) / 3]
    parts.append(torus(0.4, 0.03).translate((0.0, 0.0, 0.4)))
    return union(parts)


def handled_ball(handles: int = 3, ring: float = 0.3, tube: float = 0.07):
    """A ball of radius 1 with `handles` small ring handles (ring radius `ring`, tube `tube`) standing on it, half
    sunk, at spread-out directions: genus `handles`, with loops small beside the body (an elephant's handles)."""
    parts = [sphere(1.0)]  # made before the handles (see drilled_block)
    handle = _upright(torus(ring, tube))  # in the xz plane, around the y axis
    for i in range(handles):  # golden-angle directions on the upper half: apart from each other
        height = 0.8 - 1.2 * i / max(handles - 1, 1)
        azimuth = np.degrees(2.39996 * i)
        tilt = np.degrees(np.arccos(height))
        # standing on the north pole (its inner arc sunk by half the ring), then turned to its direction
        standing = handle.translate((0.0, 0.0, 1.0 + ring / 2))
        parts.append(standing.rotate((0.0, tilt, 0.0)).rotate((0.0, 0.0, azimuth)))
    return union(parts)


def trefoil(minor: float = 0.25, steps: int = 400):
    """A tube of radius `minor` along the trefoil knot (sin t + 2 sin 2t, cos t - 2 cos 2t, -sin 3t): genus 1,
    knotted. Its strands pass 1.21 apart at the closest, so the gap (0.71) is over 8 standard deviations of the
    strongest benchmark noise. The tube's frame is the tangent's cross product with z (never vertical: the
    tangent's horizontal part is at least 3 long), so the frame closes on itself."""
    m3d = manifold3d()
    t = 2 * np.pi * np.arange(steps) / steps
    centre = np.c_[np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)]
    tangent = np.c_[np.cos(t) + 4 * np.cos(2 * t), -np.sin(t) + 4 * np.sin(2 * t), -3 * np.cos(3 * t)]
    normal = np.cross(tangent, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent / np.linalg.norm(tangent, axis=1, keepdims=True), normal)
    angle = 2 * np.pi * np.arange(SEGMENTS) / SEGMENTS
    rim = (np.cos(angle)[None, :, None] * normal[:, None] + np.sin(angle)[None, :, None] * binormal[:, None])
    vertices = (centre[:, None] + minor * rim).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(steps), np.arange(SEGMENTS), indexing="ij")
    a, b = i * SEGMENTS + j, ((i + 1) % steps) * SEGMENTS + j
    c, d = ((i + 1) % steps) * SEGMENTS + (j + 1) % SEGMENTS, i * SEGMENTS + (j + 1) % SEGMENTS
    faces = np.vstack([np.c_[a.ravel(), b.ravel(), c.ravel()], np.c_[a.ravel(), c.ravel(), d.ravel()]])
    return m3d.Manifold(m3d.Mesh(vert_properties=vertices.astype(np.float32), tri_verts=faces.astype(np.uint32)))


# name -> (builder, ends of a correct skeleton or None when the construction does not fix them, description)
SOLIDS: dict[str, tuple[Callable, int | None, str]] = {
    "block_1_hole": (lambda: drilled_block(1), 0, "plate with 1 drilled hole"),
    "block_2_holes": (lambda: drilled_block(2), 0, "plate with 2 drilled holes in a row"),
    "block_3_holes": (lambda: drilled_block(3), 0, "plate with 3 drilled holes in a row"),
    "block_4_holes": (lambda: drilled_block(4), 0, "plate with 4 drilled holes in a 2x2 grid"),
    "mug": (mug, None, "cup with an open cavity and a ring handle"),
    "pretzel": (pretzel, 0, "three overlapping rings in a row (genus 3)"),
    "linked_rings_2": (lambda: linked_rings(2), 0, "two linked rings (Hopf link)"),
    "linked_rings_3": (lambda: linked_rings(3), 0, "three rings linked in a chain"),
    "gear": (gear, None, "12-tooth gear with a bore and 4 lightening holes"),
    "chain": (chain, 0, "three oval chain links"),
    "trefoil": (trefoil, 0, "tube along a trefoil knot"),
    "handled_ball": (handled_ball, None, "ball with 3 small ring handles (genus 3)"),
    "thin_handled_ball": (lambda: handled_ball(3, 0.2, 0.04), None,
                          "ball with 3 thin ring handles, one or two points across at 10k points (genus 3)"),
    "thick_torus": (lambda: torus(1.0, 0.5), 0, "torus whose tube is half its ring radius (a doughnut)"),
    "table": (table, None, "table: a top plate on four round legs"),
    "chair": (chair, None, "chair: seat on four legs, a back of two uprights and two rails (genus 2)"),
    "stool": (stool, None, "round stool: three legs joined by a ring below the seat (genus 3)"),
}
EVERYDAY = {**PARTS, **HOUSEHOLD}  # the shapes not in the default grid: `--parts`, or by name


def _solid(name: str) -> tuple[Callable, int | None, str]:
    """The entry of solid `name`: one of SOLIDS, or of the everyday parts and household objects (EVERYDAY)."""
    entry = SOLIDS.get(name) or EVERYDAY.get(name)
    if entry is None:
        raise InputError(f"solid {name!r}: unknown (choose from {', '.join([*SOLIDS, *EVERYDAY])})")
    return entry


def solid_mesh(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (v,3) and triangles (f,3) of the closed mesh of solid `name` (one of SOLIDS or EVERYDAY)."""
    return solid_arrays(_solid(name)[0]())


def solid_arrays(solid) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (v,3) and triangles (f,3) of a manifold3d solid's mesh."""
    mesh = solid.to_mesh()
    return np.asarray(mesh.vert_properties[:, :3], dtype=np.float64), np.asarray(mesh.tri_verts, dtype=np.int64)


def mesh_topology(vertices: np.ndarray, faces: np.ndarray) -> dict:
    """Components, Euler characteristic, boundary loops and total genus of a triangle mesh
    (skelcore.mesh_topology), its vertices at the same position merged first, so that a mesh stored as triangle
    soup counts like the surface it is."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=True)
    return surface_topology(mesh.faces, len(mesh.vertices))


def sample_mesh(vertices: np.ndarray, faces: np.ndarray, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """n points spread evenly over a mesh surface (skelcore.surface_sampling.sample_surface), and the outward face
    normal at each."""
    import trimesh

    points, face_index = sample_surface(vertices, faces, n, seed)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    # Outward normals: a mesh wound inside out (negative signed volume) has its face normals flipped.
    outward = -1.0 if mesh.volume < 0 else 1.0
    return points, outward * np.asarray(mesh.face_normals[face_index])


def solid_shape(name: str, points: int = DEFAULT_POINTS, seed: int = 0) -> BenchmarkShape:
    """Solid `name` (one of SOLIDS or EVERYDAY) sampled evenly, its truth read from its closed mesh's Euler
    characteristic."""
    vertices, faces = solid_mesh(name)
    topology = mesh_topology(vertices, faces)
    samples, normals = sample_mesh(vertices, faces, points, seed)
    _, ends, description = _solid(name)
    return BenchmarkShape(name, samples, topology["genus"], topology["components"], f"manifold3d: {description}",
                          normals, ends, f"genus {topology['genus']} by the Euler characteristic of its closed mesh",
                          (vertices, faces))


# --- reference meshes and scans -------------------------------------------------------------------

@dataclass(frozen=True)
class _Reference:
    file: str
    cycles: int
    components: int
    note: str
    rig: str | None = None  # an animator's rig beside it: its leaves give the expected ends
    mesh: bool = True  # False: a scan without faces, its truth stated with a reason


# Checked with mesh_topology on each file (tests/test_quality_bench.py repeats the check for the meshes).
REFERENCES: dict[str, _Reference] = {
    "simplejoint": _Reference("cloudcontr_simplejoint_v4770.off", 0, 1, "closed Y tube: chi 2, genus 0"),
    "test_animation": _Reference("cloudcontr_test_animation.off", 0, 1, "closed humanoid: chi 2, genus 0",
                                 "cloudcontr_test_animation.skeleton"),
    "hand": _Reference("libigl_hand_surface.ply", 0, 1, "closed hand: chi 2, genus 0", "libigl_hand.tgf"),
    "elephant": _Reference("libigl_elephant.obj", 0, 1, "closed elephant: chi 2, genus 0", "libigl_elephant.tgf"),
    "horse": _Reference("glskeleton_horse_v1987.ply", 0, 1,
                        "main part closed with chi 2 (genus 0); a stray 2-triangle sliver is the file's 2nd part"),
    "duck": _Reference("glskeleton_duck_model.ply", 0, 1,
                       "scan without faces: a solid toy duck, one piece without handles", mesh=False),
    "bunny": _Reference("glskeleton_bun_zipper_res2.ply", 0, 1,
                        "main part chi -3 with 5 boundary loops (open bottom, small scan holes): genus 0; "
                        "2-triangle slivers aside"),
    "tree": _Reference("cloudcontr_tree_small_pointcloud.off", 0, 1,
                       "scan without faces: one branching tree, branches do not grow back together", mesh=False),
}


def reference_shape(name: str, reference_dir, points: int = DEFAULT_POINTS, seed: int = 0) -> BenchmarkShape:
    """A reference mesh sampled evenly over its surface, or a scan thinned by farthest-point sampling
    (an even spread that keeps the scan's own points; no normals: perturb estimates them)."""
    from . import io

    reference = REFERENCES[name]
    path = Path(reference_dir) / reference.file
    cloud = io.load(path, sample=0)  # the mesh itself: sampled here, with its normals
    normals = None
    if cloud.faces is not None:
        samples, normals = sample_mesh(cloud.points, cloud.faces, points, seed)
    elif len(cloud.points) > points:
        samples = _farthest_points(cloud.points, points, seed)
    else:
        samples = cloud.points
    ends = None
    if reference.rig is not None:
        from .evaluate import graph_topology, load_graph

        rig = load_graph(Path(reference_dir) / reference.rig)
        ends = graph_topology(len(rig.nodes), rig.edges)["ends"]
    elif name == "simplejoint":
        ends = 3
    return BenchmarkShape(name, samples, reference.cycles, reference.components, f"reference: {reference.file}",
                          normals, ends, reference.note, None if cloud.faces is None else (cloud.points, cloud.faces))


def _farthest_points(points: np.ndarray, count: int, seed: int) -> np.ndarray:
    import open3d as o3d

    start = int(np.random.default_rng(seed).integers(len(points)))
    order = np.r_[start:len(points), 0:start]  # open3d starts from the first point
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points[order]))
    return np.asarray(cloud.farthest_point_down_sample(count).points, dtype=np.float64)


def default_reference_dir() -> Path:
    """../shared/reference beside the project root (present on the project's machines, absent in a clone)."""
    return Path(__file__).resolve().parents[1].parent / "shared" / "reference"


def shape_names(reference_dir=None) -> list[str]:
    """Every solid, then every reference shape when the reference folder (default ../shared/reference) exists."""
    folder = Path(reference_dir) if reference_dir is not None else default_reference_dir()
    return list(SOLIDS) + (list(REFERENCES) if folder.is_dir() else [])


def benchmark_shapes(reference_dir=None, points: int = DEFAULT_POINTS, seed: int = 0,
                     names: list[str] | None = None) -> list[BenchmarkShape]:
    """The benchmark's shapes, each sampled to `points` points: every solid, then every reference shape
    when `reference_dir` (default ../shared/reference beside the project) exists. `names` picks some, among
    them the everyday parts and household objects (EVERYDAY), which are not in the default set."""
    folder = Path(reference_dir) if reference_dir is not None else default_reference_dir()
    available = shape_names(folder)
    names = available if names is None else list(names)
    unknown = [name for name in names if name not in available and name not in EVERYDAY]
    if unknown:
        raise InputError(f"shape {unknown[0]!r}: unknown or its reference folder is missing "
                         f"(choose from {', '.join([*available, *EVERYDAY])})")
    return [reference_shape(name, folder, points, seed) if name in REFERENCES else solid_shape(name, points, seed)
            for name in names]
