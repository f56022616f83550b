"""Text point clouds: XYZ, TXT and PTS files (and the bare vertex rows of a header-less OFF).

Text clouds (`read_text`) are read as their writers make them: a UTF-8 byte order mark, leading comment lines
(`#`, `//`), one line of column names or a .pts point count, values separated by blanks, commas or
semicolons (between semicolons, a comma is a decimal comma). x, y and z are the first three columns unless the
names line names them elsewhere (`id x y z`, or pandas' `,x,y,z` with its index column first). Files of equal
lines are parsed at once, others line by line. Blank-separated decimal commas (`-0,845 -0,983`) are refused:
they cannot be told from commas between numbers. Lines end in LF, CR LF, or CR alone (`lf_lines`).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .errors import InputError
from .sizing import is_number

DECIMAL_COMMAS = re.compile(rb"-?\d+,\d+[ \t]+-?\d+,\d+[ \t]+-?\d+,\d+")  # three numbers with decimal commas
BOM = b"\xef\xbb\xbf"  # UTF-8's byte order mark, which some Windows programs write first
COMMENTS = (b"#", b"//")
WORDS = re.compile(rb"[\s,;]+")  # what separates the words of a text line, before its separators are known
XYZ_FIRST = (0, 1, 2)  # the columns of x, y and z in a text cloud whose names line does not name them


def read_text(path: Path) -> np.ndarray:
    """(n,3) float64 from an XYZ/TXT/PTS file: x y z first on each line (the module docstring says what else)."""
    return text_points(Path(path).read_bytes(), path)


def text_points(data: bytes, path) -> np.ndarray:
    """The points of a text cloud's bytes `data`, read from `path` (which messages name)."""
    data = lf_lines(data)
    start, skipped, columns = _header(data)
    body = _separated(data[start:], path)
    points = _equal_rows(body, columns)
    return points if points is not None else _rows(body, skipped, data, path, columns)


def lf_lines(data: bytes) -> bytes:
    """`data` with its lines ending in LF: a file whose lines end in CR alone (classic Mac OS) has no LF."""
    return data.replace(b"\r", b"\n") if b"\n" not in data else data


def _header(data: bytes) -> tuple[int, int, tuple[int, int, int]]:
    """(bytes, lines) before a text cloud's values: a byte order mark, blank and comment lines, and one line
    of column names (none of its words a number) or a .pts point count; and the columns of x, y and z."""
    start = len(BOM) if data.startswith(BOM) else 0
    lines, named, columns = 0, False, XYZ_FIRST
    while start < len(data):
        end = data.find(b"\n", start) + 1 or len(data)
        line = data[start:end].strip()
        if line and not line.startswith(COMMENTS):
            words = WORDS.split(line)
            names_or_count = line.isdigit() or not any(map(is_number, words))
            if named or not names_or_count:
                break
            named, columns = True, _xyz_columns(words)
        start, lines = end, lines + 1
    return start, lines, columns


def _xyz_columns(names: list[bytes]) -> tuple[int, int, int]:
    """The columns a names line gives x, y and z (any case, quoted or not); the first three unless it names all
    three. An empty name counts as a column: pandas writes its index column's name so (`,x,y,z`)."""
    names = [name.strip(b"\"'").lower() for name in names]
    if not all(axis in names for axis in (b"x", b"y", b"z")):
        return XYZ_FIRST
    return names.index(b"x"), names.index(b"y"), names.index(b"z")


def _separated(body: bytes, path) -> bytes:
    """`body` with its values separated by blanks only: semicolons and commas become blanks, except that
    between semicolons a comma is a decimal comma when no value has a decimal point."""
    decimal = b";" in body and b"." not in body
    commas = DECIMAL_COMMAS.search(body) if b"." not in body and not decimal else None
    if commas:  # "-0,845 -0,983": read as separators, the commas would split every number in two
        raise InputError(f"{path}: the coordinates are written with decimal commas (like "
                         f"{commas.group(0).split()[0].decode()}); write them with decimal points")
    return body.translate(bytes.maketrans(b";,", b" ." if decimal else b"  "))


def _equal_rows(body: bytes, columns: tuple[int, int, int]) -> np.ndarray | None:
    """(n,3) float64 from lines that all hold the same number of numbers (x, y and z in `columns` among them),
    parsed at once; None otherwise."""
    if b"#" in body or b"//" in body:
        return None
    widths = _tokens_per_line(body)
    widths = widths[widths > 0]
    if not len(widths) or widths[0] <= max(columns) or (widths != widths[0]).any():
        return None
    try:
        values = np.array(body.split(), dtype=np.float64)
    except ValueError:
        return None
    return np.ascontiguousarray(values.reshape(len(widths), widths[0])[:, list(columns)])


def _rows(body: bytes, skipped: int, data: bytes, path, columns: tuple[int, int, int]) -> np.ndarray:
    """Line by line (lines of unequal length, comments among them): x y z the values in `columns` of each line.
    `skipped`: the header's lines, so that messages count lines as the file does."""
    rows, numbers = [], []
    for number, line in enumerate(body.split(b"\n"), start=skipped + 1):
        fields = line.split()
        if not fields or fields[0].startswith(COMMENTS):
            continue
        if len(fields) <= max(columns):
            raise InputError(f"{path}: line {number} has fewer than 3 coordinates" if columns == XYZ_FIRST else
                             f"{path}: line {number} has {len(fields)} values; x, y and z are its columns "
                             f"{', '.join(str(column + 1) for column in columns)} by the names line")
        rows.append([fields[column] for column in columns])
        numbers.append(number)
    if not rows:
        raise InputError(f"{path}: the file holds no points")
    try:
        return np.asarray(rows, dtype=np.float64)
    except ValueError:
        data.decode("utf-8")  # a file that is not text is refused as such (io.load words the UnicodeDecodeError)
        numeric = [all(map(is_number, values)) for values in rows]
        if not any(numeric):  # prose, not a cloud with a bad line: naming one line would mislead
            raise InputError(f"{path}: no line holds three numbers (x y z); is it a point cloud?") from None
        bad = numeric.index(False)
        words = b" ".join(rows[bad]).decode()[:40]
        raise InputError(f"{path}: line {numbers[bad]} holds {words!r}, not three numbers") from None


def _tokens_per_line(data: bytes) -> np.ndarray:
    """The number of whitespace-separated tokens on each line."""
    text = np.frombuffer(data, dtype=np.uint8)
    blank = text <= 32  # space, tab, CR, LF and the other control characters
    starts = np.flatnonzero(~blank[1:] & blank[:-1]) + 1
    if len(text) and not blank[0]:
        starts = np.concatenate([[0], starts])
    newlines = np.flatnonzero(text == 10)
    return np.bincount(np.searchsorted(newlines, starts), minlength=len(newlines) + 1)
