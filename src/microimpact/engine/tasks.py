"""Tasks described by arrays: a fixed-size Monte Carlo run's groups of blocks
without a Python object per point (issue 31).

A task of the driver is a run of *groups*: group ``i`` holds blocks
``first[i] .. last[i]`` of stream ``point[i]`` (replicate 0), merged in block
order into one accumulator by the compiled kernel. Every stream has ``stop``
blocks of ``block_size`` impacts, the last one ``last_n``. The driver's tuples
(``((point, 0, block, n), ...)`` per group) describe the same groups; a
:class:`BlockTask` still iterates as them, so every consumer of tasks (the
per-group merge, the Dask partials) works unchanged, and the hot paths (the
kernel call, the merge of a sweep's first groups) read the arrays.

The groups are the ones :func:`~.montecarlo._fixed_tasks` forms point by point
(aligned on multiples of ``BLOCKS_PER_TASK``), and they are packed into tasks by
the same rule as :func:`~.montecarlo._pack` (at least ``TASK_IMPACTS`` impacts
or ``TASK_GROUPS`` groups; a larger group alone): the same tasks, so the same
kernel calls and the same bits.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from .kernel import SpecArrays

__all__ = ["BlockTask", "block_tasks"]

#: Streams turned into groups at a time (bounds the driver's arrays on a sweep of
#: 10^6 points; the packing carries over from one chunk to the next).
CHUNK_STREAMS = 1 << 16


@dataclass(frozen=True, eq=False)
class BlockTask:
    """Groups of consecutive blocks as arrays (see the module docstring)."""

    point: np.ndarray  # int64 (G,): the point of each group (its stream)
    first: np.ndarray  # int64 (G,): its first block
    last: np.ndarray  # int64 (G,): its last block
    stop: int  # blocks of every stream
    block_size: int
    last_n: int  # impacts of block stop - 1
    #: Every group is a whole stream (blocks 0 .. stop - 1): known where
    #: block_tasks made the task, None where not known (then not assumed).
    whole: bool | None = field(default=None, compare=False)

    def __len__(self) -> int:
        return int(self.point.size)

    def _n(self, block: int) -> int:
        return self.last_n if block == self.stop - 1 else self.block_size

    def __getitem__(self, i: int) -> tuple:
        """Group `i` as the driver's tuple of block specs."""
        p, f, last = int(self.point[i]), int(self.first[i]), int(self.last[i])
        return tuple((p, 0, b, self._n(b)) for b in range(f, last + 1))

    def __iter__(self) -> Iterator[tuple]:
        for i in range(len(self)):
            yield self[i]

    @property
    def lengths(self) -> np.ndarray:
        """Blocks per group."""
        return self.last - self.first + 1

    def impacts(self) -> np.ndarray:
        """Impacts per group."""
        return self.lengths * self.block_size - np.where(
            self.last == self.stop - 1, self.block_size - self.last_n, 0
        )

    def specs(self) -> SpecArrays:
        """Every block of every group, in order, as the kernel's arrays."""
        if np.array_equal(self.first, self.last):  # a block per group
            n = np.where(self.first == self.stop - 1, self.last_n, self.block_size)
            return SpecArrays(self.point, self.first, n.astype(np.int64))
        ln = self.lengths
        total = int(ln.sum())
        start = np.zeros(ln.size, dtype=np.int64)
        np.cumsum(ln[:-1], out=start[1:])
        block = np.arange(total, dtype=np.int64) + np.repeat(self.first - start, ln)
        n = np.where(block == self.stop - 1, self.last_n, self.block_size)
        return SpecArrays(np.repeat(self.point, ln), block, n.astype(np.int64))


def _groups(ks, starts, stop, per_group):
    """The groups of streams `ks` from their next blocks `starts` to `stop`,
    cut at multiples of `per_group`: ``(point, first, last)`` arrays, in stream
    then block order."""
    ks = np.asarray(ks, dtype=np.int64)
    starts = np.asarray(starts, dtype=np.int64)
    # groups per stream: the multiples of per_group in (start, stop), plus one
    count = -(-stop // per_group) - starts // per_group
    count = np.where(starts < stop, count, 0)
    point = np.repeat(ks, count)
    total = int(count.sum())
    offset = np.zeros(count.size, dtype=np.int64)
    np.cumsum(count[:-1], out=offset[1:])
    j = np.arange(total, dtype=np.int64) - np.repeat(offset, count)  # group in stream
    s = np.repeat(starts, count)
    first = np.where(j == 0, s, (s // per_group + j) * per_group)
    last = np.minimum((first // per_group + 1) * per_group, stop) - 1
    return point, first, last


def size_rule(task_impacts):
    """`task_impacts` as a function of the impacts packed before: itself where
    it is one (``montecarlo.task_sizes``), else the constant."""
    if callable(task_impacts):
        return task_impacts
    return lambda _packed: task_impacts


def block_tasks(
    points,
    starts,
    *,
    stop: int,
    block_size: int,
    last_n: int,
    per_group: int,
    task_impacts: int,
    task_groups: int,
) -> Iterator[BlockTask]:
    """The tasks of the streams of `points` (ascending) whose next blocks are
    `starts`: their remaining blocks in groups aligned on multiples of
    `per_group`, packed in order into tasks that close when they hold at least
    `task_impacts` impacts or `task_groups` groups (the driver's ``_pack``).
    `task_impacts` may be a function of the impacts packed into the tasks
    before (``montecarlo.task_sizes``: smaller tasks toward the end)."""
    size = size_rule(task_impacts)
    packed = 0
    ks = np.asarray(points, dtype=np.int64)
    starts = np.asarray(starts, dtype=np.int64)
    carry = None  # the open task's groups, carried into the next chunk
    for c in range(0, ks.size, CHUNK_STREAMS):
        point, first, last = _groups(
            ks[c : c + CHUNK_STREAMS], starts[c : c + CHUNK_STREAMS], stop, per_group
        )
        if carry is not None:
            point, first, last = (
                np.concatenate([a, b])
                for a, b in zip(carry, (point, first, last), strict=True)
            )
        task = BlockTask(point, first, last, stop, block_size, last_n)
        # (Python integers: a bisection per task costs no array call)
        cum = np.cumsum(task.impacts()).tolist()
        # groups that are not a whole stream, counted up to each group
        part = np.cumsum((first != 0) | (last != stop - 1)).tolist()
        g, i = point.size, 0
        carry = None
        while i < g:
            before = cum[i - 1] if i else 0
            # the first group at which the task holds task_impacts impacts
            j = bisect.bisect_left(cum, before + size(packed), lo=i)
            end = min(j + 1, i + task_groups)
            # every group a whole stream: no group that is not, from i to end
            whole = part[min(end, g) - 1] == (part[i - 1] if i else 0)
            if end > g:  # open: may take groups of the next chunk
                carry = (point[i:], first[i:], last[i:])
                break
            yield BlockTask(
                point[i:end],
                first[i:end],
                last[i:end],
                stop,
                block_size,
                last_n,
                whole,
            )
            packed += cum[min(end, g) - 1] - before
            i = end
    if carry is not None and carry[0].size:
        yield BlockTask(*carry, stop, block_size, last_n, whole)
