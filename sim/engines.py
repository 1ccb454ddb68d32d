"""Where a campaign's runs execute: a process pool on this machine, or a Dask cluster.

Both engines offer the same two calls, ``submit(fn, *args)`` returning a future and
``as_completed(futures)`` yielding them as they finish, so the campaign code is one path.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os

#: One BLAS/OpenMP thread per worker process: more threads than cores oversubscribe the
#: machine (the Makefile sets the same).
SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def single_threaded_workers() -> None:
    """Set the thread counts in this process's environment, which the workers it starts inherit
    before they import numpy."""
    os.environ.update(SINGLE_THREADED)


class LocalEngine:
    """A pool of ``workers`` fresh processes (spawned, so they read the environment set here)."""

    name = "local"

    def __init__(self, workers: int | None = None):
        single_threaded_workers()
        self.workers = workers or os.cpu_count() or 1
        self._pool = concurrent.futures.ProcessPoolExecutor(
            self.workers, mp_context=multiprocessing.get_context("spawn"))

    def submit(self, fn, *args):
        return self._pool.submit(fn, *args)

    def as_completed(self, futures):
        return concurrent.futures.as_completed(futures)

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class DaskEngine:
    """A Dask distributed client: to the scheduler at ``scheduler``, or to a ``LocalCluster`` of
    ``workers`` single-threaded worker processes started here (and stopped on close).

    Workers of a remote cluster load the worlds and write the run folders themselves: they need
    gpexplore installed, the world files and the output folder at the same paths.
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, workers: int | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ImportError("the dask engine needs Dask distributed: "
                              "pip install 'gpexplore[cluster]'") from None
        self._cluster = None
        if scheduler is None:
            single_threaded_workers()
            self._cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                         processes=True, dashboard_address=None)
            self._client = Client(self._cluster)
        else:
            self._client = Client(scheduler)
        self.workers = len(self._client.scheduler_info()["workers"])

    def submit(self, fn, *args):
        # every run is its own task, even when its arguments repeat (a retry)
        return self._client.submit(fn, *args, pure=False)

    def as_completed(self, futures):
        from distributed import as_completed

        return as_completed(list(futures))

    def close(self) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def make_engine(name: str, workers: int | None = None, scheduler: str | None = None):
    """The engine called ``name`` ("local" or "dask")."""
    if name == "local":
        if scheduler is not None:
            raise ValueError("a scheduler address needs the dask engine")
        return LocalEngine(workers)
    if name == "dask":
        return DaskEngine(scheduler, workers)
    raise ValueError(f"unknown engine '{name}' (have: local, dask)")
