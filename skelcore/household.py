"""Household objects and hardware for `skelcore bench-quality --parts`, beside skelcore.parts: twelve more closed
manifold3d solids from a third probe of objects the benchmark did not hold (2026-12-06), each with its genus in
its description. Bulky bodies with a handle (a kettlebell, a watering can), thin-walled vessels with loop handles
(a cooking pot, a frying pan with a hanging hole), flat plates with holes or slots (a bottle opener, a belt
buckle, a picture frame, a trivet, a bent sheet-metal bracket), thin rings on a plate or a post (a ring binder, a
towel ring) and a pair of pliers. Eight more from a fourth probe (2026-12-07): hardware loops (a padlock, a
carabiner), a coil spring, a frame of bars (a cube's twelve edges), a stool with a footrest ring, headphones, and
parallel prongs a few point spacings apart (a table fork, a comb), which noise bridges. A stapler from a sixth
probe (2026-12-07): an arm over a base, the slot between them closed at the hinge, open at three sides and a few
point spacings wide. Four from a seventh probe the same day: a jug and a teapot (bulky bodies with loop handles,
which a single view barely sees where they join), an office chair (its backrest's opening, the backrest a little
behind the seat) and a hand grip (an open coil whose turns lie closer than the skeleton resolves). Units:
centimetres.
"""
from __future__ import annotations

import numpy as np

from .solid_blocks import (SEGMENTS, arc_points, box, cylinder, manifold3d, rod, rounded_rectangle, slab, sphere,
                           stadium, torus, tube_along, union)


def kettlebell():
    """A ball of radius 10 flattened to stand, a bar of radius 1.8 bent on an arc of radius 7.5 over it."""
    ball = sphere(10.0).trim_by_plane((0.0, 0.0, 1.0), -8.5)
    return union([ball, tube_along(arc_points((0.0, 0.0, 9.0), 7.5, -20.0, 200.0, "xz", 45), 1.8)])


def watering_can():
    """A closed body of radius 8, 18 high, an arched handle (tube 0.8) from its top to its back, and a spout
    tapering from radius 0.9 to 0.5 with a rose."""
    spout_end = np.array([17.5, 0.0, 19.0])
    along = np.array([12.5, 0.0, 16.0]) / np.hypot(12.5, 16.0)
    return union([cylinder(18.0, 8.0, (0.0, 0.0, 9.0)),
                   tube_along(arc_points((-6.0, 0.0, 14.0), 6.0, 20.0, 260.0, "xz", 45), 0.8),
                   rod((5.0, 0.0, 3.0), spout_end, 0.9, 0.5),
                   rod(spout_end - 0.2 * along, spout_end + 1.5 * along, 0.5, 1.6)])


def cooking_pot():
    """A pot of radius 10, 12 high, wall 0.25 with a rolled rim, two loop handles of wire 0.35 reaching 3 out."""
    m3d = manifold3d()
    body = m3d.Manifold.revolve(m3d.CrossSection([[(0.0, 0.0), (10.0, 0.0), (10.0, 12.0), (9.75, 12.0),
                                                   (9.75, 0.35), (0.0, 0.35)]]), 2 * SEGMENTS)
    handles = [tube_along(np.r_[[[9.45, -3.0, 9.0]], arc_points((10.0, 0.0, 9.0), 3.0, -90.0, 90.0, "xy", 25),
                           [[9.45, 3.0, 9.0]]] * [side, 1.0, 1.0], 0.35) for side in (-1.0, 1.0)]
    return union([body, torus(9.875, 0.3).translate((0.0, 0.0, 12.0)), *handles])


def bottle_opener():
    """A tapered plate 11 long and 0.2 thick with a slot 2 x 1 near its wide end."""
    return slab(stadium(0.0, 9.5, 1.6, 1.1) - stadium(-0.5, 0.5, 0.5), 0.2)


def belt_buckle():
    """A rounded frame 6 x 5 of bars 0.6 wide and 0.35 thick with a centre bar, and a prong (rod 0.12) over one
    opening."""
    frame = (rounded_rectangle(6.0, 5.0, 0.6) - rounded_rectangle(4.8, 3.8, 0.2)
             + manifold3d().CrossSection.square((0.6, 4.4), True))
    return union([slab(frame, 0.35), rod((-0.1, 0.0, 0.2), (2.0, 0.0, 0.42), 0.12), sphere(0.12, (2.0, 0.0, 0.42))])


def picture_frame():
    """A moulding 3 wide and 1.8 thick round a 24 x 19 opening, a rebate 0.5 wide and 0.8 deep at its back."""
    square = manifold3d().CrossSection.square
    return slab(square((30.0, 25.0), True) - square((24.0, 19.0), True), 1.8) - slab(square((25.0, 20.0), True),
                                                                                       0.8, -0.01)


def trivet():
    """A plate 18 x 18 x 0.6 with a 3 x 3 grid of 4.6 x 4.6 holes, on four feet."""
    square = manifold3d().CrossSection.square
    plate = square((18.0, 18.0), True)
    for i in (-1, 0, 1):
        for j in (-1, 0, 1):
            plate = plate - square((4.6, 4.6), True).translate((5.6 * i, 5.6 * j))
    feet = [cylinder(1.05, 0.8, (sx * 8.0, sy * 8.0, -0.5)) for sx in (-1, 1) for sy in (-1, 1)]
    return union([slab(plate, 0.6), *feet])


def sheet_bracket():
    """Two legs 8 x 5 of sheet 0.2 thick bent at a right angle (inner radius 0.3), a slot 3 x 0.7 in each."""
    m3d = manifold3d()
    thickness, bend = 0.2, 0.3
    leg = m3d.CrossSection.square((8.0, 5.0)).translate((0.0, -2.5)) - stadium(2.5, 5.5, 0.35)
    base = slab(leg, thickness).translate((bend + thickness, 0.0, 0.0))
    wall = slab(leg, thickness).rotate((0.0, -90.0, 0.0)).translate((thickness, 0.0, bend + thickness))
    corner = m3d.Manifold.revolve(m3d.CrossSection.square((thickness, 5.0)).translate((bend, -2.5)), SEGMENTS, 90.0)
    corner = corner.rotate((90.0, 0.0, 0.0)).rotate((0.0, 180.0, 0.0)).translate((bend + thickness, 0.0,
                                                                                   bend + thickness))
    return union([base, wall, corner])


def frying_pan():
    """A pan flaring from radius 9 to 12, wall 0.3, and a flat handle 18 x 2.6 x 0.8 with a hanging hole of radius
    0.7."""
    m3d = manifold3d()
    pan = m3d.Manifold.revolve(m3d.CrossSection([[(0.0, 0.0), (9.0, 0.0), (12.0, 4.5), (11.7, 4.5), (8.85, 0.4),
                                                  (0.0, 0.4)]]), 2 * SEGMENTS)
    handle = stadium(11.1, 28.0, 1.3) - m3d.CrossSection.circle(0.7, SEGMENTS).translate((26.6, 0.0))
    return union([pan, slab(handle, 0.8, 3.1)])


def ring_binder():
    """A plate 25 x 3.2 x 0.2 with three rings (radius 1.5, wire 0.12) standing on it."""
    rings = [torus(1.5, 0.12).rotate((0.0, 90.0, 0.0)).translate((x, 0.0, 1.58)) for x in (-10.8, 0.0, 10.8)]
    return union([box((25.0, 3.2, 0.2), (0.0, 0.0, 0.1)), *rings])


def towel_ring():
    """A wall rosette (a disc of radius 3, 1 thick), a post 4.5 long with a knuckle, and a ring of radius 8 (tube
    0.45) hanging from it."""
    return union([cylinder(1.0, 3.0, (0.0, 0.0, 0.0), (90.0, 0.0, 0.0)), rod((0.0, 0.0, 0.0), (0.0, 4.5, 0.0), 0.6),
                   sphere(0.9, (0.0, 4.5, 0.0)),
                   torus(8.0, 0.45).rotate((90.0, 0.0, 0.0)).translate((0.0, 4.5, -8.0))])


def pliers():
    """Pliers 20 long: two bars crossing at a rivet, open jaws and handles with grip sleeves."""
    parts = [cylinder(1.3, 1.0)]
    for side in (-1.0, 1.0):
        z = 0.2 * side
        parts += [tube_along([(-6.0, 0.6 * side, z), (-3.0, 0.35 * side, z), (0.0, 0.0, z)], [0.35, 0.45, 0.5]),
                  tube_along([(0.0, 0.0, z), (4.0, -0.9 * side, z), (6.0, -1.3 * side, z)], 0.4),
                  tube_along([(6.0, -1.3 * side, z), (14.0, -2.5 * side, z)], 0.7)]
    return union(parts)


def padlock():
    """A body 5 x 2 x 4.2 (rounded in plan) and a shackle of rod 0.4, an inverted U 2.6 wide inside, its top 3 above
    the body and both legs sunk 1.2 into it."""
    leg, top = 1.7, 7.2
    shackle = np.r_[[[-leg, 0.0, 3.0]], arc_points((0.0, 0.0, top - leg), leg, 180.0, 0.0, "xz", 25), [[leg, 0.0, 3.0]]]
    return union([slab(rounded_rectangle(5.0, 2.0, 0.4), 4.2), tube_along(shackle, 0.4)])


def carabiner():
    """A loop of rod 0.5, 10 x 6, in the xy plane: a straight spine, round ends, and a gate of rod 0.4 between a
    hinge knob (0.55) and a nose knob (0.6)."""
    return union([tube_along(arc_points((2.0, 0.0, 0.0), 3.0, -90.0, 90.0, "xy", 25), 0.5),
                  tube_along(arc_points((-2.0, 0.0, 0.0), 3.0, 90.0, 270.0, "xy", 25), 0.5),
                  tube_along([(-2.0, -3.0, 0.0), (2.0, -3.0, 0.0)], 0.5),
                  tube_along([(-2.0, 3.0, 0.0), (-1.6, 3.0, 0.0)], 0.5),
                  tube_along([(-1.6, 3.05, 0.0), (1.6, 3.05, 0.0)], 0.4),
                  sphere(0.55, (-1.6, 3.0, 0.0)), sphere(0.6, (1.7, 3.0, 0.0))])


def coil_spring():
    """Six turns of wire 0.15 on a coil of radius 1.2, pitch 1.2 (0.9 between turns), open ends."""
    turn = np.linspace(0.0, 12 * np.pi, 6 * 36 + 1)
    return tube_along(np.c_[1.2 * np.cos(turn), 1.2 * np.sin(turn), 1.2 * turn / (2 * np.pi)], 0.15)



def table_fork():
    """A fork 19 long, 0.25 thick: a handle tapering 1.6 -> 0.6 wide, a head 2.5 wide bent up 10 degrees, four
    tines 0.36 wide and 3.8 long, 0.35 apart."""
    section = manifold3d().CrossSection
    handle = section.batch_hull([section.circle(0.8, 48).translate((-10.2, 0.0)),
                                 section.circle(0.3, 48).translate((0.0, 0.0))])
    head = section([[(-0.2, -0.3), (0.8, -1.25), (3.0, -1.25), (3.0, 1.25), (0.8, 1.25), (-0.2, 0.3)]])
    tines = [section.square((3.8, 0.36)).translate((3.0, -1.25 + k * 0.713)) for k in range(4)]
    front = slab(section.batch_boolean([head, *tines], manifold3d().OpType.Add), 0.25).rotate((0.0, -10.0, 0.0))
    return union([slab(handle, 0.25), front])


def comb():
    """A pocket comb: a spine 15 x 1, 0.3 thick, and 24 teeth 0.25 wide, 2.2 long and 0.25 thick, 0.39 apart."""
    section = manifold3d().CrossSection
    teeth = [section.square((0.25, 2.3)).translate((-7.47 + k * 14.69 / 23, -2.2)) for k in range(24)]
    return union([slab(section.square((15.0, 1.0)).translate((-7.5, 0.0)), 0.3),
                  slab(section.batch_boolean(teeth, manifold3d().OpType.Add), 0.25, 0.025)])


def cube_frame():
    """The twelve edges of a cube 10 across as square bars 0.8 thick."""
    bars = []
    for axis in range(3):
        across = [other for other in range(3) if other != axis]
        for first in (-5.0, 5.0):
            for second in (-5.0, 5.0):
                size, centre = [0.8, 0.8, 0.8], [0.0, 0.0, 0.0]
                size[axis], centre[across[0]], centre[across[1]] = 10.8, first, second
                bars.append(box(tuple(size), tuple(centre)))
    return union(bars)


def footrest_stool():
    """A bar stool 48 high: a seat of radius 16, 3 thick, on four legs (rod 1.2) splayed from radius 11 under it to
    15 at the floor, and a footrest ring (tube 0.9) through the legs 16 up."""
    corners = np.pi / 4 + np.pi / 2 * np.arange(4)
    directions = np.c_[np.cos(corners), np.sin(corners), np.zeros(4)]
    legs = [rod(15.0 * d, 11.0 * d + (0.0, 0.0, 45.5), 1.2) for d in directions]
    return union([cylinder(3.0, 16.0, (0.0, 0.0, 46.5)), *legs,
                  torus(15.0 - 4.0 * 16.0 / 45.0, 0.9).translate((0.0, 0.0, 16.0))])


def stapler():
    """A desk stapler 16 long: a base 16 x 4 x 1.2, an arm 15 x 3.6 x 2.2 over it tilted down to a hinge block at
    the back, the slot under the arm narrowing from 0.9 at the front to 0.4 at the hinge."""
    base = slab(rounded_rectangle(16.0, 4.0, 1.0), 1.2)
    tilt = np.degrees(np.arctan2(0.5, 12.5))
    arm = slab(rounded_rectangle(15.0, 3.6, 1.0), 2.2).translate((0.5, 0.0, -1.1)).rotate((0.0, -tilt, 0.0))
    return union([base, arm.translate((0.0, 0.0, 2.95)), box((3.0, 3.0, 1.6), (-6.3, 0.0, 1.9))])


def jug():
    """A water jug 21 high: a closed body of revolution (radius 6 at the base, 7.5 at the belly, 5 at the neck)
    and a loop handle of tube 1.0 on one side, its opening about 4 x 9."""
    profile = [(0.0, 0.0), (6.0, 0.0), (7.3, 4.0), (7.5, 8.0), (6.8, 13.0), (5.4, 17.0), (5.0, 19.5), (5.2, 21.0),
               (0.0, 21.0)]
    body = manifold3d().Manifold.revolve(manifold3d().CrossSection([profile]), 96)
    angle = np.radians(np.linspace(80.0, -80.0, 30))
    arc = np.c_[-6.0 - 5.0 * np.cos(angle), np.zeros(30), 10.5 + 6.0 * np.sin(angle)]
    return union([body, tube_along(np.r_[[(-4.5, 0.0, 16.4)], arc, [(-5.5, 0.0, 4.6)]], 1.0)])


def teapot():
    """A teapot 17 high: a squat body (an ellipsoid 18 x 18 x 14 cut flat at its foot), a lid with a knob, a loop
    handle of tube 0.9 and a solid spout tapering from radius 1.4 to 0.6."""
    body = sphere(1.0).scale((9.0, 9.0, 7.0)).translate((0.0, 0.0, 7.5)) - box((30.0, 30.0, 2.0))
    lid = cylinder(1.0, 4.5, (0.0, 0.0, 14.2)) + sphere(1.2, (0.0, 0.0, 15.8))
    angle = np.radians(np.linspace(70.0, -70.0, 30))
    arc = np.c_[-8.0 - 4.5 * np.cos(angle), np.zeros(30), 8.0 + 5.0 * np.sin(angle)]
    handle = tube_along(np.r_[[(-5.0, 0.0, 12.7)], arc, [(-7.0, 0.0, 3.3)]], 0.9)
    along = np.linspace(0.0, 1.0, 20)
    spout = tube_along(np.c_[6.5 + 9.0 * along, np.zeros(20), 4.5 + 10.0 * along ** 1.6], 1.4 - 0.8 * along)
    return union([body, lid, handle, spout])


def office_chair():
    """An office chair 112 high: a five-star base on castors, a gas column, a seat 48 x 46 x 8 and, 2 behind it
    on a bar, a backrest 44 x 50 x 4 with a lumbar opening 24 x 8."""
    parts = [cylinder(6.0, 4.0, (0.0, 0.0, 10.0)), rod((0.0, 0.0, 10.0), (0.0, 0.0, 47.0), 2.5)]
    for degrees in np.arange(5) * 72.0:
        x, y = 29.0 * np.cos(np.radians(degrees)), 29.0 * np.sin(np.radians(degrees))
        parts += [box((30.0, 4.0, 3.0), (15.0, 0.0, 0.0)).rotate((0.0, 0.0, degrees)).translate((0.0, 0.0, 9.0)),
                  rod((x, y, 9.0), (x, y, 4.5), 0.8), cylinder(2.0, 2.5, (x, y, 2.5), (90.0, 0.0, degrees))]
    seat = slab(rounded_rectangle(48.0, 46.0, 6.0), 8.0, 46.0)
    bar = [box((4.0, 6.0, 2.0), (-24.0, 0.0, 47.0)), box((2.0, 6.0, 16.0), (-25.5, 0.0, 54.0))]
    back = box((4.0, 44.0, 50.0), (-28.0, 0.0, 86.0)) - box((10.0, 24.0, 8.0), (-28.0, 0.0, 70.0))
    return union([*parts, seat, *bar, back])


def hand_grip():
    """A hand-grip exerciser 18 high: two handles (rod 1.3, 10 long) on wire legs (0.25) from a torsion coil of
    2.5 turns (radius 1, pitch 0.7: the turns 0.2 apart, not touching), an open coil."""
    turn = np.linspace(0.0, 5.0 * np.pi, 161)
    coil = np.c_[np.cos(turn), 0.7 * turn / (2.0 * np.pi) - 0.875, 15.0 + np.sin(turn)]
    legs = [[coil[0], (4.0, coil[0, 1], 9.0), (4.0, 0.0, 6.0), (4.0, 0.0, 3.0)],
            [coil[-1], (-4.0, coil[-1, 1], 9.0), (-4.0, 0.0, 6.0), (-4.0, 0.0, 3.0)]]
    return union([tube_along(coil, 0.25), *(tube_along(leg, 0.25) for leg in legs),
                  *(rod((x, 0.0, -5.0), (x, 0.0, 5.0), 1.3) for x in (4.0, -4.0))])


def headphones():
    """A headband 3 wide, 0.6 thick, on an arc of radius 9 over the top with a pad under it, and on a single post
    (rod 0.5) at each end an ear cup (a disc of radius 4.5, 3 thick, a cushion ring on its inner face)."""
    m3d = manifold3d()
    band = m3d.Manifold.revolve(m3d.CrossSection.square((0.6, 3.0)).translate((9.0, -1.5)), 96, 200.0)
    pad = m3d.Manifold.revolve(m3d.CrossSection.square((0.9, 2.4)).translate((8.2, -1.2)), 64, 80.0)
    parts = [band.rotate((0.0, 0.0, -10.0)).rotate((90.0, 0.0, 0.0)),
             pad.rotate((0.0, 0.0, 50.0)).rotate((90.0, 0.0, 0.0))]
    end_x, end_z = 9.3 * np.cos(np.radians(-10.0)), 9.3 * np.sin(np.radians(-10.0))
    for side in (-1.0, 1.0):
        parts += [rod((side * end_x, 0.0, end_z + 0.5), (side * end_x, 0.0, -4.0), 0.5),
                  cylinder(3.0, 4.5, (side * 8.4, 0.0, -8.0), (0.0, 90.0, 0.0)),
                  torus(3.5, 1.0).rotate((0.0, 90.0, 0.0)).translate((side * 6.2, 0.0, -8.0))]
    return union(parts)


# name -> (builder, ends where the shape fixes them, description with its genus), as skelcore.parts.PARTS
HOUSEHOLD = {
    "kettlebell": (kettlebell, None, "ball with a thick bar handle (genus 1)"),
    "watering_can": (watering_can, 1, "closed can with an arched handle and a spout (genus 1)"),
    "cooking_pot": (cooking_pot, None, "pot with a 0.25 wall and two wire loop handles (genus 2)"),
    "bottle_opener": (bottle_opener, None, "plate 0.2 thick with a slot (genus 1)"),
    "belt_buckle": (belt_buckle, 1, "flat frame with a centre bar and a prong (genus 2)"),
    "picture_frame": (picture_frame, 0, "flat moulding round an opening (genus 1)"),
    "trivet": (trivet, None, "plate 0.6 thick with a 3 x 3 grid of holes, on feet (genus 9)"),
    "sheet_bracket": (sheet_bracket, None, "sheet 0.2 thick bent at a right angle, a slot in each leg (genus 2)"),
    "frying_pan": (frying_pan, None, "pan with a flat handle, its hanging hole below the skeleton's resolution "
                                     "(genus 1)"),
    "ring_binder": (ring_binder, None, "plate with three thin rings standing on it (genus 3)"),
    "towel_ring": (towel_ring, 1, "ring hanging from a post on a wall rosette (genus 1)"),
    "pliers": (pliers, 4, "two crossing bars at a rivet"),
    "padlock": (padlock, None, "body with a shackle (genus 1)"),
    "carabiner": (carabiner, None, "loop of rod with a gate between two knobs (genus 1)"),
    "coil_spring": (coil_spring, 2, "six turns of thin wire"),
    "table_fork": (table_fork, 5, "flat fork, its four tines 0.35 apart"),
    "comb": (comb, 24, "spine with 24 teeth 0.39 apart"),
    "cube_frame": (cube_frame, 0, "the twelve edges of a cube as bars (genus 5)"),
    "footrest_stool": (footrest_stool, None, "seat on four splayed legs joined by a footrest ring (genus 4)"),
    "headphones": (headphones, None, "headband with an ear cup on a post at each end"),
    "stapler": (stapler, None, "arm over a base, the slot between them a few spacings wide, closed at the hinge"),
    "jug": (jug, None, "bulky body with a loop handle (genus 1)"),
    "teapot": (teapot, None, "squat body with a loop handle, a spout and a lid's knob (genus 1)"),
    "office_chair": (office_chair, None, "five-star base, seat, and 2 behind it a backrest with an opening (genus 1)"),
    "hand_grip": (hand_grip, None, "two handles on the legs of an open coil whose turns are 0.2 apart"),
}
