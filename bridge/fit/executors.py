"""Where a generation's simulations run: in this process, a process pool, or a dask cluster.

Every backend is a `concurrent.futures.Executor`; a task is one (candidate, trial) pair, so two workers share
even a small generation. A task carries its trial, the parameter spec and values, and a reference to the
object database (its root and dataset roots), never the database itself: each worker process loads it once
(the process pool through its initializer, dask workers on their first task) and keeps its own Drake diagrams
(`rollout.scene_for`). Results are collected in submission order and each simulation is deterministic, so
the backend and the number of workers never change a fit's result.
"""
from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from ..errors import FitError
from ..odb import ObjectDatabase, load_object_database
from ..sim.scene import SimConfig
from .error import DEFAULT_C
from .params import ParameterSpec
from .rollout import TrialError, evaluate_trial
from .trials import Trial

EXECUTORS = ("process", "dask", "serial")


@dataclass(frozen=True)
class OdbRef:
    """How a worker finds the object database: its root and the dataset roots (for dataset:// meshes)."""

    root: str
    datasets: tuple[tuple[str, str], ...] = ()

    @classmethod
    def of(cls, odb: ObjectDatabase) -> "OdbRef":
        return cls(str(odb.root), tuple(sorted((k, str(v)) for k, v in odb.datasets.items())))


_ODBS: dict[OdbRef, ObjectDatabase] = {}


def init_worker(ref: OdbRef) -> None:
    """Process-pool initializer: load the object database once per worker."""
    worker_odb(ref)


def worker_odb(ref: OdbRef) -> ObjectDatabase:
    if ref not in _ODBS:
        _ODBS[ref] = load_object_database(ref.root, datasets=dict(ref.datasets))
    return _ODBS[ref]


@dataclass(frozen=True)
class Task:
    trial: Trial
    spec: ParameterSpec
    x: tuple[float, ...] | None
    odb: OdbRef
    c: float = DEFAULT_C
    config: SimConfig = SimConfig()


def run_task(task: Task) -> TrialError:
    """One simulation and its error (runs in a worker)."""
    return evaluate_trial(task.trial, task.spec, task.x, odb=worker_odb(task.odb), c=task.c, config=task.config)


class SerialExecutor(Executor):
    """Runs each task when it is submitted, in this process (tests, debugging, one core)."""

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to the caller through the future, like the other executors
            future.set_exception(exc)
        return future


class FitExecutor:
    """A `concurrent.futures.Executor` plus what a fit needs to send it tasks. Use as a context manager."""

    def __init__(self, kind: str, executor: Executor, odb: ObjectDatabase, workers: int, closer: Callable[[], None]):
        self.kind, self.executor, self.workers = kind, executor, workers
        self.odb_ref = OdbRef.of(odb)
        self._closer = closer
        _ODBS.setdefault(self.odb_ref, odb)  # serial tasks use the caller's database

    def evaluate(self, trials: Sequence[Trial], spec: ParameterSpec, xs: Sequence[Sequence[float] | None], *,
                 c: float = DEFAULT_C, config: SimConfig = SimConfig()) -> list[list[TrialError]]:
        """Errors of every trial for every parameter vector (`xs[i]` in parameter units): result[i][j]."""
        futures = [[self.executor.submit(run_task, Task(t, spec, None if x is None else tuple(float(v) for v in x),
                                                        self.odb_ref, c, config)) for t in trials] for x in xs]
        return [[f.result() for f in row] for row in futures]

    def close(self) -> None:
        self._closer()

    def __enter__(self) -> "FitExecutor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"FitExecutor({self.kind}, workers={self.workers})"


def make_executor(kind: str = "process", odb: ObjectDatabase | None = None, *, workers: int | None = None,
                  scheduler: str | None = None) -> FitExecutor:
    """`process` (ProcessPoolExecutor, spawned workers), `dask` (a local cluster of `workers` processes, or the
    scheduler at `scheduler`) or `serial`. `workers` defaults to the number of CPUs."""
    if odb is None:
        odb = load_object_database()
    if kind not in EXECUTORS:
        raise FitError(f"unknown executor {kind!r}; valid: {', '.join(EXECUTORS)}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise FitError(f"workers must be a whole number >= 1, got {workers!r}")
    if scheduler is not None and kind != "dask":
        raise FitError("a scheduler address needs the dask executor (--executor dask)")
    n = workers or os.cpu_count() or 1
    if kind == "serial":
        return FitExecutor(kind, SerialExecutor(), odb, 1, lambda: None)
    if kind == "process":
        pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=init_worker, initargs=(OdbRef.of(odb),))
        return FitExecutor(kind, pool, odb, n, lambda: pool.shutdown(wait=True, cancel_futures=True))
    return _dask_executor(odb, n, scheduler)


def _dask_executor(odb: ObjectDatabase, n: int, scheduler: str | None) -> FitExecutor:
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise FitError("the dask executor needs dask.distributed: pip install 'bridge[distributed]'") from None
    cluster = None
    try:
        if scheduler is not None:
            client = Client(scheduler, timeout="20s")
        else:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
    except (OSError, TimeoutError, ValueError) as exc:
        where = f"scheduler {scheduler}" if scheduler else "a local dask cluster"
        raise FitError(f"cannot connect to {where}: {exc}") from None
    workers = len(client.scheduler_info().get("workers", {})) or n

    def close() -> None:
        client.close()
        if cluster is not None:
            cluster.close()

    return FitExecutor("dask", client.get_executor(pure=False), odb, workers, close)
