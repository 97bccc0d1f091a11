"""Where rollouts run: in this process, a process pool, or a dask cluster; one interface for fitting, diagnosis,
the proof and sampling.

Every backend is a `concurrent.futures.Executor`; a task is one `Job` (a rollout and what to record), so two
workers share even a small batch. A task carries a reference to the object database (its root and dataset
roots), never the database itself: each worker process loads it once (the process pool through its initializer,
dask workers on their first task) and keeps its own Drake diagrams (`rollout.scene_for`). Results come back in
submission order and each simulation is deterministic, so the backend and the number of workers never change a
result. A failed simulation comes back as a failed `Outcome`; any other error (bad input) is raised in the
caller with its message.
"""
from __future__ import annotations

import logging

import multiprocessing
import os
from collections import deque
from concurrent.futures import Executor as FuturesExecutor
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator, Sequence

from ..errors import BridgeError
from ..odb import ObjectDatabase, load_object_database
from .rollout import Job, Outcome, RolloutCache, job_key, run_job, served

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


def run_task(job: Job, ref: OdbRef) -> Outcome:
    """One job in a worker."""
    return run_job(job, worker_odb(ref))


def expected_seconds(job: Job) -> float:
    """Simulated seconds of a job: what its cost scales with (a quasi-static replay, `Rollout.time_scale`,
    simulates its recording's span that many times faster)."""
    if job.options.end is not None:
        span = float(job.options.end)
    else:
        telemetry = job.rollout.telemetry
        span = (float(telemetry.end) if telemetry is not None else 0.0) + job.options.settle
    return span / job.rollout.time_scale


class SerialExecutor(FuturesExecutor):
    """Runs each task when it is submitted, in this process (tests, debugging, one core)."""

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to the caller through the future, like the other executors
            future.set_exception(exc)
        return future


class Executor:
    """A `concurrent.futures.Executor` and the object database its tasks use, with a rollout cache in front
    (`cache`: a job simulated once is not simulated again while its outcome is held; `cache.counts()` says how
    many were simulated and how many came from it). Use as a context manager."""

    def __init__(self, kind: str, executor: FuturesExecutor, odb: ObjectDatabase, workers: int,
                 closer: Callable[[], None], cache: RolloutCache | None = None):
        self.kind, self.executor, self.workers = kind, executor, workers
        self.odb = odb
        self.odb_ref = OdbRef.of(odb)
        self._closer = closer
        self.cache = cache if cache is not None else RolloutCache()
        _ODBS.setdefault(self.odb_ref, odb)  # serial tasks use the caller's database

    def run(self, jobs: Sequence[Job]) -> list[Outcome]:
        """Simulate every job (each distinct job once; a job whose outcome the cache holds not at all); outcomes in
        the order of `jobs`."""
        held: dict[str | int, Outcome] = {}  # answered by the cache
        todo: dict[str | int, Job] = {}  # to simulate now
        slots: list[str | int] = []
        for k, job in enumerate(jobs):
            key = job_key(job)
            ident: str | int = key if key is not None else k
            slots.append(ident)
            if ident in held or ident in todo:
                continue
            outcome = self.cache.get(key)
            if outcome is not None:
                held[ident] = outcome
            else:
                todo[ident] = job
        # longest first: the workers take jobs in submission order, so a long replay does not start last and keep
        # one worker busy while the other waits at the end of the batch
        order = sorted(todo, key=lambda ident: -expected_seconds(todo[ident]))
        futures = {ident: self.executor.submit(run_task, todo[ident], self.odb_ref) for ident in order}
        done = {ident: f.result() for ident, f in futures.items()}
        self.cache.simulated += len(done)
        for ident, outcome in done.items():
            if isinstance(ident, str):
                self.cache.put(ident, outcome)
        out, first = [], set()
        for job, ident in zip(jobs, slots):
            if ident in done and ident not in first:
                first.add(ident)
                out.append(done[ident])
            else:
                self.cache.cached += 1
                out.append(served(held.get(ident) or done[ident], job))
        return out

    def run_pruned(self, jobs: Sequence[Job], groups: Sequence[int],
                   told: Callable[[int, Outcome], Iterable[int]]) -> list[Outcome | None]:
        """The jobs in the order given, a group of them dropped as soon as `told(position, outcome)`, called with
        each outcome as it arrives, names it: the group's jobs not yet started are not simulated (None in their
        place). Only a worker's worth of jobs is submitted ahead of the workers, so a dropped job costs nothing;
        outcomes the cache holds are told at once. What was simulated is cached, dropped group or not: a caller
        that needs a dropped model after all pays only for the replays that were cut."""
        out: list[Outcome | None] = [None] * len(jobs)
        dropped: set[int] = set()
        ahead = 1 if self.kind == "serial" else self.workers + 1
        queue = deque(range(len(jobs)))
        running: dict[Future, tuple[int, str | None]] = {}

        def tell(k: int, outcome: Outcome) -> None:
            out[k] = outcome
            dropped.update(told(k, outcome))
        try:
            while queue or running:
                while queue and len(running) < ahead:
                    k = queue.popleft()
                    if groups[k] in dropped:
                        continue
                    key = job_key(jobs[k])
                    held = self.cache.get(key)
                    if held is not None:
                        self.cache.cached += 1
                        tell(k, served(held, jobs[k]))
                    else:
                        running[self.executor.submit(run_task, jobs[k], self.odb_ref)] = (k, key)
                if not running:
                    continue
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    k, key = running.pop(future)
                    if future.cancelled():
                        continue
                    outcome = future.result()
                    self.cache.simulated += 1
                    self.cache.put(key, outcome)
                    tell(k, outcome)
                for future, (k, _) in list(running.items()):
                    if groups[k] in dropped and future.cancel():
                        del running[future]
        finally:
            for future in running:
                future.cancel()
        return out

    def iterate(self, jobs: Sequence[Job]) -> Iterator[Outcome]:
        """Each job's outcome in the order of `jobs`, as soon as it (and those before it) is done; no more than a
        few jobs per worker are submitted ahead, so a caller that stops iterating (a time limit) leaves the rest
        unstarted, and those submitted but not started are cancelled. Outcomes the cache holds are not simulated."""
        ahead = 1 if self.kind == "serial" else 2 * self.workers
        pending: deque[tuple[Job, str | None, Future | Outcome]] = deque()
        queue = iter(jobs)
        try:
            while True:
                while len(pending) < ahead:
                    job = next(queue, None)
                    if job is None:
                        break
                    key = job_key(job)
                    held = self.cache.get(key)
                    pending.append((job, key, held if held is not None
                                    else self.executor.submit(run_task, job, self.odb_ref)))
                if not pending:
                    return
                job, key, item = pending.popleft()
                if isinstance(item, Outcome):
                    self.cache.cached += 1
                    yield served(item, job)
                    continue
                outcome = item.result()
                self.cache.simulated += 1
                self.cache.put(key, outcome)
                yield outcome
        finally:
            for _, _, item in pending:
                if isinstance(item, Future):
                    item.cancel()

    def close(self) -> None:
        self._closer()

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Executor({self.kind}, workers={self.workers})"


def make_executor(kind: str = "process", odb: ObjectDatabase | None = None, *, workers: int | None = None,
                  scheduler: str | None = None) -> Executor:
    """`process` (ProcessPoolExecutor, spawned workers), `dask` (a local cluster of `workers` processes, or the
    scheduler at `scheduler`) or `serial`. `workers` defaults to the number of CPUs."""
    if odb is None:
        odb = load_object_database()
    if kind not in EXECUTORS:
        raise BridgeError(f"unknown executor {kind!r}; valid: {', '.join(EXECUTORS)}")
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise BridgeError(f"workers must be a whole number >= 1, got {workers!r}")
    if scheduler is not None and kind != "dask":
        raise BridgeError("a scheduler address needs the dask executor (--executor dask)")
    n = workers or os.cpu_count() or 1
    if kind == "serial":
        return Executor("serial", SerialExecutor(), odb, 1, lambda: None)
    if kind == "process":
        pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=init_worker, initargs=(OdbRef.of(odb),))
        return Executor(kind, pool, odb, n, lambda: pool.shutdown(wait=True, cancel_futures=True))
    return _dask_executor(odb, n, scheduler)


def _dask_executor(odb: ObjectDatabase, n: int, scheduler: str | None) -> Executor:
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise BridgeError("the dask executor needs dask.distributed: pip install 'bridge[distributed]'") from None
    cluster = None
    try:
        if scheduler is not None:
            client = Client(scheduler, timeout="20s")
        else:
            import dask

            # dask's statistical profiler samples every worker thread each 10 ms, a cost on replays that run Python
            # between Drake calls (fit benchmark, best of 2: 27.4 -> 23.6 s); a remote cluster's owner configures it
            with dask.config.set({"distributed.worker.profile.enabled": False}):
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                       silence_logs=logging.ERROR)  # its INFO lines drown the progress
            client = Client(cluster)
    except (OSError, TimeoutError, ValueError) as exc:
        where = f"scheduler {scheduler}" if scheduler else "a local dask cluster"
        raise BridgeError(f"cannot connect to {where}: {exc}") from None
    workers = len(client.scheduler_info().get("workers", {})) or n
    return Executor("dask", client.get_executor(pure=False), odb, workers,
                    lambda: (client.close(), cluster.close() if cluster is not None else None))
