"""Batch runs: the pipeline over many objects, resumable, serial or on a Dask cluster, with a summary and a report.

Layout of OUT: OUT/<name>/ holds what `skelcore run` writes (skelcore.results.RESULT_FILES) and, last, `done.json`;
OUT/summary.csv, OUT/summary.json (one row per object, SUMMARY_COLUMNS) and OUT/report.html (skelcore.report).

Each object is resumable (skelcore.batch_object: its `done.json` marker) and may run on Dask workers
(skelcore.batch_dask); the throughput benchmark is skelcore.batch_bench.
"""
from __future__ import annotations

import csv
import dataclasses
import glob
import io as _io
import json
import os
import re
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from . import __version__, io
from .batch_object import (DONE_FILE, RUN_COLUMNS, SUMMARY_COLUMNS, Job, one_line, options_digest, run_object,
                           write_text_atomic)
from .batch_dask import check_workers
from .errors import InputError
from .options import RunOptions
from .results import REPORT_FILE, RESULT_FILES

__all__ = ["DONE_FILE", "RUN_COLUMNS", "SUMMARY_COLUMNS", "BatchResult", "collect_inputs", "object_names", "plan",
           "run_batch", "write_summary"]


@dataclass
class BatchResult:
    """The outcome of a batch: one summary row per object, the report page, the time taken."""
    out_dir: Path
    rows: list[dict]
    report: Path | None
    elapsed: float

    @property
    def failed(self) -> list[dict]:
        """The rows of the objects that failed."""
        return [row for row in self.rows if row["status"] == "failed"]

    def summary_line(self) -> str:
        """One line: objects done, reused and failed, the time, the output folder."""
        reused = sum(bool(row["reused"]) for row in self.rows)
        done = len(self.rows) - len(self.failed)
        report = f", {self.report.name}" if self.report else ""
        return (f"{done} of {len(self.rows)} objects done ({reused} reused), {len(self.failed)} failed; "
                f"{self.elapsed:.1f} s -> {self.out_dir}/summary.csv{report}")


# --- inputs and names ---------------------------------------------------------------------------

def collect_inputs(inputs: list[str], out_dir=None) -> list[Path]:
    """Files named, the point cloud and mesh files of folders named, and those matching glob patterns.

    Explicit files are taken whatever their suffix (the pipeline then reports an unsupported one). Result files
    of an earlier batch inside OUT are never inputs. An INPUT that matches nothing is an InputError.
    """
    outputs = Path(out_dir).resolve() if out_dir is not None else None
    found: dict[Path, Path] = {}
    for text in inputs:
        path = Path(text)
        if path.is_file():
            matches = [path]
        elif path.is_dir():
            matches = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in io.FORMATS)
        elif any(c in text for c in "*?["):
            matches = sorted(Path(m) for m in glob.glob(text, recursive=True)
                             if Path(m).is_file() and Path(m).suffix.lower() in io.FORMATS)
        else:
            raise InputError(f"{text}: no such file or folder")
        if not matches:
            raise InputError(f"{text}: no point cloud or mesh files ({' '.join(io.FORMATS)})")
        for match in matches:
            resolved = match.resolve()
            if outputs is not None and match.name in RESULT_FILES and outputs in resolved.parents:
                continue
            found.setdefault(resolved, match)
    if not found:
        raise InputError("no inputs left: every file given is a result file inside the output folder")
    return list(found.values())


def object_names(paths: list[Path]) -> list[str]:
    """A folder name per input: its stem, made unique by the extension and then by parent folders when stems
    collide (a/torus.ply, b/torus.ply -> a_torus, b_torus; torus.ply, torus.xyz -> torus_ply, torus_xyz).
    Depends only on the inputs, so a rerun finds the same folders."""
    names = [_safe(p.stem) for p in paths]
    counts = Counter(names)
    for stem in [stem for stem, count in counts.items() if count > 1]:
        group = [i for i, name in enumerate(names) if name == stem]
        others = set(names) - {stem}
        depth_limit = max(len(paths[i].resolve().parent.parts) for i in group)
        for depth in range(depth_limit + 1):
            for extension in (False, True):
                proposal = [_safe(_label(paths[i].resolve(), depth, extension)) for i in group]
                if len(set(proposal)) == len(group) and not set(proposal) & others:
                    break
            else:
                continue
            break
        else:  # still clashing, with another object's name: number them
            proposal = [f"{stem}-{position + 1}" for position in range(len(group))]
        for i, name in zip(group, proposal):
            names[i] = name
    return names


def _label(path: Path, depth: int, extension: bool) -> str:
    parents = list(path.parent.parts[len(path.parent.parts) - depth:]) if depth else []
    return "_".join(parents + [path.stem] + ([path.suffix.lstrip(".")] if extension else []))


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".") or "object"


# --- the batch ----------------------------------------------------------------------------------

def plan(inputs: list[str], out_dir, options: RunOptions, force: bool = False) -> list[Job]:
    """One Job per input object (files, folders and globs expanded), each with its output folder."""
    paths = collect_inputs(inputs, out_dir)
    digest = options_digest(options)
    return [Job(name, str(path), str(Path(out_dir) / name), options, digest, force)
            for name, path in zip(object_names(paths), paths)]


def run_batch(inputs: list[str], out_dir, options: RunOptions = RunOptions(), *, workers: int | None = None,
              scheduler: str | None = None, force: bool = False, progress: bool = True,
              report: bool = True) -> BatchResult:
    """Run every object of INPUTS into OUT_DIR/<name>, then write the summary and the report.

    workers: run on a local Dask cluster of this many single-threaded processes (0: one per CPU core);
    scheduler: address of an existing Dask scheduler instead. Neither: one object after the other, here.
    report: also write report.html (it loads every object's clouds again: skip it for very large batches).
    """
    started = time.perf_counter()
    options.validated()  # bad parameters fail before any work
    check_workers(workers)
    out_dir = Path(out_dir)
    jobs = plan(inputs, out_dir, options, force)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{out_dir}: cannot create the output folder ({error.strerror})") from None
    from tqdm import tqdm

    rows: list[dict | None] = [None] * len(jobs)
    with tqdm(total=len(jobs), unit="obj", desc="batch", disable=not progress, file=sys.stderr) as bar:
        results = _serial(jobs) if workers is None and scheduler is None else _dask(jobs, workers, scheduler, bar)
        for index, row in results:
            rows[index] = row
            state = "failed" if row["status"] == "failed" else "skipped (done)" if row["reused"] else "done"
            bar.set_postfix_str(f"{row['name']}: {state}", refresh=False)
            bar.update()
            if row["status"] == "failed":
                bar.write(f"{row['name']}: failed: {row['error']}", file=sys.stderr)
    write_summary(out_dir, rows, options)
    page = _write_report(out_dir, rows) if report else None
    return BatchResult(out_dir, rows, page, time.perf_counter() - started)


def _serial(jobs: list[Job]) -> Iterator[tuple[int, dict]]:
    for index, job in enumerate(jobs):
        yield index, run_object(job)


# --- summary and report -------------------------------------------------------------------------

def write_summary(out_dir, rows: list[dict], options: RunOptions) -> None:
    """summary.csv and summary.json, one row per object in input order, each written atomically."""
    out_dir = Path(out_dir)
    table = _io.StringIO()
    writer = csv.DictWriter(table, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({key: "" if value is None else value for key, value in row.items()} for row in rows)
    write_text_atomic(out_dir / "summary.csv", table.getvalue())
    counts = {"objects": len(rows), "ok": sum(row["status"] == "ok" for row in rows),
              "failed": sum(row["status"] == "failed" for row in rows),
              "reused": sum(bool(row["reused"]) for row in rows)}
    document = {"skelcore_version": __version__, "options": dataclasses.asdict(options), "counts": counts,
                "columns": list(SUMMARY_COLUMNS), "objects": rows}
    write_text_atomic(out_dir / "summary.json", json.dumps(document, indent=1))


def _write_report(out_dir: Path, rows: list[dict]) -> Path | None:
    """report.html: the table of every object (failed ones with their error), the figures comparing those that
    succeeded and, for a batch of moderate size, each one's figures; a report failure is one line and leaves
    the summary."""
    run_dirs = [out_dir / row["name"] for row in rows if row["status"] == "ok"]
    path = out_dir / REPORT_FILE
    temporary = path.with_name(f".report.{os.getpid()}.tmp.html")
    try:
        from .report import write_report

        write_report(run_dirs, temporary, rows=rows)
        os.replace(temporary, path)
    except Exception as error:
        print(f"report.html not written: {one_line(error)}", file=sys.stderr)
        return None
    finally:
        temporary.unlink(missing_ok=True)
    return path


def _dask(jobs: list[Job], workers: int | None, scheduler: str | None, bar) -> Iterator[tuple[int, dict]]:
    from .batch_dask import on_dask

    return on_dask(jobs, workers, scheduler, bar)
