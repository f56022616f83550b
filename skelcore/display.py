"""Numbers behind the inspector's pictures: a metric value for every point, and a camera that frames a cloud.

Metrics are measured on a fixed sample of the points of large clouds (see skelcore.metrics); to colour
every point, `values_for_all_points` gives each point the value of the nearest measured point of the
same iteration (a measured point keeps its own). `framing_camera` places a perspective camera along a
given viewing direction so that the object's bounding box fills a chosen share of the image.
`see_through_size` scales an original cloud's points down until its surface no longer hides what lies inside;
`display_origin` places a scene of float32 positions near the cloud.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .errors import ParameterError
from .io import as_points
from .metrics import IterationMetrics


@dataclass(frozen=True)
class PointValues:
    """One value per point of an iteration and how many of them were measured rather than carried."""
    values: np.ndarray  # (n,) finite wherever any measured point has a finite value
    measured: int  # points whose own value was computed
    carried: int  # points that took the value of their nearest measured point


def values_for_all_points(metrics: IterationMetrics, points: np.ndarray, quantity: str) -> PointValues:
    """Values of "d_theta" or "delta_kappa" for every row of `points` (the cloud `metrics` was evaluated on).

    Points outside the measured sample, and measured points whose neighbourhood collapsed (NaN), take
    the value of the nearest measured point with a finite value, in the current positions."""
    points = as_points(points, "points")
    if len(points) != metrics.n_present:
        raise ParameterError(f"points: {len(points)} rows, the metrics were evaluated on {metrics.n_present}")
    values = metrics.per_point(quantity)
    known = np.isfinite(values)
    missing = np.flatnonzero(~known)
    if len(missing) and known.any():
        sources = np.flatnonzero(known)
        _, nearest = cKDTree(points[sources]).query(points[missing], k=1)
        values[missing] = values[sources[nearest]]
    return PointValues(values, measured=int(known.sum()), carried=int(len(missing) if known.any() else 0))


@dataclass(frozen=True)
class Camera:
    """A perspective camera's pose."""
    position: np.ndarray  # (3,)
    look_at: np.ndarray  # (3,)
    rotation: np.ndarray  # (3,3) camera-to-world, columns: right, down, forward (OpenCV convention)


FRAMING_SAMPLE = 20_000  # points enough to find a cloud's projected extent
# A drawn point's diameter per spacing of the drawn points: about an eighth of a sampled surface covered, so a
# closed scan's front and back together leave most of the view through them open (at 0.6 spacings a bunny
# scan's points hid its skeleton; at 0.37 it shows, the surface still read as one).
SEE_THROUGH = 0.37
SPACING_SAMPLE = 20_000  # points whose spacing, scaled to the whole cloud, gives its spacing
SMALLEST_SIZE = 0.5  # of the default size: smaller points vanish at a window's scale


def see_through_size(points: np.ndarray, drawn_share: float, default_size: float) -> float:
    """The share of `default_size` (a point diameter, a fraction of the cloud's diagonal) at which a surface
    sampled by `points`, of which `drawn_share` are drawn, covers about SEE_THROUGH^2 of itself: SEE_THROUGH times
    the drawn points' median nearest-neighbour spacing, at most 1 (a sparse cloud keeps the default) and at least
    SMALLEST_SIZE, in steps of 0.1 (the inspector's size slider)."""
    points = as_points(points, "points")
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0)))
    if len(points) < 2 or diagonal <= 0 or not 0 < drawn_share <= 1 or default_size <= 0:
        return 1.0
    sample = points
    if len(points) > SPACING_SAMPLE:  # a surface's spacing goes as 1/sqrt(density): measured on a sample, scaled
        sample = points[np.random.default_rng(0).choice(len(points), SPACING_SAMPLE, replace=False)]
    gaps = cKDTree(sample).query(sample, k=2)[0][:, 1]
    spacing = float(np.median(gaps[gaps > 0])) if (gaps > 0).any() else 0.0
    drawn_spacing = spacing * math.sqrt(len(sample) / len(points) / drawn_share)
    share = SEE_THROUGH * drawn_spacing / (default_size * diagonal)
    return float(np.clip(round(share, 1), SMALLEST_SIZE, 1.0))


def display_origin(points: np.ndarray) -> np.ndarray:
    """(3,) where the scene's 0 sits in the coordinates of the cloud `points`: 0 itself, unless the cloud lies
    farther from it than its own size; then the centre of its bounding box. The scene holds float32 positions,
    whose steps are a ten-millionth of their magnitude: a tree trunk 0.3 m across in map coordinates (5e6 m) was
    drawn as a few lines of points, and at 1e18 the camera's position equalled the point it looked at."""
    low, high = points.min(axis=0), points.max(axis=0)
    centre = low / 2 + high / 2
    return centre if np.abs(centre).max() > np.abs(high / 2 - low / 2).max() * 2 else np.zeros(3)


CLIPPING = 1e3  # a camera's near and far planes, the cloud's diagonal over and times this
# The scene's up, by name: +Z as most scanners and CAD tools have it; glTF, and many graphics scans, have +Y
UP_AXES = {"+Z": (0.0, 0.0, 1.0), "+Y": (0.0, 1.0, 0.0), "+X": (1.0, 0.0, 0.0),
           "-Z": (0.0, 0.0, -1.0), "-Y": (0.0, -1.0, 0.0), "-X": (-1.0, 0.0, 0.0)}
DEFAULT_UP = "+Z"  # the up of a cloud whose format fixes none


def turned_up(direction, up) -> np.ndarray:
    """`direction`, given for a scene whose up is +Z, turned with the scene to one whose up is `up`: by the
    rotation of least angle taking +Z to `up` (Rodrigues' formula), half a turn about +X for -Z."""
    direction, up = np.asarray(direction, float), np.asarray(up, float) / np.linalg.norm(up)
    axis, cosine = np.cross((0.0, 0.0, 1.0), up), up[2]
    sine = np.linalg.norm(axis)
    if sine < 1e-12:
        return direction.copy() if cosine > 0 else direction * (1.0, -1.0, -1.0)
    axis /= sine
    return (direction * cosine + np.cross(axis, direction) * sine
            + axis * (axis @ direction) * (1.0 - cosine))


def clipping_planes(points: np.ndarray) -> tuple[float, float]:
    """(near, far) clipping distances for a camera on the cloud `points`: its diagonal / CLIPPING and x CLIPPING.
    A browser's camera clips at 0.01 and 1000 by default: a scan in millimetres 2 m long, framed from about its
    own size away, lay past the far plane and the view stayed blank."""
    diagonal = float(np.linalg.norm(np.ptp(points / 2, axis=0))) * 2 or 1.0  # halves: no overflow
    return diagonal / CLIPPING, diagonal * CLIPPING


def _checked(points: np.ndarray, fov: float, aspect: float, fill: float) -> np.ndarray:
    points = as_points(points, "points")
    if not (0 < fov < np.pi and aspect > 0 and 0 < fill <= 1):
        raise ParameterError(f"framing: need 0 < fov < pi, aspect > 0, 0 < fill <= 1 (got {fov}, {aspect}, {fill})")
    return points


def _axes(direction, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(right, down, forward) of a camera looking along `direction` with `up` up in the picture."""
    forward = np.asarray(direction, float)
    if not np.isfinite(forward).all() or np.linalg.norm(forward) == 0:
        forward = np.array([-0.7, 0.7, -0.5])
    forward = forward / np.linalg.norm(forward)
    up = np.asarray(up, float)
    right = np.cross(forward, up)
    if np.linalg.norm(right) < 1e-6 * np.linalg.norm(up):  # looking along `up`: any sideways axis will do
        right = np.cross(forward, np.eye(3)[np.argmin(np.abs(forward))])
    right /= np.linalg.norm(right)
    return right, np.cross(forward, right), forward


def framing_sample(points: np.ndarray) -> np.ndarray:
    """About FRAMING_SAMPLE of the points, evenly through them: what `framing_camera` finds their extent from."""
    return points[::max(1, len(points) // FRAMING_SAMPLE)]


def framing_camera(points: np.ndarray, direction, fov: float, aspect: float, fill: float,
                   up=(0.0, 0.0, 1.0), bottom: float = 0.0) -> Camera:
    """A camera looking along `direction` at the middle of the points' projected extent, as close as lets every
    point fit in `fill` of the image: the projected bounding box of the points spans `fill` of the image
    height or width, whichever binds. fov: vertical field of view in radians; aspect: width / height.
    bottom: the share of the image height at its foot that a panel covers; the points are framed in the rest."""
    points = _checked(points, fov, aspect, fill)
    if not 0 <= bottom < 1:
        raise ParameterError(f"framing: need 0 <= bottom < 1 (got {bottom})")
    low, high = points.min(axis=0), points.max(axis=0)
    centre = (low + high) / 2
    right, down, forward = _axes(direction, up)
    sample = framing_sample(points)
    half = np.tan(fov / 2)
    for _ in range(4):  # aim, then re-aim at the middle of the projected extent (near points look larger)
        local = sample - centre
        x, y, z = local @ right, local @ down, local @ forward
        # Pinhole: a point at depth D + z projects to x / ((D + z) tan(fov/2) aspect) of the half-width;
        # each point and axis gives the least distance D that keeps it inside `fill` (the tightest binds).
        distance = max(np.max(-z + np.abs(x) / (fill * half * aspect)),
                       np.max(-z + np.abs(y) / (fill * (1 - bottom) * half)))
        distance = max(distance, 1e-9 + np.max(-z))  # in front of every point
        u, v = x / (distance + z), y / (distance + z)
        centre = centre + distance * ((u.max() + u.min()) / 2 * right + (v.max() + v.min()) / 2 * down)
    # aim below the points' middle by half the covered share, so that they sit in the middle of the free part
    centre = centre + bottom * half * distance * down
    rotation = np.column_stack([right, down, forward])
    return Camera(centre - forward * distance, centre, rotation)

