"""Paths given for output and input: of a path type, without a NUL byte, not blank; an output folder that can be
written, checked before any work so that no result is lost to a path that cannot hold it."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .errors import OutputError, ParameterError, SkelError


def as_path(value, what: str, blank: SkelError | None = None) -> Path:
    """`value` (a str or os.PathLike) as a Path, or a ParameterError naming `what` when it is of another type or
    holds a NUL byte; when it is blank (Path("") is the working folder) `blank`, by default an OutputError."""
    if not isinstance(value, (str, os.PathLike)) or isinstance(value, bytes):
        raise ParameterError(f"{what}={value!r}: must be a path (a str or pathlib.Path)")
    if "\0" in str(value):
        raise ParameterError(f"{what}={str(value)!r}: a path cannot hold a NUL byte")
    if not str(value).strip():
        raise blank or OutputError(f"{what}: give a name (the path is empty)")
    return Path(value)


def writable_folder(folder, what: str) -> Path:
    """`folder` as a Path, or an OutputError naming `what` when it is blank, a file, under a file, or where no
    folder can be made (checked before any work, so that no result is lost to a path that cannot hold it)."""
    folder = as_path(folder, what)
    if any(part.is_file() for part in (folder, *folder.parents)):
        raise OutputError(f"{what} {folder}: is a file, or under one, not a folder")
    existing = next(part for part in (folder, *folder.parents, Path(".")) if part.exists())
    try:  # a folder made and removed at once: permissions alone do not tell (root may not write in /proc)
        tempfile.TemporaryDirectory(dir=existing, prefix=".skelcore-probe-").cleanup()
    except OSError as error:
        raise OutputError(f"{what} {folder}: cannot be written ({error.strerror or error} in {existing})") from None
    return folder
