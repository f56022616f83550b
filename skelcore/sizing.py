"""Size an input file before it is parsed, so that no file can make the reader exhaust memory.

`points_in(path, suffix)` reads only a header, or streams the file in fixed-size chunks (text
formats: lines, NUL bytes, the longest line), checks the counts a header promises against the
file's length, and returns how many points parsing would produce at most. Parsers then run only on
files whose size is known to fit the memory budget.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from .errors import InputError
from .formats import LASER_FORMATS

HEADER_BYTES = 1 << 16  # longest PLY/PCD header read
CHUNK_BYTES = 1 << 22
MAX_LINE_BYTES = 1 << 14  # no text format needs a longer line
OFF_KEYWORD = re.compile(r"^(ST)?C?N?n?OFF(_\w+)?$", re.IGNORECASE)
# Bytes the readers take per point while parsing (text: Python rows of strings; binary: arrays).
PARSE_BYTES_PER_POINT = {".xyz": 400, ".pts": 400, ".txt": 400, ".off": 400, ".obj": 400,
                         ".ply": 120, ".pcd": 120, ".stl": 200, ".glb": 200, ".gltf": 200, ".las": 120, ".laz": 120}
PLY_TYPES = {  # PLY's property types as numpy kinds (skelcore.readers reads them; here their sizes count)
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
PLY_ENDIAN = {"binary_little_endian": "<", "binary_big_endian": ">", "ascii": ""}  # PLY's formats


def points_in(path: Path, suffix: str) -> int:
    """The most points `path` can yield (an InputError naming the file when its header and length
    disagree, or it is not the text it claims to be)."""
    size = path.stat().st_size
    if size == 0:
        raise InputError(f"{path}: the file is empty, it holds no points")
    if suffix == ".ply":
        return _ply(path, size)
    if suffix == ".pcd":
        return _pcd(path, size)
    if suffix == ".stl":
        return _stl(path, size)
    if suffix == ".glb":
        return size // 12  # at most one float32 vertex per 12 bytes
    if suffix == ".gltf":  # the same of the buffers it declares
        buffers = json.loads(path.read_bytes()).get("buffers", ())
        return sum(int(buffer.get("byteLength", 0)) for buffer in buffers) // 12
    if suffix in LASER_FORMATS:
        import laspy

        with laspy.open(path) as reader:  # reads the header only
            return int(reader.header.point_count)
    lines = text_lines(path)
    if suffix == ".off":
        return _off(path, lines)
    return lines


def text_lines(path: Path) -> int:
    """Lines of a text file, streamed: a NUL byte or an overlong line refuses it (binary data). Lines end in LF
    (or CR LF), or in CR alone where the file has no LF (classic Mac OS)."""
    lines, run, end = 0, 0, None
    with open(path, "rb") as handle:
        while chunk := handle.read(CHUNK_BYTES):
            if b"\0" in chunk:
                if chunk.startswith((b"\xff\xfe", b"\xfe\xff")) or chunk[1::2].count(0) > len(chunk) // 4:
                    raise InputError(f"{path}: is UTF-16 text (as Windows PowerShell writes it); save it as UTF-8 "
                                     f"or ASCII")
                raise InputError(f"{path}: holds binary data (NUL bytes), not the text its format needs")
            end = end or (13 if b"\r" in chunk and b"\n" not in chunk else 10)
            breaks = np.flatnonzero(np.frombuffer(chunk, np.uint8) == end)
            if len(breaks) == 0:
                run += len(chunk)
            else:
                longest = max(run + breaks[0], int(np.diff(breaks).max(initial=0)))
                run = len(chunk) - 1 - breaks[-1]
                if longest > MAX_LINE_BYTES:
                    run = longest
            if run > MAX_LINE_BYTES:
                raise InputError(f"{path}: a line is longer than {MAX_LINE_BYTES:,} bytes; not a point file")
            lines += len(breaks)
    return lines + (run > 0)


def _header(path: Path, end: bytes) -> tuple[list[str], int]:
    """The header lines up to and including `end` (a line starting with it), and its length in bytes."""
    with open(path, "rb") as handle:
        head = handle.read(HEADER_BYTES)
    match = re.search(rb"^" + end + rb"[^\n]*\n", head, re.MULTILINE)
    if match is None:
        raise InputError(f"{path}: no '{end.decode()}' within the first {HEADER_BYTES // 1024} kB; "
                         f"the header is missing or damaged")
    return head[:match.end()].decode("latin-1").splitlines(), match.end()


def _count(path: Path, value: str, what: str) -> int:
    try:
        count = int(value)
    except ValueError:
        raise InputError(f"{path}: {what} {value[:20]!r} is not a whole number") from None
    if count < 0:
        raise InputError(f"{path}: {what} {count} is negative")
    return count


def _ply(path: Path, size: int) -> int:
    with open(path, "rb") as handle:
        if handle.read(4).rstrip(b"\r\n") != b"ply":
            raise InputError(f"{path}: not a PLY file (it does not start with 'ply')")
    lines, header = _header(path, b"end_header")
    binary, vertices, least = False, None, 0  # least: bytes the body needs at minimum
    element = None
    for line in lines:
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "format" and len(fields) > 1:
            if fields[1] not in PLY_ENDIAN:
                raise InputError(f"{path}: format {fields[1][:30]!r} is not one of PLY's ({', '.join(PLY_ENDIAN)})")
            binary = fields[1].startswith("binary")
        elif fields[0] == "element" and len(fields) == 3:
            count = _count(path, fields[2], f"element {fields[1]} count")
            element = [fields[1], count, 0]
            if fields[1] == "vertex":
                vertices = count
            least += count * (0 if binary else 2)  # ascii: at least one digit and a line break
        elif fields[0] == "property" and element is not None:
            if len(fields) < 3:
                raise InputError(f"{path}: the header line {line[:40]!r} names no property type and name")
            kinds = fields[2:4] if fields[1] == "list" else fields[1:2]
            unknown = next((kind for kind in kinds if kind not in PLY_TYPES), None)
            if unknown is not None:
                raise InputError(f"{path}: property {fields[-1][:30]!r} has type {unknown[:30]!r}, which PLY does "
                                 f"not define ({' '.join(PLY_TYPES)})")
            if binary:
                least += element[1] * np.dtype(PLY_TYPES[kinds[0]]).itemsize  # a list: at least its count
    if vertices is None:
        raise InputError(f"{path}: PLY file has no vertex element")
    if least > size - header:
        raise InputError(f"{path}: the header promises {vertices:,} vertices ({least:,} bytes at least) "
                         f"but the file holds {size - header:,} bytes after it")
    return vertices


def pcd_header(path: Path) -> tuple[dict[str, list[str]], int]:
    """A PCD header's values by keyword (FIELDS, SIZE, TYPE, COUNT, POINTS, DATA, ...) and its length in bytes."""
    lines, header = _header(path, b"DATA")
    return {line.split()[0].upper(): line.split()[1:] for line in lines if line.split() and line[0] != "#"}, header


def pcd_points(path: Path, fields: dict[str, list[str]]) -> int:
    """The number of points a PCD header (pcd_header's values) promises: POINTS, else WIDTH x HEIGHT."""
    if fields.get("POINTS"):
        return _count(path, fields["POINTS"][0], "POINTS")
    return (_count(path, (fields.get("WIDTH") or ["0"])[0], "WIDTH")
            * _count(path, (fields.get("HEIGHT") or ["1"])[0], "HEIGHT"))


def _pcd(path: Path, size: int) -> int:
    fields, header = pcd_header(path)
    names = [name.lower() for name in fields.get("FIELDS", [])]
    if names and not {"x", "y", "z"} <= set(names):
        raise InputError(f"{path}: the PCD fields ({' '.join(names)[:60]}) hold no x, y and z")
    count = pcd_points(path, fields)
    data = (fields.get("DATA") or ["ascii"])[0].lower()
    if data == "binary":
        record = sum(_count(path, s, "SIZE") * _count(path, c, "COUNT")
                     for s, c in zip(fields.get("SIZE", []), fields.get("COUNT", ["1"] * len(fields.get("SIZE", [])))))
        if count * record > size - header:
            raise InputError(f"{path}: the header promises {count:,} points ({count * record:,} bytes) "
                             f"but the file holds {size - header:,} bytes after it")
    elif data == "ascii" and count * 2 > size - header:
        raise InputError(f"{path}: the header promises {count:,} points but the file is too short for them")
    return count


def _stl(path: Path, size: int) -> int:
    with open(path, "rb") as handle:
        head = handle.read(84)
    if len(head) == 84 and 84 + 50 * int.from_bytes(head[80:84], "little") == size:
        return 3 * int.from_bytes(head[80:84], "little")  # binary STL: three vertices per triangle
    if not head.lstrip().lower().startswith(b"solid"):
        raise InputError(f"{path}: neither a binary STL (its triangle count does not match its length) "
                         f"nor a text STL")
    return 3 * (text_lines(path) // 7 + 1)  # text STL: seven lines per triangle


def off_layout(first_line: list[str]) -> str:
    """How an .off file starts, from the words of its first line: "keyword" ([ST][C][N][n]OFF, also with a suffix
    such as cloudcontr's NOFF_SK), "counts" (Geomview's header keyword is optional: the line of vertex, face and
    edge counts comes first) or "rows" (no header at all: vertex rows, read as an XYZ file)."""
    if first_line and OFF_KEYWORD.match(first_line[0]):
        return "keyword"
    if len(first_line) == 3 and all(word.isdigit() for word in first_line):
        return "counts"
    if len(first_line) >= 3 and all(is_number(word) for word in first_line):
        return "rows"
    raise InputError(f"not an OFF file (it starts with {' '.join(first_line)[:30]!r}, not OFF)")


def is_number(word: str | bytes) -> bool:
    """True when `word` reads as a float (Python's float(): "1e3", "nan", "-0.5")."""
    try:
        float(word)
    except ValueError:
        return False
    return True


def _off(path: Path, lines: int) -> int:
    """The OFF header's counts: non-negative, and no more rows than the file has lines."""
    words: list[str] = []
    with open(path, "rb") as handle:
        for raw in handle:
            line = raw.split(b"#", 1)[0].decode("utf-8", "replace").removeprefix("\ufeff").split()
            if not words and line:
                try:
                    layout = off_layout(line)
                except InputError as error:
                    raise InputError(f"{path}: {error}") from None
                if layout == "rows":
                    return lines
                if layout == "counts":
                    words = ["OFF"]  # read on as if the keyword were there
            words += line
            if len(words) >= 3:
                break
    if not words:
        raise InputError(f"{path}: the file holds no points")
    if len(words) < 3:
        raise InputError(f"{path}: the OFF header lacks its vertex and face counts")
    vertices = _count(path, words[1], "OFF vertex count")
    faces = _count(path, words[2], "OFF face count")
    if vertices + faces > lines:
        raise InputError(f"{path}: the OFF header promises {vertices:,} vertices and {faces:,} faces "
                         f"but the file has {lines:,} lines")
    return vertices
