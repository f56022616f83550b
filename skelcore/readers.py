"""The readers of the point and mesh files, by suffix (READERS): numpy for the common files, trimesh or open3d
for the rest.

`read_ply` covers the PLY files that need no general parser: a first element `vertex` with scalar x, y, z
properties (in any case; any others are skipped), followed by nothing or by a `face` element of triangles; anything else
falls back to trimesh. Reading a million-point binary PLY this way takes milliseconds; importing trimesh alone
takes longer. OBJ files without faces are point clouds, read here (trimesh finds no mesh in them); OFF files
here too, a header-less one of bare vertex rows as a text cloud. PCD files with binary or ascii data are read by
their header's field layout (skelcore.pcd), binary_compressed ones by open3d. LAS and LAZ (airborne and
terrestrial laser scans) by laspy.

Text clouds (XYZ, TXT, PTS) are read by skelcore.text_clouds.
"""
from __future__ import annotations

import logging
import os
import re
from pathlib import Path

import numpy as np

from .errors import InputError
from .formats import GLTF_FORMATS
from .pcd import read_pcd
from .sizing import PLY_ENDIAN, PLY_TYPES, off_layout
from .text_clouds import BOM, lf_lines, read_text, text_points

HEADER_LIMIT = 1 << 16  # a PLY header longer than this is not a common file
OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]", re.MULTILINE)
OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)  # x y z [w | r g b]


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
    axes = _ply_axes([name for name, _ in vertex_properties])
    if any(isinstance(kind, tuple) for _, kind in vertex_properties) or axes is None:
        return None
    if fmt == "ascii":
        return _ascii_ply(path, body_start, n_vertices, vertex_properties, elements[1:], axes)
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
        extra = os.fstat(handle.fileno()).st_size - handle.tell()
    if extra >= vertex_type.itemsize:  # a trailing newline is no vertex; a whole record more is a header's miscount
        promised = f"{n_vertices:,} vertices" + (f" and {len(faces):,} faces" if faces is not None else "")
        raise InputError(f"{path.name}: the header promises {promised}, the file holds {extra:,} bytes more after "
                         f"them (room for {extra // vertex_type.itemsize:,} more vertices): its counts are wrong")
    points = np.column_stack([vertices[axis].astype(np.float64) for axis in axes])
    return points, faces


def _ply_axes(names: list[str]) -> tuple[str, str, str] | None:
    """The vertex properties that hold x, y and z: named so, or else in another case (`X Y Z`, as some scanners
    write them; the general readers find only lower-case ones); None without all three."""
    lower = {}
    for name in names:
        lower.setdefault(name.lower(), name)
    axes = tuple(axis if axis in names else lower.get(axis) for axis in "xyz")
    return None if None in axes else axes


def read_off(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertices (n,3) and triangles (m,3, polygons fanned) or None of an OFF file. The first line tells the
    layout (sizing.off_layout): a file of bare vertex rows is read as a text cloud, in the same single pass."""
    data = lf_lines(Path(path).read_bytes())
    first = _first_words(data)
    if not first:
        raise InputError(f"{path}: the file holds no points")
    try:
        layout = off_layout(first)
    except InputError as error:
        raise InputError(f"{path}: {error}") from None
    if layout == "rows":
        return text_points(data, path), None
    lines = [line.split("#", 1)[0].split() for line in data.decode("utf-8").removeprefix("\ufeff").split("\n")]
    lines = [fields for fields in lines if fields]
    if layout == "counts":
        counts, body = lines[0], lines[1:]
    else:
        counts, body = (lines[0][1:], lines[1:]) if len(lines[0]) > 1 or len(lines) < 2 else (lines[1], lines[2:])
    if len(counts) < 2 or not all(value.isdigit() for value in counts[:2]):
        raise InputError(f"{path}: the OFF header needs two non-negative whole counts (vertices, faces), "
                         f"got {' '.join(counts)[:40]!r}")
    n_vertices, n_faces = int(counts[0]), int(counts[1])
    if len(body) < n_vertices + n_faces:
        raise InputError(f"{path}: the OFF header promises {n_vertices} vertices and {n_faces} faces but the "
                         f"file has {len(body)} rows")
    # vertex lines may carry a normal (N) and a colour (C) after x y z
    if any(len(fields) < 3 for fields in body[:n_vertices]):
        raise InputError(f"{path}: an OFF vertex row has fewer than 3 coordinates")
    points = np.asarray([fields[:3] for fields in body[:n_vertices]], dtype=np.float64)
    triangles = []
    for row, fields in enumerate(body[n_vertices:n_vertices + n_faces], start=1):
        size = int(fields[0])
        if size < 3:
            raise InputError(f"{path}: OFF face {row} has {size} vertex indices; a face needs at least 3")
        if len(fields) < 1 + size:
            raise InputError(f"{path}: OFF face {row} counts {size} vertex indices but lists {len(fields) - 1}")
        polygon = [int(value) for value in fields[1:1 + size]]
        triangles.extend([polygon[0], polygon[i], polygon[i + 1]] for i in range(1, len(polygon) - 1))
    return points, (np.asarray(triangles, dtype=np.int64) if triangles else None)


def read_obj_points(path: Path) -> np.ndarray | None:
    """The vertices (n,3) of an OBJ file without faces, a point cloud (which trimesh refuses as no mesh);
    None when it has faces: a mesh, for trimesh."""
    data = Path(path).read_bytes()
    if OBJ_FACE.search(data):
        return None
    coordinates = OBJ_VERTEX.findall(data)
    if not coordinates:
        raise InputError(f"{path}: an OBJ file without faces or vertices (lines 'v x y z')")
    try:
        return np.array(coordinates, dtype=np.float64)
    except ValueError:
        raise InputError(f"{path}: OBJ vertex coordinates are not numbers") from None


def quiet_trimesh():
    """trimesh, its log kept off stderr (a short surface sample, an odd file): our notes and errors say what
    matters, in one line; an application that configures logging still receives its records."""
    import trimesh

    logging.getLogger("trimesh").addHandler(_QUIET)  # idempotent: the same handler is added once
    return trimesh


_QUIET = logging.NullHandler()


def _read_ply(path: Path):
    fast = read_ply(path)
    if fast is not None:
        return fast
    trimesh = quiet_trimesh()
    loaded = trimesh.load(path, process=False)
    if isinstance(loaded, trimesh.Trimesh):
        return np.asarray(loaded.vertices), np.asarray(loaded.faces)
    vertices = getattr(loaded, "vertices", None)
    if vertices is None:
        raise InputError(f"{path}: PLY file has no vertex element")
    return np.asarray(vertices), None


def _read_pcd(path: Path):
    points = read_pcd(path)
    if points is not None:
        return points, None
    import open3d as o3d

    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):  # its warning is ours to word
        cloud = o3d.io.read_point_cloud(str(path), format="pcd")
    points = np.asarray(cloud.points)
    if len(points) == 0 and path.stat().st_size > 0:
        raise InputError(f"{path}: cannot parse as PCD (damaged, or its data is not ascii, binary or "
                         f"binary_compressed) or it holds no points")
    return points, None


def _read_obj(path: Path):
    points = read_obj_points(path)
    return (points, None) if points is not None else _read_mesh(path)


def _read_mesh(path: Path):
    trimesh = quiet_trimesh()
    if path.suffix.lower() not in GLTF_FORMATS:
        loaded = trimesh.load(path, process=False, force="mesh")
        if isinstance(loaded, trimesh.Trimesh) and len(loaded.vertices):
            return np.asarray(loaded.vertices), np.asarray(loaded.faces)
        raise InputError(f"{path}: the file holds no mesh geometry and no points")
    try:  # dump() places each geometry where the scene's transforms put it
        geometry = trimesh.load(path, process=False, force="scene").dump(concatenate=False)
    except FileNotFoundError as error:  # trimesh's resolver names the file it did not find, and no more
        raise InputError(f"{path}: its buffer file '{error.args[0]}' is missing (a .gltf reads its buffers from "
                         f"files beside it, which an upload cannot bring; a .glb holds its own)") from None
    meshes = [g for g in geometry if isinstance(g, trimesh.Trimesh) and len(g.vertices)]
    clouds = [np.asarray(g.vertices) for g in geometry if isinstance(g, trimesh.PointCloud) and len(g.vertices)]
    if meshes:
        mesh = trimesh.util.concatenate(meshes)
        notes = [f"its glTF POINTS primitive ({sum(map(len, clouds)):,} points) is left out: the mesh is read"
                 ] if clouds else []
        return np.asarray(mesh.vertices), np.asarray(mesh.faces), notes
    if clouds:  # a scan kept as a glTF POINTS primitive: no triangles, so no mesh
        return np.vstack(clouds), None
    raise InputError(f"{path}: the file holds no mesh geometry and no points")


def _read_text(path: Path):
    return read_text(path), None


def _read_las(path: Path):
    """LAS, or LAZ (laspy with its lazrs backend): x, y, z with the header's scale and offset applied."""
    import laspy

    return np.asarray(laspy.read(path).xyz, dtype=np.float64), None


READERS = {  # suffix -> reader of (points, faces or None[, notes on what was left out])
    ".off": read_off,
    ".xyz": _read_text,
    ".pts": _read_text,
    ".txt": _read_text,
    ".ply": _read_ply,
    ".pcd": _read_pcd,
    ".obj": _read_obj,
    ".stl": _read_mesh,
    ".glb": _read_mesh,
    ".gltf": _read_mesh,  # its buffers in data URIs or in files beside it
    ".las": _read_las,
    ".laz": _read_las,
}


def _first_words(data: bytes) -> list[str]:
    """The words of the first line of `data` that holds any (after a byte order mark; `#` comments left out)."""
    start = len(BOM) if data.startswith(BOM) else 0
    while start < len(data):
        end = data.find(b"\n", start) + 1 or len(data)
        words = data[start:end].split(b"#", 1)[0].split()
        if words:
            return [word.decode("utf-8", "replace") for word in words]
        start = end
    return []


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


def _ascii_ply(path: Path, body_start: int, n_vertices: int, vertex_properties, rest, axes) -> tuple | None:
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
    return table[:, [columns.index(axis) for axis in axes]].copy(), None
