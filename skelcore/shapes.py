"""Synthetic point clouds sampled on tubes around known centrelines (ground truth for `evaluate`).

A shape is a polyline graph (nodes, edges) with a radius per node, linear along each edge. Its solid
is the set where `tube_field(x) = min_e (|x - c_e(t*)| - r_e(t*)) <= 0`, c_e(t*) the closest point of
edge e: the union of one capsule per edge (a truncated cone when the radius varies). So open ends get
hemispherical caps, bends and junctions are closed, clean surfaces, and the distance from a surface
point to the centreline is the radius. Points are drawn uniformly per unit area on every piece that can
carry the boundary (edge frustums, end caps, the lune on the outside of each bend, whole spheres at
junctions and tapered nodes) and kept only where tube_field = 0: uniform over the union's surface.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .distinct import distinct_rows
from .errors import InputError, ParameterError

SHAPES = ("capsule", "torus", "helix", "y_branch", "animal", "two_hole", "thin_thick")
SHAPE_POINTS = 3000  # points per shape unless asked otherwise

# What a correct curve skeleton of each shape has: ends = degree-1 nodes, junctions = degree >= 3,
# cycles = E - V + C. The animal's legs, tail and neck leave the trunk at its two ends:
# the hip (two hind legs + tail) and the shoulder (two fore legs + neck), both of degree 4.
EXPECTED_TOPOLOGY = {
    "capsule": {"components": 1, "cycles": 0, "ends": 2, "junctions": 0},
    "torus": {"components": 1, "cycles": 1, "ends": 0, "junctions": 0},
    "helix": {"components": 1, "cycles": 0, "ends": 2, "junctions": 0},
    "y_branch": {"components": 1, "cycles": 0, "ends": 3, "junctions": 1},
    "animal": {"components": 1, "cycles": 0, "ends": 6, "junctions": 2},
    "two_hole": {"components": 1, "cycles": 2, "ends": 0, "junctions": 2},
    "thin_thick": {"components": 1, "cycles": 0, "ends": 2, "junctions": 0},
}

SPACING = 0.08  # centreline node spacing, in the shapes' units (each shape is about 2-3 units across)


@dataclass(frozen=True)
class Shape:
    """A synthetic shape: surface samples and the centreline graph (with tube radii) they were drawn around."""
    name: str
    points: np.ndarray  # (n,3) float64 surface samples
    nodes: np.ndarray  # (m,3) float64 centreline nodes
    edges: np.ndarray  # (e,2) int64 centreline edges
    radii: np.ndarray  # (m,) tube radius at each node, linear along edges
    topology: dict  # EXPECTED_TOPOLOGY[name]


def make_shape(name: str, n: int = SHAPE_POINTS, *, seed: int = 0, noise: float = 0.0,
               nonuniform: float = 0.0) -> Shape:
    """Sample `n` points on the surface of shape `name` (one of SHAPES); same seed, same points.

    noise: std of Gaussian noise added to every coordinate, as a fraction of the bounding-box diagonal.
    nonuniform: in [0, 1); the sampling density falls linearly along x from 1 to 1 - nonuniform.
    """
    if name not in SHAPES:
        raise ParameterError(f"shape {name!r}: unknown (choose from {', '.join(SHAPES)})")
    if int(n) != n or n < 20:
        raise ParameterError(f"parameter n={n!r}: must be an integer >= 20")
    if not np.isfinite(noise) or not 0 <= noise <= 1:  # a fraction of the diagonal: past 1 the shape is gone
        raise ParameterError(f"parameter noise={noise!r}: must be a fraction of the diagonal in [0, 1]")
    if not np.isfinite(nonuniform) or not 0 <= nonuniform < 1:
        raise ParameterError(f"parameter nonuniform={nonuniform!r}: must be in [0, 1)")
    nodes, edges, radii = centreline(name)
    rng = np.random.default_rng(seed)
    points = sample_tube_surface(nodes, edges, radii, int(n), rng, nonuniform=nonuniform)
    if noise > 0:
        diagonal = np.linalg.norm(points.max(axis=0) - points.min(axis=0))
        points = points + rng.normal(0.0, noise * diagonal, points.shape)
    return Shape(name, points, nodes, edges, radii, dict(EXPECTED_TOPOLOGY[name]))


def centreline(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ground-truth polyline graph of a shape: nodes (m,3), edges (e,2), radii (m,)."""
    if name not in SHAPES:
        raise ParameterError(f"shape {name!r}: unknown (choose from {', '.join(SHAPES)})")
    return _assemble(_PATHS[name]())


def tube_field(points: np.ndarray, nodes: np.ndarray, edges: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """min over edges of (distance to the edge - radius at the closest point): < 0 inside, 0 on the surface."""
    a = nodes[edges[:, 0]]
    ab = nodes[edges[:, 1]] - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    r0, dr = radii[edges[:, 0]], radii[edges[:, 1]] - radii[edges[:, 0]]
    out = np.empty(len(points))
    step = max(1, 2**20 // max(1, len(edges)))  # bounded memory: (step, e, 3) per chunk
    for start in range(0, len(points), step):
        ap = points[start:start + step, None, :] - a[None]
        t = np.clip(np.einsum("pek,ek->pe", ap, ab) / length2, 0.0, 1.0)
        gap = np.linalg.norm(ap - t[..., None] * ab, axis=2) - (r0 + t * dr)
        out[start:start + step] = gap.min(axis=1)
    return out


def sample_tube_surface(nodes: np.ndarray, edges: np.ndarray, radii: np.ndarray, n: int,
                        rng: np.random.Generator, *, nonuniform: float = 0.0) -> np.ndarray:
    """n points uniform over the surface of the union of tubes (see module docstring), in rng order."""
    pieces = _Pieces(nodes, edges, radii)
    low = (nodes[:, 0] - radii).min()
    width = (nodes[:, 0] + radii).max() - low
    kept: list[np.ndarray] = []
    count, rate = 0, 1.0
    while count < n:
        batch = int(1.2 * (n - count) / rate) + 64
        candidates = pieces.sample(batch, rng)
        # on the boundary: not inside another piece, and not a part of a sphere that is outside the solid
        keep = np.abs(tube_field(candidates, nodes, edges, radii)) <= 1e-9 * radii.max()
        if nonuniform > 0:  # thinning by a density that falls linearly along x
            keep &= rng.random(batch) < 1.0 - nonuniform * (candidates[:, 0] - low) / width
        rate = max(keep.mean(), 0.02)
        kept.append(candidates[keep])
        count += int(keep.sum())
    return np.concatenate(kept)[:n]


class _Pieces:
    """The surface pieces of a tube graph with their areas; draws points uniformly per unit area."""

    def __init__(self, nodes, edges, radii):
        self.nodes, self.radii = nodes, radii
        # Edge frustums: lateral area pi (r0 + r1) * slant length.
        self.a = nodes[edges[:, 0]]
        self.axis = nodes[edges[:, 1]] - self.a
        self.r0, self.r1 = radii[edges[:, 0]], radii[edges[:, 1]]
        self.e1, self.e2 = _frames(self.axis)
        slant = np.hypot(np.linalg.norm(self.axis, axis=1), self.r1 - self.r0)
        frustum_area = np.pi * (self.r0 + self.r1) * slant
        # Node pieces: degree 1 -> hemispherical cap beyond the end; degree 2 -> the lune between the
        # end planes of the two edges (outside of the bend); junctions, and nodes of an edge whose
        # radius varies (the ball then sticks out of the frustum in a thin band) -> the whole sphere.
        src = np.concatenate([edges[:, 0], edges[:, 1]])
        dst = np.concatenate([edges[:, 1], edges[:, 0]])
        order = np.argsort(src, kind="stable")
        degree = np.bincount(src, minlength=len(nodes))
        first = np.concatenate([[0], np.cumsum(degree)[:-1]])
        nb0 = dst[order][np.minimum(first, len(src) - 1)]
        nb1 = dst[order][np.minimum(first + 1, len(src) - 1)]
        self.d1 = _unit(nodes - nodes[nb0])  # along the first edge, arriving at the node
        d2 = _unit(nodes[nb1] - nodes)  # along the second edge, leaving the node
        cross = np.cross(self.d1, d2)
        self.angle = np.arctan2(np.linalg.norm(cross, axis=1), np.einsum("ij,ij->i", self.d1, d2))
        self.lune_axis = _unit(cross)
        tapered = np.zeros(len(nodes), dtype=bool)
        tapered[edges[self.r0 != self.r1].ravel()] = True
        self.kind = np.select([tapered | (degree < 1) | (degree > 2), degree == 1], [3, 1], 2)
        node_area = np.select([self.kind == 1, self.kind == 2], [2 * np.pi * radii**2, 2 * radii**2 * self.angle],
                              4 * np.pi * radii**2)
        areas = np.concatenate([frustum_area, node_area])
        self.n_edges = len(edges)
        self.p = areas / areas.sum()

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        piece = rng.choice(len(self.p), size=count, p=self.p)
        u, v = rng.random(count), rng.random(count)
        out = np.empty((count, 3))
        on_edge = piece < self.n_edges
        e = piece[on_edge]
        r0, r1 = self.r0[e], self.r1[e]
        # t with density proportional to r(t) (the frustum's circumference): inverse CDF, stable form.
        t = u[on_edge] * (r0 + r1) / (r0 + np.sqrt(r0**2 + u[on_edge] * (r1**2 - r0**2)))
        theta = 2 * np.pi * v[on_edge]
        ring = np.cos(theta)[:, None] * self.e1[e] + np.sin(theta)[:, None] * self.e2[e]
        out[on_edge] = self.a[e] + t[:, None] * self.axis[e] + (r0 + t * (r1 - r0))[:, None] * ring
        i = piece[~on_edge] - self.n_edges
        # Archimedes: z uniform in [-1, 1] and azimuth uniform give a uniform point on the sphere.
        z = 2 * u[~on_edge] - 1
        rho = np.sqrt(1 - z**2)[:, None]
        phi = 2 * np.pi * v[~on_edge]
        direction = rng.normal(size=(len(i), 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        cap = self.kind[i] == 1  # reflect into the half-space beyond the end
        along = np.einsum("ij,ij->i", direction, self.d1[i])
        direction[cap] -= 2 * np.minimum(along[cap], 0)[:, None] * self.d1[i][cap]
        lune = self.kind[i] == 2  # azimuth in (-pi/2, angle - pi/2) from d1 about the bend axis
        x, axis = self.d1[i][lune], self.lune_axis[i][lune]
        phi_l = self.angle[i][lune] * phi[lune] / (2 * np.pi) - np.pi / 2
        direction[lune] = rho[lune] * (np.cos(phi_l)[:, None] * x + np.sin(phi_l)[:, None] * np.cross(axis, x)) \
            + z[lune][:, None] * axis
        out[~on_edge] = self.nodes[i] + self.radii[i][:, None] * direction
        return out


def write_shape(shape: Shape, out_dir, *, seed: int | None = None) -> list[Path]:
    """Write NAME.ply (binary float32 points) and NAME_centreline.json beside it; returns both paths."""
    out_dir = Path(out_dir)
    cloud, truth = out_dir / f"{shape.name}.ply", out_dir / f"{shape.name}_centreline.json"
    header = (f"ply\nformat binary_little_endian 1.0\ncomment skelcore shape {shape.name} seed {seed}\n"
              f"element vertex {len(shape.points)}\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        cloud.write_bytes(header.encode("ascii") + shape.points.astype("<f4").tobytes())
        truth.write_text(json.dumps({
            "shape": shape.name,
            "nodes": np.round(shape.nodes, 9).tolist(),
            "edges": shape.edges.tolist(),
            "radii": np.round(shape.radii, 9).tolist(),
            "topology": shape.topology,
        }) + "\n")
    except OSError as error:
        raise InputError(f"{out_dir}: cannot write the shape files ({error.strerror})") from None
    return [cloud, truth]


def write_shapes(out_dir, names=SHAPES, n: int = SHAPE_POINTS, *, seed: int = 0, noise: float = 0.0,
                 nonuniform: float = 0.0) -> list[Path]:
    """make_shape + write_shape for each name; returns the paths written."""
    written: list[Path] = []
    for name in names:
        shape = make_shape(name, n, seed=seed, noise=noise, nonuniform=nonuniform)
        written += write_shape(shape, out_dir, seed=seed)
    return written


# ---- centrelines: each shape is a list of paths (points (k,3), radius per point) ----

def _unit(vectors: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(norm > 0, norm, 1.0)


def _frames(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to each axis and to each other."""
    d = _unit(axis)
    helper = np.where((np.abs(d[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = _unit(np.cross(d, helper))
    return e1, np.cross(d, e1)


def _through(*corners, radius: float, start_radius: float | None = None):
    """A straight-segment path through the corners, nodes about SPACING apart."""
    corners = np.asarray(corners, dtype=np.float64)
    parts = [corners[:1]]
    for a, b in zip(corners[:-1], corners[1:]):
        count = max(1, int(np.ceil(np.linalg.norm(b - a) / SPACING)))
        parts.append(a + np.linspace(0, 1, count + 1)[1:, None] * (b - a))
    points = np.concatenate(parts)
    radii = np.full(len(points), radius)
    if start_radius is not None:  # the path starts inside a thicker tube: share that node's radius
        radii[0] = start_radius
    return points, radii


def _curve(function, t_end: float, length: float, radius):
    """A path along function(t), t in [0, t_end], about SPACING apart; radius: float or function of t / t_end."""
    count = 4 * max(1, int(np.ceil(length / SPACING / 4)))  # a multiple of 4: loops hit their quarter points
    t = np.linspace(0.0, t_end, count + 1)
    radii = radius(t / t_end) if callable(radius) else np.full(len(t), radius)
    return function(t), radii


def _assemble(paths):
    """Merge paths into one graph: points at the same position become one node (the largest radius wins)."""
    points = np.concatenate([p for p, _ in paths])
    radii = np.concatenate([r for _, r in paths])
    offsets = np.cumsum([0] + [len(p) for p, _ in paths])
    local = np.concatenate([np.stack([np.arange(o, o + len(p) - 1), np.arange(o + 1, o + len(p))], axis=1)
                            for o, (p, _) in zip(offsets, paths)])
    key = np.round(points, 9) + 0.0  # + 0.0 turns -0.0 into 0.0
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))  # node ids in order of first appearance
    index = rank[inverse.ravel()]
    nodes = points[np.sort(first)]
    node_radii = np.zeros(len(nodes))
    np.maximum.at(node_radii, index, radii)
    edges = np.sort(index[local], axis=1)
    edges = distinct_rows(edges[edges[:, 0] != edges[:, 1]])
    return nodes, edges.astype(np.int64), node_radii


def _capsule():
    return [_through([-1.0, 0, 0], [1.0, 0, 0], radius=0.3)]


def _torus():
    circle = lambda t: np.stack([np.cos(t), np.sin(t), 0 * t], axis=1)
    return [_curve(circle, 2 * np.pi, 2 * np.pi, 0.3)]


def _helix():
    turns, radius, pitch = 2.5, 0.6, 0.8
    helix = lambda t: np.stack([radius * np.cos(t), radius * np.sin(t), pitch * t / (2 * np.pi) - 1.0], axis=1)
    length = turns * np.hypot(2 * np.pi * radius, pitch)
    return [_curve(helix, 2 * np.pi * turns, length, 0.15)]


def _y_branch():
    return [_through([0, 0, 0], end, radius=0.2) for end in ([0, -1.1, 0], [-0.75, 0.85, 0], [0.75, 0.85, 0])]


def _animal():
    hip, shoulder, trunk = [-0.6, 0, 0.9], [0.6, 0, 0.9], 0.25
    paths = [_through(hip, shoulder, radius=trunk)]
    for root in (hip, shoulder):
        for side in (-0.18, 0.18):
            paths.append(_through(root, [root[0], side, 0.5], [root[0], side, 0.05], radius=0.08, start_radius=trunk))
    paths.append(_through(shoulder, [0.95, 0, 1.35], [1.3, 0, 1.25], radius=0.12, start_radius=trunk))  # neck, head
    paths.append(_through(hip, [-1.0, 0, 0.85], [-1.35, 0, 0.55], radius=0.05, start_radius=trunk))  # tail
    return paths


def _two_hole():
    a, b = 1.4, 0.7  # an elliptic loop split by a bar along its minor axis
    ellipse = lambda t: np.stack([a * np.cos(t), b * np.sin(t), 0 * t], axis=1)
    perimeter = np.pi * (3 * (a + b) - np.sqrt((3 * a + b) * (a + 3 * b)))  # Ramanujan
    return [_curve(ellipse, 2 * np.pi, perimeter, 0.17), _through([0, -b, 0], [0, b, 0], radius=0.17)]


def _thin_thick():
    arc = lambda t: np.stack([2.4 * t - 1.2, 0.25 * np.sin(np.pi * t), 0 * t], axis=1)
    return [_curve(arc, 1.0, 2.5, lambda s: 0.05 + 0.15 * (1 - np.cos(np.pi * s)) / 2)]  # 0.05 -> 0.2


_PATHS = {"capsule": _capsule, "torus": _torus, "helix": _helix, "y_branch": _y_branch, "animal": _animal,
          "two_hole": _two_hole, "thin_thick": _thin_thick}
