"""Whether a cloud's coordinates can be computed with, and at what scale.

A shape is computed in float64 at a power-of-two scale (exact), so that the engine's floors and the squares and
cubes of its distances stay far from underflow and overflow; coordinates too coarse for the shape's extent
(float64 at a far offset, or float32 as PLY and STL files store them) and points on one line are refused.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError
from .normalise import SAMPLE_RADIUS, binary_unit, bounds, object_core, object_diagonal

# A cloud whose core (normalise.object_core) spans less than 1/EXTREME, or whose coordinates reach EXTREME, is
# computed at an exact power-of-two scale that brings the core's extent to about 1: the engine's floors
# (1e-300, 1e-12 of a norm) and its squares and cubes of distances then stay far from underflow and overflow.
# A point more than EXTREME core extents from the core is refused: no scale keeps it and the core in that range.
EXTREME = 2.0 ** 64
MIN_STEPS = 4096  # float64 steps the core's extent must span at its coordinates (fewer: a coarse grid of values)


def computed_scale(points: np.ndarray, name: str) -> tuple[np.ndarray, float]:
    """The points at the power-of-two scale they are computed at (see EXTREME), and that scale; or an InputError
    when the shape cannot be computed: its core (the object without far strays, which cleaning removes) is
    too small for float64 at its coordinates, or lies on one line, or a point lies absurdly far from it."""
    magnitude = float(np.abs(points).max())
    # near float64's end its margins could overflow: judged at magnitude ~1 then, which changes no comparison
    inside = object_core(points if magnitude < EXTREME else points / binary_unit(magnitude))
    core = points if inside is None else points[inside]
    low, high = bounds(core)
    half, place = float(np.max(high / 2 - low / 2)), float(np.abs(core).max())  # halves: no overflow
    steps = 2 * half / float(np.spacing(place))
    if steps < MIN_STEPS:
        raise InputError(f"{name}: the cloud's extent is too small: it spans {2 * half:.3g} at coordinates of "
                         f"magnitude {place:.3g}, which float64 resolves in only {steps:,.0f} steps "
                         f"(at least {MIN_STEPS:,} are needed)")
    resolution = float(np.spacing(place))
    if _float32_values(core):  # stored as float32 (a PLY's `float`, every STL): rounded to float32's steps
        resolution = float(np.spacing(np.float32(place)))
        _check_float32_steps(name, resolution, place, object_diagonal(core), (low / 2 + high / 2))
    if inside is not None:  # strays: how far from the core (in halves, as the extent)
        strays = points[~inside]
        reach = np.abs(strays / 2 - (low / 2 + high / 2) / 2).max(axis=1)
        if reach.max() > EXTREME * half:
            far, count = int(np.argmax(reach)), int((reach > EXTREME * half).sum())
            which = "a point lies" if count == 1 else f"{count} points lie, the farthest"
            ratio = float(reach[far]) / half
            times = f"{ratio:.3g} times" if np.isfinite(ratio) else "more times than float64 counts"
            raise InputError(f"{name}: {which} absurdly far from the rest of the cloud: at "
                             f"({', '.join(f'{value:.3g}' for value in strays[far])}), "
                             f"{times} the extent of the rest; remove "
                             f"{'it' if count == 1 else 'them'} from the file")
    scale = 1.0
    if half < 0.5 / EXTREME or magnitude >= EXTREME:
        scale = binary_unit(half)
        points, core = points / scale, core / scale  # exact: a power of two
    if on_one_line(core, resolution / scale):
        raise InputError(f"{name}: all points lie on one line; a surface is needed")
    return points, scale


def on_one_line(points: np.ndarray, resolution: float = 0.0) -> bool:
    """Whether the points lie on one line: across it they spread less than a billionth of their length, or no
    more (RMS) than `resolution`, the rounding of their coordinates (float32's rounds a line off it)."""
    sample = points[:: max(1, len(points) // 100_000)]
    singular = np.linalg.svd(sample - sample.mean(axis=0), compute_uv=False)
    return bool(singular[1] <= 1e-9 * singular[0] or singular[1] / np.sqrt(len(sample)) <= resolution)


def _float32_values(points: np.ndarray) -> bool:
    """Whether every coordinate is a float32 value: the cloud was stored (or made) in float32."""
    with np.errstate(over="ignore"):
        return bool(np.array_equal(points.astype(np.float32), points))


def _check_float32_steps(name: str, step: float, place: float, diagonal: float, centre: np.ndarray) -> None:
    """An InputError when float32's rounding at the coordinates is coarser than a skeleton ball (its diameter, twice
    the default sample radius of the diagonal): a georeferenced scan stored as float32 is then a few slabs of
    points, and balls that fall between two slabs break the skeleton apart."""
    ball = 2 * SAMPLE_RADIUS * diagonal
    if step > ball:
        raise InputError(f"{name}: the coordinates are float32 values, which at magnitude {place:.3g} are rounded "
                         f"to steps of {step:g}, coarser than a skeleton ball ({ball:.3g} across); store them as "
                         f"float64, or subtract an offset such as ({', '.join(str(round(value)) for value in centre)})")
