"""Per-point labels and contraction weights (semantic LBC).

A per-point weight w_i multiplies point i's contraction weight: its Laplacian row of eq. 2 (Cao et al. 2010)
becomes W_L w_i L_i, so in the normal equations the Laplacian term is W_L^2 L^T diag(w^2) L. A point with
w_i > 1 is pulled towards its neighbours' centroid harder than its attraction holds it back, so it
contracts further per step; w_i < 1 holds it closer to the input. Every weight 1 is plain LBC.

pc-skeletor's SLBC (Meyer et al. 2023) has two classes: it multiplies the rows of W_L L of the trunk points
whose neighbourhood lies wholly in the trunk by a semantic weight (10 by default); trunk points next to a
branch and branch points keep 1. Here any number of integer labels each take a weight (`label_weights`,
unnamed labels keep 1, boundary points take their own label's), or the weights are given per point. Labels come
from a PLY vertex property (the first of LABEL_PROPERTIES present, or one named), a LAS point dimension (named),
or from a text/.npy file with one integer per point in the file's vertex order.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import InputError, ParameterError
from .formats import LASER_FORMATS
from .params import WEIGHT_MAX, is_integer, is_real
from .readers import quiet_trimesh

# PLY vertex properties read as labels when present, in this order (case-insensitive)
LABEL_PROPERTIES = ("label", "labels", "class", "classification", "scalar_label", "scalar_labels",
                    "scalar_class", "semantic", "segment", "part")
LABEL_FILE_FORMATS = (".txt", ".csv", ".labels", ".npy")
INT64 = 2 ** 63  # labels are int64: within [-INT64, INT64)
FLOAT_LABELS = 2 ** 53  # labels read as floats are exact integers up to this magnitude, no further


def check_weights(weights, n: int, name: str = "weights") -> np.ndarray:
    """`weights` as an (n,) float64 array of positive numbers up to WEIGHT_MAX, or a ParameterError. A weight
    multiplies W_L on its point's row, so it meets the same float range as W_L (skelcore.params.WEIGHT_MAX)."""
    if np.iscomplexobj(weights):
        raise ParameterError(f"parameter {name}: complex numbers; give their real parts (np.real)")
    try:
        values = np.asarray(weights, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"parameter {name}: not numbers") from None
    if values.shape != (n,):
        raise ParameterError(f"parameter {name}: expected one weight per point ({n}), got shape {values.shape}")
    bad = int((~(values > 0) | ~(values <= WEIGHT_MAX)).sum())
    if bad:
        raise ParameterError(f"parameter {name}: {bad} of {n} weights are not positive numbers up to {WEIGHT_MAX:g}")
    return values


def input_weights(weights, n: int, rows: np.ndarray | None, input_rows: int, name: str = "weights") -> np.ndarray:
    """`weights` given one per row of an input of `input_rows` rows, as the (n,) checked weights of the n points
    loading kept from it, whose input `rows` are given (skelcore.io.Cloud.rows): the rows kept take theirs (a
    repeated point its first row's, as labels do; a left-out row's weight is not read); one per point kept is
    taken as it is. Points drawn anew (sampled over a mesh's surface, voxel-downsampled; `rows` None) have no
    input row, so weights given for the input are refused."""
    if rows is None:
        raise ParameterError(f"parameter {name}: the input's points were replaced by {n:,} drawn anew (sampled over a "
                             f"mesh's surface or voxel-downsampled), so weights given for the input do not apply: "
                             f"load it first (skelcore.load) and give one weight per point of the cloud it returns")
    try:
        values = None if np.iscomplexobj(weights) else np.asarray(weights, dtype=np.float64)
    except (TypeError, ValueError):
        values = None
    if values is None:
        return check_weights(weights, n, name)  # which names the problem
    if values.shape == (input_rows,):
        values = values[rows]
    elif values.shape != (n,):
        kept = f" or per point kept ({n:,})" if n != input_rows else ""
        raise ParameterError(f"parameter {name}: expected one weight per input point ({input_rows:,}){kept}, got "
                             f"shape {values.shape}")
    return check_weights(values, n, name)


def check_label_weights(label_weights) -> dict[int, float]:
    """{label: weight} with integer labels and positive weights up to WEIGHT_MAX (numbers, not text), or a
    ParameterError."""
    checked = {}
    for label, weight in dict(label_weights or {}).items():
        if not is_real(weight) or not 0 < weight <= WEIGHT_MAX:
            raise ParameterError(f"parameter label_weights: weight {weight!r} of label {label!r} must be a positive "
                                 f"number up to {WEIGHT_MAX:g}")
        checked[as_label(label, "label_weights")] = float(weight)
    return checked


def as_label(value, name: str) -> int:
    """An integer label from an integer or an integral float, within the range of the labels (as_labels)."""
    if not (is_integer(value) or is_real(value) and math.isfinite(value) and value == int(value)):
        raise ParameterError(f"parameter {name}: label {value!r} is not an integer")
    if not -INT64 <= int(value) < INT64:
        raise ParameterError(f"parameter {name}: label {value!r} is too large (labels are 64-bit integers)")
    return int(value)


def parse_label_weight(text: str) -> tuple[int, float]:
    """'LABEL=W' as (label, weight), for the command line's --label-weight."""
    label, sep, weight = text.partition("=")
    try:
        if not sep:
            raise ParameterError("no '='")
        return next(iter(check_label_weights({_number(label): _number(weight)}).items()))
    except ParameterError as error:
        detail = str(error).removeprefix("parameter label_weights: ")
        raise ParameterError(f"{text!r}: {detail} (LABEL=W: an integer label and a positive weight, e.g. 1=10)") from None


def _number(text: str):
    """`text` as an int, else a float, else itself (which the checks then refuse by name)."""
    for kind in (int, float):
        try:
            return kind(text.strip())
        except ValueError:
            pass
    return text.strip()


def weights_from_labels(labels: np.ndarray, label_weights) -> np.ndarray:
    """Per-point weights: each point takes its label's weight; labels not in `label_weights` take 1."""
    table = check_label_weights(label_weights)
    weights = np.ones(len(labels))
    for label, weight in table.items():
        weights[labels == label] = weight
    return weights


def as_labels(values, n: int | None, name: str) -> np.ndarray:
    """`values` as an (n,) int64 array of labels, or an InputError naming `name`. Integers are taken as they
    are, within int64; others are read as floats, exact integers only within +-2^53 (FLOAT_LABELS)."""
    try:
        array = np.asarray(values).ravel()
        if array.dtype.kind not in "iuc":
            array = array.astype(np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: labels are not numbers") from None
    if array.dtype.kind == "c":  # a float conversion would drop the imaginary parts with only a warning
        raise InputError(f"{name}: labels are complex numbers; labels are integers")
    if n is not None and len(array) != n:
        raise InputError(f"{name}: {len(array)} labels for {n} points")
    if array.dtype.kind == "f" and (not np.isfinite(array).all() or (array != np.round(array)).any()):
        raise InputError(f"{name}: labels must be integers")
    if array.dtype.kind == "f":  # a float beyond 2^53 may already be another label rounded to it
        beyond, limit = np.abs(array) > FLOAT_LABELS, f"within +-{FLOAT_LABELS:,} when written as decimals"
    else:  # only unsigned 64-bit ones can pass int64, which would wrap them
        beyond, limit = array > INT64 - 1, f"up to {INT64 - 1:,}"
    if beyond.any():
        raise InputError(f"{name}: label {array[np.argmax(beyond)]:.0f} is too large (labels are integers {limit})")
    return array.astype(np.int64)


def ply_label_property(path, wanted: str | None = None) -> str | None:
    """The name of the label property of a PLY file's vertex element: `wanted` if given (an InputError when
    absent), else the first of LABEL_PROPERTIES present, else None. Reads the header only."""
    properties = _vertex_properties(Path(path))
    if wanted is not None:
        if wanted not in properties:
            raise InputError(f"{path}: no vertex property {wanted!r} (has: {', '.join(properties) or 'none'})")
        return wanted
    lower = {name.lower(): name for name in properties}
    return next((lower[name] for name in LABEL_PROPERTIES if name in lower), None)


def read_labels(source, cloud_path=None, n: int | None = None) -> np.ndarray:
    """Labels from `source`: an array, a label file (.txt/.csv/.labels: one integer per line; .npy), or
    the name of a vertex property of `cloud_path` (a PLY file)."""
    if not isinstance(source, (str, Path)):
        return as_labels(source, n, "labels")
    path = Path(source)
    if path.suffix.lower() in LABEL_FILE_FORMATS and path.is_file():
        return _read_label_file(path, n)
    what = "no such file" if not path.exists() else "is a folder" if path.is_dir() else "not a label file"
    if path.suffix.lower() in LABEL_FILE_FORMATS or len(path.parts) > 1:  # a path, not a property's name
        raise InputError(f"labels {source}: {what} (label files: {' '.join(LABEL_FILE_FORMATS)})")
    if cloud_path is not None and Path(cloud_path).suffix.lower() == ".ply":
        try:
            prop = ply_label_property(cloud_path, str(source))
        except InputError:
            if not path.exists():
                raise
            raise InputError(f"labels {source}: {what}, and no vertex property of the PLY input") from None
        return read_ply_labels(cloud_path, prop, n)
    if cloud_path is not None and Path(cloud_path).suffix.lower() in LASER_FORMATS:
        return read_las_labels(cloud_path, str(source), n)
    raise InputError(f"labels {source}: neither a label file ({' '.join(LABEL_FILE_FORMATS)}) nor a vertex "
                     f"property of a PLY input or a point dimension of a LAS one")


def read_las_labels(path, name: str, n: int | None = None) -> np.ndarray:
    """The point dimension `name` (any case) of a LAS or LAZ file as integer labels, in point order: its
    classification, say, or a forestry scan's tree ids in an extra dimension."""
    import laspy

    points = laspy.read(path).points
    dimensions = {dimension.lower(): dimension for dimension in points.point_format.dimension_names}
    dimension = dimensions.get(name.lower())
    if dimension is None:
        raise InputError(f"{path}: no point dimension {name!r} (has: {', '.join(dimensions.values())})")
    return as_labels(np.asarray(points[dimension]), n, f"{path} dimension {dimension}")


def read_ply_labels(path, prop: str, n: int | None = None) -> np.ndarray:
    """The vertex property `prop` of a PLY file as integer labels, in vertex order."""
    try:
        loaded = quiet_trimesh().load(path, process=False)
        data = loaded.metadata["_ply_raw"]["vertex"]["data"][prop]
    except (KeyError, ValueError, TypeError, OSError) as error:
        raise InputError(f"{path}: cannot read vertex property {prop!r} ({error})") from None
    return as_labels(data, n, f"{path} property {prop}")


def _read_label_file(path: Path, n: int | None) -> np.ndarray:
    if path.stat().st_size == 0:  # numpy reads an empty text file as no labels, with a warning
        raise InputError(f"{path}: the label file is empty")
    try:
        if path.suffix.lower() == ".npy":
            values = np.load(path, allow_pickle=False)
        else:
            delimiter = "," if path.suffix.lower() == ".csv" else None
            try:  # integers exactly first: as floats, those beyond 2^53 would merge
                values = np.loadtxt(path, delimiter=delimiter, ndmin=1, dtype=np.int64)
            except ValueError:
                values = np.loadtxt(path, delimiter=delimiter, ndmin=1)
    except (OSError, ValueError) as error:
        raise InputError(f"{path}: cannot read labels ({' '.join(str(error).split())[:120]})") from None
    return as_labels(values, n, str(path))


def _vertex_properties(path: Path) -> list[str]:
    """Property names of the vertex element, from the PLY header."""
    try:
        with open(path, "rb") as handle:
            header = handle.read(65536).split(b"end_header", 1)[0].decode("ascii", errors="replace")
    except OSError as error:
        raise InputError(f"{path}: cannot read file ({error.strerror or error})") from None
    properties, in_vertex = [], False
    for line in header.splitlines():
        fields = line.split()
        if fields[:1] == ["element"]:
            in_vertex = fields[1:2] == ["vertex"]
        elif in_vertex and fields[:1] == ["property"] and len(fields) >= 3 and fields[1] != "list":
            properties.append(fields[-1])
    return properties
