"""One object of a batch, as a worker runs it: its job, its resume key and `done.json` marker, its summary row.

An object is done when its `done.json` exists and carries the key of this run: a hash of the run options, the
skelcore version and the input file's content. The marker is written atomically after every result file, and
removed before an object is (re)run, so a killed batch leaves either a complete object with its marker or files
without one, which the next run redoes. The marker also holds the object's summary row, so skipped objects need
no recomputation. Failed objects get no marker: a rerun tries them again.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path

from . import __version__
from .errors import SkelError
from .options import RunOptions
from .pipeline import run_pipeline
from .results import DONE_FILE, RESULT_FILES, write_atomic
from .verdict import StabilityThresholds, failed_line

SUMMARY_COLUMNS = (
    "name", "input", "status", "error", "points", "iterations", "termination", "seconds",
    "nodes", "edges", "components", "cycles", "ends", "junctions",
    "d_theta_mean", "delta_kappa_mean", "d_theta_skewness", "delta_kappa_skewness", "d_theta_peaks",
    "delta_kappa_peaks", "inside_share", "spread_ratio", "bounded", "verdict", "verdict_failed", "reused",
)
RUN_COLUMNS = ("seconds", "reused")  # differ between two runs of the same batch


@dataclass(frozen=True)
class Job:
    """One object of a batch: everything a worker needs, and nothing big."""
    name: str
    input: str
    out_dir: str  # the object's own folder, OUT/<name>
    options: RunOptions
    options_digest: str
    force: bool = False


def options_digest(options: RunOptions) -> str:
    """Hash of everything that shapes a result: the run options and the skelcore version."""
    document = {"options": dataclasses.asdict(options), "skelcore_version": __version__}
    return hashlib.sha256(json.dumps(document, sort_keys=True).encode()).hexdigest()


def file_digest(path) -> str:
    """SHA-256 of a file's content: a copied or touched input is the same object, an edited one is not."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def done_row(job: Job, key: str) -> dict | None:
    """The summary row stored by a finished run of this job with this key, or None (also for a marker that is
    not the object this module writes: the object is run again)."""
    folder = Path(job.out_dir)
    try:
        marker = json.loads((folder / DONE_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(marker, dict) or not isinstance(marker.get("row"), dict) or marker.get("key") != key:
        return None
    return marker["row"] if all((folder / name).is_file() for name in RESULT_FILES) else None


def run_object(job: Job) -> dict:
    """Run one object unless it is already done; returns its summary row. Never raises for a bad object."""
    folder = Path(job.out_dir)
    try:
        key = hashlib.sha256(f"{job.options_digest}:{file_digest(job.input)}".encode()).hexdigest()
    except OSError as error:
        return failed_row(job, f"{job.input}: cannot read file ({error.strerror or error})")
    if not job.force and (row := done_row(job, key)) is not None:
        return {**row, "name": job.name, "input": job.input, "reused": True}
    try:
        folder.mkdir(parents=True, exist_ok=True)
        # Not done until the marker says so: drop an old one before any result file changes.
        (folder / DONE_FILE).unlink(missing_ok=True)
        for leftover in folder.glob(".*.tmp"):  # temporary files of a killed run
            leftover.unlink(missing_ok=True)
        result = run_pipeline(job.input, folder, job.options)
        row = _row(job, result)
        write_text_atomic(folder / DONE_FILE, json.dumps({
            "key": key, "input": str(Path(job.input).resolve()), "options_digest": job.options_digest,
            "skelcore_version": __version__, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "row": row,
        }, indent=1))
    except SkelError as error:
        return failed_row(job, str(error))
    except Exception as error:  # a bug or a resource failure in one object must not stop the batch
        return failed_row(job, one_line(error))
    return {**row, "reused": False}


def _row(job: Job, result) -> dict:
    final_state = result.states[-1]
    iterations = result.metrics["iterations"]
    final = iterations[-1]
    topology = result.skeleton.topology()
    thresholds = StabilityThresholds()
    bounded = all(entry["boundedness"]["inside_share"] >= thresholds.min_inside_share
                  and entry["boundedness"]["shrinking"] for entry in iterations[1:])
    row = dict.fromkeys(SUMMARY_COLUMNS)
    row.update({
        "name": job.name, "input": job.input, "status": "ok", "error": "",
        "points": len(result.cloud.points), "iterations": final_state.iteration,
        "termination": final_state.termination, "seconds": round(result.elapsed, 3),
        "nodes": result.skeleton.graph.number_of_nodes(), "edges": result.skeleton.graph.number_of_edges(),
        **{name: topology[name] for name in ("components", "cycles", "ends", "junctions")},
        "d_theta_mean": final["d_theta"]["mean"], "delta_kappa_mean": final["delta_kappa"]["mean"],
        "d_theta_skewness": final["d_theta"]["skewness"], "delta_kappa_skewness": final["delta_kappa"]["skewness"],
        "d_theta_peaks": final["d_theta"]["peaks"]["count"],
        "delta_kappa_peaks": final["delta_kappa"]["peaks"]["count"],
        "inside_share": final["boundedness"]["inside_share"], "spread_ratio": final["boundedness"]["spread_ratio"],
        "bounded": bounded, "verdict": result.metrics["verdict"]["label"],
        "verdict_failed": failed_line(result.metrics["verdict"]),
    })
    return row


def failed_row(job: Job, error: str) -> dict:
    """The summary row of an object that failed with `error`."""
    row = dict.fromkeys(SUMMARY_COLUMNS)
    row.update(name=job.name, input=job.input, status="failed", error=error, reused=False)
    return row


def one_line(error: BaseException) -> str:
    """An exception as one line: its type and the first line of its message."""
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0]}" if text else type(error).__name__


def write_text_atomic(path: Path, text: str) -> None:
    """Write `text` to `path` through a temporary file renamed into place (skelcore.results.write_atomic)."""
    write_atomic(path, lambda temporary: temporary.write_text(text))
