"""A single view's normals signed to face its viewer.

A depth camera or one side of a scanner sees each surface point from the front, so a view's outward normals all
face one direction (exactly, seen orthographically; within the field of view, through a camera). The orientation
propagated along a spanning tree (skelcore.normals.orient_outward) turns whole parts of a view inward where the
tree crosses a gap or a crease, or the whole view where the flux about its centroid misleads (the benchmark's views
of a door pull, a stool and a footrest stool had all their normals inward, a cup and saucer's 58%, a coffee table's
50%), and the open space cannot set them right, as it lies on both sides of a view (skelcore.open_space).

Signing every PCA normal to face a direction d leaves neighbouring normals disagreeing only where they are seen
edge-on. In a view that is at its rim, where the surface ends; a closed surface goes on past its silhouette, so
every d leaves disagreements away from any rim. A cloud is taken as a view when, under the direction whose signing
leaves the fewest neighbours disagreeing, those that remain lie within RIM_HOPS of the rim. The viewer's side of
d is told by the rim too: seen edge-on, a surface curves away from the viewer behind its outline, so the rim's
outward directions point away from the viewer. A thin closed wall, whose two faces each sign alike and disagree
only at its folds, has folds turning both ways and is no view. A wall thinner than the sampling's spacing is one
sheet to the normals (a frying pan's wall, 0.3 thick, sampled 0.45 apart at 5,000 points, reads as a view), and
the lip of a container seen from above turns towards the viewer (a colander's view is signed from below).
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .neighbours import plane_basis, widest_gap

COARSE = 200  # view directions first tried, spread over the sphere (half of them: -d signs alike), 14 degrees apart
FINE = 3200  # directions over the sphere, 3.6 degrees apart, tried next where within REFINE of the best coarse one
REFINE = 15.0  # degrees
RIM_NEIGHBOURS = 16  # neighbours whose directions in a point's tangent plane tell whether it lies on the rim
RIM_GAP = 120.0  # degrees of a point's tangent plane its neighbours leave empty, at least, on the rim
RIM_HOPS = 2  # neighbour hops from a rim point within which a disagreement counts as the rim's
INNER_SHARE = 0.05  # disagreeing edges away from the rim per rim point, at most, in a view
AGREE = 0.5  # |cosine| between neighbours' normals above which their signs must agree
ALIGNED = 0.5  # cosine between a rim point's outward direction and the view direction that counts it as turning
ONE_SIDED = 3.0  # rim points turning away from the viewer per one turning towards it, more than, in a view
NOTE = ("read as a single view (the object seen from one side): its surface is taken to face the viewer where points "
        "are judged inside or outside the original")


def _directions(count: int) -> np.ndarray:
    """`count` unit directions spread evenly over the sphere (a golden-angle spiral)."""
    k = np.arange(count)
    z = 1.0 - (2 * k + 1) / count
    ring = np.sqrt(1.0 - z * z)
    angle = 2 * np.pi * k / ((1 + math.sqrt(5)) / 2)
    return np.c_[ring * np.cos(angle), ring * np.sin(angle), z]


def _fewest_disagreeing(normals: np.ndarray, relation: sp.csr_matrix, directions: np.ndarray) -> np.ndarray:
    """The direction d whose signing of `normals` leaves the fewest surface edges disagreeing: an edge agrees when
    its ends' d-signs relate as their normals do (relation: +1 where they agree, -1 where they are opposed)."""
    signs = np.where(normals @ directions.T >= 0, 1.0, -1.0).astype(np.float32)  # (points, directions)
    return directions[int(np.einsum("ij,ij->j", signs, relation @ signs).argmax())]


def _rim(points: np.ndarray, normals: np.ndarray, neighbours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rim, outward): whether each point's `neighbours` (kNN indices, itself first) leave at least RIM_GAP of its
    tangent plane empty, and the unit direction in that plane through the middle of the widest gap (off the
    surface's edge)."""
    gap, outward = widest_gap(points[neighbours[:, 1:]] - points[:, None], *plane_basis(normals))
    return gap >= math.radians(RIM_GAP), outward


def towards_viewer(points: np.ndarray, normals: np.ndarray, edges: tuple[np.ndarray, np.ndarray],
                   neighbours: np.ndarray) -> np.ndarray | None:
    """The unit direction towards the viewer if the cloud is a single view, else None. normals: unit PCA normals,
    NaN where a point has none; edges: (rows, cols) of the surface edges between neighbours
    (skelcore.normals.tangent_edges); neighbours: each point's RIM_NEIGHBOURS nearest (kNN indices, itself first;
    fewer in a smaller cloud)."""
    usable = np.nan_to_num(normals)
    rows, cols = edges
    cosines = np.einsum("ij,ij->i", usable[rows], usable[cols])
    binding = np.abs(cosines) > AGREE
    rows, cols, same = rows[binding], cols[binding], cosines[binding] > 0
    if not len(rows):
        return None
    relation = sp.csr_matrix((np.where(same, 1.0, -1.0).astype(np.float32), (rows, cols)), shape=(len(points),) * 2)
    coarse = _directions(COARSE)
    coarse = _fewest_disagreeing(usable, relation, coarse[coarse[:, 2] >= 0])
    fine = _directions(FINE)
    seen_along = _fewest_disagreeing(usable, relation,
                                     np.vstack([coarse, fine[fine @ coarse >= math.cos(math.radians(REFINE))]]))
    facing = usable @ seen_along >= 0
    disagree = (facing[rows] == facing[cols]) != same
    neighbours = neighbours[:, :RIM_NEIGHBOURS]
    rim, outward = _rim(points, usable, neighbours)
    near_rim = rim.copy()
    for _ in range(RIM_HOPS):
        near_rim = near_rim[neighbours].any(axis=1)
    inner = np.count_nonzero(disagree & ~near_rim[rows] & ~near_rim[cols])
    if inner > INNER_SHARE * np.count_nonzero(rim):
        return None
    # A view's rim turns away from its viewer; a thin closed wall's folds turn both ways.
    along = outward[rim] @ seen_along
    away, towards = np.count_nonzero(along < -ALIGNED), np.count_nonzero(along > ALIGNED)
    if away > ONE_SIDED * towards:
        return seen_along
    if towards > ONE_SIDED * away:
        return -seen_along
    return None


def with_note(notes: list[str], inside) -> list[str]:
    """A cloud's `notes` with NOTE added where its inside test (skelcore.inside.InsideTest, or None) read it as a
    single view and they do not say so yet."""
    return [*notes, NOTE] if inside is not None and inside.single_view and NOTE not in notes else list(notes)


def facing_viewer(points: np.ndarray, normals: np.ndarray, edges: tuple[np.ndarray, np.ndarray],
                  neighbours: np.ndarray) -> np.ndarray | None:
    """`normals` (NaN where none) signed to face the viewer if the cloud is a single view (towards_viewer), else
    None."""
    viewer = towards_viewer(points, normals, edges, neighbours)
    return None if viewer is None else normals * np.where(normals @ viewer < 0, -1.0, 1.0)[:, None]
