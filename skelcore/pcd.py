"""PCD files (the Point Cloud Library's format) whose data is binary or ascii, read directly.

A PCD header names each field with its SIZE in bytes, TYPE (F float, I signed, U unsigned integer) and COUNT;
`DATA binary` then packs POINTS records of those fields, little-endian, and `DATA ascii` writes each record's
values on a line. open3d's reader returns zeros for 8-byte binary fields (a cloud saved with double coordinates
came out flat, or as one point) and misreads ascii x of COUNT 2, so both are read here from the header's own
layout; binary_compressed (LZF) goes to open3d, refused when its coordinates are 8 bytes wide.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputError
from .sizing import pcd_header, pcd_points

_KINDS = {"F": "f", "I": "i", "U": "u"}


def read_pcd(path: Path) -> np.ndarray | None:
    """(n,3) float64 x, y, z of a PCD file with `DATA binary` or `ascii`; None when it is binary_compressed, for
    open3d. Raises InputError for a layout it cannot follow or data shorter than the header says."""
    header, offset = pcd_header(path)
    data = (header.get("DATA") or [""])[0].lower()
    fields = [name.lower() for name in header.get("FIELDS", [])]
    sizes, types = header.get("SIZE", []), [kind.upper() for kind in header.get("TYPE", [])]
    counts = header.get("COUNT", ["1"] * len(fields))
    if not {"x", "y", "z"} <= set(fields) or not len(fields) == len(sizes) == len(types) == len(counts):
        raise InputError(f"{path}: PCD header lacks x, y, z fields or its FIELDS, SIZE, TYPE and COUNT differ in "
                         "length")
    if data == "binary_compressed" and any(sizes[fields.index(axis)] == "8" for axis in "xyz"):
        raise InputError(f"{path}: binary_compressed PCD with 8-byte coordinates is not supported; save it with "
                         "DATA binary or ascii")
    if data not in ("binary", "ascii"):
        return None
    n = pcd_points(path, header)
    try:
        widths = [int(count) for count in counts]
        layout = np.dtype([(f"field{i}", f"<{_KINDS[kind]}{size}", (width,))
                           for i, (size, kind, width) in enumerate(zip(sizes, types, widths))])
        if min(widths[fields.index(axis)] for axis in "xyz") < 1:
            raise ValueError
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{path}: PCD fields of SIZE {' '.join(sizes)}, TYPE {' '.join(types)}, COUNT "
                         f"{' '.join(counts)} are no layout it can read") from None
    if data == "ascii":  # one line per point, each field's values in turn
        with open(path, "rb") as handle:
            handle.seek(offset)
            words = handle.read().split()
        if len(words) < n * sum(widths):
            raise InputError(f"{path}: PCD ascii data holds {len(words):,} values, its header says {n:,} points of "
                             f"{sum(widths)}")
        try:
            values = np.array(words[:n * sum(widths)]).astype(np.float64).reshape(-1, sum(widths))
        except ValueError:
            raise InputError(f"{path}: PCD ascii data holds a value that is no number, or not {sum(widths)} "
                             "values per point") from None
        starts = np.cumsum([0, *widths])
        return values[:, [starts[fields.index(axis)] for axis in "xyz"]]
    body = path.stat().st_size - offset
    if n * layout.itemsize > body:
        raise InputError(f"{path}: PCD data holds {max(body, 0) // layout.itemsize:,} of the {n:,} points its "
                         "header says (truncated?)")
    records = np.fromfile(path, dtype=layout, count=n, offset=offset)
    return np.column_stack([records[f"field{fields.index(axis)}"][:, 0] for axis in "xyz"]).astype(np.float64)
