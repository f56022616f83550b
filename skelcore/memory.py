"""Memory budgets: how many points a run may take on this machine, and the voxel size that brings a
cloud down to that many.

A run's peak memory grows linearly with its points (one-rings, Laplacian, factorisation, metrics,
skeleton). PIPELINE_BYTES_PER_POINT is that slope at full resolution, measured with `skelcore run
--full-resolution` on tori of 50,000 and 200,000 points (peak RSS 305 MB and 893 MB: 3.9 kB per point;
2026-12), with a margin; the default multi-resolution path takes less (224 MB and 331 MB). The
inspector keeps every iteration, their metrics and skeletons, and serves browsers meanwhile, so it
takes a smaller share of the machine than the command line does.
"""
from __future__ import annotations

import os

import numpy as np

from .distinct import distinct
from .errors import ParameterError

PIPELINE_BYTES_PER_POINT = 4_800
CLI_SHARE = 0.5  # of the memory available when the run starts
INSPECTOR_SHARE = 0.25
GIB = 2.0 ** 30
AVAILABLE_VARIABLE = "SKELCORE_AVAILABLE_MB"


def available_bytes() -> int:
    """Memory the system can give without swapping (MemAvailable), or its physical size; the environment
    variable SKELCORE_AVAILABLE_MB states it instead (a machine shared with other work, or a test)."""
    stated = os.environ.get(AVAILABLE_VARIABLE)
    if stated:
        try:
            value = float(stated)
        except ValueError:
            value = -1.0
        if not value > 0:
            raise ParameterError(f"{AVAILABLE_VARIABLE}={stated!r}: must be a positive number of megabytes")
        return int(value * 2**20)
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def budget_bytes(share: float = CLI_SHARE) -> int:
    """The bytes a run may take: `share` of the memory available now."""
    return int(available_bytes() * share)


def describe(size: float) -> str:
    """A number of bytes for people: GiB from 1 GiB, MiB below."""
    return f"{size / GIB:.1f} GiB" if size >= GIB else f"{size / 2**20:.0f} MiB"


def point_cap(budget: int) -> int:
    """The most points a run may have within `budget` bytes."""
    return max(0, int(budget // PIPELINE_BYTES_PER_POINT))


def voxel_size_for(points: np.ndarray, target: int) -> float:
    """A voxel size (3 significant digits) that leaves at most `target` occupied voxels, i.e. points
    after downsampling. A surface's occupied voxels scale as 1/size^2: a first guess from the extent,
    two corrections by that law, then growth by 10% until the count is within the target."""
    extent = float(np.ptp(points, axis=0).max())
    size = extent / max(np.sqrt(target), 1.0)
    for _ in range(2):
        count = _occupied(points, size)
        size *= np.sqrt(count / target) if count > 0 else 1.0
    while True:
        rounded = float(f"{size:.3g}")
        if _occupied(points, rounded) <= target:
            return rounded
        size *= 1.1


def _occupied(points: np.ndarray, size: float) -> int:
    keys = np.floor((points - points.min(axis=0)) / size).astype(np.int64)
    span = keys.max(axis=0) + 1
    flat = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    return len(distinct(flat))
