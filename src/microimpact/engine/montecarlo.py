"""The Monte Carlo driver: ``iter_blocks`` (a generator) and ``run`` (drains it).

Work is split into blocks of :data:`~microimpact.engine.plan.BLOCK_SIZE` impacts. Block
``b`` of sweep point ``p`` draws variable ``v`` from the stream
``SeedSequence(entropy, spawn_key=(p, b, v))``; blocks are grouped into tasks for the
workers and their accumulators are merged on the driver in (point, replicate, block)
order. Hence one seed reproduces a run bit for bit, serially, on a process pool or on
a Dask cluster, whatever the worker count, and whether or not the run was interrupted
and resumed from its checkpoint.
"""

from __future__ import annotations

import math
import os
import sys
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from .._validation import check_choice, check_int
from ..errors import ConvergenceWarning, InputError
from . import checkpoint as ckpt
from .accumulators import PointAccumulator
from .parallel import BACKENDS, make_runner
from .plan import Plan, build_plan, resolve_entropy  # noqa: F401 (re-exported)
from .statistics import wilson_interval, z_value

#: Consecutive blocks per task (fixed-size runs): a worker merges them in order and
#: returns one accumulator. An algorithm constant like the block size: it fixes the
#: merge order, so the bits depend on it, never on the workers or the backend.
BLOCKS_PER_TASK = 64
#: Seconds between checkpoint writes (override: MICROIMPACT_CHECKPOINT_INTERVAL).
CHECKPOINT_INTERVAL = 2.0


def checkpoint_interval() -> float:
    """Seconds between checkpoint writes: ``MICROIMPACT_CHECKPOINT_INTERVAL`` if set
    (a positive number), else :data:`CHECKPOINT_INTERVAL`."""
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
    """One merged task, as yielded by :func:`iter_blocks`: a block, or (fixed-size
    runs) a group of up to ``BLOCKS_PER_TASK`` consecutive blocks."""

    point: int
    replicate: int
    block: int  # the last block merged
    accumulator: PointAccumulator | None  # these blocks alone (None: restored)
    total: PointAccumulator  # all blocks of (point, replicate) merged so far
    done: bool  # no more blocks will follow for (point, replicate)


@dataclass
class _Stream:
    """Driver-side state of one (point, replicate)."""

    target: int | None  # samples, None = until the precision target
    max_samples: int  # the target, or the cap of a precision target
    next_block: int = 0
    acc: PointAccumulator | None = None
    done: bool = False

    def samples_done(self):
        return self.acc.n if self.acc is not None else 0

    def block_n(self, b, block_size):
        return min(block_size, self.max_samples - b * block_size)

    def n_blocks(self, block_size):
        return math.ceil(self.max_samples / block_size)


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
    """Run the simulation block by block, yielding each merged block in key order.

    Arguments are those of :func:`run`. Stopping the iteration early leaves the
    checkpoint (if any) holding everything merged so far.
    """
    if samples is not None:
        samples = check_int(samples, "samples")
    workers = check_int(workers, "workers")
    check_choice(backend, "backend", BACKENDS)
    interval = checkpoint_interval() if checkpoint is not None else math.inf
    plan = build_plan(scenario, seed=seed) if plan is None else plan
    B = plan.block_size
    precision = scenario.precision if samples is None else None
    n_target = samples if samples is not None else scenario.samples
    streams = {
        key: _Stream(target, cap)
        for key, (target, cap) in _targets(plan, n_target, precision).items()
    }
    fingerprint = _fingerprint(plan, n_target, precision)
    if checkpoint is not None:
        saved = ckpt.load(checkpoint, fingerprint) or {}
        for key, (nxt, acc) in saved.items():
            if key in streams:
                st = streams[key]
                st.next_block, st.acc = nxt, acc
                st.done = nxt >= st.n_blocks(B) or (
                    precision is not None
                    and _converged(acc, precision, scenario.confidence)
                )
    for key, st in streams.items():
        if st.done:  # finished before the interruption: report it as it was
            yield BlockResult(key[0], key[1], st.next_block - 1, None, st.acc, True)
    total = None if precision is not None else sum(s.target for s in streams.values())
    if progress is None:
        progress = sys.stderr.isatty()
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(
            total=total,
            unit="impacts",
            unit_scale=True,
            delay=1.0,
            desc=scenario.name,
            leave=False,
        )
        bar.update(sum(s.samples_done() for s in streams.values()))

    if all(st.done for st in streams.values()):
        if bar is not None:
            bar.close()
        return  # everything was restored from the checkpoint: no workers needed
    runner = make_runner(
        plan, workers=workers, backend=backend, executor=executor, address=address
    )
    last_save = time.monotonic()

    def specs(key, start, stop):
        """Block specifications of (point, rep) for blocks start..stop-1."""
        st = streams[key]
        return tuple((key[0], key[1], b, st.block_n(b, B)) for b in range(start, stop))

    def merge(task, acc):
        """Merge the blocks of `task` if the first is the next one; else None."""
        point, rep, first, _n = task[0]
        last = task[-1][2]
        st = streams[(point, rep)]
        if st.done or first != st.next_block:
            return None  # after convergence: discarded, deterministically
        st.acc = acc if st.acc is None else st.acc.merge(acc)
        st.next_block = last + 1
        if st.next_block >= st.n_blocks(B):
            st.done = True
        elif precision is not None and _converged(
            st.acc, precision, scenario.confidence
        ):
            st.done = True
        if bar is not None:
            bar.update(acc.n)
        return BlockResult(point, rep, last, acc, st.acc, st.done)

    def save_now_and_then():
        nonlocal last_save
        if checkpoint is not None and time.monotonic() - last_save > interval:
            _save(checkpoint, fingerprint, streams)
            last_save = time.monotonic()

    try:
        if precision is None:
            # fixed sizes: stream the remaining tasks (groups of BLOCKS_PER_TASK
            # blocks aligned on multiples of it, so a resumed run groups as an
            # uninterrupted one) in key order through the runner with bounded
            # look-ahead; results come back in the same order
            T = BLOCKS_PER_TASK
            tasks = [
                specs(key, start, min((start // T + 1) * T, st.n_blocks(B)))
                for key, st in sorted(streams.items())
                if not st.done
                for start in (
                    st.next_block,
                    *range((st.next_block // T + 1) * T, st.n_blocks(B), T),
                )
            ]
            for task, acc in zip(tasks, runner.imap(tasks), strict=True):
                yield merge(task, acc)
                save_now_and_then()
        else:
            # precision targets: waves of blocks, convergence checked block by block
            per_key = max(1, runner.workers * 2)
            while active := [k for k, st in streams.items() if not st.done]:
                # one block per task: convergence is decided block by block
                wave = [
                    (spec,)
                    for k in active
                    for spec in specs(
                        k,
                        streams[k].next_block,
                        min(streams[k].next_block + per_key, streams[k].n_blocks(B)),
                    )
                ]
                done = dict(zip(wave, runner.map(wave), strict=True))
                for task in sorted(done):
                    br = merge(task, done[task])
                    if br is not None:
                        yield br
                save_now_and_then()
    finally:
        # normal end, an exception, Ctrl-C or the caller closing the generator: keep
        # everything merged so far (the state is consistent between two yields)
        if checkpoint is not None:
            _save(checkpoint, fingerprint, streams)
        runner.close()
        if bar is not None:
            bar.close()
    if precision is not None:
        short = [
            plan.points[p]
            for (p, _r), s in streams.items()
            if not _converged(s.acc, precision, scenario.confidence)
        ]
        if short:
            pts = ", ".join(
                f"({sp.surface_name}, {sp.speed} m/s, {sp.angle_deg} deg)"
                for sp in short[:5]
            )
            warnings.warn(
                f"{len(short)} sweep point(s) did not reach the precision target "
                f"{precision.half_width} on {precision.statistic} within "
                f"max_samples={precision.max_samples}: {pts}",
                ConvergenceWarning,
                stacklevel=2,
            )


def _save(path, fingerprint, streams):
    state = {k: (s.next_block, s.acc) for k, s in streams.items() if s.acc is not None}
    ckpt.save(path, fingerprint, state)


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
    scenario : Scenario
        The study (see :class:`microimpact.Scenario`).
    samples : int, optional
        Impacts per sweep point; overrides the scenario's count and its precision
        target.
    seed : int, optional
        Root seed; overrides the scenario's. None (and no scenario seed) draws fresh
        entropy, which is recorded in the result.
    workers : int, default 1
        Worker processes (``backend="process"``) or Dask workers for a local
        cluster (``backend="dask"``).
    backend : {"process", "dask"}
    executor : object with ``map``, optional
        Any pool (``concurrent.futures`` executor, ``multiprocessing.Pool``,
        emcee-style pool); overrides `workers` and `backend`.
    address : str, optional
        Dask scheduler address; None starts a ``LocalCluster``.
    checkpoint : path, optional
        File that keeps finished work; re-running with the same arguments resumes.
    progress : bool, optional
        Show a progress bar; default: only when stderr is a terminal.

    Returns
    -------
    SimulationResult
    """
    from .result import SimulationResult

    plan = build_plan(scenario, seed=seed)
    t0 = time.perf_counter()
    totals: dict[tuple[int, int], PointAccumulator] = {}
    for br in iter_blocks(
        scenario,
        samples=samples,
        workers=workers,
        backend=backend,
        executor=executor,
        address=address,
        checkpoint=checkpoint,
        progress=progress,
        plan=plan,
    ):
        if br.done:
            totals[(br.point, br.replicate)] = br.total
    elapsed = time.perf_counter() - t0
    return SimulationResult.from_accumulators(
        scenario,
        plan,
        totals,
        elapsed=elapsed,
        samples=samples,
        workers=workers,
        backend=backend if executor is None else "executor",
    )


def _targets(plan, n_target, precision):
    """(target samples or None, cap) for every (point, replicate)."""
    out = {}
    for sp in plan.points:
        for rep in range(plan.replicates):
            if precision is not None:
                out[(sp.index, rep)] = (None, precision.max_samples)
            else:
                per_rep = math.ceil(n_target / plan.replicates)
                out[(sp.index, rep)] = (per_rep, per_rep)
    return out


def _fingerprint(plan, n_target, precision):
    targets = _targets(plan, n_target, precision)
    return ckpt.plan_fingerprint(
        plan, (targets, None if precision is None else vars(precision))
    )


def sample_point(scenario, point=0, n=4000, *, seed=None, replicate=0):
    """Per-impact arrays at one sweep point (for inspection and small studies).

    Returns a dict of arrays (``diameter`` [m], ``roughness_angle`` [rad],
    ``speed`` [m s-1], ``e_m``, ``mu_m``, ``captured``, ``shadowed``, ``reimpact``).
    The draws are exactly those :func:`run` makes for the same seed and point.
    """
    from .kernel import simulate_block

    plan = build_plan(scenario, seed=seed)
    n = check_int(n, "n")
    if not 0 <= point < len(plan.points):
        raise ValueError(f"`point` must be in [0, {len(plan.points)}); got {point!r}.")
    parts = []
    for b in range(math.ceil(n / plan.block_size)):
        m = min(plan.block_size, n - b * plan.block_size)
        parts.append(simulate_block(plan, point, replicate, b, m, store=True))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
