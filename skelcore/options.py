"""What shapes a run besides its input: contraction and skeleton parameters, sampling, cleaning, labels."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import io, multires
from .errors import InputError, ParameterError
from .labels import check_label_weights, weights_from_labels
from .metrics import METRICS_K, NORMAL_CONVENTION
from .params import LIMITS, SEED, CleaningParams, ContractionParams, check_flags, is_integer
from .skeleton import SkeletonParams



@dataclass(frozen=True)
class RunOptions:
    """Everything that shapes a run besides the input: contraction and skeleton parameters, sampling, labels."""
    params: ContractionParams = ContractionParams()
    sample_radius: float = SkeletonParams.sample_radius  # skeleton ball radius, fraction of the object's diagonal
    seed: int = SEED
    sample: int | None = None  # mesh input: points sampled evenly over the surface
    voxel_size: float | None = None
    max_points: int = io.MAX_POINTS
    metrics_k: int = METRICS_K
    normal_convention: str = NORMAL_CONVENTION  # D_theta's normals (skelcore.metrics)
    cleaning: CleaningParams = CleaningParams()  # outliers and stray pieces removed before contraction
    labels: str | None = None  # label file or PLY vertex property; None: the PLY's label property, if any
    label_weights: tuple[tuple[int, float], ...] = ()  # (label, contraction weight) pairs (skelcore.labels)
    # larger clouds: multi-resolution; within it, parts far denser than the rest thinned (None or 0: neither)
    point_budget: int | None = multires.POINT_BUDGET
    drop_nonfinite: bool = False  # leave out points with NaN or Inf coordinates instead of refusing the input
    # a cloud whose skeleton keeps fewer loops than its solid has is contracted again with params.hold_inside
    # (skelcore.pipeline); off where hold_inside was chosen either way
    hold_retry: bool = True

    def validated(self) -> "RunOptions":
        """These options, or a ParameterError naming the first of the wrong type or range (before any work)."""
        for name, kind in (("params", ContractionParams), ("cleaning", CleaningParams)):
            if not isinstance(getattr(self, name), kind):
                raise ParameterError(f"parameter {name}={getattr(self, name)!r}: must be a {kind.__name__}")
        self.params.validated()
        self.cleaning.validated()
        self.skeleton_params()
        io.check_sampling(sample=self.sample, voxel_size=self.voxel_size, max_points=self.max_points, seed=self.seed)
        low, high, _ = LIMITS["k"]  # a neighbourhood, as the contraction's
        if not is_integer(self.metrics_k) or not low <= self.metrics_k <= high:
            raise ParameterError(f"parameter metrics_k={self.metrics_k!r}: must be an integer between {low} and {high}")
        if self.point_budget is not None and (not is_integer(self.point_budget) or self.point_budget < 0):
            raise ParameterError(f"parameter point_budget={self.point_budget!r}: must be a whole number >= 0 or None")
        if self.labels is not None and not isinstance(self.labels, str):
            raise ParameterError(f"parameter labels={self.labels!r}: must be a label file or a vertex property name")
        check_label_weights(dict(self.label_weights))
        check_flags(self)
        return self

    def weights(self, cloud: io.Cloud) -> np.ndarray | None:
        """Per-point contraction weights from the cloud's labels and `label_weights` (None: none given)."""
        if not self.label_weights:
            return None
        if cloud.labels is None:
            if io.LABELS_DROPPED in cloud.notes:
                raise InputError(f"{cloud.name}: label weights given but resampling (--sample or --voxel-size) "
                                 f"dropped the labels: they belong to the input points")
            raise InputError(f"{cloud.name}: label weights given but the input has no labels "
                             f"(a PLY label property or --labels FILE)")
        return weights_from_labels(cloud.labels, dict(self.label_weights))

    def skeleton_params(self) -> SkeletonParams:
        """The skeleton parameters of this run, validated."""
        # GLSkeleton's graph step drops collinear degree-2 nodes (Wen et al. 2024).
        return SkeletonParams(sample_radius=self.sample_radius,
                              drop_collinear=self.params.method == "glskeleton").validated()
