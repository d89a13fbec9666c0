"""Serial, process-pool and Dask adapters for the engine (lazy imports).

A *runner* takes a list of tasks and returns their results in the same order. A task
is a tuple of *groups*; a group is a tuple of block specifications ``(point, rep,
block, n)`` of consecutive blocks of one (point, replicate). The result of a task is
one accumulator per group, the group's blocks merged in block order in the worker,
returned as the rows of a :class:`~microimpact.engine.summary.Stacked` (flat arrays).
The groups are fixed by the plan (``montecarlo.BLOCKS_PER_TASK`` blocks, aligned),
and a task packs consecutive groups up to a fixed number of impacts
(``montecarlo.TASK_IMPACTS``), never by the number of workers; the driver merges the
groups in key order, so the merge order - and every bit of the result - is the same
on one core, a process pool or a Dask cluster, and does not even depend on how the
groups are packed into tasks.

On this machine (``backend="process"``), more than one worker runs as threads of
this process when the plan's kernel frees the GIL (the compiled kernel, Monte
Carlo and QMC: :func:`releases_gil`), else as a process pool. The plan (tables of
~2 MB) is shared by threads, sent to each worker process once through the pool
initializer, and to Dask workers by ``Client.scatter(..., broadcast=True)``.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import itertools
import multiprocessing as mp
import os
import signal
import threading
import warnings
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from ..errors import InputError
from . import kernel
from .plan import resolve_kernel
from .summary import Stacked
from .tasks import BlockTask

_WORKER_PLAN = None
#: Seconds to wait for a Dask scheduler given by address.
DASK_CONNECT_TIMEOUT = 10


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS tells)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def cap_workers(workers: int, *, backend="process", address=None) -> int:
    """`workers`, capped at :func:`available_cores` for the local backends.

    More processes than cores only slow a run down (the kernel is compute-bound),
    so a larger request is reduced with a ``RuntimeWarning`` naming both counts. A
    remote Dask cluster (`address` given) is not capped: its size is its own.
    """
    if backend == "dask" and address is not None:
        return workers
    cores = available_cores()
    if workers > cores:
        warnings.warn(
            f"workers={workers} exceeds the {cores} core(s) available to this "
            f"process; using {cores}",
            RuntimeWarning,
            stacklevel=3,
        )
        return cores
    return workers


def _simulate(plan, specs):
    """One accumulator per block spec: ``kernel.simulate_specs`` when the kernel
    has it (one call for many small blocks), else one ``simulate_block`` each."""
    many = getattr(kernel, "simulate_specs", None)
    if many is not None:
        return many(plan, specs)
    return [kernel.simulate_block(plan, *spec) for spec in specs]


def run_task(plan, task):
    """Run the groups of one task with `plan`: one row per group of a
    :class:`~microimpact.engine.summary.Stacked` (its accumulator, the group's
    blocks merged in block order).

    Merging here rather than on the driver keeps the driver's share of the cores to
    a few microseconds per group; returning the rows as a few flat arrays rather
    than one object per group makes the result cheap to send back (one buffer per
    array, not two small arrays and a dozen numbers per group).
    """
    if isinstance(task, BlockTask) and plan.kernel == "compiled":
        # described by arrays: no tuple per block or point (tasks.py); where the
        # plan's points are parsed once, one kernel call gives the final rows
        rows = kernel.task_rows(plan, task)
        if rows is not None:
            return rows
        flat, lengths = task.specs(), task.lengths
    else:
        flat = [spec for group in task for spec in group]
        lengths = [len(g) for g in task]
    # the compiled kernel merges each group's blocks itself (no object per block)
    rows = kernel.simulate_specs_stacked(plan, flat, lengths)
    if rows is None:
        accs = iter(_simulate(plan, flat))
        out = []
        for group in task:
            acc = next(accs)
            for _ in range(len(group) - 1):
                acc = acc.merge(next(accs))
            out.append(acc)
        rows = Stacked.of(out)
    if int(rows.counts[:, 0].sum()) < 2**31:  # no histogram count can exceed it
        rows = rows.narrow()
    return rows


def task_partial(plan, task) -> tuple:
    """:func:`run_task` as a *partial result*: ``(keys, first, last, rows)`` with
    each row's (point, replicate) ``keys`` (an ``(n, 2)`` array), the first and
    last blocks it holds, and the rows themselves (one per group). Partials of
    consecutive tasks are reduced by :func:`combine_partials` on the workers."""
    rows = run_task(plan, task)
    if isinstance(task, BlockTask):
        keys = np.stack([task.point, np.zeros_like(task.point)], axis=1)
        return keys, task.first.copy(), task.last.copy(), rows
    keys = np.array([g[0][:2] for g in task], dtype=np.int64).reshape(-1, 2)
    first = np.array([g[0][2] for g in task], dtype=np.int64)
    last = np.array([g[-1][2] for g in task], dtype=np.int64)
    return keys, first, last, rows


def combine_partials(*parts) -> tuple:
    """Partial results of consecutive tasks (in task order) as one: their rows
    one after the other, a stream's groups folded where the driver would fold
    them, in the same order, so the bits are the driver's.

    The driver merges a stream's groups left to right: ``((g0 + g1) + g2) + ...``
    (:meth:`~.accumulators.PointAccumulator.merge`). A row that starts a stream
    (its first block is 0) absorbs the rows of the stream's next groups as they
    follow it, one group at a time; a row that does not start its stream stays a
    single group, to be folded onto its prefix later (by a later combination, or
    by the driver when the prefix was restored from a checkpoint). Folding
    ``g2 + g3`` first would change the last bits; concatenating rows changes
    none."""
    parts = [p for p in parts if len(p[3])]
    if not parts:
        none = np.zeros(0, dtype=np.int64)
        return none.reshape(0, 2), none, none, Stacked.of([])
    keys = np.concatenate([p[0] for p in parts])
    first = np.concatenate([p[1] for p in parts])
    last = np.concatenate([p[2] for p in parts])
    rows = Stacked.concat([p[3] for p in parts])
    follows = (
        np.flatnonzero(
            np.all(keys[1:] == keys[:-1], axis=1) & (first[1:] == last[:-1] + 1)
        )
        + 1
    )
    if follows.size == 0:
        return keys, first, last, rows
    keep = np.ones(len(rows), dtype=bool)
    head = np.arange(len(rows))  # the row each row was folded into
    folded = {}
    for j in follows.tolist():
        h = head[j - 1]
        if first[h] != 0 or last[h] + 1 != first[j]:
            continue  # not a stream's start: stays a group of its own
        acc = folded.get(h)
        if acc is None:
            acc = rows.accumulator(h)
        folded[h] = acc.merge(rows.accumulator(j))
        last[h] = last[j]
        keep[j] = False
        head[j] = h
    pieces, at = [], 0
    for h in sorted(folded):
        pieces.append(rows.slice(at, h))
        pieces.append(Stacked.of([folded[h]]))
        at = h + 1
    pieces.append(rows.slice(at, len(rows)))
    merged = Stacked.concat(pieces)  # a row per kept row, in order
    kept = np.flatnonzero(keep)
    # `merged` has every original row, the folded heads replaced: drop the
    # absorbed ones
    return keys[kept], first[kept], last[kept], merged.take(kept).narrow()


def _init_worker(plan):
    global _WORKER_PLAN
    _WORKER_PLAN = plan


def _run_task_global(task):
    return run_task(_WORKER_PLAN, task)


def _ordered(submit, tasks, in_flight):
    """Yield ``submit(task).result()`` in task order, keeping at most `in_flight`
    tasks submitted ahead (bounded memory, no barrier between waves)."""

    pending = collections.deque()
    it = iter(tasks)
    for task in it:
        pending.append(submit(task))
        if len(pending) >= in_flight:
            break
    while pending:
        result = pending.popleft().result()
        for task in it:
            pending.append(submit(task))
            break
        yield result


class SerialRunner:
    """Run tasks in this process."""

    workers = 1
    background = "now"  # see ThreadRunner.background
    local_workers = None  # see ThreadRunner.local_workers

    def __init__(self, plan):
        self.plan = plan

    def map(self, tasks):
        return [run_task(self.plan, t) for t in tasks]

    def imap(self, tasks):
        return (run_task(self.plan, t) for t in tasks)

    def close(self):
        pass


def start_method() -> str:
    """How the project starts worker processes: ``"fork"`` (instant, and the
    workers inherit the tables already built) while no other thread runs, else
    ``"forkserver"`` (``"spawn"`` on Windows)."""

    if os.name == "nt":  # pragma: no cover - not tested here
        return "spawn"
    if threading.active_count() == 1 and "fork" in mp.get_all_start_methods():
        return "fork"
    return "forkserver"


def process_pool(workers: int, **kwargs):
    """A :class:`concurrent.futures.ProcessPoolExecutor` of `workers` processes
    started with :func:`start_method` (`kwargs` go to the executor)."""

    return ProcessPoolExecutor(
        max_workers=workers, mp_context=mp.get_context(start_method()), **kwargs
    )


def map_tasks(func, items, *, workers=1, executor=None, threads=False, in_flight=None):
    """``func(item)`` for every item, yielded in order: how the engine's callers
    (runs, the wall law, sensitivity, calibration) spread work, except whole
    model evaluations on local workers where this process can fork
    (:func:`fork_pool`).

    On `executor` (anything with ``submit``, e.g. a ``concurrent.futures``
    executor or Dask's client, else ``map``); else on `workers` threads of this
    process when `threads` (the work frees the GIL: the compiled kernel, see
    :func:`releases_gil`) or a process pool; one worker runs in this process. At
    most `in_flight` items (default ``4 * workers``) are submitted ahead, so memory
    stays bounded; a pool of our own is shut down at the end (or on an error).
    """
    items = list(items)
    if in_flight is None:
        in_flight = 4 * max(int(workers), 1)
    if executor is not None:
        if hasattr(executor, "submit"):
            yield from _ordered(lambda it: executor.submit(func, it), items, in_flight)
        else:
            yield from executor.map(func, items)
        return
    workers = min(int(workers), len(items))
    if workers <= 1:
        for item in items:
            yield func(item)
        return
    pool = ThreadPoolExecutor(workers) if threads else process_pool(workers)
    try:
        yield from _ordered(lambda it: pool.submit(func, it), items, in_flight)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


#: The callable each worker process of a :func:`fork_pool` holds (set there,
#: inherited at the fork: never pickled).
_HELD = None


def _hold(func) -> None:
    global _HELD
    _HELD = func


def _call_held(item):
    return _HELD(item)


def fork_pool(workers: int, func):
    """A pool of `workers` processes forked from this one, each holding `func`
    as it is now (inherited, not pickled: a model with its tables built, a
    closure), for :func:`map_held`; None where there is nothing to spread
    (``workers <= 1``) or this process cannot fork now (:func:`start_method`:
    another thread runs, or the platform has no fork), and the caller spreads
    its work as before.

    For whole model evaluations (sensitivity's design rows, calibration's
    bootstrap refits), which hold the GIL for 40-85 % of their time (building
    their tables, the summary, the optimiser): in threads they wait for one
    another (issue 31: a design row of 20,000 impacts per point is ~41 % GIL,
    so 2 threads gave 1.26x and 16 cores 1.3-1.7x); in processes they do not
    (2 processes: 1.94x). A fork is ~10-30 ms; every worker is forked at the
    first submit (the fork context starts them all before the pool's own
    thread). Shut the pool down when done (a ``with`` block)."""
    if int(workers) <= 1 or start_method() != "fork":
        return None
    return ProcessPoolExecutor(
        max_workers=int(workers),
        mp_context=mp.get_context("fork"),
        initializer=_hold,
        initargs=(func,),
    )


def map_held(pool, items, *, in_flight=None):
    """The held callable of `pool` (:func:`fork_pool`) at every item, yielded in
    order, at most `in_flight` (default 4 per worker) submitted ahead."""
    if in_flight is None:
        in_flight = 4 * pool._max_workers
    workers = {}

    def submit(item):
        future = pool.submit(_call_held, item)
        if not workers:  # every worker is forked at the first submit
            workers.update(pool._processes or {})
        return future

    try:
        yield from _ordered(submit, items, in_flight)
    except BrokenProcessPool as err:
        # a worker killed by SIGKILL: the kernel's out-of-memory killer (an
        # environment failure), not a bug of ours (a crash ends by its own signal)
        for proc in workers.values():
            proc.join(timeout=1.0)
        if any(proc.exitcode == -signal.SIGKILL for proc in workers.values()):
            raise MemoryError(
                "a worker process was killed (SIGKILL: most likely the system's "
                "out-of-memory killer)"
            ) from err
        raise


class RunPool:
    """``map(func, items)`` (also as a call) for the model runs of one fit or
    sampler: on `executor`, else on one pool of our own, started at its first
    use with several workers and kept for every batch (threads where the runs
    free the GIL, else processes: an install without the compiled kernel
    starts its worker processes once, not once per batch). :meth:`release`
    ends it (its threads end, so that the caller may fork); the next batch
    starts it again. :meth:`close` when done."""

    def __init__(self, workers, executor=None):
        self.threads = runs_release_gil()
        self.executor = executor
        self.workers = workers if executor is not None else cap_workers(int(workers))
        self._own = None

    def map(self, func, items) -> list:
        executor = self.executor
        if executor is None and self.workers > 1:
            if self._own is None:
                self._own = (
                    ThreadPoolExecutor(self.workers)
                    if self.threads
                    else process_pool(self.workers)
                )
            executor = self._own
        return list(
            map_tasks(
                func,
                list(items),
                workers=self.workers,
                executor=executor,
                threads=self.threads,
            )
        )

    __call__ = map

    def release(self) -> None:
        if self._own is not None:
            self._own.shutdown(wait=True, cancel_futures=True)
            self._own = None

    close = release


def runs_release_gil() -> bool:
    """Whether whole runs spend their time in the compiled kernel with the GIL
    released (it is installed and chosen: every scenario runs on it since issue
    24), so that worker threads serve them (:func:`releases_gil` for a plan)."""
    return resolve_kernel() == "compiled"


def releases_gil(plan) -> bool:
    """Whether `plan`'s tasks run almost wholly outside the GIL: the compiled
    kernel (``_ckernel.specs`` frees the GIL for the whole simulation of a task,
    Monte Carlo or QMC; what holds it is ~1-2 µs of argument parsing per block,
    a QMC replicate's scrambled Sobol' sequence once per point (~0.2 ms) and the
    task's stacking). The NumPy kernel (``kernel="numpy"``, or an install without
    a C compiler) holds it for much of its time."""
    return plan.kernel == "compiled"


class ThreadRunner:
    """Run tasks on a :class:`concurrent.futures.ThreadPoolExecutor` of `workers`
    threads in this process (for plans whose kernel frees the GIL: see
    :func:`releases_gil`).

    Threads share the plan and its tables and return their rows without pickling,
    so a sweep of many small points costs no fork, no copy-on-write faults and no
    transport: on two cores a 10^4-point grid needs ~15 % less CPU in all than with
    two worker processes (docs/performance.md). The results are those of any other
    runner, bit for bit: a task's rows depend on its specs alone."""

    #: When the driver's own work that does not depend on the results (the
    #: scenario's description: SciPy quadratures, Python-heavy) may run in a
    #: thread of its own: ``"now"`` (no fork to come), ``"later"`` (after the first
    #: result: a process pool forks on its first task, and a thread must not be
    #: running then) or ``"end"`` (after the last result: here, a Python-heavy
    #: thread beside the worker threads makes them wait for the GIL after each
    #: kernel call; on a 10^4-point grid it cost ~1,500 more context switches and
    #: more time than doing its ~30 ms of work at the end).
    background = "end"
    #: What the provenance records as ``local_workers``: ``"threads"`` or
    #: ``"processes"`` for several workers on this machine, None otherwise.
    local_workers = "threads"

    def __init__(self, plan, workers: int):

        self.plan = plan
        self.workers = workers
        self._pool = ThreadPoolExecutor(
            max_workers=workers, thread_name_prefix="microimpact-worker"
        )

    def _run(self, task):
        return run_task(self.plan, task)

    def map(self, tasks):
        return list(self._pool.map(self._run, tasks))

    def imap(self, tasks):
        return _ordered(
            lambda t: self._pool.submit(self._run, t), tasks, 4 * self.workers
        )

    def close(self):
        self._pool.shutdown(wait=True, cancel_futures=True)


class PoolRunner:
    """Run tasks on a :class:`concurrent.futures.ProcessPoolExecutor`."""

    background = "later"  # see ThreadRunner.background
    local_workers = "processes"

    def __init__(self, plan, workers: int):
        self.workers = workers
        # 'fork' starts workers instantly with the tables already built, but is
        # unsafe once threads run; otherwise 'forkserver' (or 'spawn').
        method = start_method()
        if method == "fork":
            # build the first angle table and touch the kernel here, once, so that
            # forked workers inherit them instead of each building them per run
            kernel.simulate_block(plan, 0, 0, 0, 1)
        self._pool = process_pool(workers, initializer=_init_worker, initargs=(plan,))

    def map(self, tasks):
        return list(self._pool.map(_run_task_global, tasks))

    def imap(self, tasks):
        return _ordered(
            lambda t: self._pool.submit(_run_task_global, t), tasks, 4 * self.workers
        )

    def close(self):
        self._pool.shutdown(wait=True, cancel_futures=True)


class ExecutorRunner:
    """Run tasks on any user object with a ``map(fn, iterable)`` method (emcee-style
    pools, ``concurrent.futures`` executors, ``multiprocessing.Pool``...)."""

    background = "later"  # it may start processes on its first task
    local_workers = None

    def __init__(self, plan, executor):
        self.plan = plan
        self.executor = executor
        self.workers = getattr(executor, "_max_workers", None) or os.cpu_count() or 1

    def map(self, tasks):

        return list(self.executor.map(functools.partial(run_task, self.plan), tasks))

    def imap(self, tasks):

        it = iter(tasks)
        while batch := list(itertools.islice(it, 8 * self.workers)):
            yield from self.map(batch)

    def close(self):
        pass


def dask_connect(*, address=None, workers: int = 2, set_as_default: bool = True):
    """``(client, cluster)``: a Dask ``Client`` connected to the scheduler at
    `address` (``"tcp://host:8786"``; `cluster` is None), or to a new
    ``LocalCluster`` of `workers` single-threaded worker processes. The caller
    closes both (:func:`dask_client` does). An unreachable address is the user's
    :class:`~microimpact.errors.InputError`; a missing Dask an ``ImportError``
    naming the extra."""
    try:
        # deferred: optional extra [dask]
        from dask.distributed import Client, LocalCluster
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError(
            "backend='dask' requires Dask distributed: pip install 'microimpact[dask]'"
        ) from None
    if address is None:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
        )
        return Client(cluster), cluster
    try:
        return (
            Client(
                address, timeout=DASK_CONNECT_TIMEOUT, set_as_default=set_as_default
            ),
            None,
        )
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(
            f"cannot connect to a Dask scheduler at {address!r} within "
            f"{DASK_CONNECT_TIMEOUT} s ({type(exc).__name__}); give the "
            "address of a running scheduler, e.g. 'tcp://host:8786', or "
            "none to start a local cluster",
            field="address",
        ) from None


#: Clients of the schedulers runs were given by address, kept for the next run
#: (:func:`shared_dask_client`).
_SHARED_CLIENTS: dict = {}
_SHARED_LOCK = threading.Lock()


def shared_dask_client(address: str):
    """A client of the scheduler at `address`, connected once and kept for
    the runs after this one (while it is running), not set as Dask's default:
    connecting and closing a client took ~17 ms of every run on a 2-worker
    cluster, ~4 % of a run of 64 x 10^6 impacts (issue 31). Dask closes it when
    the interpreter exits."""
    with _SHARED_LOCK:
        client = _SHARED_CLIENTS.get(address)
        if client is None or client.status != "running":
            client, _ = dask_connect(address=address, set_as_default=False)
            _SHARED_CLIENTS[address] = client
        return client


@contextlib.contextmanager
def dask_client(*, address=None, workers: int = 2):
    """:func:`dask_connect` as a context manager: the client (and the local
    cluster it started) is closed on exit."""
    client, cluster = dask_connect(address=address, workers=workers)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: Tasks per Dask worker in one reduced batch (:meth:`DaskRunner.reduced`): the
#: client receives one partial result per batch, and the checkpoint is written
#: between batches.
BATCH_TASKS = 4
#: Partials combined by one reduction task.
REDUCE_FAN_IN = 8


class DaskRunner:
    """Run tasks on a Dask distributed cluster.

    Connects to `address` (``"tcp://host:8786"``) or, if None, starts a
    ``LocalCluster`` with `workers` single-threaded worker processes.
    """

    #: the cluster (a LocalCluster too) is up before the first task: no fork to
    #: come, so the driver's own work runs while the workers do theirs
    background = "now"
    local_workers = None

    def __init__(self, plan, *, address=None, workers: int = 2):
        if address is None:  # a cluster of its own, closed with the run
            self._client, self._cluster = dask_connect(workers=workers)
        else:  # the user's scheduler: its client is kept for the next run
            self._client, self._cluster = shared_dask_client(address), None
        self.workers = max(1, len(self._client.scheduler_info()["workers"]))
        [self._plan] = self._client.scatter([plan], broadcast=True)

    def map(self, tasks):
        futures = self._client.map(
            run_task, [self._plan] * len(tasks), tasks, pure=False
        )
        return self._client.gather(futures)

    def imap(self, tasks):
        return _ordered(
            lambda t: self._client.submit(run_task, self._plan, t, pure=False),
            tasks,
            4 * self.workers,
        )

    def reduced(self, tasks, *, batch=None):
        """The tasks' results reduced on the workers: tasks are submitted in
        batches of `batch` (default :data:`BATCH_TASKS` per worker); each batch's
        partials (:func:`task_partial`) are combined in order in a tree of
        :data:`REDUCE_FAN_IN` (:func:`combine_partials`, on the workers), and only
        its root comes to the client. Yields one partial per batch, in order; two
        batches are in flight, so the workers never wait for the client.

        A worker lost mid-run costs its tasks: the scheduler runs them again
        elsewhere (and any combination whose input was kept on it), each a pure
        function of the plan and its blocks, so the bits do not change."""
        if batch is None:
            batch = BATCH_TASKS * self.workers
        client, plan = self._client, self._plan

        def submit(chunk):
            futures = [
                client.submit(task_partial, plan, t, pure=False, retries=2)
                for t in chunk
            ]
            while len(futures) > 1:
                futures = [
                    client.submit(
                        combine_partials,
                        *futures[i : i + REDUCE_FAN_IN],
                        pure=False,
                        retries=2,
                    )
                    for i in range(0, len(futures), REDUCE_FAN_IN)
                ]
            return futures[0]

        pending = collections.deque()
        it = iter(tasks)
        try:
            while chunk := list(itertools.islice(it, batch)):
                pending.append(submit(chunk))
                if len(pending) >= 2:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            # an interrupted run's batches in flight: cancelled (the client
            # stays open for the next run, so closing it no longer does)
            if pending:
                client.cancel(list(pending), force=True)

    def close(self):
        if self._cluster is not None:  # (a shared client stays open)
            self._client.close()
            self._cluster.close()


BACKENDS = ("process", "dask")


def make_runner(plan, *, workers=1, backend="process", executor=None, address=None):
    """The runner for the requested parallelism (`workers` as given: the caller
    caps it with :func:`cap_workers`, once, and records the effective count)."""
    if executor is not None:
        return ExecutorRunner(plan, executor)
    if backend == "dask":
        return DaskRunner(plan, address=address, workers=workers)
    if workers == 1:
        return SerialRunner(plan)
    if releases_gil(plan):
        return ThreadRunner(plan, workers)
    return PoolRunner(plan, workers)
