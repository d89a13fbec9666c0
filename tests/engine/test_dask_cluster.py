"""Dask at scale (issue 31, item 2): results reduced on the workers, and a real
cluster over TCP that loses a worker mid-run and resumes from a checkpoint, with
the bits of a local run.

The reduction's oracle is the driver's own merge (a task's rows merged by
``_Streams.merge_task``, groups folded left to right); the cluster's is a local
run of one thread.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from engine_helpers import rough, scenario
from numpy.testing import assert_array_equal

import microimpact
from microimpact.engine import montecarlo, parallel
from microimpact.engine.checkpoint import Checkpoint
from microimpact.engine.montecarlo import _fixed_tasks, _Streams, run
from microimpact.engine.plan import BLOCK_SIZE, build_plan


def _sweep():
    return scenario(
        surfaces=(rough(8.0), rough(20.0, name="steep")),
        speeds_m_s=(0.05, 0.3, 0.9),
        angles_deg=(20.0, 70.0),
        samples=5 * BLOCK_SIZE + 123,  # 6 blocks: 3 groups of 2 per point
    )


@pytest.fixture
def many_groups(monkeypatch):
    """Groups of 2 blocks, tasks of 2 blocks: every stream spans 3 tasks, so the
    reduction must fold groups that reach it from different tasks."""
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 2 * BLOCK_SIZE)
    monkeypatch.setattr(montecarlo, "DASK_TASK_IMPACTS", 2 * BLOCK_SIZE)


def _same(a, b):
    cols = [c for c in a.summary.columns if c != "surface"]
    assert_array_equal(a.summary[cols].to_numpy(), b.summary[cols].to_numpy())
    for k in a.accumulators:
        assert a.accumulators[k] == b.accumulators[k]


def _same_rows(a, b):
    assert_array_equal(a.counts, b.counts)
    for x, y in ((a.e, b.e), (a.mu, b.mu), (a.lateral, b.lateral)):
        assert_array_equal(x.view(np.uint64), y.view(np.uint64))
    for x, y in ((a.e_spans, b.e_spans), (a.mu_spans, b.mu_spans)):
        assert_array_equal(x.dense(np.int64), y.dense(np.int64))


def _tree(parts, rng):
    """Combine consecutive partials in a random tree (any fan-in, any split)."""
    while len(parts) > 1:
        out, at = [], 0
        while at < len(parts):
            k = int(rng.integers(1, 4))
            out.append(parallel.combine_partials(*parts[at : at + k]))
            at += k
        parts = out
    return parts[0]


@pytest.mark.parametrize("restored", [False, True])
def test_a_tree_reduction_folds_as_the_driver(many_groups, rng, restored):
    """Partials combined in random trees, then merged by the driver, equal the
    driver merging every task's rows itself, bit for bit; also when the streams
    start from restored prefixes (their rows stay single groups)."""
    sc = _sweep()
    plan = build_plan(sc, seed=5)

    def streams():
        s = _Streams(plan, sc.samples, None, 0.95)
        if restored:  # point 1 and point 4 resume after their first group
            for p in (1, 4):
                task = ((tuple((p, 0, b, BLOCK_SIZE) for b in range(2)),),)
                rows = parallel.run_task(plan, task[0])
                s.merge_task(task[0], rows)
        return s

    ref = streams()
    for task in list(_fixed_tasks(ref)):
        ref.merge_task(task, parallel.run_task(plan, task))
    assert max(len(t) for t in _fixed_tasks(streams())) >= 1
    for _ in range(3):
        got = streams()
        tasks = list(_fixed_tasks(got))
        assert len(tasks) > 20
        partial = _tree([parallel.task_partial(plan, t) for t in tasks], rng)
        got.merge_partial(partial)
        assert np.array_equal(got.next_block, ref.next_block) and all(got.done)
        _same_rows(got.stacked(), ref.stacked())


def test_a_partial_row_that_does_not_start_its_stream_is_not_folded(many_groups):
    """A row of blocks 2..3 followed by blocks 4..5 of the same stream: both stay
    (folding them before the prefix would change the last bits)."""
    sc = _sweep()
    plan = build_plan(sc, seed=5)
    g1 = ((0, 0, 2, BLOCK_SIZE), (0, 0, 3, BLOCK_SIZE))
    g2 = ((0, 0, 4, BLOCK_SIZE), (0, 0, 5, 123))
    _, first, last, _ = parallel.combine_partials(
        parallel.task_partial(plan, (g1,)), parallel.task_partial(plan, (g2,))
    )
    assert first.tolist() == [2, 4] and last.tolist() == [3, 5]
    g0 = ((0, 0, 0, BLOCK_SIZE), (0, 0, 1, BLOCK_SIZE))
    _, first, last, rows = parallel.combine_partials(
        parallel.task_partial(plan, (g0,)),
        parallel.task_partial(plan, (g1,)),
        parallel.task_partial(plan, (g2,)),
    )
    assert first.tolist() == [0] and last.tolist() == [5]
    assert rows.counts[0, 0] == 5 * BLOCK_SIZE + 123


# ------------------------------------------------------------------ TCP cluster
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Cluster:
    """``dask scheduler`` and worker processes on 127.0.0.1, as a user starts
    them by hand (docs/engine.md)."""

    def __init__(self, tmp: Path, workers: int):
        src = str(Path(microimpact.__file__).parents[1])
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(
            [src, *filter(None, [env.get("PYTHONPATH")])]
        )
        self.env = env
        self.address = f"tcp://127.0.0.1:{_free_port()}"
        self.log = tmp
        self.procs = []
        port = self.address.rsplit(":", 1)[1]
        self.scheduler = self._start(
            "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard"
        )
        # the workers import the package as they start (not on their first task)
        options = ("--nthreads", "1", "--no-nanny", "--no-dashboard")
        options += ("--preload", "microimpact.engine.parallel")
        self.workers = [
            self._start("worker", self.address, *options, "--name", f"w{k}")
            for k in range(workers)
        ]

    def _start(self, *args):
        log = open(self.log / f"{args[0]}-{len(self.procs)}.log", "w")
        proc = subprocess.Popen(
            [sys.executable, "-m", "dask", *args],
            env=self.env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.procs.append((proc, log))
        return proc

    def wait(self, n: int, timeout=60.0):
        from dask.distributed import Client

        deadline = time.monotonic() + timeout
        while True:
            try:
                with Client(self.address, timeout=5) as client:
                    client.wait_for_workers(
                        n, timeout=max(1.0, deadline - time.monotonic())
                    )
                    return
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise

    def n_workers(self) -> int:
        from dask.distributed import Client

        with Client(self.address, timeout=5) as client:
            return len(client.scheduler_info()["workers"])

    def close(self):
        for proc, log in reversed(self.procs):
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
                try:
                    proc.wait(10)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()
            log.close()


class _Stop(Exception):
    pass


def test_a_tcp_cluster_loses_a_worker_and_resumes_with_the_same_bits(
    tmp_path, many_groups, monkeypatch
):
    """A scheduler and two workers started as `dask scheduler` / `dask worker`
    on loopback. A run reduced on the workers is stopped after its first batch
    (its checkpoint keeps it); the resumed run loses a worker (SIGKILL) when its
    first results are in, and finishes on the other with the bits of a local run
    of one thread."""
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(parallel, "BATCH_TASKS", 1)  # a batch of 2 tasks
    received = []  # what reached the client: one partial per batch
    reduced = parallel.DaskRunner.reduced

    def spy(self, tasks, **kw):
        for partial in reduced(self, tasks, **kw):
            received.append(len(partial[3]))
            yield partial

    monkeypatch.setattr(parallel.DaskRunner, "reduced", spy)
    sc = _sweep()
    cluster = _Cluster(tmp_path, workers=2)
    try:
        local = run(sc, seed=9)  # while the cluster starts
        cluster.wait(2)
        ck = Checkpoint(tmp_path / "run.npz", interval=1e-9)

        def stop(done, total):
            raise _Stop

        with pytest.raises(_Stop):
            run(
                sc,
                seed=9,
                backend="dask",
                address=cluster.address,
                checkpoint=ck,
                progress=stop,
            )
        assert ck.writes >= 1 and ck.path.exists()
        seen = []

        def kill(done, total):
            if not seen:
                seen.append((done, total))
                cluster.workers[0].kill()  # SIGKILL: no goodbye to the scheduler

        ck = Checkpoint(tmp_path / "run.npz")
        res = run(
            sc,
            seed=9,
            backend="dask",
            address=cluster.address,
            checkpoint=ck,
            progress=kill,
        )
        assert ck.restored_blocks > 0
        # reduced on the workers: each batch of 2 tasks (a group each; 36 groups
        # in all) reached the client as one partial, and a stream's first two
        # groups as one row
        assert 0 < len(received) <= 36 // 2
        assert any(rows < 2 for rows in received)
        assert res.provenance["resumed_blocks"] == ck.restored_blocks
        assert seen and seen[0][0] < seen[0][1]  # killed mid-run
        assert cluster.workers[0].wait(10) == -signal.SIGKILL
        assert cluster.n_workers() == 1
        _same(local, res)
    finally:
        cluster.close()


def test_runs_on_one_scheduler_share_its_client():
    """Runs given the same scheduler address reuse one client (connecting and
    closing took ~17 ms a run), not set as Dask's default; a closed one is
    replaced; the results are the threads' bits."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import LocalCluster, default_client

    sc = scenario(speeds_m_s=(0.3, 0.9), angles_deg=(40.0,), samples=2000)
    local = run(sc, seed=3)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        address = cluster.scheduler_address
        first = run(sc, seed=3, backend="dask", address=address)
        client = parallel._SHARED_CLIENTS[address]
        assert client.status == "running"
        second = run(sc, seed=3, backend="dask", address=address)
        assert parallel._SHARED_CLIENTS[address] is client
        with pytest.raises(ValueError):
            default_client()  # no default client was set
        client.close()
        third = run(sc, seed=3, backend="dask", address=address)
        assert parallel._SHARED_CLIENTS[address] is not client
        parallel._SHARED_CLIENTS.pop(address).close()
    for res in (first, second, third):
        for k in local.accumulators:
            assert res.accumulators[k] == local.accumulators[k]
