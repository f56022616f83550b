"""The building blocks of the benchmark's closed manifold3d solids (skelcore.solids, skelcore.parts,
skelcore.household): rods, boxes, rings, tubes along a path, plates cut from 2-D sections."""
from __future__ import annotations

import numpy as np

SEGMENTS = 64  # facets around every circle of a solid: sampling sees no facets


def manifold3d():
    """The manifold3d module, imported when a solid is first built."""
    import manifold3d as module

    return module


def cylinder(height: float, radius: float, centre=(0.0, 0.0, 0.0), turn=(0.0, 0.0, 0.0), segments: int = SEGMENTS):
    """A cylinder along z, centred, turned by `turn` degrees about x, y, z, then moved."""
    solid = manifold3d().Manifold.cylinder(height, radius, radius, segments, True)
    return solid.rotate(turn).translate(centre)


def box(size, centre=(0.0, 0.0, 0.0)):
    """A box of edge lengths `size`, centred at `centre`."""
    return manifold3d().Manifold.cube(size, True).translate(centre)


def sphere(radius: float, centre=(0.0, 0.0, 0.0)):
    """A ball of `radius` about `centre`."""
    return manifold3d().Manifold.sphere(radius, SEGMENTS).translate(tuple(centre))


def torus(major: float, minor: float):
    """A torus of ring radius `major` and tube radius `minor`, around z in the xy plane."""
    manifold = manifold3d()
    return manifold.Manifold.revolve(manifold.CrossSection.circle(minor, SEGMENTS).translate((major, 0.0)), SEGMENTS)


def standing_ring(major: float, minor: float):
    """A torus in the xz plane (it stands up)."""
    return torus(major, minor).rotate((90.0, 0.0, 0.0))


def flat_ring(outer: float, inner: float, thickness: float, centre=(0.0, 0.0, 0.0)):
    """A flat ring (a washer) lying in the xy plane."""
    return (cylinder(thickness, outer) - cylinder(2 * thickness, inner)).translate(centre)


def cone(height: float, bottom: float, top: float, lift: float = 0.0):
    """A cone frustum along z from z = lift, of radii `bottom` and `top`."""
    return manifold3d().Manifold.cylinder(height, bottom, top, SEGMENTS, False).translate((0.0, 0.0, lift))


def rod(start, end, radius: float, end_radius: float | None = None):
    """A cylinder (a cone frustum to `end_radius`) from `start` to `end`."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(end - start))
    axis = (end - start) / length
    top = radius if end_radius is None else end_radius
    solid = manifold3d().Manifold.cylinder(length, radius, top, SEGMENTS, False)
    tilt, turn = np.degrees(np.arccos(np.clip(axis[2], -1.0, 1.0))), np.degrees(np.arctan2(axis[1], axis[0]))
    return solid.rotate((0.0, tilt, 0.0)).rotate((0.0, 0.0, turn)).translate(tuple(start))


def union(solids):
    """The union of `solids`, in one boolean operation."""
    manifold = manifold3d()
    return manifold.Manifold.batch_boolean(list(solids), manifold.OpType.Add)


def tube_along(path, radius, closed: bool = False):
    """A round tube along a polyline: the hulls of balls on consecutive points (`radius`: one, or one per point)."""
    manifold = manifold3d()
    path = np.asarray(path, dtype=float)
    radii = np.broadcast_to(np.asarray(radius, dtype=float), (len(path),))
    balls = [manifold.Manifold.sphere(float(r), 32).translate(tuple(p)) for p, r in zip(path, radii)]
    pairs = list(zip(balls, balls[1:] + balls[:1] if closed else balls[1:]))
    return union(manifold.Manifold.batch_hull([a, b]) for a, b in pairs)


def arc_points(centre, radius: float, start: float, stop: float, plane: str = "xz", count: int = 40) -> np.ndarray:
    """Points on a circular arc about `centre` from angle `start` to `stop` (degrees) in a coordinate plane."""
    angle = np.radians(np.linspace(start, stop, count))
    a, b, zero = radius * np.cos(angle), radius * np.sin(angle), np.zeros(count)
    return {"xy": np.c_[a, b, zero], "xz": np.c_[a, zero, b], "yz": np.c_[zero, a, b]}[plane] + np.asarray(centre)


def stadium(x0: float, x1: float, r0: float, r1: float | None = None):
    """The 2-D hull of a circle of radius r0 at (x0, 0) and one of r1 (default r0) at (x1, 0)."""
    section = manifold3d().CrossSection
    return section.batch_hull([section.circle(r0, SEGMENTS).translate((x0, 0.0)),
                               section.circle(r0 if r1 is None else r1, SEGMENTS).translate((x1, 0.0))])


def rounded_rectangle(width: float, height: float, corner: float):
    """A 2-D rectangle `width` x `height`, centred, its corners rounded to radius `corner`."""
    section = manifold3d().CrossSection
    corners = [(sx * (width / 2 - corner), sy * (height / 2 - corner)) for sx in (-1, 1) for sy in (-1, 1)]
    return section.batch_hull([section.circle(corner, 32).translate(centre) for centre in corners])


def slab(section, thickness: float, bottom: float = 0.0):
    """A 2-D section extruded `thickness` up from z = bottom."""
    return manifold3d().Manifold.extrude(section, thickness).translate((0.0, 0.0, bottom))
