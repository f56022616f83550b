"""Load point clouds and meshes into a validated (n,3) float64 array.

Every problem is reported as an InputError whose message is one line naming the file and the
problem; recoverable oddities (duplicate points) are fixed and reported in `Cloud.notes`.
"""
from __future__ import annotations

import dataclasses
import errno
import functools
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import memory, readers, sizing
from .coordinates import computed_scale
from .distinct import distinct_rows, row_groups
from .errors import InputError, NonFiniteError, ParameterError, TooLargeError
from .formats import FORMATS
from .labels import as_labels, check_weights, input_weights, ply_label_property, read_labels, read_ply_labels
from .mesh_topology import closed_solid
from .normalise import bounds, half_extent, object_diagonal
from .params import check_flag, is_integer, is_real
from .paths import as_path
from .repeats import welded, without_repeats
from .surface_sampling import points_to_draw, sample_surface

MIN_POINTS = 20
LABELS_DROPPED = "labels dropped: they belong to the input points, not to a resampled cloud"  # a Cloud note
MAX_POINTS = 2_000_000


@dataclass
class Cloud:
    """A validated point cloud: points, optional mesh faces and labels, its name, notes on what loading fixed."""
    points: np.ndarray  # (n,3) float64, finite, unique
    faces: np.ndarray | None = None  # (m,3) int64 into points, when the file is a mesh
    name: str = "cloud"
    notes: list[str] = field(default_factory=list)
    cleaning: dict | None = None  # what skelcore.clean removed before contraction (counts), once it ran
    labels: np.ndarray | None = None  # (n,) int64 per-point labels (skelcore.labels), when the input has them
    scale: float = 1.0  # the file's coordinates are points * scale (a power of two; 1 unless extreme)
    # the input's row of every point, when validation kept input rows (None once resampled, and after cleaning),
    # and how many rows the input had: per-point values given for the input follow the points kept (input_weights)
    rows: np.ndarray | None = None
    input_rows: int = 0
    # the loops through the solid a closed mesh file bounds (its genus, skelcore.mesh_topology), read from its own
    # faces before any resampling; None for a point cloud or a mesh that bounds no solid
    solid_loops: int | None = None
    solid_pieces: int | None = None  # ... and the pieces of that mesh
    # the points as cleaning's denoising projects them with a thin wall's two faces kept apart (skelcore.clean),
    # which the inside tests sample where that differs from `points`; None: the points themselves
    surface: np.ndarray | None = None

    @property
    def loops_at_most(self) -> int | None:
        """The most loops a skeleton of this cloud keeps, where known exactly: a closed mesh's genus when the mesh
        is one piece (separate closed pieces may pass through each other, and their union then has loops that no
        piece's genus counts: a handle modelled as its own solid sunk into a mug's wall)."""
        return self.solid_loops if self.solid_pieces == 1 else None

    @functools.cached_property
    def diagonal(self) -> float:
        """The object diagonal of the points (skelcore.normalise.object_diagonal), computed once per cloud."""
        return object_diagonal(self.points)


def load(path, *, sample: int | None = None, voxel_size: float | None = None,
         max_points: int = MAX_POINTS, budget: int | None = None, seed: int = 0, labels=None,
         drop_nonfinite: bool = False) -> Cloud:
    """Read a file into a validated Cloud.

    sample: for a mesh, draw this many points evenly over its surface instead of using its vertices; 0: its
    vertices; None: its vertices where they cover its surface, else points drawn evenly (skelcore.surface_sampling).
    voxel_size: downsample to one point per voxel (the way to bring a huge cloud under max_points).
    labels: per-point labels (skelcore.labels.read_labels): a label file, a PLY vertex property name or an
    array in the file's vertex order; None: a PLY file's label property (LABEL_PROPERTIES) when it has one.
    drop_nonfinite: leave out points with NaN or Inf coordinates (their faces and labels too) instead of refusing.
    budget: bytes a run on the cloud may take (default: skelcore.memory's share for the command line);
    the file is sized before it is parsed, and the cloud's points are checked against it.
    """
    check_sampling(sample=sample, voxel_size=voxel_size, max_points=max_points, seed=seed)  # before reading
    check_flag("drop_nonfinite", drop_nonfinite)
    if isinstance(path, np.ndarray):
        raise ParameterError("load reads a file; an array of points goes to skeletonize or contract as it is")
    path = as_path(path, "input", blank=InputError("input: give a file name (the path is empty)"))
    budget = memory.budget_bytes() if budget is None else budget
    suffix = path.suffix.lower()
    try:
        _check_file(path)
        if suffix not in FORMATS:
            raise InputError(f"{path}: unknown format '{suffix or path.name}' (supported: {' '.join(FORMATS)})")
        most = sizing.points_in(path, suffix)
        if most * sizing.PARSE_BYTES_PER_POINT[suffix] > budget:
            raise InputError(f"{path}: may hold up to {most:,} points, too many to read within the memory "
                             f"budget of {memory.describe(budget)}; thin it out before loading")
        points, faces, *left_out = readers.READERS[suffix](path)  # a reader may add notes on what it left out
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{path}: ran out of memory while reading the file") from None
    except OSError as error:
        raise InputError(f"{path}: cannot read file ({error.strerror or 'input/output error'})") from None
    except UnicodeDecodeError as error:
        raise InputError(f"{path}: not UTF-8 text (byte 0x{error.object[error.start]:02x} at offset "
                         f"{error.start})") from None
    except Exception as error:  # a parser's own failure on a malformed file
        raise InputError(f"{path}: cannot parse as {suffix[1:].upper()} ({_parser_words(error)})") from None
    if labels is not None:
        labels = read_labels(labels, path, len(points))
    elif suffix == ".ply" and (prop := ply_label_property(path)) is not None:
        labels = read_ply_labels(path, prop, len(points))
    cloud = validate(points, faces, name=str(path), sample=sample, voxel_size=voxel_size,
                     max_points=max_points, budget=budget, seed=seed, labels=labels, drop_nonfinite=drop_nonfinite)
    left_out = left_out[0] if left_out else []
    return dataclasses.replace(cloud, notes=[*left_out, *cloud.notes]) if left_out else cloud


def _check_file(path: Path) -> None:
    """A readable regular file, or an InputError saying why not (a symlink loop is not 'not found')."""
    try:
        info = path.stat()
    except OSError as error:
        reason = {errno.ENOENT: "file not found", errno.ELOOP: "a loop of symbolic links, no file at its end",
                  errno.EACCES: "permission denied", errno.ENAMETOOLONG: "the path is too long",
                  errno.ENOTDIR: "a part of the path is not a folder"}.get(error.errno)
        raise InputError(f"{path}: {reason or 'cannot read file (' + (error.strerror or 'error') + ')'}") from None
    if not path.is_file():
        raise InputError(f"{path}: not a regular file")
    if info.st_size == 0:
        raise InputError(f"{path}: the file is empty, it holds no points")


def _parser_words(error: Exception) -> str:
    """A parser's failure in our words: no internal reprs, C++ exception names or source paths."""
    text = _one_line(error)
    if "bad_alloc" in text:
        return "out of memory"
    if isinstance(error, KeyError):
        return f"a field it needs is missing: {text.strip(chr(39) + chr(34) + '()')}"
    if isinstance(error, RecursionError):
        return "nested too deeply"
    if isinstance(error, IndexError):
        return "an index refers to an element that does not exist"
    if type(error).__name__ == "JSONDecodeError":
        return "its JSON part is damaged"
    if outside := re.search(r"'([^']*)' escapes resolver root", text):  # trimesh's advice names its own API
        return f"it names {outside.group(1)!r}, outside its own folder, which is not read"
    if isinstance(error, (ValueError, TypeError)) and not re.search(r"[\\/]\w+\.\w+|\bline \d+, in\b", text):
        return f"damaged or not in this format: {text}"
    return "damaged or not in this format"


def load_bytes(data: bytes, filename: str, **options) -> Cloud:
    """Load an uploaded file: parsed from a private temporary directory, never from a client path."""
    suffix = Path(filename).suffix.lower()
    display = Path(filename).name or "upload"
    if suffix not in FORMATS:
        raise InputError(f"{display}: unknown format '{suffix or display}' (supported: {' '.join(FORMATS)})")
    with tempfile.TemporaryDirectory(prefix="skelcore-upload-") as tmp:
        target = Path(tmp) / f"upload{suffix}"
        try:
            target.write_bytes(data)
        except OSError as error:
            raise InputError(f"{display}: cannot store the upload to read it ({error.strerror})") from None
        try:
            cloud = load(target, **options)
        except InputError as error:  # the same error (a TooLargeError keeps its voxel size), named for the user
            error.args = (str(error).replace(str(target), display),)
            raise error from None
    cloud.name = display
    return cloud


def check_sampling(*, sample=None, voxel_size=None, max_points=MAX_POINTS, seed=0) -> None:
    """The loading options (see `load`), or a ParameterError naming the first of the wrong type or range."""
    if sample is not None and not (is_integer(sample) and (sample == 0 or sample >= MIN_POINTS)):
        raise ParameterError(f"parameter sample={sample!r}: must be a whole number of points, at least {MIN_POINTS} "
                             f"(or 0: a mesh's vertices as they are)")
    if voxel_size is not None and (not is_real(voxel_size) or not 0 < voxel_size < np.inf):
        raise ParameterError(f"parameter voxel_size={voxel_size!r}: must be a positive finite number")
    if not is_integer(max_points) or max_points < MIN_POINTS:
        raise ParameterError(f"parameter max_points={max_points!r}: must be a whole number, at least {MIN_POINTS}")
    if not is_integer(seed) or seed < 0:  # numpy's generators refuse negative seeds
        raise ParameterError(f"parameter seed={seed!r}: must be a whole number >= 0")


def validate(points, faces=None, *, name: str = "cloud", sample: int | None = None,
             voxel_size: float | None = None, max_points: int = MAX_POINTS, budget: int | None = None,
             seed: int = 0, labels=None, drop_nonfinite: bool = False) -> Cloud:
    """Check an array of points (and optional faces, per-point labels) and return a clean Cloud; more points
    than max_points or the memory budget allows raise a TooLargeError with the voxel size that fits.
    drop_nonfinite: leave out points with NaN or Inf coordinates instead of refusing them (NonFiniteError)."""
    check_sampling(sample=sample, voxel_size=voxel_size, max_points=max_points, seed=seed)
    notes: list[str] = []
    dropped = 0
    kept = None  # the input rows left after dropping NaN or Inf rows (None: all)
    if drop_nonfinite:
        points, faces, labels, kept, dropped = _drop_nonfinite(points, faces, labels, name)
        if dropped:
            notes.append(f"dropped {dropped} points with NaN or Inf coordinates")
        if dropped and len(points) < MIN_POINTS:  # said before as_points calls a file of NaN rows empty
            raise _too_few(name, len(distinct_rows(points)), dropped)
    points = as_points(points, name)
    if faces is not None:
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if len(faces) == 0:
            faces = None
        elif faces.min() < 0 or faces.max() >= len(points):
            raise InputError(f"{name}: faces refer to vertices that do not exist")
    if labels is not None:
        labels = as_labels(labels, len(points), name)
    had_faces = faces is not None
    input_rows = len(points) + dropped
    rows = np.arange(len(points)) if kept is None else kept  # the input row of every point
    if faces is not None:  # before the cap, unsaid: an STL file repeats each vertex for every face it has
        points, faces, labels, rows = without_repeats(points, faces, labels, rows, [])
    loops, pieces, no_solid = closed_solid(faces, len(points))  # said after what loading did to the points
    if no_solid and (weld := welded(points, faces, labels, rows, notes)) is not None:
        (points, faces, labels, rows, loops, pieces), no_solid = weld, ""
    budget = memory.budget_bytes() if budget is None else budget
    cap = min(max_points, memory.point_cap(budget))
    note = None
    if sample is None and faces is not None:
        sample, note = points_to_draw(points, faces, labels is not None, cap, seed)
        notes += [note] if note else []
    if sample or voxel_size is not None:  # new points: no input row's labels or values belong to them
        rows = None
        if labels is not None:
            labels = None
            notes.append(LABELS_DROPPED)
    if sample:
        if faces is None:
            raise InputError(f"{name}: the mesh has no surface to sample (its triangles have no area)" if had_faces
                             else f"{name}: surface sampling needs a mesh, but the file has no faces")
        if sample > cap:  # refused before drawing them: a huge sample would exhaust the memory first
            raise ParameterError(f"parameter sample={sample:,}: more points than the cap of {cap:,}")
        computed_scale(points, name)  # the vertices as stored: points drawn over them hide float32's rounding
        points = sample_surface(points, faces, int(sample), seed, name)[0]
        faces = None
        if note is None:  # the choice's own note says it
            notes.append(f"sampled {len(points)} points evenly over the mesh surface")
    if voxel_size is not None:
        before = len(points)
        points = voxel_downsample(points, voxel_size, name)
        faces = None
        notes.append(f"voxel downsampling ({voxel_size:g}) kept {len(points)} of {before} points")
    if len(points) > cap:
        why = (f"the cap of {cap:,}" if cap == max_points else
               f"the cap of {cap:,} that the memory budget of {memory.describe(budget)} allows")
        voxel = memory.voxel_size_for(points, max(cap, MIN_POINTS))
        raise TooLargeError(f"{name}: {len(points):,} points exceed {why}; a voxel size of {voxel:g} brings "
                            f"them under", len(points), cap, voxel)
    if faces is None:  # a mesh that kept its faces has had its repeats merged above, and nothing since moved it
        points, _, labels, rows = without_repeats(points, None, labels, rows, notes)
    if len(points) < MIN_POINTS:
        raise _too_few(name, len(points), dropped, voxel_size)
    points, scale = computed_scale(points, name)
    if scale != 1.0:
        notes.append(f"extreme coordinates: computed at 1/{scale:g} of their size, results written at full size")
    notes += [no_solid] if no_solid else []
    return Cloud(points=points, faces=faces, name=name, notes=notes, labels=labels, scale=scale, rows=rows,
                 input_rows=input_rows, solid_loops=loops, solid_pieces=pieces)


def checked(cloud: Cloud, drop_nonfinite: bool = False) -> Cloud:
    """`cloud` itself when it holds what `validate` makes: (n,3) finite float64 points, at least MIN_POINTS of
    them spanning more than a point, labels one per point; else (a Cloud made by hand) `validate` of its points,
    faces and labels, its notes kept, so that it is refused in words as an array would be."""
    points, labels = cloud.points, cloud.labels
    if (isinstance(points, np.ndarray) and points.dtype == np.float64 and points.ndim == 2
            and points.shape[1] == 3 and len(points) >= MIN_POINTS and np.isfinite(points).all()
            and (points.max(axis=0) > points.min(axis=0)).any()  # no subtraction: it could overflow
            and (labels is None or isinstance(labels, np.ndarray) and labels.shape == (len(points),))):
        return cloud
    fresh = validate(points, cloud.faces, name=cloud.name, labels=labels, drop_nonfinite=drop_nonfinite)
    return dataclasses.replace(fresh, notes=[*cloud.notes, *fresh.notes],
                               **({"solid_loops": cloud.solid_loops, "solid_pieces": cloud.solid_pieces}
                                  if cloud.faces is None else {}))


def weights_of(source, cloud: Cloud, weights) -> np.ndarray | None:
    """The per-point weights of `cloud`, made from `source`: a Cloud given is weighted point by point, an array or a
    file row by row (input_weights)."""
    if weights is None:
        return None
    if isinstance(source, Cloud):
        return check_weights(weights, len(cloud.points))
    return input_weights(weights, len(cloud.points), cloud.rows, cloud.input_rows)


def _too_few(name: str, distinct: int, dropped: int, voxel_size: float | None = None) -> InputError:
    """Too few distinct points to contract, and whether dropping the NaN or Inf rows or the voxels left so few."""
    why = ([f"after dropping the {dropped} with NaN or Inf coordinates"] if dropped else []) + (
        [f"in voxels of {voxel_size:g} (a smaller voxel size keeps more)"] if voxel_size is not None else [])
    left = f" remain {' and '.join(why)}" if why else ""
    return InputError(f"{name}: only {distinct} distinct point{'' if distinct == 1 else 's'}{left}, at least "
                      f"{MIN_POINTS} are needed")


def as_points(value, name: str) -> np.ndarray:
    """`value` as a non-empty (n,3) float64 array of finite coordinates, or an InputError naming `name`."""
    try:
        if np.iscomplexobj(value):
            raise InputError(f"{name}: coordinates are complex numbers; give their real parts (np.real)")
        points = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: coordinates are not numbers (got {type(value).__name__})") from None
    if points.size == 0:
        raise InputError(f"{name}: holds no points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{name}: expected (n,3) coordinates, got shape {points.shape}")
    bad = int((~np.isfinite(points).all(axis=1)).sum())
    if bad:
        raise NonFiniteError(f"{name}: {bad} of {len(points)} points are not finite (NaN or Inf)", bad, len(points))
    return points


def _drop_nonfinite(points, faces, labels, name: str):
    """Points without their NaN/Inf rows, faces and labels without theirs, the input rows kept (None: all), and
    how many rows went."""
    try:
        points = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        return points, faces, labels, None, 0  # as_points names the problem
    if points.ndim != 2 or points.shape[1] != 3:
        return points, faces, labels, None, 0
    keep = np.isfinite(points).all(axis=1)
    if keep.all():
        return points, faces, labels, None, 0
    if faces is not None:
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if len(faces) and (faces.min() < 0 or faces.max() >= len(points)):
            raise InputError(f"{name}: faces refer to vertices that do not exist")
        remap = np.cumsum(keep) - 1
        faces = remap[faces[keep[faces].all(axis=1)]]
    if labels is not None and len(labels) == len(points):
        labels = np.asarray(labels)[keep]
    return points[keep], faces, labels, np.flatnonzero(keep), int((~keep).sum())


def voxel_downsample(points: np.ndarray, voxel_size: float, name: str = "cloud") -> np.ndarray:
    """One point per occupied voxel: the centroid of the points in it. A voxel finer than float64 resolves the
    cloud's extent is refused (its index would not fit an integer; no two points could share one)."""
    half = half_extent(points)
    if half > 2.0 ** 51 * voxel_size:
        raise ParameterError(f"{name}: voxel size {voxel_size:g} is finer than float64 resolves the cloud's extent "
                             f"({2 * half:.3g}); give at least {half * 2.0 ** -50:.3g}")
    keys = np.floor((points / 2 - bounds(points)[0] / 2) / voxel_size * 2).astype(np.int64)  # halves: no overflow
    inverse, counts = row_groups(keys)
    centroids = np.zeros((len(counts), 3))
    np.add.at(centroids, inverse, points / counts[inverse, None])  # each point's share: no sum of huge coordinates
    return centroids


def _one_line(error: Exception) -> str:
    text = " ".join(str(error).split())
    return text[:160] or type(error).__name__
