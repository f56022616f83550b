"""Running a batch's objects on Dask: a local cluster of single-threaded worker processes, or an existing one.

The work unit is one object (skelcore.batch_object.run_object). Workers read the input and write the result files
and the marker straight into OUT, and return only the small summary row: the clouds never travel through the
scheduler, a finished object survives the death of the client, and there is one writer for results (the
pipeline's). The price is that INPUTs and OUT must be on a filesystem every worker sees at the same path (always
true on one machine).
"""
from __future__ import annotations

import logging
import os
import sys
from typing import Iterator

from .batch_object import Job, failed_row, one_line, run_object
from .errors import ParameterError, SkelError
from .params import is_integer

CONNECT_TIMEOUT = "15s"  # to an existing Dask scheduler

MAX_WORKERS_PER_CPU = 8  # more single-threaded worker processes only compete for the cores (and memory)


def on_dask(jobs: list[Job], workers: int | None, scheduler: str | None, bar) -> Iterator[tuple[int, dict]]:
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
            raise SkelError(f"--scheduler {scheduler}: cannot connect ({one_line(error)})") from None
        cluster = None
        if not client.scheduler_info().get("workers"):
            bar.write(f"{scheduler} has no workers yet; objects wait until one joins", file=sys.stderr)
    else:
        cluster = local_cluster(min(workers or cpus(), max(1, len(jobs))))  # an idle worker would only start
        client = Client(cluster)
    try:
        futures = {client.submit(run_object, job, key=f"skelcore-{job.name}-{os.urandom(4).hex()}"): index
                   for index, job in enumerate(jobs)}
        for future in as_completed(futures):
            index = futures[future]
            try:
                row = future.result()
            except Exception as error:  # the worker died (e.g. out of memory) or the task could not run
                row = failed_row(jobs[index], one_line(error))
            future.release()
            yield index, row
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def check_workers(workers) -> None:
    """None (no cluster), 0 (one per CPU core) or a whole number of workers up to MAX_WORKERS_PER_CPU per core,
    else a ParameterError (checked before a batch starts)."""
    if workers is None or (workers == 0 and is_integer(workers)):
        return
    if not is_integer(workers) or not 1 <= workers <= MAX_WORKERS_PER_CPU * cpus():
        raise ParameterError(f"parameter workers={workers!r}: must be between 1 and {MAX_WORKERS_PER_CPU * cpus()} "
                             f"({MAX_WORKERS_PER_CPU} per CPU core; no value: one per core)")


def local_cluster(workers: int):
    """A Dask cluster on this machine: `workers` processes of one thread each, reachable from 127.0.0.1 only."""
    from distributed import LocalCluster

    check_workers(workers)
    try:
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                            dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)
    except Exception as error:
        raise SkelError(f"--workers {workers}: cannot start a local Dask cluster ({one_line(error)})") from None


def cpus() -> int:
    """CPU cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
