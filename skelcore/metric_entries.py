"""Per-iteration metrics as metrics.json holds them: entries made from IterationMetrics or checked when read
back from a file, and a run summarised from them for the figures that compare runs.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError
from .metrics import IterationMetrics
from .verdict import run_verdict


def entry_problem(entry) -> str | None:
    """What makes `entry` unusable as one iteration of metrics.json (its histograms, statistics, boundedness
    and verdict), or None."""
    if not isinstance(entry, dict):
        return "is not an object"
    if "iteration" in entry and (not isinstance(entry["iteration"], int) or isinstance(entry["iteration"], bool)):
        return f"has an iteration that is no whole number ({entry['iteration']!r:.30})"
    for key in ("d_theta", "delta_kappa"):
        stats = entry.get(key)
        if not isinstance(stats, dict):
            return f"lacks {key}"
        histogram = stats.get("histogram")
        if (not isinstance(histogram, dict) or not isinstance(histogram.get("edges"), list)
                or not isinstance(histogram.get("counts"), list)
                or len(histogram["edges"]) != len(histogram["counts"]) + 1):
            return f"{key} has no histogram with edges and counts"
        try:
            edges, counts = np.asarray(histogram["edges"], float), np.asarray(histogram["counts"], float)
        except (TypeError, ValueError):
            edges = counts = np.array([np.nan])
        if not (np.isfinite(edges).all() and np.isfinite(counts).all() and (np.diff(edges) > 0).all()):
            return f"{key} has histogram edges or counts that are not increasing finite numbers"
        missing = [field for field in ("mean", "median", "skewness", "kurtosis", "symmetry", "unimodality", "n")
                   if field not in stats]
        if missing or not isinstance(stats.get("peaks"), dict):
            return f"{key} lacks {', '.join(missing) or 'peaks'}"
    if not isinstance(entry.get("boundedness"), dict) or not isinstance(entry.get("verdict"), dict):
        return "lacks boundedness or verdict"
    return None


def metrics_entry(metrics) -> dict:
    """One iteration's metrics as a metrics.json entry: an IterationMetrics turned into one, a dict checked."""
    if isinstance(metrics, IterationMetrics):
        return {"iteration": metrics.iteration, **metrics.to_dict()}
    problem = entry_problem(metrics)
    if problem:
        raise InputError(f"metrics: {problem}")
    return metrics


def metrics_entries(iterations) -> list[dict]:
    """Every iteration's entry (metrics_entry), numbered in order."""
    entries = [metrics_entry(item) for item in iterations]
    return [{"iteration": position, **entry} for position, entry in enumerate(entries)]


def run_summary(name: str, metrics, verdict: dict | None = None) -> dict:
    """A run as the comparison figures take it, from its per-iteration metrics (objects or dicts). verdict: the
    run's verdict when the caller has it with the skeleton's checks (skelcore.verdict.run_verdict with evidence);
    None: judged from the metrics alone."""
    entries = metrics_entries(metrics)
    return {"name": name, "iterations": entries, "verdict": verdict or run_verdict(entries)}
