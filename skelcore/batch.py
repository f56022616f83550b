"""Batch runs: the pipeline over many objects, resumable, serial or on a Dask cluster, with a summary and a report.

Layout of OUT: OUT/<name>/ holds what `skelcore run` writes (pipeline.RESULT_FILES) and, last, `done.json`;
OUT/summary.csv, OUT/summary.json (one row per object, SUMMARY_COLUMNS) and OUT/report.html (skelcore.report).

Resume: an object is done when its `done.json` exists and carries the key of this run: a hash of the run options,
the skelcore version and the input file's content. The marker is written atomically after every result file, and
removed before an object is (re)run, so a killed batch leaves either a complete object with its marker or files
without one, which the next run redoes. The marker also holds the object's summary row, so skipped objects need no
recomputation. Failed objects get no marker: a rerun tries them again.

Dask: the work unit is one object (`run_object`). Workers read the input and write the result files and the marker
straight into OUT, and return only the small summary row: the clouds never travel through the scheduler, a finished
object survives the death of the client, and there is one writer for results (the pipeline's). The price is that
INPUTs and OUT must be on a filesystem every worker sees at the same path (always true on one machine).
"""
from __future__ import annotations

import csv
import dataclasses
import glob
import hashlib
import io as _io
import json
import logging
import os
import re
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from . import __version__, io
from .errors import InputError, ParameterError, SkelError
from .pipeline import RESULT_FILES, RunOptions, run_pipeline, write_atomic
from .verdict import StabilityThresholds

DONE_FILE = "done.json"
SUMMARY_COLUMNS = (
    "name", "input", "status", "error", "points", "iterations", "termination", "seconds",
    "nodes", "edges", "components", "cycles", "ends", "junctions",
    "d_theta_mean", "delta_kappa_mean", "d_theta_skewness", "delta_kappa_skewness", "d_theta_peaks",
    "delta_kappa_peaks", "inside_share", "spread_ratio", "bounded", "verdict", "reused",
)
RUN_COLUMNS = ("seconds", "reused")  # differ between two runs of the same batch
CONNECT_TIMEOUT = "15s"  # to an existing Dask scheduler


@dataclass(frozen=True)
class Job:
    """One object of a batch: everything a worker needs, and nothing big."""
    name: str
    input: str
    out_dir: str  # the object's own folder, OUT/<name>
    options: RunOptions
    options_digest: str
    force: bool = False


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


# --- keys and markers ---------------------------------------------------------------------------

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
    """The summary row stored by a finished run of this job with this key, or None."""
    folder = Path(job.out_dir)
    try:
        marker = json.loads((folder / DONE_FILE).read_text())
    except (OSError, ValueError):
        return None
    if marker.get("key") != key or not all((folder / name).is_file() for name in RESULT_FILES):
        return None
    return marker.get("row")


# --- one object (runs on a worker) --------------------------------------------------------------

def run_object(job: Job) -> dict:
    """Run one object unless it is already done; returns its summary row. Never raises for a bad object."""
    folder = Path(job.out_dir)
    try:
        key = hashlib.sha256(f"{job.options_digest}:{file_digest(job.input)}".encode()).hexdigest()
    except OSError as error:
        return _failed_row(job, f"{job.input}: cannot read file ({error.strerror or error})")
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
        _write_atomic(folder / DONE_FILE, json.dumps({
            "key": key, "input": str(Path(job.input).resolve()), "options_digest": job.options_digest,
            "skelcore_version": __version__, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "row": row,
        }, indent=1))
    except SkelError as error:
        return _failed_row(job, str(error))
    except Exception as error:  # a bug or a resource failure in one object must not stop the batch
        return _failed_row(job, _one_line(error))
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
    })
    return row


def _failed_row(job: Job, error: str) -> dict:
    row = dict.fromkeys(SUMMARY_COLUMNS)
    row.update(name=job.name, input=job.input, status="failed", error=error, reused=False)
    return row


def _one_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0]}" if text else type(error).__name__


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
    options.params.validated()
    options.skeleton_params()  # bad parameters fail before any work
    out_dir = Path(out_dir)
    jobs = plan(inputs, out_dir, options, force)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise InputError(f"{out_dir}: cannot create the output folder ({error.strerror})") from None
    from tqdm import tqdm

    rows: list[dict | None] = [None] * len(jobs)
    with tqdm(total=len(jobs), unit="obj", desc="batch", disable=not progress, file=sys.stderr) as bar:
        results = _serial(jobs) if workers is None and scheduler is None else _on_dask(jobs, workers, scheduler, bar)
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


def _on_dask(jobs: list[Job], workers: int | None, scheduler: str | None, bar) -> Iterator[tuple[int, dict]]:
    """Submit one task per object; yield the rows as they finish. Processes with one thread each: the engine
    is numpy-heavy and holds the GIL between BLAS calls (the nanny also sets OMP/MKL/OPENBLAS_NUM_THREADS=1)."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SkelError("--workers and --scheduler need Dask: pip install 'skelcore[dask]'") from None
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as error:
            raise SkelError(f"--scheduler {scheduler}: cannot connect ({_one_line(error)})") from None
        cluster = None
        if not client.scheduler_info().get("workers"):
            bar.write(f"{scheduler} has no workers yet; objects wait until one joins", file=sys.stderr)
    else:
        cluster = local_cluster(workers or _cpus())
        client = Client(cluster)
    try:
        futures = {client.submit(run_object, job, key=f"skelcore-{job.name}-{os.urandom(4).hex()}"): index
                   for index, job in enumerate(jobs)}
        for future in as_completed(futures):
            index = futures[future]
            try:
                row = future.result()
            except Exception as error:  # the worker died (e.g. out of memory) or the task could not run
                row = _failed_row(jobs[index], _one_line(error))
            future.release()
            yield index, row
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def local_cluster(workers: int):
    """A Dask cluster on this machine: `workers` processes of one thread each, reachable from 127.0.0.1 only."""
    from distributed import LocalCluster

    if workers < 1:
        raise ParameterError(f"parameter workers={workers}: must be >= 1 (or no value for one per CPU core)")
    try:
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                            dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)
    except Exception as error:
        raise SkelError(f"--workers {workers}: cannot start a local Dask cluster ({_one_line(error)})") from None


# --- summary and report -------------------------------------------------------------------------

def write_summary(out_dir, rows: list[dict], options: RunOptions) -> None:
    """summary.csv and summary.json, one row per object in input order, each written atomically."""
    out_dir = Path(out_dir)
    table = _io.StringIO()
    writer = csv.DictWriter(table, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({key: "" if value is None else value for key, value in row.items()} for row in rows)
    _write_atomic(out_dir / "summary.csv", table.getvalue())
    counts = {"objects": len(rows), "ok": sum(row["status"] == "ok" for row in rows),
              "failed": sum(row["status"] == "failed" for row in rows),
              "reused": sum(bool(row["reused"]) for row in rows)}
    document = {"skelcore_version": __version__, "options": dataclasses.asdict(options), "counts": counts,
                "columns": list(SUMMARY_COLUMNS), "objects": rows}
    _write_atomic(out_dir / "summary.json", json.dumps(document, indent=1))


def _write_report(out_dir: Path, rows: list[dict]) -> Path | None:
    """report.html: the table of every object (failed ones with their error), the figures comparing those that
    succeeded and, for a batch of moderate size, each one's figures; a report failure is one line and leaves
    the summary."""
    run_dirs = [out_dir / row["name"] for row in rows if row["status"] == "ok"]
    path = out_dir / "report.html"
    temporary = path.with_name(f".report.{os.getpid()}.tmp.html")
    try:
        from .report import write_report

        write_report(run_dirs, temporary, rows=rows)
        os.replace(temporary, path)
    except Exception as error:
        print(f"report.html not written: {_one_line(error)}", file=sys.stderr)
        return None
    finally:
        temporary.unlink(missing_ok=True)
    return path


def _cpus() -> int:
    """CPU cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _write_atomic(path: Path, text: str) -> None:
    write_atomic(path, lambda temporary: temporary.write_text(text))


# --- benchmark ----------------------------------------------------------------------------------

def bench_batch(n_objects: int = 20, workers: int = 2, n_points: int = 10_000, max_iterations: int | None = None,
                work_dir=None, out=sys.stdout) -> dict:
    """Throughput (objects per minute) of a batch of n_objects suite shapes, serial against `workers` Dask
    workers, timed in one call. The Dask figure is given with and without starting the local cluster
    (the workers' first import of skelcore stays in both). Returns the figures."""
    import tempfile

    from .params import ContractionParams
    from .shapes import SHAPES, make_shape, write_shape

    params = ContractionParams() if max_iterations is None else ContractionParams(max_iterations=max_iterations)
    options = RunOptions(params=params.validated())
    seconds = {}
    with tempfile.TemporaryDirectory(prefix="skelcore-bench-", dir=work_dir) as folder:
        shapes = Path(folder) / "shapes"
        for i in range(n_objects):
            shape = make_shape(SHAPES[i % len(SHAPES)], n_points, seed=i)
            write_shape(dataclasses.replace(shape, name=f"{i:03d}_{shape.name}"), shapes, seed=i)

        def timed(mode: str, **where) -> float:
            started = time.perf_counter()
            result = run_batch([str(shapes)], Path(folder) / mode, options, force=True, progress=False,
                               report=False, **where)
            if result.failed:
                raise SkelError(f"bench: {len(result.failed)} objects failed, first: {result.failed[0]['error']}")
            return time.perf_counter() - started

        seconds["serial"] = timed("serial")
        started = time.perf_counter()
        with local_cluster(workers) as cluster:
            seconds["cluster_start"] = time.perf_counter() - started
            seconds["dask_running"] = timed("dask", scheduler=cluster.scheduler_address)
    seconds["dask"] = seconds["cluster_start"] + seconds["dask_running"]
    per_minute = {mode: 60 * n_objects / seconds[mode] for mode in ("serial", "dask", "dask_running")}
    figures = {"objects": n_objects, "points": n_points, "workers": workers, "cpus": _cpus(), "seconds": seconds,
               "objects_per_minute": per_minute, "ratio": per_minute["dask"] / per_minute["serial"],
               "ratio_running": per_minute["dask_running"] / per_minute["serial"]}
    print(f"batch of {n_objects} shapes of {n_points} points, {figures['cpus']} CPUs", file=out)
    for mode, label in (("serial", "serial"), ("dask", f"dask x{workers} with start-up"),
                        ("dask_running", f"dask x{workers} running")):
        ratio = "" if mode == "serial" else f"  ratio {per_minute[mode] / per_minute['serial']:.2f}"
        print(f"  {label:>24}: {seconds[mode]:7.1f} s {per_minute[mode]:7.1f} objects/min{ratio}", file=out)
    return figures


def main(argv: list[str] | None = None) -> int:
    """`python -m skelcore.batch --bench`: the batch throughput benchmark."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m skelcore.batch", description=main.__doc__)
    parser.add_argument("--bench", action="store_true", required=True, help="run the throughput benchmark")
    parser.add_argument("--objects", type=int, default=20, help="shapes in the batch (default: %(default)s)")
    parser.add_argument("--workers", type=int, default=2, help="Dask workers (default: %(default)s)")
    parser.add_argument("--points", type=int, default=10_000, help="points per shape (default: %(default)s)")
    parser.add_argument("--max-iterations", type=int, default=None, help="contraction iterations cap (default: 20)")
    args = parser.parse_args(argv)
    try:
        bench_batch(args.objects, args.workers, args.points, args.max_iterations)
    except SkelError as error:
        print(f"skelcore batch bench: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
