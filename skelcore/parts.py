"""Everyday parts outside the quality benchmark's default shapes: tools, hardware and household objects built
with manifold3d, each closed, its genus read from its mesh like the benchmark's solids (skelcore.solids).

They are the shapes a user brings that no default benchmark shape stands for: flat plates with holes (wrench, key,
L-bracket), hardware rings of every height (nut, washer, pipe), frames of thin rods (glasses, ladder, wheel),
bodies with limbs (octopus, star) and plain primitives (capsule, pin, box). `skelcore bench-quality --parts` runs
them; they stay out of the default grid and of `skelcore study`, whose calibration halves they would move.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

SEGMENTS = 64  # facets around every circle of a part or solid (skelcore.solids): sampling sees no facets


def _m3d():
    import manifold3d

    return manifold3d


def _cylinder(height: float, radius: float, centre=(0.0, 0.0, 0.0), turn=(0.0, 0.0, 0.0), segments: int = SEGMENTS):
    """A cylinder along z, centred, turned by `turn` degrees about x, y, z, then moved."""
    solid = _m3d().Manifold.cylinder(height, radius, radius, segments, True)
    return solid.rotate(turn).translate(centre)


def _box(size, centre=(0.0, 0.0, 0.0)):
    return _m3d().Manifold.cube(size, True).translate(centre)


def _ring(major: float, minor: float):
    """A ring of radius `major` and tube `minor` in the xz plane (it stands up)."""
    m3d = _m3d()
    return m3d.Manifold.revolve(m3d.CrossSection.circle(minor, SEGMENTS).translate((major, 0.0)), SEGMENTS).rotate(
        (90.0, 0.0, 0.0))


def _plate_ring(outer: float, inner: float, thickness: float, centre=(0.0, 0.0, 0.0)):
    """A flat ring (a washer) lying in the xy plane."""
    return (_cylinder(thickness, outer) - _cylinder(2 * thickness, inner)).translate(centre)


def _union(parts):
    m3d = _m3d()
    return m3d.Manifold.batch_boolean(list(parts), m3d.OpType.Add)


def wrench():
    """A flat spanner: a handle with a closed ring at one end and an open jaw (two prongs) at the other."""
    thickness = 0.12
    jaw = _plate_ring(0.45, 0.22, thickness, (-1.75, 0.0, 0.0)) - _box((0.8, 0.36, 1.0), (-2.15, 0.0, 0.0))
    return _union([_box((3.0, 0.3, thickness)), _plate_ring(0.45, 0.25, thickness, (1.75, 0.0, 0.0)), jaw])


def key():
    """A flat key: a bow with a hole and a straight blade."""
    thickness = 0.15
    return _plate_ring(0.6, 0.25, thickness) + _box((2.5, 0.25, thickness), (1.8, 0.0, 0.0))


def glasses():
    """Two upright rims joined by a bridge, and two temples reaching back."""
    rim = _ring(0.6, 0.06)
    parts = [rim.translate((-0.75, 0.0, 0.0)), rim.translate((0.75, 0.0, 0.0)),
             _cylinder(0.5, 0.05, (0.0, 0.0, 0.1), (0.0, 90.0, 0.0))]
    parts += [_cylinder(1.6, 0.05, (x, 0.8, 0.1), (90.0, 0.0, 0.0)) for x in (-1.35, 1.35)]
    return _union(parts)


def hex_nut():
    """A hexagonal nut 1 across its flats and 0.5 high with a bore of radius 0.3."""
    return _cylinder(0.5, 1.0 / np.sqrt(3.0), segments=6) - _cylinder(1.0, 0.3)


def tube(height: float, outer: float = 1.0, inner: float = 0.85):
    """A round tube (a washer when low, a pipe when tall) with a wall of outer - inner."""
    return _cylinder(height, outer) - _cylinder(height + 1.0, inner)


def l_bracket():
    """Two plates 2 x 1 x 0.15 at a right angle, a bolt hole through each."""
    thickness = 0.15
    plates = _box((2.0, 1.0, thickness), (0.0, 0.0, thickness / 2)) + _box((2.0, thickness, 1.0),
                                                                          (0.0, -0.5 + thickness / 2, 0.5))
    holes = _cylinder(1.0, 0.18, (-0.5, 0.1, 0.0)) + _cylinder(1.0, 0.18, (0.5, -0.5, 0.55), (90.0, 0.0, 0.0))
    return plates - holes


def sugar_bowl():
    """A cup with an open cavity (walls 0.1 thick) and a ring handle on each side."""
    body = _cylinder(1.1, 0.5, (0.0, 0.0, 0.55)) - _cylinder(1.1, 0.4, (0.0, 0.0, 0.67))
    handles = _ring(0.3, 0.08).translate((0.5, 0.0, 0.55)) + _ring(0.3, 0.08).translate((-0.5, 0.0, 0.55))
    return body + (handles - _cylinder(1.1, 0.45, (0.0, 0.0, 0.55)))


def ladder():
    """Two rails 4 long and four rungs between them."""
    rails = [_cylinder(4.0, 0.06, (x, 0.0, 0.0)) for x in (-0.5, 0.5)]
    rungs = [_cylinder(1.0, 0.05, (0.0, 0.0, z), (0.0, 90.0, 0.0)) for z in (-1.2, -0.4, 0.4, 1.2)]
    return _union(rails + rungs)


def spoked_wheel(spokes: int = 3):
    """A rim with a hub and `spokes` spokes, lying in the xy plane."""
    parts = [_ring(1.0, 0.06).rotate((-90.0, 0.0, 0.0)), _cylinder(0.2, 0.15)]
    parts += [_cylinder(1.0, 0.04, (0.5, 0.0, 0.0), (0.0, 90.0, 0.0)).rotate((0.0, 0.0, 360.0 * k / spokes))
              for k in range(spokes)]
    return _union(parts)


def capsule():
    """A pill: a cylinder 2 long of radius 0.3 with round ends."""
    ball = _m3d().Manifold.sphere(0.3, SEGMENTS)
    return _union([_cylinder(2.0, 0.3), ball.translate((0.0, 0.0, 1.0)), ball.translate((0.0, 0.0, -1.0))])


def star(arms: int = 5):
    """A small ball with `arms` straight arms 1 long in one plane."""
    parts = [_m3d().Manifold.sphere(0.18, SEGMENTS)]
    parts += [_cylinder(1.0, 0.12, (0.5, 0.0, 0.0), (0.0, 90.0, 0.0)).rotate((0.0, 0.0, 360.0 * k / arms))
              for k in range(arms)]
    return _union(parts)


def octopus(arms: int = 8):
    """A ball of radius 1 with `arms` tapering tentacles 1.8 long pointing out and down."""
    parts = [_m3d().Manifold.sphere(1.0, SEGMENTS)]
    for k in range(arms):
        tentacle = _m3d().Manifold.cylinder(1.8, 0.2, 0.05, SEGMENTS, False).translate((0.0, 0.0, 0.8))
        parts.append(tentacle.rotate((0.0, 120.0, 0.0)).rotate((0.0, 0.0, 360.0 * k / arms)))
    return _union(parts)


# name -> (builder, ends of a correct skeleton or None when the shape does not fix them, description)
PARTS: dict[str, tuple[Callable, int | None, str]] = {
    "wrench": (wrench, 2, "flat spanner: a ring end and an open jaw (genus 1)"),
    "key": (key, 1, "flat key: a bow with a hole and a blade (genus 1)"),
    "glasses": (glasses, 2, "two rims, a bridge and two temples (genus 2)"),
    "hex_nut": (hex_nut, 0, "hexagonal nut (genus 1)"),
    "washer": (lambda: tube(0.3), 0, "round tube 0.3 high, radius 1, wall 0.15 (genus 1)"),
    "pipe": (lambda: tube(2.0), 0, "round tube 2 high, radius 1, wall 0.15 (genus 1)"),
    "l_bracket": (l_bracket, None, "two plates at a right angle, a bolt hole in each (genus 2)"),
    "sugar_bowl": (sugar_bowl, None, "cup with a ring handle on each side (genus 2)"),
    "ladder": (ladder, 4, "two rails and four rungs (genus 3)"),
    "spoked_wheel": (spoked_wheel, 0, "rim, hub and three spokes (genus 3)"),
    "capsule": (capsule, 2, "pill: a cylinder with round ends"),
    "pin": (lambda: _cylinder(4.0, 0.1), 2, "round rod 4 long of radius 0.1"),
    "box": (lambda: _box((2.0, 1.0, 0.6)), None, "box 2 x 1 x 0.6"),
    "star": (star, 5, "small ball with five arms in a plane"),
    "octopus": (octopus, 8, "ball with eight tapering tentacles"),
}
