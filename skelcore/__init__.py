"""skelcore: Laplacian-based contraction of point clouds into curve skeletons, with stability metrics."""

__version__ = "0.1.0"
