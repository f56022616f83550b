"""Statistics of one per-point measure's histogram (D_theta or delta_kappa): moments, the seed paper's
significant peaks (a peak counts when the frequency falls by 2% of the points on both sides), a quantile
symmetry and Sarle's bimodality coefficient.
"""
from __future__ import annotations

import numpy as np

_SYMMETRY_LEVELS = np.linspace(0.02, 0.48, 24)


def significant_peaks(counts: np.ndarray, n_points: int, drop: float = 0.02) -> np.ndarray:
    """Bins of the peaks whose frequency falls by at least drop * n_points on both sides (the paper's rule).

    A side is followed until a higher bin (to the left) or an equally high one (to the right), so a
    plateau, or two equal maxima with a shallow dip between them, counts once; beyond the ends the
    frequency is 0. A loop over bins (about 50), not points.
    """
    heights = np.concatenate([[0.0], np.asarray(counts, dtype=float), [0.0]])
    needed = drop * n_points
    peaks = []
    for i in range(1, len(heights) - 1):
        top = heights[i]
        if top <= 0 or top < heights[i - 1] or top < heights[i + 1]:
            continue
        left, right = heights[i - 1::-1], heights[i + 1:]
        left = left[:np.argmax(left > top)] if (left > top).any() else left
        right = right[:np.argmax(right >= top)] if (right >= top).any() else right
        if len(right) and top - left.min() >= needed and top - right.min() >= needed:
            peaks.append(i - 1)
    return np.asarray(peaks, dtype=np.int64)


def distribution_stats(values: np.ndarray, value_range: tuple[float, float], bins: int,
                       peak_drop: float) -> dict:
    """JSON-ready statistics of one per-point measure; NaN values are left out and counted."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    n = len(finite)
    counts, edges = np.histogram(finite, bins=bins, range=value_range)
    peaks = significant_peaks(counts, n, peak_drop)
    centres = (edges[:-1] + edges[1:]) / 2
    stats = {"histogram": {"edges": edges.tolist(), "counts": counts.tolist()}, "n": n,
             "n_undefined": int(len(values) - n),
             "peaks": {"count": int(len(peaks)), "positions": centres[peaks].tolist(),
                       "heights": counts[peaks].tolist()},
             "mean": None, "median": None, "std": None, "skewness": None, "kurtosis": None,
             "symmetry": None, "unimodality": None}
    if n == 0:
        return stats
    mean = float(finite.mean())
    deviation = finite - mean
    m2, m3, m4 = (float(np.mean(deviation ** p)) for p in (2, 3, 4))
    quantiles = np.quantile(finite, np.concatenate([[0.5], _SYMMETRY_LEVELS, 1.0 - _SYMMETRY_LEVELS]))
    median, low, high = quantiles[0], quantiles[1:1 + len(_SYMMETRY_LEVELS)], quantiles[1 + len(_SYMMETRY_LEVELS):]
    stats.update(mean=mean, median=float(median), std=float(np.sqrt(m2)))
    spread = float(np.mean(high - low))
    # Symmetry: quantiles mirrored about the median (Bowley's skewness over many levels), 1 = symmetric.
    mismatch = float(np.mean(np.abs(high + low - 2 * median)))
    stats["symmetry"] = 1.0 if spread <= 0 else float(np.clip(1.0 - mismatch / spread, 0, 1))
    if m2 > 1e-18:  # the measures live on ranges of order 1
        skewness, kurtosis = m3 / m2 ** 1.5, m4 / m2 ** 2 - 3.0
        stats.update(skewness=float(skewness), kurtosis=float(kurtosis))
        if n > 3:
            # Sarle's bimodality coefficient BC (5/9 for a uniform, 1/3 for a normal); reported as 1 - BC.
            # Informative only: heavy tails also raise BC, so the verdict counts peaks (the paper's rule).
            bc = (skewness ** 2 + 1) / (kurtosis + 3 * (n - 1) ** 2 / ((n - 2) * (n - 3)))
            stats["unimodality"] = float(np.clip(1.0 - bc, 0.0, 1.0))
    else:
        # A single value: skewness and kurtosis are undefined, the distribution is one spike.
        stats["unimodality"] = 1.0
    return stats
