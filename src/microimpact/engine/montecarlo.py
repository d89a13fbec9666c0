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

import concurrent.futures
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
from .accumulators import (
    E_EDGES,
    LATERAL_BINS,
    MU_EDGES,
    Moments,
    PointAccumulator,
)
from .checkpoint import (
    Checkpoint,
    CheckpointWarning,
    StackedState,
    plan_fingerprint,
)
from .kernel import (
    KernelTasks,
    kernel_tasks_available,
    plan_points_parsed,
    prepare_plan,
    simulate_block,
)
from .parallel import (
    BACKENDS,
    SerialRunner,
    ThreadRunner,
    _simulate,
    available_cores,
    cap_workers,
    make_runner,
)
from .plan import BLOCK_SIZE, Plan, build_plan, resolve_entropy
from .result import SimulationResult
from .statistics import wilson_interval, z_value
from .summary import Spans, Stacked, gather_segments, release_memory
from .tasks import BlockTask, block_tasks, size_rule

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
#: Tasks a run of several workers makes per worker at least, where its tasks
#: can be as small as :data:`MIN_TASK_IMPACTS` (:func:`task_impacts`): the last
#: round of tasks then leaves at most a quarter of a worker's share idle.
TASKS_PER_WORKER = 4
#: The smallest task made to keep more workers busy: 4 full blocks, ~2-4 ms of
#: kernel on one core, ~50x the ~55 us of GIL the driver spends per task.
MIN_TASK_IMPACTS = 4 * BLOCK_SIZE
#: Toward the end of a run on several local workers, a task holds at most the
#: impacts left over this many times the workers (:func:`task_sizes`).
TAIL_SPLIT = 2
#: The largest task made for a Dask cluster (:func:`task_impacts`): 256 full
#: blocks, ~0.1-0.2 s of kernel on one core, so that a lost worker's retried
#: tasks and the batches between checkpoints stay short. The cap was picked
#: from timings of caps of 1, 2, 4 and 8 x TASK_IMPACTS on a 2-worker
#: LocalCluster running ``run()`` over 64 points of 10^6 impacts (599, 544,
#: 524, 486 ms; 2 threads 403 ms): the docs' ratio on that path is the best of
#: the four (docs/performance.md says so).
DASK_TASK_IMPACTS = 256 * BLOCK_SIZE
#: Points :func:`estimate_duration` times in one calibration batch (at most).
CALIBRATION_POINTS = 2048
#: Impacts of that batch (at most, unless 16 points of one block hold more).
CALIBRATION_IMPACTS = 2**22
#: Most groups per task (bounds a task's result when points have very few samples).
TASK_GROUPS = 2048
#: Tasks whose rows the driver keeps before it copies them into its table in one
#: step (``_Streams._flush``): the table's per-field copies are paid once per
#: this many tasks, not per task (issue 31: the GIL between kernel calls).
PENDING_TASKS = 256
#: ... and at most this many rows (a sweep of small points packs 2,048 into a
#: task: ~0.4 MB of rows each, kept once more while they are copied).
PENDING_ROWS = 1 << 15
#: Fresh fixed-size runs of whole streams run their tasks inside the compiled
#: kernel (:class:`~.kernel.KernelTasks`; False: task by task, as other runs).
KERNEL_TASKS = True
#: Seconds between the progress updates (and checkpoint checks) of such a run.
KERNEL_POLL_S = 0.2
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


#: The histograms a stream keeps, in the order of :class:`~.summary.Stacked`.
_SPANS = ("e", "mu", "lateral")


class _Streams:
    """The merged prefix of every (point, replicate), in key order; merges groups.

    Merging is the only place results are combined, always in block order, so the
    bits depend on the plan alone.

    Stream ``k`` is (the ``k // R``-th point in index order, replicate ``k % R``).
    Its state is held in lists and arrays, not in an object per stream (a sweep of
    10^6 points): ``next_block[k]`` (blocks ``[0, next_block)`` are merged),
    ``done[k]``, and its total. A stream whose only merged group is its first
    (every point of a sweep of small points) keeps that group's row in
    preallocated arrays (counts, moments, the spans' offsets and lengths) and its
    histogram counts as a segment of its task's flat arrays: nothing is built per
    point, and :meth:`stacked` returns those arrays themselves. A stream merged
    from several groups, or restored from a checkpoint, holds a
    :class:`~.accumulators.PointAccumulator` (`loose`).
    """

    def __init__(self, plan: Plan, n_target, precision, confidence):
        self.block_size = plan.block_size
        self.precision = precision
        self.confidence = confidence
        R = self.replicates = plan.replicates
        # the samples of every stream (for a precision target: its cap)
        self.cap = (
            precision.max_samples
            if precision is not None
            else math.ceil(n_target / plan.replicates)
        )
        if hasattr(plan.points, "columns"):  # a grid's points: 0 .. n - 1
            ids = np.arange(len(plan.points), dtype=np.int64)
        else:
            ids = np.fromiter(
                (sp.index for sp in plan.points), np.int64, len(plan.points)
            )
            ids.sort()
        # the point of each stream: its index in the common case of every point
        # (no list of 10^6 numbers); else the sorted indices
        identity = np.array_equal(ids, np.arange(ids.size))
        self.point_ids = None if identity else ids  # (sorted)
        self._pos = None if identity else {p: i for i, p in enumerate(ids.tolist())}
        K = self.size = ids.size * R
        self.next_block = np.zeros(K, dtype=np.int64)
        self.done = np.zeros(K, dtype=bool)
        # fixed-size Monte Carlo runs on the compiled kernel: tasks as arrays
        self.array_tasks = (
            plan.kernel == "compiled" and plan.sampling != "qmc" and R == 1
        )
        self.loose: dict[int, PointAccumulator] = {}
        # the table of streams held as their first group's row
        self._held = np.zeros(K, dtype=bool)
        self._counts = np.zeros((K, 5), dtype=np.int64)
        self._moments = {n: np.zeros((K, 4)) for n in _SPANS}
        # per histogram: offset, length, chunk (the flat array), start in it
        self._spans = {
            n: (
                np.zeros(K, dtype=np.int32),
                np.zeros(K, dtype=np.int32),
                np.zeros(K, dtype=np.int32),
                np.zeros(K, dtype=np.int64),
            )
            for n in _SPANS
        }
        self._flats: dict[str, list] = {n: [] for n in _SPANS}
        self._flat_ids: dict[str, dict] = {n: {} for n in _SPANS}
        # tasks' rows of first groups not yet copied into the table: (streams,
        # rows), copied together (:meth:`_flush`) before the table is read
        self._pending: list[tuple] = []
        self._pending_rows = 0
        # every stream from this one on is untouched (no block merged or
        # restored): a task of them needs no check of their state
        self._fresh_from = 0

    # ------------------------------------------------------------ addressing
    def index(self, point: int, rep: int) -> int:
        pos = point if self._pos is None else self._pos[point]
        return pos * self.replicates + rep

    def key(self, k: int) -> tuple[int, int]:
        point, rep = divmod(k, self.replicates)
        return (point if self.point_ids is None else int(self.point_ids[point])), rep

    def n_blocks(self) -> int:
        """Blocks of every stream (at the cap of a precision target)."""
        return -(-self.cap // self.block_size)

    def specs(self, k: int, start: int, stop: int) -> tuple:
        """Block specifications ``(point, rep, block, n)`` of stream `k`'s blocks
        start..stop-1."""
        cap, B = self.cap, self.block_size
        return tuple((*self.key(k), b, min(B, cap - b * B)) for b in range(start, stop))

    @property
    def total_blocks(self) -> int:
        return self.size * self.n_blocks()

    @property
    def merged_blocks(self) -> int:
        return int(self.next_block.sum())

    def samples_done(self) -> int:
        self._flush()
        held = int(self._counts[self._held, 0].sum())
        return held + sum(acc.n for acc in self.loose.values())

    def active(self) -> list[int]:
        """The streams not done, in key order."""
        return np.flatnonzero(~self.done).tolist()

    def any_active(self) -> bool:
        return not bool(self.done.all())

    def acc(self, k: int) -> PointAccumulator | None:
        """Stream `k`'s total (None before its first group)."""
        acc = self.loose.get(k)
        if acc is not None:
            return acc
        self._flush()
        if not self._held[k]:
            return None
        spans = {}
        for n in _SPANS:
            off, ln, chunk, start = self._spans[n]
            at = int(start[k])
            flat = self._flats[n][chunk[k]]
            spans[n] = (int(off[k]), flat[at : at + int(ln[k])])
        m = {n: Moments.from_array(self._moments[n][k]) for n in _SPANS}
        return PointAccumulator(
            *self._counts[k].tolist(),
            e=m["e"],
            mu=m["mu"],
            e_span=spans["e"],
            mu_span=spans["mu"],
            lateral=m["lateral"],
            lateral_span=spans["lateral"],
        )

    # ------------------------------------------------------------ restoring
    def restore(self, saved: dict) -> None:
        """Take the prefixes of a checkpoint (keys of this run only)."""
        for (point, rep), (nxt, acc) in saved.items():
            if rep >= self.replicates or (
                point not in self._pos
                if self._pos is not None
                else not 0 <= point < self.size // self.replicates
            ):
                continue
            k = self.index(point, rep)
            self._fresh_from = max(self._fresh_from, k + 1)
            self.next_block[k] = nxt
            self.loose[k] = acc
            self._held[k] = False
            self.done[k] = self._finished(k)

    def _finished(self, k: int) -> bool:
        if int(self.next_block[k]) >= self.n_blocks():
            return True
        return self.precision is not None and _converged(
            self.acc(k), self.precision, self.confidence
        )

    def finished_results(self) -> Iterator[BlockResult]:
        """The (point, replicate) already done (restored), as they were."""
        for k in np.flatnonzero(self.done).tolist():
            p, r = self.key(k)
            last = int(self.next_block[k]) - 1
            yield BlockResult(p, r, last, None, self.acc(k), True)

    # ------------------------------------------------------------ merging
    def merge(self, group: tuple, rows: Stacked, i: int) -> int | None:
        """Merge `group` (its accumulator: row `i` of `rows`) if its first block is
        the next one of its stream; returns the stream's index, or None if the
        stream is done or the group is not next (blocks run after convergence:
        discarded, deterministically)."""
        point, rep, first, _n = group[0]
        k = self.index(point, rep)
        if self.done[k] or first != self.next_block[k]:
            return None
        self._merge_rows([(i, point, rep, first, group[-1][2])], rows)
        return k

    def merge_task(self, task: tuple, rows: Stacked) -> int:
        """Merge every group of `task` (row ``i`` of `rows` for its ``i``-th group)
        as :meth:`merge` does, the first groups' rows copied into the table in one
        step; returns the samples merged."""
        if isinstance(task, BlockTask):
            merged = self._merge_first_groups(task, rows)
            if merged is not None:
                return merged
            items = zip(
                range(len(task)),
                task.point.tolist(),
                itertools.repeat(0),
                task.first.tolist(),
                task.last.tolist(),
            )
        else:
            items = ((i, *g[0][:3], g[-1][2]) for i, g in enumerate(task))
        return self._merge_rows(items, rows)

    def _merge_first_groups(self, task: BlockTask, rows: Stacked) -> int | None:
        """:meth:`_merge_rows` for a task of distinct streams each merging its
        first group (a sweep of small points), in array steps; None where the
        task is not that (then merged group by group)."""
        if self.precision is not None:
            return None
        ids = self.point_ids
        ks = task.point if ids is None else np.searchsorted(ids, task.point)
        if not ks.size:
            return 0
        lo, hi = ks[[0, -1]].tolist()
        hi += 1
        # consecutive streams: slices (a task's groups are in stream order)
        consecutive = hi - lo == ks.size
        # whole streams never touched (the common case of a fresh run) need no
        # look at their state; others must be first groups of streams not begun
        fresh = bool(task.whole) and consecutive and lo >= self._fresh_from
        if not fresh:
            if task.first.any() or not (consecutive or np.all(np.diff(ks) > 0)):
                return None
            if self.done[ks].any() or self.next_block[ks].any():
                return None
        if consecutive:
            ks = slice(lo, hi)
        # copied into the table with other tasks' rows later (_flush): a few
        # array steps per task here, the copies in one step per field there
        self._hold_later(ks, rows)
        if task.whole:  # every block of each stream: done, cap impacts each
            self.next_block[ks] = task.stop
            self.done[ks] = True
            merged = len(task) * ((task.stop - 1) * task.block_size + task.last_n)
        else:
            self.next_block[ks] = task.last + 1
            self.done[ks] = self.next_block[ks] >= self.n_blocks()
            merged = int(rows.counts[:, 0].sum())
        self._fresh_from = max(self._fresh_from, hi)
        return merged

    def _hold_later(self, ks, rows: Stacked) -> None:
        """Keep a task's rows for :meth:`_flush` (streams `ks`: a slice or
        indices), which copies them in once :data:`PENDING_TASKS` tasks or
        :data:`PENDING_ROWS` rows are kept."""
        self._pending.append((ks, rows))
        self._pending_rows += len(rows)
        if len(self._pending) >= PENDING_TASKS or self._pending_rows >= PENDING_ROWS:
            self._flush()

    def _flush(self) -> None:
        """Copy the pending tasks' rows (:meth:`_merge_first_groups`) into the
        table, all of them at once."""
        pending = self._pending
        if not pending:
            return
        self._pending = []
        self._pending_rows = 0
        ks = np.concatenate(
            [
                np.arange(k.start, k.stop) if isinstance(k, slice) else k
                for k, _ in pending
            ]
        )
        self._hold(ks, Stacked.concat([rows for _, rows in pending]), slice(None))

    # ------------------------------------------------------------ kernel tasks
    def whole_fresh(self) -> bool:
        """Whether the compiled kernel may run this fixed-size run's tasks
        itself (:class:`~.kernel.KernelTasks`): array tasks, every stream a
        point of its own (no replicates, no ids), none begun or restored, and
        every stream one group (at most :data:`BLOCKS_PER_TASK` blocks)."""
        return (
            self.array_tasks
            and self.precision is None
            and self.point_ids is None
            and not self.loose
            and not self._pending
            and self.n_blocks() <= BLOCKS_PER_TASK
            and not self.next_block.any()
        )

    def kernel_table(self) -> tuple:
        """The 13 arrays of the table that ``_ckernel.tasks`` writes: counts,
        the moments of e, mu and lateral, then their spans' offsets, lengths
        and starts (the chunks are set by :meth:`take_kernel_tasks`)."""
        spans = [self._spans[n] for n in _SPANS]
        return (
            self._counts,
            *(self._moments[n] for n in _SPANS),
            *(s[0] for s in spans),
            *(s[1] for s in spans),
            *(s[3] for s in spans),
        )

    def take_kernel_tasks(self, kt, items: list) -> int:
        """Hold the streams of the tasks of `kt` in `items` (``harvest()``'s:
        the kernel has written their rows): their flats kept, their chunks set,
        each stream done. Returns the impacts taken."""
        if not items:
            return 0
        idx = np.array([item[0] for item in items])
        starts = kt.starts
        if idx[-1] - idx[0] + 1 == idx.size:  # consecutive tasks (the usual)
            rows = kt.point[starts[idx[0]] : starts[idx[-1] + 1]]
        else:
            rows = np.concatenate([kt.point[starts[i] : starts[i + 1]] for i in idx])
        per = starts[idx + 1] - starts[idx]
        for h, n in enumerate(_SPANS):
            chunks = [self._chunk(n, item[1 + h]) for item in items]
            self._spans[n][2][rows] = np.repeat(np.array(chunks, np.int32), per)
        self.next_block[rows] = kt.stop
        self.done[rows] = True
        self._held[rows] = True  # last: what a checkpoint reads as taken
        self._fresh_from = max(self._fresh_from, int(rows.max()) + 1)
        return int(self._counts[rows, 0].sum())

    def merge_partial(self, partial: tuple) -> int:
        """Merge a partial result of the workers (``parallel.combine_partials``:
        rows of (point, replicate) ``keys`` holding blocks ``first .. last``)
        as :meth:`merge_task` merges a task's groups; returns the samples merged."""
        keys, first, last, rows = partial
        items = zip(
            range(len(keys)),
            keys[:, 0].tolist(),
            keys[:, 1].tolist(),
            first.tolist(),
            last.tolist(),
            strict=True,
        )
        return self._merge_rows(items, rows)

    def _merge_rows(self, items, rows: Stacked) -> int:
        """Merge row ``i`` of `rows`, blocks ``first .. last`` of stream (point,
        rep), for every ``(i, point, rep, first, last)`` of `items`, unless the
        stream is done or the row is not its next group (blocks run after
        convergence: discarded, deterministically); a row that does not start its
        stream is a single group (``combine_partials``). Returns the samples
        merged."""
        # (rows held back by _merge_first_groups are first groups: none of
        # these streams takes a first group here, and acc() copies them in)
        nb, done, n_blocks = self.next_block, self.done, self.n_blocks()
        # (int() and bool(): numpy scalars of the stream arrays kept out of the
        # accumulators and the specs)
        ks, idx = [], []
        merged = 0
        samples = rows.counts[:, 0]
        top = -1  # the last stream merged
        for i, point, rep, first, last in items:
            k = self.index(point, rep)
            if done[k] or first != int(nb[k]):
                continue
            top = max(top, k)
            if first == 0:
                ks.append(k)
                idx.append(i)
            else:
                if ks:  # this stream's first group may be among them
                    self._hold(ks, rows, idx)
                    ks, idx = [], []
                self.loose[k] = self.acc(k).merge(rows.accumulator(i))
                self._held[k] = False
            merged += int(samples[i])
            nb[k] = last + 1
            if nb[k] >= n_blocks:
                done[k] = True
            elif self.precision is not None:
                pending = bool(ks) and ks[-1] == k
                if pending:
                    self._hold(ks, rows, idx)
                    ks, idx = [], []
                done[k] = self._finished(k)
        if ks:
            self._hold(ks, rows, idx)
        self._fresh_from = max(self._fresh_from, top + 1)
        return merged

    def _hold(self, ks, rows: Stacked, idx) -> None:
        """Streams `ks` take rows `idx` of `rows` as their totals (indices, or
        slices)."""
        if not isinstance(ks, slice):
            ks = np.asarray(ks, dtype=np.intp)
        if not isinstance(idx, slice):
            idx = np.asarray(idx, dtype=np.intp)
        self._held[ks] = True
        self._counts[ks] = rows.counts[idx]
        for n, moments, spans in (
            ("e", rows.e, rows.e_spans),
            ("mu", rows.mu, rows.mu_spans),
            ("lateral", rows.lateral, rows.lateral_spans),
        ):
            self._moments[n][ks] = moments[idx]
            off, ln, chunk, start = self._spans[n]
            off[ks] = spans.offset[idx]
            ln[ks] = spans.length[idx]
            start[ks] = spans.start[idx]
            chunk[ks] = self._chunk(n, spans.counts)

    def _chunk(self, name: str, flat: np.ndarray) -> int:
        """The index of `flat` among the kept flat counts of histogram `name` (it
        is kept alive there, so its id is not reused while it is listed)."""
        ids = self._flat_ids[name]
        c = ids.get(id(flat))
        if c is None:
            c = ids[id(flat)] = len(self._flats[name])
            self._flats[name].append(flat)
        return c

    # ------------------------------------------------------------ results
    def stacked(self) -> Stacked:
        """The accumulator of every (point, replicate), as the rows of one
        :class:`~.summary.Stacked` in key order (point-major): the table's arrays
        themselves (the rows of streams not held overwritten with their
        accumulators, or empty), and the histogram counts gathered from the tasks'
        flat arrays, which are then replaced by that one array (a later call
        copies nothing more)."""
        self._flush()
        # streams not held: their accumulators; a stream never run keeps its
        # table row of zeros (an empty accumulator), without an object
        other = np.array(sorted(self.loose), dtype=np.intp)
        extra = Stacked.of(self.loose[k] for k in other.tolist()).narrow()
        self._counts[other] = extra.counts
        spans = []
        for n, moments, ex, size in (
            ("e", extra.e, extra.e_spans, E_EDGES.size + 1),
            ("mu", extra.mu, extra.mu_spans, MU_EDGES.size + 1),
            ("lateral", extra.lateral, extra.lateral_spans, LATERAL_BINS),
        ):
            self._moments[n][other] = moments
            spans.append(self._gather(n, other, ex, size))
        return Stacked(
            self._counts,
            self._moments["e"],
            self._moments["mu"],
            spans[0],
            spans[1],
            self._moments["lateral"],
            spans[2],
        )

    def _gather(self, name, other, extra, size) -> Spans:
        off, ln, chunk, start = self._spans[name]
        flats = self._flats[name]
        held = self._held
        base = np.zeros(len(flats) + 1, dtype=np.int64)
        np.cumsum([f.size for f in flats], out=base[1:])
        off[other] = extra.offset
        ln[other] = extra.length
        never = ~held
        never[other] = False
        off[never] = 0
        ln[never] = 0
        length = ln.astype(np.int64)
        packed = np.zeros(self.size, dtype=np.int64)
        np.cumsum(length[:-1], out=packed[1:])
        where = packed.copy()  # where each row's counts are (empty rows: anywhere)
        where[held] = base[chunk[held]] + start[held]
        where[other] = base[-1] + extra.start
        if len(flats) != 1 or other.size:
            parts = [*flats, extra.counts] if other.size else flats
            flat = np.concatenate(parts) if parts else np.zeros(0, dtype=np.uint8)
        else:
            flat = flats[0]
        flat = gather_segments(flat, where, length)  # itself where already packed
        if not other.size:  # compact: the one array the table's rows point into
            self._flats[name] = [flat]
            self._flat_ids[name] = {id(flat): 0}
            chunk[:] = 0
            start[:] = packed
        return Spans(off, ln, flat, size)

    def state(self) -> StackedState:
        """What the checkpoint keeps: every (point, replicate) with merged work, its
        next block and its accumulator, as arrays (:meth:`stacked`): no
        accumulator object is built for a stream held in the table."""
        self._flush()
        has = self._held.copy()
        if self.loose:
            has[np.fromiter(self.loose, dtype=np.intp, count=len(self.loose))] = True
        rows = np.flatnonzero(has)
        R = self.replicates
        points = rows // R
        if self.point_ids is not None:
            points = self.point_ids[points]
        keys = np.stack([points, rows % R], axis=1)
        next_block = self.next_block[rows]
        return StackedState(keys, next_block, self.stacked().take(rows))

    def unconverged(self) -> list:
        out = []
        for k in range(self.size):
            acc = self.acc(k)
            if acc is None or not _converged(acc, self.precision, self.confidence):
                out.append(self.key(k)[0])
        return out


# ------------------------------------------------------------------- scheduling
def _pack(groups, max_groups=None, task_impacts=None) -> Iterator[tuple]:
    """Consecutive groups packed into tasks of up to `task_impacts` (default
    :data:`TASK_IMPACTS`; or a function of the impacts packed before:
    :func:`task_sizes`) impacts or `max_groups` (default :data:`TASK_GROUPS`)
    groups; a larger group is a task alone. `groups` yields ``(group, impacts)``.
    Packing is transport only: it changes no bit."""
    max_groups = TASK_GROUPS if max_groups is None else min(max_groups, TASK_GROUPS)
    size = size_rule(TASK_IMPACTS if task_impacts is None else task_impacts)
    task, impacts, packed = [], 0, 0
    for group, n in groups:
        task.append(group)
        impacts += n
        if impacts >= size(packed) or len(task) >= max_groups:
            yield tuple(task)
            packed += impacts
            task, impacts = [], 0
    if task:
        yield tuple(task)


def task_impacts(remaining: int, workers: int, *, remote: bool = False) -> int:
    """Impacts per task of a run with `remaining` impacts to draw on `workers`
    workers: :data:`TASK_IMPACTS`, or fewer where that would make fewer than
    :data:`TASKS_PER_WORKER` tasks per worker (a 60 x 60 grid at 8,000 impacts
    per point is 55 tasks of TASK_IMPACTS: 16 workers would run 4 rounds for 3.4
    rounds of work, 64 workers would leave 9 idle), but not below
    :data:`MIN_TASK_IMPACTS`. On a Dask cluster (`remote`), more: as many as
    make TASKS_PER_WORKER tasks per worker, up to :data:`DASK_TASK_IMPACTS`
    (each task costs the scheduler, the client and the network ~1-2 ms, not the
    ~55 us of a thread's). The tasks pack the same groups: no bit changes."""
    if remote:
        share = int(remaining) // (TASKS_PER_WORKER * max(int(workers), 1))
        return max(TASK_IMPACTS, min(DASK_TASK_IMPACTS, share))
    if workers <= 1:
        return TASK_IMPACTS
    share = int(remaining) // (TASKS_PER_WORKER * int(workers))
    return max(MIN_TASK_IMPACTS, min(TASK_IMPACTS, share))


def task_sizes(remaining: int, workers: int, *, remote: bool = False):
    """The impacts of each task of a run, as a function of the impacts packed
    into the tasks before it: :func:`task_impacts`, and on several local
    workers smaller toward the end, ``(remaining - packed) / (TAIL_SPLIT
    workers)`` where that is less, down to :data:`MIN_TASK_IMPACTS` (guided
    self-scheduling): the last round's tasks are short, so the workers finish
    together (with 4 tasks of 450,000 impacts each, 16 workers were busy 85 %
    of a 60 x 60 grid's time). No bit changes: the same groups, packed."""
    base = task_impacts(remaining, workers, remote=remote)
    if remote:
        return lambda _packed: base
    return lambda packed: tail_size(
        base, MIN_TASK_IMPACTS, int(remaining) - packed, workers
    )


def tail_size(base: int, floor: int, left: int, workers: int) -> int:
    """The guided rule of :func:`task_sizes` (and of the wall law's node
    groups): `base` on one worker; on several, at most `left` (the work not yet
    packed) over ``TAIL_SPLIT x workers``, but not below `floor`."""
    if workers <= 1:
        return base
    return max(floor, min(base, left // (TAIL_SPLIT * int(workers))))


def _fixed_tasks(
    streams: _Streams, workers: int = 1, *, remote: bool = False
) -> Iterator[tuple]:
    """The remaining blocks of a fixed-size run, in key order: groups of
    :data:`BLOCKS_PER_TASK` blocks aligned on multiples of it (so a resumed run groups
    as an uninterrupted one), packed into tasks of :func:`task_impacts` impacts for
    `workers` workers (`remote`: of a Dask cluster)."""
    T, B = BLOCKS_PER_TASK, streams.block_size
    # (a finished stream has nothing left: its next block is past the cap)
    left = np.maximum(streams.cap - streams.next_block * B, 0)
    size = task_sizes(int(left.sum()), workers, remote=remote)
    if streams.array_tasks:
        # the same groups and tasks as arrays (tasks.py): no tuple per block
        cap = streams.cap
        stop = -(-cap // B)
        ks = np.flatnonzero(~streams.done)
        return block_tasks(
            ks if streams.point_ids is None else streams.point_ids[ks],
            streams.next_block[ks],
            stop=stop,
            block_size=B,
            last_n=cap - (stop - 1) * B,
            per_group=T,
            task_impacts=size,
            task_groups=TASK_GROUPS,
        )

    def groups():
        cap = streams.cap
        stop = -(-cap // B)
        last = cap - (stop - 1) * B  # impacts of the last block
        for k, start in enumerate(streams.next_block.tolist()):
            if streams.done[k]:
                continue
            point, rep = streams.key(k)
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

    return _pack(groups(), task_impacts=size)


def _precision_wave(streams: _Streams, per_key: int, workers: int) -> list[tuple]:
    """The next `per_key` blocks of every unfinished stream, one block per group
    (convergence is decided block by block), packed into at least ``4 workers``
    tasks when there are enough blocks (a wave is short: every worker gets some)."""
    groups = []
    n_blocks = streams.n_blocks()
    for k in streams.active():
        start = int(streams.next_block[k])
        stop = min(start + per_key, n_blocks)
        groups.extend(((spec,), spec[3]) for spec in streams.specs(k, start, stop))
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
        self.total_blocks = self.streams.total_blocks
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
            "total_blocks": self.total_blocks,
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
        stacked = self.streams.stacked()
        self.streams = None  # the table's arrays now belong to `stacked` alone
        return stacked

    def _drive(self, *, results: bool) -> Iterator[BlockResult]:
        streams, ck = self.streams, self.checkpoint
        if ck is not None:
            streams.restore(ck.open(self._fingerprint, interval=checkpoint_interval()))
            self.resumed_blocks = streams.merged_blocks
            ck.started(self.resumed_blocks, streams.total_blocks)
        if results:
            yield from streams.finished_results()
        if not streams.any_active():
            self._start_background()
            return  # everything was restored from the checkpoint: no workers needed
        fixed = self.precision is None
        if fixed and streams.array_tasks:
            # the plan's points parsed here, once, before any worker waits on it
            prepare_plan(self.plan)
        runner = make_runner(
            self.plan,
            workers=self.workers,
            backend=self.backend,
            executor=self.executor,
            address=self.address,
        )
        self.local_workers = runner.local_workers
        self._background_policy = runner.background
        if fixed and streams.cap * streams.size < BACKGROUND_IMPACTS:
            self._background_policy = "short"  # a short run: in the caller
        if runner.background == "now":
            self._start_background()  # no fork to come: the kernel frees the GIL
        bar = Progress(
            self.progress,
            total=streams.cap * streams.size if fixed else None,
            unit="impacts",
            desc=self.scenario.name,
            initial=streams.samples_done(),
        )
        try:
            if fixed and not results and hasattr(runner, "reduced"):
                # reduced on the workers (Dask): one partial per batch of tasks
                for partial in runner.reduced(
                    _fixed_tasks(streams, runner.workers, remote=True)
                ):
                    self._start_background()
                    bar.update(streams.merge_partial(partial))
                    self._checkpoint_if_due()
            elif fixed and not results and self._in_kernel(runner):
                self._drive_in_kernel(runner, bar)
            elif fixed:
                tasks, todo = itertools.tee(_fixed_tasks(streams, runner.workers))
                for task, rows in zip(todo, runner.imap(tasks), strict=True):
                    # the workers have started (a pool forks on its first task)
                    self._start_background()
                    if results:
                        yield from self._merge(
                            zip(task, itertools.repeat(rows), range(len(task))),
                            bar,
                            results,
                        )
                    else:  # the task's first groups in one step
                        bar.update(streams.merge_task(task, rows))
                        self._checkpoint_if_due()
            else:
                per_key = max(1, runner.workers * 2)
                while streams.any_active():
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

    def _in_kernel(self, runner) -> bool:
        """Whether this run's tasks go to the compiled kernel whole
        (:class:`~.kernel.KernelTasks`): a fresh fixed-size run of whole
        streams, on this process's threads (or one worker), with the plan's
        points parsed once."""
        return (
            KERNEL_TASKS
            and isinstance(runner, SerialRunner | ThreadRunner)
            and kernel_tasks_available()
            and self.streams.whole_fresh()
            and plan_points_parsed(self.plan)
        )

    def _drive_in_kernel(self, runner, bar) -> None:
        """Run every task in the compiled kernel: `runner.workers` threads each
        make one ``KernelTasks.run`` call, and this thread only waits, updates
        the progress bar and writes the checkpoints (the workers paused at a
        task's end while it does). On an exception here (Ctrl-C) or in a
        worker, the workers stop after their current task and every finished
        task is kept (the caller writes the checkpoint)."""
        streams = self.streams
        kt = KernelTasks(
            self.plan,
            _fixed_tasks(streams, runner.workers),
            streams.kernel_table(),
        )
        workers = max(1, min(runner.workers, len(kt)))

        def take():
            n = streams.take_kernel_tasks(kt, kt.harvest()[1])
            if n:
                bar.update(n)

        if workers == 1 and self._background_policy == "short":
            # a short run (under BACKGROUND_IMPACTS, ~50 ms) on one worker: in
            # this thread (a model run of a calibration or a design row paid
            # ~0.3 ms for a thread and its wake-ups); Ctrl-C waits for its end
            try:
                kt.run()
            finally:
                take()
            return
        # a bar or a checkpoint is served between waits; else one wait
        poll = KERNEL_POLL_S if (bar.active or self.checkpoint is not None) else None
        pool = concurrent.futures.ThreadPoolExecutor(
            workers, thread_name_prefix="microimpact-kernel"
        )
        futures: list = []

        def start():
            kt.halt(False)
            futures[:] = [pool.submit(kt.run) for _ in range(workers)]

        def stop():
            kt.halt(True)
            for f in concurrent.futures.as_completed(futures):
                f.result()  # a worker's MemoryError
            futures.clear()

        try:
            start()
            # no Python runs in the workers: the description may run beside
            # them (not for a short run: its caller would wait for the thread)
            if self._background_policy != "short":
                self._background_policy = "now"
            self._start_background()
            while futures:
                done, pending = concurrent.futures.wait(
                    futures,
                    timeout=poll,
                    return_when=concurrent.futures.FIRST_EXCEPTION,
                )
                for f in done:
                    f.result()
                futures[:] = pending
                if futures and self.checkpoint is not None and self.checkpoint.due():
                    stop()  # the table is read whole: no worker writes it
                    take()
                    self.checkpoint.write(streams.state())
                    start()
                else:
                    take()
        except BaseException:
            # every worker stopped before the caller reads the table (for the
            # checkpoint), also through a second Ctrl-C; then the finished tasks
            kt.halt(True)
            again = None
            while True:
                try:
                    concurrent.futures.wait(futures)
                    break
                except KeyboardInterrupt as exc:
                    again = exc
            take()
            if again is not None:
                raise again from None
            raise
        finally:
            pool.shutdown(wait=True)

    def _merge(self, items, bar, results) -> Iterator[BlockResult]:
        """Merge ``(group, rows, i)`` items in order; with `results`, yield a
        :class:`BlockResult` for each group merged."""
        streams = self.streams
        n = 0
        for group, rows, i in items:
            k = streams.merge(group, rows, i)
            if k is None:
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
                    streams.acc(k),
                    bool(streams.done[k]),
                )
        bar.update(n)
        self._checkpoint_if_due()

    def _checkpoint_if_due(self) -> None:
        ck = self.checkpoint
        if ck is not None and ck.due():
            ck.write(self.streams.state())

    # ------------------------------------------------------------ background
    def in_background(self, fn, *, inline=None) -> None:
        """Run `fn` in a thread while the workers run (driver work that does not
        depend on the results, e.g. the scenario's description); its value is
        :meth:`background_result`. The thread starts once no fork is to come (a
        process pool forks on its first task: a thread must not be running then).
        `inline`: what the caller runs instead where no thread was started
        (default `fn`)."""
        self._background = _Background(fn, inline)

    def _start_background(self) -> None:
        """Start the background work unless it is wanted at the end (the
        runner's :attr:`~.parallel.ThreadRunner.background`, or a short run:
        :data:`BACKGROUND_IMPACTS`): then :meth:`background_result` computes it
        in the caller."""
        if self._background is not None and self._background_policy not in (
            "end",
            "short",
        ):
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


#: A fixed-size run of fewer impacts than this (~0.1 s of kernel on one core)
#: computes its background work (:meth:`_Job.in_background`, ~0.5 ms for a
#: small scenario) in the caller instead of a thread: a thread that waits for the
#: GIL while the driver runs Python gets it only at the switch interval (5 ms),
#: so a short run's caller waited ~5 ms for it at the end (issue 31: a
#: calibration's model runs and a sensitivity study's design rows are short).
BACKGROUND_IMPACTS = 2**22


class _Background:
    """A function run once in a daemon thread, or (its inline form) in the
    caller if never started."""

    def __init__(self, fn, inline=None):
        self._fn = fn
        self._inline = fn if inline is None else inline
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
            return self._inline()
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
    plan=None,
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
    plan : Plan, optional
        The study's tables, already built by ``build_plan(scenario, seed=seed)``
        (for a caller that also draws per-impact outputs from them): not built
        again. One built with another seed is refused.

    Returns
    -------
    SimulationResult
        Its provenance records ``resumed_blocks`` (0 for a fresh run),
        ``total_blocks`` and the effective ``workers``.
    """

    t0 = time.perf_counter()
    if plan is not None:
        if not isinstance(plan, Plan):
            raise TypeError(f"`plan` must be a Plan (build_plan); got {plan!r}.")
        scenario = as_scenario(scenario)
        entropy = resolve_entropy(scenario.seed if seed is None else seed)
        if plan.entropy != entropy:
            raise ValueError(
                "`plan` was built with another seed than this run's; build it with "
                "build_plan(scenario, seed=seed)"
            )
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
            plan=plan,
        )
        del plan  # the job's now (released with it)
        # what the result needs of the scenario alone is prepared while the
        # workers run
        job.in_background(
            functools.partial(SimulationResult.prepare, job.scenario),
            # in the caller (a short run): the description when first read
            inline=functools.partial(
                SimulationResult.prepare, job.scenario, describe=False
            ),
        )
        stacked = job.drain()
        elapsed = time.perf_counter() - t0
        result = SimulationResult.from_stacked(
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
        large = job.total_blocks >= RELEASE_BLOCKS
        del job, stacked
    if large:  # the plan and the driver's state of a large sweep are garbage now
        release_memory(collect=True)
    return result


#: Runs of at least this many blocks (a sweep of 65,536 small points) give the
#: memory they freed back to the system when they end (:func:`release_memory`).
RELEASE_BLOCKS = 2**16


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
            streams.merge_task(task, rows)
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
