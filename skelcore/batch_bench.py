"""`python -m skelcore.batch_bench`: the throughput of a batch, serial against Dask workers."""
from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

from .batch import run_batch
from .batch_dask import cpus, local_cluster
from .errors import SkelError
from .options import RunOptions


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
    figures = {"objects": n_objects, "points": n_points, "workers": workers, "cpus": cpus(), "seconds": seconds,
               "objects_per_minute": per_minute, "ratio": per_minute["dask"] / per_minute["serial"],
               "ratio_running": per_minute["dask_running"] / per_minute["serial"]}
    print(f"batch of {n_objects} shapes of {n_points} points, {figures['cpus']} CPUs", file=out)
    for mode, label in (("serial", "serial"), ("dask", f"dask x{workers} with start-up"),
                        ("dask_running", f"dask x{workers} running")):
        ratio = "" if mode == "serial" else f"  ratio {per_minute[mode] / per_minute['serial']:.2f}"
        print(f"  {label:>24}: {seconds[mode]:7.1f} s {per_minute[mode]:7.1f} objects/min{ratio}", file=out)
    return figures


def main(argv: list[str] | None = None) -> int:
    """`python -m skelcore.batch_bench`: the batch throughput benchmark."""
    import argparse

    from .cli import default_of
    from .params import ContractionParams

    parser = argparse.ArgumentParser(prog="python -m skelcore.batch_bench", description=main.__doc__)
    parser.add_argument("--objects", type=int, default=default_of(bench_batch, "n_objects"),
                        help="shapes in the batch (default: %(default)s)")
    parser.add_argument("--workers", type=int, default=default_of(bench_batch, "workers"),
                        help="Dask workers (default: %(default)s)")
    parser.add_argument("--points", type=int, default=default_of(bench_batch, "n_points"),
                        help="points per shape (default: %(default)s)")
    parser.add_argument("--max-iterations", type=int, default=None,
                        help=f"contraction iterations cap (default: {ContractionParams.max_iterations})")
    args = parser.parse_args(argv)
    try:
        bench_batch(args.objects, args.workers, args.points, args.max_iterations)
    except SkelError as error:
        print(f"skelcore batch bench: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
