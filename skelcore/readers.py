"""Direct numpy readers for the common point-cloud files: PLY (binary either endianness, or ASCII) and plain
whitespace-separated XYZ text.

They cover the files that need no general parser: a PLY whose first element is `vertex` with scalar x, y, z
properties (any others are skipped), followed by nothing or by a `face` element of triangles; an XYZ/TXT/PTS
file whose lines all hold the same number (>= 3) of numbers. Anything else returns None and the caller
falls back to trimesh (PLY) or the line-by-line reader (text), which also words the error of a malformed
file. Reading a million-point binary PLY this way takes milliseconds; importing trimesh alone takes longer.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .errors import InputError

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
PLY_ENDIAN = {"binary_little_endian": "<", "binary_big_endian": ">", "ascii": ""}
DECIMAL_COMMAS = re.compile(rb"-?\d+,\d+[ \t]+-?\d+,\d+[ \t]+-?\d+,\d+")  # three numbers with decimal commas
HEADER_LIMIT = 1 << 16  # a PLY header longer than this is not a common file


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Vertices (n,3) float64 and triangles (m,3) or None; None when the file is not a common case."""
    with open(path, "rb") as handle:
        head = handle.read(HEADER_LIMIT)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return None
    body_start = head.index(b"\n", end) + 1
    elements = _ply_elements(head[:end].decode("ascii", errors="replace").splitlines())
    if elements is None:
        return None
    fmt, elements = elements
    names = [name for name, _, _ in elements]
    if not names or names[0] != "vertex" or names[1:] not in ([], ["face"]):
        return None
    _, n_vertices, vertex_properties = elements[0]
    names = {name for name, _ in vertex_properties}
    if any(isinstance(kind, tuple) for _, kind in vertex_properties) or not {"x", "y", "z"} <= names:
        return None
    if fmt == "ascii":
        return _ascii_ply(path, body_start, n_vertices, vertex_properties, elements[1:])
    order = PLY_ENDIAN[fmt]
    vertex_type = np.dtype([(name, order + kind) for name, kind in vertex_properties])
    faces = None
    with open(path, "rb") as handle:
        handle.seek(body_start)
        vertices = np.fromfile(handle, dtype=vertex_type, count=n_vertices)
        if len(vertices) < n_vertices:
            return None
        if len(elements) > 1:
            faces = _binary_triangles(handle, order, *elements[1][1:])
            if faces is None:
                return None
    points = np.column_stack([vertices[axis].astype(np.float64) for axis in "xyz"])
    return points, faces


def read_xyz(path: Path) -> np.ndarray | None:
    """(n,3) float64 from a text file of equal lines of >= 3 numbers (x y z first); None otherwise."""
    data = Path(path).read_bytes()
    if b"#" in data or b"//" in data:
        return None
    commas = DECIMAL_COMMAS.search(data) if b"." not in data else None  # "-0,845 -0,983": commas would split numbers
    if commas:
        raise InputError(f"{Path(path).name}: the coordinates are written with decimal commas (like "
                         f"{commas.group(0).split()[0].decode()}); write them with decimal points")
    data = data.replace(b",", b" ")
    widths = _tokens_per_line(data)
    widths = widths[widths > 0]
    if not len(widths) or widths[0] < 3 or (widths != widths[0]).any():
        return None
    try:
        values = np.array(data.split(), dtype=np.float64)
    except ValueError:
        return None
    return values.reshape(len(widths), widths[0])[:, :3].copy()


def _tokens_per_line(data: bytes) -> np.ndarray:
    """The number of whitespace-separated tokens on each line."""
    text = np.frombuffer(data, dtype=np.uint8)
    blank = text <= 32  # space, tab, CR, LF and the other control characters
    starts = np.flatnonzero(~blank[1:] & blank[:-1]) + 1
    if len(text) and not blank[0]:
        starts = np.concatenate([[0], starts])
    newlines = np.flatnonzero(text == 10)
    return np.bincount(np.searchsorted(newlines, starts), minlength=len(newlines) + 1)


def _ply_elements(header: list[str]):
    """(format, [(element name, count, [(property, numpy kind, or ('list', length kind, index kind))])]), or None
    when a line is not understood."""
    fmt, elements = None, []
    for line in header[1:]:
        fields = line.split()
        if not fields or fields[0] in ("comment", "obj_info"):
            continue
        if fields[0] == "format" and len(fields) >= 2 and fields[1] in PLY_ENDIAN:
            fmt = fields[1]
        elif fields[0] == "element" and len(fields) == 3 and fields[2].isdigit():
            elements.append((fields[1], int(fields[2]), []))
        elif fields[0] == "property" and elements and len(fields) == 3 and fields[1] in PLY_TYPES:
            elements[-1][2].append((fields[2], PLY_TYPES[fields[1]]))
        elif (fields[0] == "property" and elements and len(fields) == 5 and fields[1] == "list"
              and fields[2] in PLY_TYPES and fields[3] in PLY_TYPES):
            elements[-1][2].append((fields[4], ("list", PLY_TYPES[fields[2]], PLY_TYPES[fields[3]])))
        else:
            return None
    return None if fmt is None else (fmt, elements)


def _binary_triangles(handle, order: str, count: int, properties) -> np.ndarray | None:
    """A face element of one list property, every face a triangle."""
    if len(properties) != 1 or not isinstance(properties[0][1], tuple):
        return None
    _, length_kind, index_kind = properties[0][1]
    face_type = np.dtype([("length", order + length_kind), ("index", order + index_kind, (3,))])
    faces = np.fromfile(handle, dtype=face_type, count=count)
    if len(faces) < count or (faces["length"] != 3).any():
        return None
    return faces["index"].astype(np.int64)


def _ascii_ply(path: Path, body_start: int, n_vertices: int, vertex_properties, rest) -> tuple | None:
    if rest:  # ASCII faces: the general reader
        return None
    with open(path, "rb") as handle:
        handle.seek(body_start)
        body = handle.read()
    width = len(vertex_properties)
    try:
        values = np.array(body.split(), dtype=np.float64)
    except ValueError:
        return None
    if len(values) != n_vertices * width:  # the general readers would take the rows there are: say so instead
        raise InputError(f"{path.name}: the header promises {n_vertices:,} vertices of {width} values, the file "
                         f"holds {len(values):,} values ({len(values) / width:,.4g} vertices)")
    table = values.reshape(n_vertices, width)
    columns = [name for name, _ in vertex_properties]
    return table[:, [columns.index(axis) for axis in "xyz"]].copy(), None
