"""skelcore: Laplacian-based contraction of point clouds into curve skeletons, with stability metrics.

    import skelcore
    result = skelcore.skeletonize(points)          # an (n,3) array, a Cloud or a file path
    result.nodes, result.edges, result.verdict     # the skeleton and the stability verdict
    result.save("out/")                            # the files of `skelcore run`

The public names load lazily: `import skelcore` imports neither scipy nor the inspector.
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

__all__ = ["load", "skeletonize", "contract", "inspect", "Result", "Cloud", "ContractionParams",
           "CleaningParams", "SkeletonParams", "IterationState", "Skeleton", "SkelError", "InputError", "ParameterError",
           "LABEL_PROPERTIES", "__version__"]

_HOMES = {"load": "api", "skeletonize": "api", "contract": "api", "inspect": "api", "Result": "api",
          "Cloud": "io", "ContractionParams": "params", "CleaningParams": "params", "SkeletonParams": "skeleton",
          "IterationState": "contraction", "Skeleton": "skeleton", "SkelError": "errors",
          "InputError": "errors", "ParameterError": "errors", "LABEL_PROPERTIES": "labels"}


def __getattr__(name: str):
    """Import a public name's module on first use (PEP 562)."""
    if name in _HOMES:
        value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'skelcore' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
