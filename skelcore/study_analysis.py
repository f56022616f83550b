"""What `skelcore study` measured: how well each statistic and the verdict predict a right skeleton.

Shapes are split in two halves (sorted names, alternately): thresholds are chosen on the calibration half and
every goal is reported on the held-out half. A run is right when its skeleton's topology is exact and, where
a centreline exists, its Chamfer distance is at most 1% of the diagonal (skelcore.study.CHAMFER_RIGHT).
Calibration is a coordinate search over CANDIDATES: it maximises the right runs labelled stable less
FALSE_STABLE_COST per wrong one (the break-even precision is GOAL_PRECISION),
with no bad setting, collapsed or disconnected skeleton stable; of equally good thresholds it keeps the
loosest (see looseness). Writes OUT/study.csv (one row per run), OUT/study.json (the figures and
thresholds), OUT/thresholds.json and OUT/study.html.
"""
from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np

from .metrics import NORMAL_CONVENTIONS
from .verdict import (LABELS, MANY_PEAKS, StabilityThresholds, count_loops, features, judge, piece_range,
                      pieces_agree)

GOAL_PRECISION = 0.9  # "stable" must be right in this share of the runs it labels, on held-out shapes
FALSE_STABLE_COST = GOAL_PRECISION / (1 - GOAL_PRECISION)  # a wrong "stable" costs 9 right ones
BAD_SETTINGS = ("wl0 x100", "stop after 1")  # of skelcore.study.SETTINGS: must never be judged stable
CANDIDATES = {
    "max_d_theta_peaks": [1, 2, 3, MANY_PEAKS],
    "max_delta_kappa_peaks": [1, 2, 3, MANY_PEAKS],
    "min_symmetry": [0.0, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9],
    "delta_kappa_tolerance": [0.02, 0.05, 0.1, 0.2, 0.4],
    "min_inside_share": [0.0, 0.5, 0.7, 0.8, 0.9, 0.95],
    "max_step_shrink": [0.3, 0.5, 0.7, 0.9, 1.0],
    "shrink_tolerance": [0.01, 0.02, 0.03, 0.05, 0.1],
    # Never below 0.2: W_L0 x100 leaves 4-12% of the spread on the calibration shapes (most stop after one step,
    # which min_steps already catches) and every right run of another setting over 35%; the floor keeps the size
    # rule for the runs that go on.
    "min_spread_ratio": [0.2, 0.3, 0.4, 0.5, 0.6, 0.7],
    "min_curve_share": [0.0, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9],
    "min_steps": [2, 3, 4, 5],  # never 1: a run stopped after one step must never be stable (the goal)
    "loop_death": [2.0, 3.0, 4.0, 6.0, 8.0],
}
# Not calibrated: piece_gap and loop_birth stay at 2 sample radii, the widest gap the skeleton's ball cover
# (samples r apart, each covering r) bridges within a piece of the surface, so pieces and loops are counted at the
# skeleton's own scale;
# d_theta_tolerance stays at half the target (skelcore.verdict.StabilityThresholds says why).
# The loosest value of each threshold: a criterion switched off, to measure what it contributes.
PERMISSIVE = {"max_d_theta_peaks": MANY_PEAKS, "max_delta_kappa_peaks": MANY_PEAKS, "min_symmetry": 0.0,
              "d_theta_tolerance": 1.0, "delta_kappa_tolerance": 1.0, "min_inside_share": 0.0, "max_step_shrink": 1.0,
              "shrink_tolerance": 1.0, "min_spread_ratio": 0.0, "min_curve_share": 0.0, "min_steps": 1}
CRITERIA_GROUPS = {  # name in the tables -> thresholds switched off (or "skeleton": no skeleton checks)
    "D_theta peaks (paper)": ["max_d_theta_peaks"], "delta_kappa peaks (paper)": ["max_delta_kappa_peaks"],
    "histogram symmetry (paper)": ["min_symmetry"],
    "mean D_theta (paper)": ["d_theta_tolerance"], "mean delta_kappa (paper)": ["delta_kappa_tolerance"],
    "inside the original (paper)": ["min_inside_share"],
    "shrinking, no one-step collapse (paper's X_k+1 <= X_k)": ["max_step_shrink", "shrink_tolerance"],
    "size against the original (added)": ["min_spread_ratio"], "curve-likeness (added)": ["min_curve_share"],
    "steps taken (added)": ["min_steps"],
    "skeleton nodes, pieces and loops (added)": "skeleton",
}


def split_of(shape: str, names: list[str]) -> str:
    """'calibration' or 'held-out': shapes alternate in sorted order."""
    return "calibration" if sorted(names).index(shape) % 2 == 0 else "held-out"


def run_features(record: dict, convention: str, skeleton: bool = True) -> dict:
    """The verdict's figures of a run's last iteration under `convention`, with its skeleton evidence."""
    last = record["conventions"][convention][-1]
    return features(last, record["evidence"] if skeleton else None)


def label_runs(records: list[dict], convention: str, thresholds: StabilityThresholds, skeleton: bool = True):
    """The verdict's label of each run's last iteration under `thresholds`."""
    return [judge(run_features(r, convention, skeleton), r["iterations"], thresholds)["label"] for r in records]


def goals(records: list[dict], labels: list) -> dict:
    """Precision and recall of "stable", and the runs that must never be stable."""
    right = np.array([r["truth"]["right"] for r in records], bool)
    stable = np.array([label == "stable" for label in labels], bool)
    forbidden = np.array([r["setting"] in BAD_SETTINGS for r in records], bool)
    broken = np.array([r["truth"]["collapsed"] or r["truth"]["disconnected"] for r in records], bool)
    confusion = {label or "no verdict": {"right": int(np.sum((np.array(labels, object) == label) & right)),
                                         "wrong": int(np.sum((np.array(labels, object) == label) & ~right))}
                 for label in LABELS}
    return {"runs": len(records), "right_runs": int(right.sum()), "stable": int(stable.sum()),
            "precision": float((stable & right).sum() / stable.sum()) if stable.any() else None,
            "recall": float((stable & right).sum() / right.sum()) if right.any() else None,
            "bad_settings_stable": int((stable & forbidden).sum()),
            "collapsed_or_disconnected_stable": int((stable & broken).sum()), "confusion": confusion}


def _objective(result: dict) -> float:
    """Right runs labelled stable, less FALSE_STABLE_COST per wrong one (the break-even precision is
    GOAL_PRECISION) and far more per bad setting, collapsed or disconnected skeleton labelled stable."""
    true_stable = result["recall"] * result["right_runs"] if result["recall"] is not None else 0.0
    false_stable = result["stable"] - true_stable
    forbidden = result["bad_settings_stable"] + result["collapsed_or_disconnected_stable"]
    return true_stable - FALSE_STABLE_COST * false_stable - 100.0 * FALSE_STABLE_COST * forbidden


def looseness(thresholds: StabilityThresholds) -> float:
    """How far each calibrated threshold lies toward its PERMISSIVE end, summed (each 0 strictest to 1 loosest).
    The search adds a thousandth of it to the objective (whose steps are whole runs), so of thresholds that
    label the calibration half alike it keeps the loosest: no stricter than the data demand."""
    total = 0.0
    for name in CANDIDATES.keys() & PERMISSIVE.keys():
        ordered = _strict_to_loose(name)
        total += ordered.index(getattr(thresholds, name)) / (len(ordered) - 1) \
            if getattr(thresholds, name) in ordered else 0.0
    return total


def _strict_to_loose(name: str) -> list:
    """CANDIDATES[name] from the strictest to the loosest (the end nearest PERMISSIVE[name])."""
    return sorted(CANDIDATES[name], reverse=PERMISSIVE[name] <= min(CANDIDATES[name]))


def calibrate(records: list[dict], convention: str, passes: int = 4, restarts: int = 10) -> StabilityThresholds:
    """Coordinate search over CANDIDATES on `records` (the calibration half) from several starts: the shipped
    thresholds, the loosest candidates, and `restarts` random picks (fixed seed); the best end is then
    refined by moves of two thresholds at once. Every threshold it returns is one of its CANDIDATES."""
    rng = np.random.default_rng(0)
    loosest = {name: _strict_to_loose(name)[-1] for name in CANDIDATES.keys() & PERMISSIVE.keys()}
    starts = [StabilityThresholds(), dataclasses.replace(StabilityThresholds(), **loosest)]
    starts += [dataclasses.replace(StabilityThresholds(), **{name: values[rng.integers(len(values))]
                                                              for name, values in CANDIDATES.items()})
               for _ in range(restarts)]
    score_of = lambda thresholds: (_objective(goals(records, label_runs(records, convention, thresholds)))
                                   + 1e-3 * looseness(thresholds))
    ends = []
    for best in starts:
        best_score = score_of(best)
        for _ in range(passes):
            improved = False
            for name, values in CANDIDATES.items():
                for value in values:
                    trial = dataclasses.replace(best, **{name: value})
                    score = score_of(trial)
                    if score > best_score + 1e-9:
                        best, best_score, improved = trial, score, True
            if not improved:
                break
        ends.append((best_score, best))
    best_score, best = max(ends, key=lambda end: end[0])
    # Then moves of two thresholds at once, which single moves cannot see (two criteria rejecting the same runs).
    names = list(CANDIDATES)
    for _ in range(2):
        improved = False
        for i, first in enumerate(names):
            for second in names[i + 1:]:
                for a in CANDIDATES[first]:
                    for b in CANDIDATES[second]:
                        trial = dataclasses.replace(best, **{first: a, second: b})
                        score = score_of(trial)
                        if score > best_score + 1e-9:
                            best, best_score, improved = trial, score, True
        if not improved:
            break
    return best


def auc(scores, right) -> tuple[float, float, float] | None:
    """ROC AUC of `scores` for telling right runs (higher = right) with its 95% interval (Hanley-McNeil)."""
    scores, right = np.asarray(scores, float), np.asarray(right, bool)
    keep = np.isfinite(scores)
    scores, right = scores[keep], right[keep]
    positives, negatives = int(right.sum()), int((~right).sum())
    if not positives or not negatives:
        return None
    order = np.argsort(scores, kind="mergesort")
    ranks = np.empty(len(scores))
    ranks[order] = np.arange(1, len(scores) + 1)
    for value in np.unique(scores):  # ties share their mean rank
        tied = scores == value
        ranks[tied] = ranks[tied].mean()
    area = (ranks[right].sum() - positives * (positives + 1) / 2) / (positives * negatives)
    q1, q2 = area / (2 - area), 2 * area ** 2 / (1 + area)
    se = np.sqrt((area * (1 - area) + (positives - 1) * (q1 - area ** 2) + (negatives - 1) * (q2 - area ** 2))
                 / (positives * negatives))
    return float(area), float(max(0.0, area - 1.96 * se)), float(min(1.0, area + 1.96 * se))


def statistic_table(record: dict, convention: str) -> dict:
    """The last iteration's statistics of a run as flat numbers (the columns of study.csv)."""
    last = record["conventions"][convention][-1]
    row = {}
    for key, target in (("d_theta", 0.5), ("delta_kappa", 0.0)):
        stats = last[key]
        for name in ("mean", "std", "skewness", "kurtosis", "symmetry", "unimodality"):
            row[f"{key}_{name}"] = stats[name]
        row[f"{key}_gap"] = None if stats["mean"] is None else abs(stats["mean"] - target)
        row[f"{key}_peaks"] = stats["peaks"]["count"]
    row.update({name: last["boundedness"][name] for name in ("inside_share", "spread_ratio", "growth")})
    row["curve_share"] = last["curve"].get("curve_share")
    row["steps"] = record["iterations"]
    return row


def skeleton_agreement(record: dict, thresholds: StabilityThresholds) -> float:
    """1 when the run's skeleton passes every skeleton check (nodes, pieces, loops), else 0."""
    e = record["evidence"]
    pieces = pieces_agree(e["components"], piece_range(e["cloud_pieces"], thresholds),
                          piece_range(e["input_pieces"], thresholds))
    return float(pieces and e["cycles"] == count_loops(e["cloud_loops"], thresholds) and e["nodes"] >= 3)


def paper_behaviour(records: list[dict], convention: str) -> dict:
    """Default runs on clean inputs: how many end within the paper's target (|mean D_theta - 0.5| <= 0.1, one
    peak, |skewness| <= 0.5) and how many start skewed left (positive skewness at iteration 1) with one peak."""
    chosen = [r for r in records if r["setting"] == "default" and r["variant"] == "clean" and r["seed"] == 0]
    final = early = 0
    for r in chosen:
        entries = r["conventions"][convention]
        last, first = entries[-1]["d_theta"], entries[min(1, len(entries) - 1)]["d_theta"]
        final += bool(last["mean"] is not None and abs(last["mean"] - 0.5) <= 0.1 and last["peaks"]["count"] == 1
                      and last["skewness"] is not None and abs(last["skewness"]) <= 0.5)
        early += bool(first["skewness"] is not None and first["skewness"] > 0 and first["peaks"]["count"] == 1)
    means = [r["conventions"][convention][-1]["d_theta"]["mean"] for r in chosen]
    return {"runs": len(chosen), "within_target_at_end": final, "skewed_left_unimodal_at_first": early,
            "final_mean_range": [min(means), max(means)] if means else None}


def analyse(records: list[dict], out_dir, progress=print) -> dict:
    """The study's figures from its runs; writes study.csv, study.json, thresholds.json and study.html."""
    from .study_page import write_page

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    failed = [r for r in records if "error" in r]
    records = [r for r in records if "error" not in r]
    names = sorted({r["shape"] for r in records})
    halves = {half: [r for r in records if split_of(r["shape"], names) == half] for half in ("calibration", "held-out")}
    summary = {"runs": len(records), "failed_runs": [{k: r[k] for k in ("shape", "variant", "seed", "setting", "error")}
                                                       for r in failed],
               "shapes": {half: sorted({r["shape"] for r in rs}) for half, rs in halves.items()},
               "right_share": float(np.mean([r["truth"]["right"] for r in records])) if records else None,
               "conventions": {}}
    right = [r["truth"]["right"] for r in records]
    for convention in NORMAL_CONVENTIONS:
        if progress:
            progress(f"calibrating the {convention} convention")
        fitted = calibrate(halves["calibration"], convention)
        rows = [statistic_table(r, convention) for r in records]
        aucs = {name: auc([row[name] if row[name] is not None else np.nan for row in rows], right)
                for name in rows[0]} if rows else {}
        aucs["skeleton agreement"] = auc([skeleton_agreement(r, fitted) for r in records], right)
        entry = {"thresholds": dataclasses.asdict(fitted), "auc": aucs, "paper": paper_behaviour(records, convention),
                 "shipped": {half: goals(rs, label_runs(rs, convention, StabilityThresholds()))
                             for half, rs in halves.items()},
                 "calibrated": {half: goals(rs, label_runs(rs, convention, fitted)) for half, rs in halves.items()}}
        entry["contributions"] = contributions(halves["held-out"], convention, fitted)
        entry["held_out_by_source"] = {
            kind: goals(group, label_runs(group, convention, fitted))
            for kind in sorted({_kind(r) for r in halves["held-out"]})
            for group in [[r for r in halves["held-out"] if _kind(r) == kind]]}
        summary["conventions"][convention] = entry
    _write_csv(out_dir / "study.csv", records, names)
    (out_dir / "study.json").write_text(json.dumps(summary, indent=1))
    (out_dir / "thresholds.json").write_text(json.dumps(
        {c: summary["conventions"][c]["thresholds"] for c in NORMAL_CONVENTIONS}, indent=1))
    write_page(out_dir / "study.html", records, summary)
    if progress:
        for convention, entry in summary["conventions"].items():
            held = entry["calibrated"]["held-out"]
            progress(f"{convention}: held-out precision {held['precision']}, recall {held['recall']}, "
                     f"bad settings stable {held['bad_settings_stable']}, "
                     f"collapsed/disconnected stable {held['collapsed_or_disconnected_stable']}")
        progress(f"wrote {out_dir / 'study.html'}")
    return summary


def contributions(records: list[dict], convention: str, thresholds: StabilityThresholds) -> dict:
    """Held-out goals with each criterion group switched off in turn: what each one contributes."""
    result = {}
    for name, switched in CRITERIA_GROUPS.items():
        if switched == "skeleton":
            labels = label_runs(records, convention, thresholds, skeleton=False)
        else:
            labels = label_runs(records, convention, dataclasses.replace(thresholds, **{k: PERMISSIVE[k] for k in switched}))
        result[name] = goals(records, labels)
    return result


def _kind(record: dict) -> str:
    """synthetic, manifold3d (the benchmark's solids) or reference (real meshes and scans)."""
    return record["source"].split(":")[0]


def _write_csv(path: Path, records: list[dict], names: list[str]) -> None:
    columns = None
    with path.open("w", newline="") as handle:
        for r in records:
            row = {"shape": r["shape"], "source": r["source"], "variant": r["variant"], "seed": r["seed"],
                   "setting": r["setting"], "half": split_of(r["shape"], names), "iterations": r["iterations"],
                   "termination": r["termination"], "right": r["truth"]["right"],
                   "topology_exact": r["truth"]["topology_exact"], "chamfer": r["truth"]["chamfer"],
                   "hausdorff": r["truth"]["hausdorff"], "collapsed": r["truth"]["collapsed"],
                   "disconnected": r["truth"]["disconnected"], **{f"skeleton_{k}": v for k, v in r["truth"]["skeleton"].items()}}
            for convention in NORMAL_CONVENTIONS:
                row.update({f"{convention}_{k}": v for k, v in statistic_table(r, convention).items()})
                row[f"{convention}_verdict"] = judge(run_features(r, convention), r["iterations"])["label"]
            if columns is None:
                columns = list(row)
                writer = csv.DictWriter(handle, columns)
                writer.writeheader()
            writer.writerow(row)
