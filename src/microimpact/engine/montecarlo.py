"""The Monte Carlo driver: ``iter_blocks`` (a generator) and ``run`` (drains it).

Work is split into blocks of :data:`~microimpact.engine.plan.BLOCK_SIZE` impacts. Block
``b`` of sweep point ``p`` draws variable ``v`` from the stream
``SeedSequence(entropy, spawn_key=(p, b, v))``; blocks are grouped into tasks for the
workers and their accumulators are merged on the driver in (point, replicate, block)
order. Hence one seed reproduces a run bit for bit, serially, on a process pool or on
a Dask cluster, whatever the worker count, and whether or not the run was interrupted
and resumed from its checkpoint.

The driver is made of small pieces with one job each:

* :class:`_Streams` holds the merged prefix of every (point, replicate) and merges
  the next group of blocks (the only place results are combined);
* :func:`_fixed_tasks` and :func:`_precision_wave` schedule the remaining blocks
  into tasks (:func:`_pack`);
* :class:`~microimpact.engine.checkpoint.Checkpoint` restores, and decides when to
  write;
* :class:`_Job` wires them together for :func:`iter_blocks` and :func:`run`.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import itertools
import math
import os
import threading
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from .._core.progress import Progress, check_progress, stage
from .._core.validation import check_choice, check_int
from ..errors import ConvergenceWarning, InputError
from ..scenario.scenario import as_scenario
from .accumulators import PointAccumulator
from .checkpoint import (
    Checkpoint,
    CheckpointWarning,
    StackedState,
    plan_fingerprint,
)
from .kernel import simulate_block
from .parallel import (
    BACKENDS,
    _simulate,
    available_cores,
    cap_workers,
    make_runner,
)
from .plan import BLOCK_SIZE, Plan, build_plan, resolve_entropy  # noqa: F401
from .result import SimulationResult
from .statistics import wilson_interval, z_value
from .summary import Stacked

__all__ = [
    "BlockResult",
    "Checkpoint",
    "CheckpointWarning",
    "estimate_duration",
    "iter_blocks",
    "run",
    "sample_point",
]

#: Consecutive blocks merged into one group in a worker (aligned on multiples of it):
#: an algorithm constant like the block size. It fixes the merge order, so the bits
#: depend on it, never on the workers or the backend.
BLOCKS_PER_TASK = 64
#: A task packs consecutive groups (of any points) until it holds this many impacts
#: (16 full blocks, ~10-20 ms of kernel: far above the ~0.3 ms of driver CPU a task
#: costs to send, receive and merge, small enough to keep every worker busy) or
#: :data:`TASK_GROUPS` groups, so a sweep of many small points costs one task per
#: ~524,000 impacts, not one per point; a full group of 64 blocks is a task alone.
#: (8 blocks made a 100 x 100 grid at 4,000 per point 9 % slower on 2 cores.) The
#: packing does not change any bit: each group's accumulator is returned and merged
#: on the driver in key order.
TASK_IMPACTS = 16 * BLOCK_SIZE
#: Points :func:`estimate_duration` times in one calibration batch (at most).
CALIBRATION_POINTS = 2048
#: Impacts of that batch (at most, unless 16 points of one block hold more).
CALIBRATION_IMPACTS = 2**22
#: Most groups per task (bounds a task's result when points have very few samples).
TASK_GROUPS = 2048
#: Least seconds between checkpoint writes (override:
#: MICROIMPACT_CHECKPOINT_INTERVAL); writes are further spaced to take at most
#: ``checkpoint.WRITE_FRACTION`` of the run time.
CHECKPOINT_INTERVAL = 2.0


def checkpoint_interval() -> float:
    """Least seconds between checkpoint writes: ``MICROIMPACT_CHECKPOINT_INTERVAL``
    if set (a positive number), else :data:`CHECKPOINT_INTERVAL`."""
    raw = os.environ.get("MICROIMPACT_CHECKPOINT_INTERVAL")
    if raw is None or not raw.strip():
        return CHECKPOINT_INTERVAL
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(
            f"environment variable MICROIMPACT_CHECKPOINT_INTERVAL={raw!r} is not "
            "a positive number of seconds",
            field="MICROIMPACT_CHECKPOINT_INTERVAL",
        )
    return value


@dataclass(frozen=True)
class BlockResult:
    """One merged group, as yielded by :func:`iter_blocks`: a block, or (fixed-size
    runs) a group of up to ``BLOCKS_PER_TASK`` consecutive blocks."""

    point: int
    replicate: int
    block: int  # the last block merged
    accumulator: PointAccumulator | None  # these blocks alone (None: restored)
    total: PointAccumulator  # all blocks of (point, replicate) merged so far
    done: bool  # no more blocks will follow for (point, replicate)


# ----------------------------------------------------------------- driver state
class _Stream:
    """Driver-side state of one (point, replicate): blocks ``[0, next_block)`` are
    merged into `acc`.

    A stream whose first group is merged keeps that group's row of its task's
    :class:`~.summary.Stacked` (``row``), not an accumulator object: a sweep of
    many small points, each one group, never builds one per point. :attr:`acc`
    builds it on first use (a later merge, a convergence test, a checkpoint)."""

    __slots__ = ("_acc", "done", "index", "max_samples", "next_block", "row")

    def __init__(self, max_samples: int, index: int = 0):
        self.max_samples = max_samples  # the target, or the cap of a precision target
        self.index = index  # the stream's place in key order
        self.next_block = 0
        self._acc: PointAccumulator | None = None
        self.row: tuple | None = None  # (Stacked, index) while it is the only group
        self.done = False

    @property
    def acc(self) -> PointAccumulator | None:
        if self._acc is None and self.row is not None:
            rows, i = self.row
            self._acc = rows.accumulator(i)
        return self._acc

    @acc.setter
    def acc(self, value: PointAccumulator | None) -> None:
        self._acc = value
        self.row = None

    def samples_done(self) -> int:
        if self.row is not None:
            rows, i = self.row
            return int(rows.counts[i, 0])
        return self._acc.n if self._acc is not None else 0


def _converged(acc: PointAccumulator, precision, confidence) -> bool:
    if acc.n < precision.min_samples:
        return False
    stat = precision.statistic
    if stat == "capture_fraction":
        lo, hi = wilson_interval(acc.captured, acc.impacts, confidence)
        hw = (float(hi) - float(lo)) / 2.0
    else:
        m = {"e_mean": acc.e_all(), "e_rebound_mean": acc.e, "mu_mean": acc.mu}[stat]
        hw = z_value(confidence) * math.sqrt(m.variance / m.n) if m.n > 1 else math.inf
    return hw <= precision.half_width


class _Streams:
    """The merged prefix of every (point, replicate), in key order; merges groups.

    Merging is the only place results are combined, always in block order, so the
    bits depend on the plan alone.
    """

    def __init__(self, plan: Plan, n_target, precision, confidence):
        self.block_size = plan.block_size
        self.precision = precision
        self.confidence = confidence
        caps = _caps(plan, n_target, precision)
        self.by_key = {key: _Stream(caps[key], k) for k, key in enumerate(sorted(caps))}
        # the task rows that hold streams' totals (kept alive here), and per stream
        # in key order: which of them and which row (-1: none, see `acc`)
        self._chunks: list[Stacked] = []
        self._chunk_ids: dict[int, int] = {}
        self._src_chunk = [-1] * len(self.by_key)
        self._src_row = [0] * len(self.by_key)

    def n_blocks(self, st: _Stream) -> int:
        return -(-st.max_samples // self.block_size)

    def specs(self, key, start: int, stop: int) -> tuple:
        """Block specifications ``(point, rep, block, n)`` for blocks start..stop-1."""
        cap, B = self.by_key[key].max_samples, self.block_size
        return tuple((*key, b, min(B, cap - b * B)) for b in range(start, stop))

    @property
    def total_blocks(self) -> int:
        return sum(self.n_blocks(st) for st in self.by_key.values())

    @property
    def merged_blocks(self) -> int:
        return sum(st.next_block for st in self.by_key.values())

    def samples_done(self) -> int:
        return sum(st.samples_done() for st in self.by_key.values())

    def active(self) -> list:
        return [k for k, st in self.by_key.items() if not st.done]

    def restore(self, saved: dict) -> None:
        """Take the prefixes of a checkpoint (keys of this run only)."""
        for key, (nxt, acc) in saved.items():
            st = self.by_key.get(key)
            if st is None:
                continue
            st.next_block, st.acc = nxt, acc
            st.done = self._finished(st)

    def _finished(self, st: _Stream) -> bool:
        if st.next_block >= self.n_blocks(st):
            return True
        return self.precision is not None and _converged(
            st.acc, self.precision, self.confidence
        )

    def finished_results(self) -> Iterator[BlockResult]:
        """The (point, replicate) already done (restored), as they were."""
        for (p, r), st in self.by_key.items():
            if st.done:
                yield BlockResult(p, r, st.next_block - 1, None, st.acc, True)

    def merge(self, group: tuple, rows: Stacked, i: int) -> _Stream | None:
        """Merge `group` (its accumulator: row `i` of `rows`) if its first block is
        the next one of its stream; returns the stream, or None if the stream is
        done or the group is not next (blocks run after convergence: discarded,
        deterministically)."""
        point, rep, first, _n = group[0]
        st = self.by_key[(point, rep)]
        if st.done or first != st.next_block:
            return None
        if first == 0:
            # nothing merged before: the group's row is the stream's total
            st.row = (rows, i)
            c = self._chunk_ids.get(id(rows))
            if c is None:
                c = self._chunk_ids[id(rows)] = len(self._chunks)
                self._chunks.append(rows)
            self._src_chunk[st.index] = c
            self._src_row[st.index] = i
        else:
            st.acc = st.acc.merge(rows.accumulator(i))
            self._src_chunk[st.index] = -1
        st.next_block = group[-1][2] + 1
        st.done = self._finished(st)
        return st

    def stacked(self) -> Stacked:
        """The accumulator of every (point, replicate), as the rows of one
        :class:`~.summary.Stacked` in key order (point-major). Streams still held
        as a task's row are gathered from their tasks' arrays, not rebuilt."""
        chunk = np.array(self._src_chunk, dtype=np.intp)
        row = np.array(self._src_row, dtype=np.intp)
        parts = list(self._chunks)
        loose = np.flatnonzero(chunk < 0)
        if loose.size:  # merged from several groups, restored, or never run
            streams = list(self.by_key.values())  # key order
            accs = [streams[k].acc for k in loose.tolist()]
            held = [j for j, a in enumerate(accs) if a is not None]
            if held:
                chunk[loose[held]] = len(parts)
                row[loose[held]] = np.arange(len(held))
                parts.append(Stacked.of(accs[j] for j in held))
            if len(held) < loose.size:  # never run: one empty row, taken repeatedly
                empty = np.setdiff1d(np.arange(loose.size), held, assume_unique=True)
                chunk[loose[empty]] = len(parts)
                row[loose[empty]] = 0
                parts.append(Stacked.of([PointAccumulator()]))
        if not parts:
            return Stacked.of([])
        first = np.zeros(len(parts), dtype=np.intp)
        np.cumsum([len(p) for p in parts[:-1]], out=first[1:])
        return Stacked.concat(parts).take(first[chunk] + row)

    def state(self) -> StackedState:
        """What the checkpoint keeps: every (point, replicate) with merged work, its
        next block and its accumulator, as arrays gathered from the task rows
        (:meth:`stacked`). No accumulator object is built for a stream still held
        as a task's row, so a checkpoint of a 10^6-point sweep costs arrays, not
        10^6 objects kept for the rest of the run."""
        streams = list(self.by_key.values())  # key order
        has = np.fromiter(
            (st.row is not None or st._acc is not None for st in streams),
            dtype=bool,
            count=len(streams),
        )
        rows = np.flatnonzero(has)
        keys = np.array(list(self.by_key), dtype=np.int64).reshape(-1, 2)[rows]
        next_block = np.fromiter(
            (st.next_block for st in streams), dtype=np.int64, count=len(streams)
        )[rows]
        return StackedState(keys, next_block, self.stacked().take(rows))

    def unconverged(self) -> list:
        return [
            p
            for (p, _r), st in self.by_key.items()
            if st.acc is None or not _converged(st.acc, self.precision, self.confidence)
        ]


def _caps(plan, n_target, precision) -> dict:
    """Samples (or the cap of a precision target) of every (point, replicate)."""
    if precision is not None:
        cap = precision.max_samples
    else:
        cap = math.ceil(n_target / plan.replicates)
    return {
        (sp.index, rep): cap for sp in plan.points for rep in range(plan.replicates)
    }


# ------------------------------------------------------------------- scheduling
def _pack(groups, max_groups=None) -> Iterator[tuple]:
    """Consecutive groups packed into tasks of up to :data:`TASK_IMPACTS` impacts
    or `max_groups` (default :data:`TASK_GROUPS`) groups; a larger group is a task
    alone. `groups` yields ``(group, impacts)``. Packing is transport only: it
    changes no bit."""
    max_groups = TASK_GROUPS if max_groups is None else min(max_groups, TASK_GROUPS)
    task, impacts = [], 0
    for group, n in groups:
        task.append(group)
        impacts += n
        if impacts >= TASK_IMPACTS or len(task) >= max_groups:
            yield tuple(task)
            task, impacts = [], 0
    if task:
        yield tuple(task)


def _fixed_tasks(streams: _Streams) -> Iterator[tuple]:
    """The remaining blocks of a fixed-size run, in key order: groups of
    :data:`BLOCKS_PER_TASK` blocks aligned on multiples of it (so a resumed run groups
    as an uninterrupted one), packed into tasks."""
    T, B = BLOCKS_PER_TASK, streams.block_size

    def groups():
        for key in sorted(streams.by_key):
            st = streams.by_key[key]
            if st.done:
                continue
            point, rep = key
            cap = st.max_samples
            stop = -(-cap // B)
            last = cap - (stop - 1) * B  # impacts of the last block
            start = st.next_block
            while start < stop:
                end = min((start // T + 1) * T, stop)
                if end < stop:
                    group = tuple((point, rep, b, B) for b in range(start, end))
                    yield group, (end - start) * B
                else:
                    group = (
                        *((point, rep, b, B) for b in range(start, end - 1)),
                        (point, rep, end - 1, last),
                    )
                    yield group, (end - 1 - start) * B + last
                start = end

    return _pack(groups())


def _precision_wave(streams: _Streams, per_key: int, workers: int) -> list[tuple]:
    """The next `per_key` blocks of every unfinished stream, one block per group
    (convergence is decided block by block), packed into at least ``4 workers``
    tasks when there are enough blocks (a wave is short: every worker gets some)."""
    groups = []
    for key in streams.active():
        st = streams.by_key[key]
        stop = min(st.next_block + per_key, streams.n_blocks(st))
        groups.extend(
            ((spec,), spec[3]) for spec in streams.specs(key, st.next_block, stop)
        )
    return list(_pack(groups, max(1, len(groups) // (4 * workers))))


# ------------------------------------------------------------------- one run
class _Job:
    """One run: validated arguments, the plan, the streams, the checkpoint."""

    def __init__(
        self,
        scenario,
        *,
        samples,
        seed,
        workers,
        backend,
        executor,
        address,
        checkpoint,
        progress,
        plan,
    ):

        self.scenario = scenario = as_scenario(scenario)
        if samples is not None:
            samples = check_int(samples, "samples")
        self.workers_requested = check_int(workers, "workers")
        check_choice(backend, "backend", BACKENDS)
        self.backend, self.executor, self.address = backend, executor, address
        self.workers = self.workers_requested
        if executor is None:
            self.workers = cap_workers(
                self.workers_requested, backend=backend, address=address
            )
        self.samples = samples
        if plan is None:
            with stage("planning the sweep"):  # ~3 s at 10^6 points
                plan = build_plan(scenario, seed=seed)
        self.plan = plan
        self.precision = scenario.precision if samples is None else None
        n_target = samples if samples is not None else scenario.samples
        self.streams = _Streams(
            self.plan, n_target, self.precision, scenario.confidence
        )
        self.checkpoint = None
        if checkpoint is not None:
            self.checkpoint = (
                checkpoint
                if isinstance(checkpoint, Checkpoint)
                else Checkpoint(checkpoint)
            )
            self._fingerprint = plan_fingerprint(
                self.plan,
                (
                    n_target,
                    self.plan.replicates,
                    None if self.precision is None else vars(self.precision),
                ),
            )
        self.progress = check_progress(progress)
        self.resumed_blocks = 0
        #: how several local workers ran: "threads" or "processes" (None: one
        #: worker, an executor or Dask)
        self.local_workers = None
        self._background = None  # see in_background
        self._background_policy = "now"  # the runner's (see _start_background)

    def provenance(self) -> dict:
        out = {
            "resumed_blocks": self.resumed_blocks,
            "total_blocks": self.streams.total_blocks,
        }
        if self.workers != self.workers_requested:
            out["workers_requested"] = self.workers_requested
        if self.local_workers is not None:
            out["local_workers"] = self.local_workers
        return out

    def blocks(self) -> Iterator[BlockResult]:
        """Run the remaining blocks, yielding each merged group in key order."""
        yield from self._drive(results=True)

    def drain(self) -> Stacked:
        """Run the remaining blocks; the accumulator of every (point, replicate), as
        :meth:`_Streams.stacked` (no per-group result objects are built)."""
        for _ in self._drive(results=False):
            pass
        return self.streams.stacked()

    def _drive(self, *, results: bool) -> Iterator[BlockResult]:
        streams, ck = self.streams, self.checkpoint
        if ck is not None:
            streams.restore(ck.open(self._fingerprint, interval=checkpoint_interval()))
            self.resumed_blocks = streams.merged_blocks
            ck.started(self.resumed_blocks, streams.total_blocks)
        if results:
            yield from streams.finished_results()
        if not streams.active():
            self._start_background()
            return  # everything was restored from the checkpoint: no workers needed
        fixed = self.precision is None
        runner = make_runner(
            self.plan,
            workers=self.workers,
            backend=self.backend,
            executor=self.executor,
            address=self.address,
        )
        self.local_workers = runner.local_workers
        self._background_policy = runner.background
        if runner.background == "now":
            self._start_background()  # no fork to come: the kernel frees the GIL
        bar = Progress(
            self.progress,
            total=sum(st.max_samples for st in streams.by_key.values())
            if fixed
            else None,
            unit="impacts",
            desc=self.scenario.name,
            initial=streams.samples_done(),
        )
        try:
            if fixed:
                tasks, todo = itertools.tee(_fixed_tasks(streams))
                for task, rows in zip(todo, runner.imap(tasks), strict=True):
                    # the workers have started (a pool forks on its first task)
                    self._start_background()
                    yield from self._merge(
                        zip(task, itertools.repeat(rows), range(len(task))),
                        bar,
                        results,
                    )
            else:
                per_key = max(1, runner.workers * 2)
                while streams.active():
                    wave = _precision_wave(streams, per_key, runner.workers)
                    done = {}
                    for task, rows in zip(wave, runner.map(wave), strict=True):
                        for i, group in enumerate(task):
                            done[group] = (rows, i)
                    self._start_background()
                    yield from self._merge(
                        ((g, *done[g]) for g in sorted(done)), bar, results
                    )
        finally:
            # normal end, an exception, Ctrl-C or the caller closing the generator:
            # keep everything merged so far (the state is consistent between yields)
            try:
                if ck is not None:
                    ck.write(streams.state())
            finally:
                runner.close()
                bar.close()
        if not fixed:
            self._warn_unconverged()

    def _merge(self, items, bar, results) -> Iterator[BlockResult]:
        """Merge ``(group, rows, i)`` items in order; with `results`, yield a
        :class:`BlockResult` for each group merged."""
        merge = self.streams.merge
        n = 0
        for group, rows, i in items:
            st = merge(group, rows, i)
            if st is None:
                continue
            n += int(rows.counts[i, 0])
            if results:
                bar.update(n)
                n = 0
                yield BlockResult(
                    group[0][0],
                    group[0][1],
                    group[-1][2],
                    rows.accumulator(i),
                    st.acc,
                    st.done,
                )
        bar.update(n)
        ck = self.checkpoint
        if ck is not None and ck.due():
            ck.write(self.streams.state())

    # ------------------------------------------------------------ background
    def in_background(self, fn) -> None:
        """Run `fn` in a thread while the workers run (driver work that does not
        depend on the results, e.g. the scenario's description); its value is
        :meth:`background_result`. The thread starts once no fork is to come (a
        process pool forks on its first task: a thread must not be running then)."""
        self._background = _Background(fn)

    def _start_background(self) -> None:
        """Start the background work unless the runner wants it at the end
        (:attr:`~.parallel.ThreadRunner.background`): then
        :meth:`background_result` computes it in the caller."""
        if self._background is not None and self._background_policy != "end":
            self._background.start()

    def background_result(self):
        return self._background.result()

    def _warn_unconverged(self):
        short = self.streams.unconverged()
        if not short:
            return
        pts = ", ".join(
            f"({sp.surface_name}, {sp.speed} m/s, {sp.angle_deg} deg)"
            for sp in (self.plan.points[p] for p in short[:5])
        )
        precision = self.precision
        warnings.warn(
            f"{len(short)} sweep point(s) did not reach the precision target "
            f"{precision.half_width} on {precision.statistic} within "
            f"max_samples={precision.max_samples}: {pts}",
            ConvergenceWarning,
            stacklevel=3,
        )


#: While :func:`run` drives a run, the interpreter's full collections (the oldest
#: generation: every object of the process, ~75 ms with NumPy, SciPy and xarray
#: loaded) wait until the end; the young generations, where the driver's and the
#: tasks' short-lived objects die, are collected as usual.
_GC_LOCK = threading.Lock()
_GC_STATE = {"depth": 0, "saved": None}
_GC_DEFERRED = 1 << 30


@contextlib.contextmanager
def _defer_full_collections():
    """Defer the oldest generation's automatic collections (re-entrant, shared by
    concurrent runs: the thresholds are restored when the last one ends, unless the
    program changed them meanwhile). Forked workers inherit the setting."""
    with _GC_LOCK:
        if _GC_STATE["depth"] == 0:
            saved = gc.get_threshold()
            _GC_STATE["saved"] = saved
            if saved[0] > 0:
                gc.set_threshold(saved[0], saved[1], _GC_DEFERRED)
        _GC_STATE["depth"] += 1
    try:
        yield
    finally:
        with _GC_LOCK:
            _GC_STATE["depth"] -= 1
            if _GC_STATE["depth"] == 0:
                saved = _GC_STATE["saved"]
                if gc.get_threshold() == (saved[0], saved[1], _GC_DEFERRED):
                    gc.set_threshold(*saved)


class _Background:
    """A function run once in a daemon thread, or in the caller if never started."""

    def __init__(self, fn):
        self._fn = fn
        self._thread = None
        self._value = None
        self._error = None

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(
                target=self._run, name="microimpact-driver", daemon=True
            )
            self._thread.start()

    def _run(self) -> None:
        try:
            self._value = self._fn()
        except BaseException as exc:  # re-raised in the caller by result()
            self._error = exc

    def result(self):
        if self._thread is None:
            return self._fn()
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


def iter_blocks(
    scenario,
    *,
    samples=None,
    seed=None,
    workers=1,
    backend="process",
    executor=None,
    address=None,
    checkpoint=None,
    progress=None,
    plan=None,
) -> Iterator[BlockResult]:
    """Run the simulation block by block, yielding each merged group in key order.

    Arguments are those of :func:`run`. Stopping the iteration early leaves the
    checkpoint (if any) holding everything merged so far.
    """
    job = _Job(
        scenario,
        samples=samples,
        seed=seed,
        workers=workers,
        backend=backend,
        executor=executor,
        address=address,
        checkpoint=checkpoint,
        progress=progress,
        plan=plan,
    )
    yield from job.blocks()


def run(
    scenario,
    *,
    samples=None,
    seed=None,
    workers=1,
    backend="process",
    executor=None,
    address=None,
    checkpoint=None,
    progress=None,
):
    """Run a Monte Carlo study.

    Parameters
    ----------
    scenario : Scenario, path or str
        The study (see :class:`microimpact.Scenario`), a scenario file or a preset
        name.
    samples : int, optional
        Impacts per sweep point; overrides the scenario's count and its precision
        target.
    seed : int, optional
        Root seed; overrides the scenario's. None (and no scenario seed) draws fresh
        entropy, which is recorded in the result.
    workers : int, default 1
        Workers on this machine (``backend="process"``) or Dask workers for a
        local cluster (``backend="dask"``); more than the available cores is
        capped with a ``RuntimeWarning``. On this machine the workers are threads
        when the compiled kernel runs the plan (it frees the GIL: no fork, no
        transport), else processes; the provenance's ``local_workers`` says which.
        Either gives the same bits.
    backend : {"process", "dask"}
    executor : object with ``map``, optional
        Any pool (``concurrent.futures`` executor, ``multiprocessing.Pool``,
        emcee-style pool); overrides `workers` and `backend`.
    address : str, optional
        Dask scheduler address; None starts a ``LocalCluster``.
    checkpoint : path or Checkpoint, optional
        File that keeps finished work; re-running with the same arguments resumes.
        Pass a :class:`~microimpact.engine.checkpoint.Checkpoint` to learn what was
        restored (``restored_blocks``, ``total_blocks``, ``rejected``). A file of
        another run is moved aside with a ``CheckpointWarning``.
    progress : bool or callable, optional
        ``True`` shows a progress bar (tqdm, on stderr), ``False`` nothing, a
        callable is called with ``(impacts done, total)`` as blocks finish;
        default: a bar only when stderr is a terminal.

    Returns
    -------
    SimulationResult
        Its provenance records ``resumed_blocks`` (0 for a fresh run),
        ``total_blocks`` and the effective ``workers``.
    """

    t0 = time.perf_counter()
    with _defer_full_collections():
        job = _Job(
            scenario,
            samples=samples,
            seed=seed,
            workers=workers,
            backend=backend,
            executor=executor,
            address=address,
            checkpoint=checkpoint,
            progress=progress,
            plan=None,
        )
        # what the result needs of the scenario alone is prepared while the
        # workers run
        job.in_background(functools.partial(SimulationResult.prepare, job.scenario))
        stacked = job.drain()
        elapsed = time.perf_counter() - t0
        return SimulationResult.from_stacked(
            job.scenario,
            job.plan,
            stacked,
            elapsed=elapsed,
            samples=samples,
            workers=job.workers,
            backend=backend if executor is None else "executor",
            provenance=job.provenance(),
            prepared=job.background_result(),
        )


# ------------------------------------------------------------------ estimate
def estimate_duration(scenario, *, samples=None, workers=1, seed=None, plan=None):
    """Rough wall time of :func:`run` [s], from a timed calibration batch.

    Times, in this process, one batch (one kernel call, as the run's tasks make
    them) of a first block of up to a full block size at
    :data:`CALIBRATION_POINTS` points spread evenly over the sweep (all of them in
    a smaller sweep), twice: the first time builds the tables of their (surface,
    angle) pairs, the second gives the cost of a block alone; then a block of one
    impact and one of up to a full block size at the first point (their
    difference: the cost per impact). These are scaled to the whole run (every
    block of every point, a pair's tables once per pair) and divided by the
    effective worker count (capped at the available cores). A
    precision target is costed at its ``max_samples`` (an upper bound). Costs
    about twice the calibration batch and two blocks, plus the plan (pass `plan`
    to reuse one). It leaves out the driver's merging and the outputs (summary,
    files, figures; ``docs/performance.md`` has their cost at scale). Meant to
    warn that a run will take minutes or hours, not to schedule it.
    """

    scenario = as_scenario(scenario)
    workers = min(check_int(workers, "workers"), available_cores())
    t = time.perf_counter()
    built = plan is None
    plan = build_plan(scenario, seed=seed) if built else plan
    plan_s = time.perf_counter() - t if built else 0.0  # the run builds it too
    if samples is None:
        precision = scenario.precision
        n = precision.max_samples if precision is not None else scenario.samples
    else:
        n = check_int(samples, "samples")
    per_rep = math.ceil(n / plan.replicates)
    streams = len(plan.points) * plan.replicates
    blocks = math.ceil(per_rep / plan.block_size)
    probe = min(per_rep, plan.block_size)

    def timed(specs, repeat=1, simulate=_simulate):
        best = math.inf
        for _ in range(repeat):
            t = time.perf_counter()
            simulate(plan, specs)
            best = min(best, time.perf_counter() - t)
        return best

    # points enough to amortise the batch's fixed cost, impacts few enough to be
    # quick (~0.1 s at 40 M impacts/s)
    k = max(min(CALIBRATION_IMPACTS // probe, CALIBRATION_POINTS), 16)
    k = min(len(plan.points), k)
    spread = np.unique(np.round(np.linspace(0, len(plan.points) - 1, k)).astype(int))
    specs = [(int(p), 0, 0, probe) for p in spread]
    cold = timed(specs, simulate=_calibration_batch)  # their tables are built
    warm = timed(specs, simulate=_calibration_batch)  # a block's cost, batched
    one = timed([(0, 0, 0, 1)], repeat=3)  # the call's overhead cancels below
    per_impact = max(timed([(0, 0, 0, probe)], repeat=2) - one, 0.0) / max(probe - 1, 1)
    per_block = max(warm / spread.size - probe * per_impact, 0.0)
    # a point's tables are those of its (surface, angle): built once per pair
    pairs = {(plan.points[p].surface, plan.points[p].angle_deg) for p, *_ in specs}
    per_table = max(cold - warm, 0.0) / len(pairs)
    tables = len({(p.surface, p.angle_deg) for p in plan.points})
    total = streams * (blocks * per_block + per_rep * per_impact)
    return plan_s + (total + tables * per_table) / workers


def _calibration_batch(plan, specs):
    """The first blocks `specs` ``(point, 0, 0, n)`` (one `n` for all) run as
    :func:`run` runs them in one worker: a run of the plan restricted to those
    points, its tasks packed, simulated and merged by the driver (the calibration
    batch of :func:`estimate_duration`)."""
    # the streams of those points only; the kernel reads the whole plan
    sub = replace(plan, points=tuple(plan.points[p] for p, *_ in specs))
    streams = _Streams(sub, specs[0][3] * plan.replicates, None, 0.95)
    runner = make_runner(plan)
    try:
        tasks, todo = itertools.tee(_fixed_tasks(streams))
        for task, rows in zip(todo, runner.imap(tasks), strict=True):
            for i, group in enumerate(task):
                streams.merge(group, rows, i)
    finally:
        runner.close()
    return streams.stacked()


def sample_point(scenario, point=0, n=4000, *, seed=None, replicate=0):
    """Per-impact arrays at one sweep point (for inspection and small studies).

    Returns a dict of arrays (``diameter`` [m], ``roughness_angle`` [rad],
    ``speed`` [m s-1], ``e_m``, ``mu_m``, ``captured``, ``shadowed``, ``reimpact``).
    The draws are exactly those :func:`run` makes for the same seed and point.
    """

    scenario = as_scenario(scenario)
    plan = build_plan(scenario, seed=seed)
    n = check_int(n, "n")
    if not 0 <= point < len(plan.points):
        raise ValueError(f"`point` must be in [0, {len(plan.points)}); got {point!r}.")
    parts = list(iter_point_samples(plan, point, n, replicate=replicate))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def iter_point_samples(plan, point, n, *, replicate=0) -> Iterator[dict]:
    """Per-impact arrays of the first `n` draws at `point`, one dict per block (the
    blocks :func:`run` simulates, in order): bounded memory for any `n`."""

    for b in range(math.ceil(n / plan.block_size)):
        m = min(plan.block_size, n - b * plan.block_size)
        yield simulate_block(plan, point, replicate, b, m, store=True)
