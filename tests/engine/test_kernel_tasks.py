"""A fresh run's tasks inside the compiled kernel (``kernel.KernelTasks``).

The oracle is the task-by-task driver (``montecarlo.KERNEL_TASKS`` off: each
task a kernel call from Python, merged by the driver), whose bits the rest of
the suite holds to the NumPy kernel and to the paper: the same accumulators,
bit for bit, on any grid, sample count and number of worker threads; an
interrupted run keeps its finished tasks and resumes to the same bits.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from engine_helpers import correlated_areal_angles, rough, same_runs
from engine_helpers import two_surface_grid as _grid
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import microimpact as mi
from microimpact.engine import checkpoint as ckpt
from microimpact.engine import kernel, montecarlo, parallel
from microimpact.engine.checkpoint import Checkpoint
from microimpact.engine.montecarlo import run
from microimpact.engine.plan import BLOCK_SIZE
from microimpact.scenario.scenario import SurfaceVariant

pytestmark = pytest.mark.skipif(
    not kernel.kernel_tasks_available(), reason="needs the compiled kernel's task loop"
)


def _same(a, b):
    assert a.accumulators.keys() == b.accumulators.keys()
    same_runs(a, b)


class Spy:
    """Counts the KernelTasks.run calls (one per worker thread) and records
    whether each ran in the main thread (`in_main`)."""

    def __init__(self, monkeypatch):
        self.calls = 0
        self.in_main = []
        real = kernel.KernelTasks.run

        def counted(kt):
            self.calls += 1
            self.in_main.append(threading.current_thread() is threading.main_thread())
            return real(kt)

        monkeypatch.setattr(kernel.KernelTasks, "run", counted)


def _many_tasks(monkeypatch):
    """A 30 x 20 grid at 8,000 impacts (not a short run), cut into tasks of 4
    blocks, with the finished tasks taken at every poll."""
    monkeypatch.setattr(montecarlo, "KERNEL_POLL_S", 0.0)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 4 * BLOCK_SIZE)
    return _grid(
        speeds_m_s=tuple(np.linspace(0.1, 2.0, 30)),
        angles_deg=tuple(np.linspace(5.0, 90.0, 20)),
        samples=8000,
    )


def _task_by_task(monkeypatch, sc, **kw):
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", False)
    try:
        return run(sc, **kw)
    finally:
        monkeypatch.setattr(montecarlo, "KERNEL_TASKS", True)


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_the_tasks_inside_the_kernel_are_the_task_by_task_bits(monkeypatch, workers):
    """Two surfaces (one areal: the lateral histograms), normal incidence, a
    sample count that leaves a short last block, on 1-3 threads: every
    accumulator as the task-by-task driver's, through the kernel's path."""
    # (3 threads on this 2-core machine too: bits, not speed)
    monkeypatch.setattr(parallel, "available_cores", lambda: 4)
    areal = SurfaceVariant("areal", correlated_areal_angles(3000))
    sc = _grid(surfaces=(rough(8.0), areal), samples=BLOCK_SIZE + 1234)
    ref = _task_by_task(monkeypatch, sc, seed=3)
    spy = Spy(monkeypatch)
    got = run(sc, seed=3, workers=workers)
    assert spy.calls == workers
    _same(ref, got)
    if workers > 1:
        assert got.provenance["local_workers"] == "threads"


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    speeds=st.integers(1, 7),
    angles=st.integers(1, 6),
    samples=st.integers(1, 3 * BLOCK_SIZE),
    seed=st.integers(0, 2**32),
    workers=st.sampled_from([1, 2]),
)
def test_any_fresh_grid_in_the_kernel_is_the_task_by_task_run(
    monkeypatch, speeds, angles, samples, seed, workers
):
    """Random valid grids through the public run(): the kernel's tasks give
    the task-by-task driver's accumulators, bit for bit."""
    sc = _grid(
        speeds_m_s=tuple(np.linspace(0.1, 3.0, speeds)),
        angles_deg=tuple(np.linspace(5.0, 90.0, angles)),
        samples=samples,
    )
    spy = Spy(monkeypatch)
    got = run(sc, seed=seed, workers=workers)
    assert spy.calls >= 1
    _same(_task_by_task(monkeypatch, sc, seed=seed), got)


def test_runs_the_kernel_cannot_take_whole_go_task_by_task(monkeypatch):
    """Points of more blocks than a group (several groups to merge), a
    precision target and QMC replicates are not the kernel's to run whole
    (nor a resumed run: below): they take the task-by-task driver."""
    spy = Spy(monkeypatch)
    run(_grid(speeds_m_s=(0.5,), angles_deg=(40.0,), samples=20_000), seed=1)
    assert spy.calls == 1  # (the oracle: this one is)
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)
    run(_grid(speeds_m_s=(0.5,), angles_deg=(40.0,), samples=3 * BLOCK_SIZE), seed=1)
    assert spy.calls == 1
    monkeypatch.undo()
    spy = Spy(monkeypatch)
    one = dict(speeds_m_s=(0.5,), angles_deg=(40.0,))
    run(_grid(sampling="qmc", qmc_replicates=4, samples=2048, **one))
    run(_grid(precision=mi.scenario.Precision("capture_fraction", 0.05, 20_000), **one))
    assert spy.calls == 0


def test_an_interrupted_run_keeps_its_finished_tasks_and_resumes(tmp_path, monkeypatch):
    """Ctrl-C while the kernel runs the tasks (here: raised by the progress
    callback at the first task done): the workers stop after their current
    task, the finished tasks are written to the checkpoint, and a re-run
    simulates only the rest, to the bits of an uninterrupted run."""
    sc = _many_tasks(monkeypatch)
    full = run(sc, seed=9)
    raised = []

    def interrupt(done, total):
        if not raised:
            raised.append(done)
            raise KeyboardInterrupt("interrupted by the test")

    made = []
    real_init = kernel.KernelTasks.__init__

    def keep(kt, *a):
        made.append(kt)
        real_init(kt, *a)

    monkeypatch.setattr(kernel.KernelTasks, "__init__", keep)
    path = tmp_path / "run.npz"
    first = Checkpoint(path)
    with pytest.raises(KeyboardInterrupt):
        run(sc, seed=9, checkpoint=first, progress=interrupt, workers=2)
    saved = ckpt.load(path, first._fingerprint)
    assert raised and 0 < len(saved) < len(full.accumulators)
    # every task the kernel finished was taken, none is left behind
    impacts, left = made[0].harvest()
    assert left == [] and impacts == len(saved) * sc.samples
    for (p, _r), (nxt, acc) in saved.items():
        assert nxt == 1 and acc == full.accumulators[p]
    simulated = []
    real = kernel.task_rows

    def counted(plan, task):
        simulated.extend(task.point.tolist())
        return real(plan, task)

    monkeypatch.setattr(kernel, "task_rows", counted)
    ck = Checkpoint(path)
    again = run(sc, seed=9, checkpoint=ck)
    assert ck.restored_blocks == len(saved)
    assert sorted(simulated) == sorted(
        set(range(len(full.accumulators))) - {p for p, _ in saved}
    )
    _same(full, again)


def test_checkpoints_during_the_run_hold_only_finished_tasks(tmp_path, monkeypatch):
    """A checkpoint written while the kernel runs (the workers paused) holds
    the tasks finished by then, each stream as the full run's."""
    sc = _many_tasks(monkeypatch)
    full = run(sc, seed=2)
    states = []
    real_write = Checkpoint.write

    def write(self, state):
        states.append(state.keys.copy())
        return real_write(self, state)

    monkeypatch.setattr(Checkpoint, "write", write)
    ck = Checkpoint(tmp_path / "run.npz", interval=0.0)
    got = run(sc, seed=2, checkpoint=ck, workers=2)
    _same(full, got)
    assert len(states) > 2
    sizes = [len(s) for s in states]
    assert sizes == sorted(sizes) and sizes[-1] == len(full.accumulators)
    assert 0 < sizes[0] < sizes[-1]


def test_task_loop_arguments_are_checked():
    """_ckernel.tasks refuses starts that do not cover the groups, points that
    do not increase or lie outside the plan or the table, and a table of the
    wrong shape, with a ValueError, before any thread runs."""
    from microimpact.engine import _compiled
    from microimpact.engine.plan import build_plan

    ck = _compiled.ckernel
    plan = build_plan(_grid(), seed=1)
    kernel.prepare_plan(plan)
    R = len(plan.points)
    i64 = lambda *v: np.array(v, dtype=np.int64)  # noqa: E731

    def table(rows=R):
        return (
            np.zeros((rows, 5), np.int64),
            *(np.zeros((rows, 4)) for _ in range(3)),
            *(np.zeros(rows, np.int32) for _ in range(6)),
            *(np.zeros(rows, np.int64) for _ in range(3)),
        )

    def call(
        point=(0, 1),
        first=(0, 0),
        last=(0, 0),
        starts=(0, 2),
        t=None,
        stop=1,
        arrays=None,
    ):
        point, first, last, starts = arrays or (
            i64(*point),
            i64(*first),
            i64(*last),
            i64(*starts),
        )
        return ck.tasks(
            kernel.entropy_words(plan.entropy),
            kernel._common_args(plan),
            kernel._plan_points(plan),
            point,
            first,
            last,
            starts,
            stop,
            100,
            100,
            table() if t is None else t,
        )

    # the index arrays are copied when checked: changed afterwards (here to a
    # point outside the table) they change nothing
    arrays = (i64(0, 1), i64(0, 0), i64(0, 0), i64(0, 2))
    ok = call(arrays=arrays)
    arrays[0][1] = 10**12
    arrays[3][1] = 7
    assert ck.tasks_run(ok) == 1
    impacts, items = ck.tasks_harvest(ok)
    assert impacts == 200 and [i[0] for i in items] == [0]
    for bad in (
        dict(starts=(0, 1)),
        dict(starts=(1, 2)),
        dict(starts=(0, 2, 1, 2)),
        dict(point=(1, 0)),
        dict(point=(0, R)),
        dict(first=(1, 0)),
        dict(last=(0, 1)),
        dict(t=table(R)[:12]),
        dict(t=(np.zeros((R, 4), np.int64), *table()[1:])),
        dict(t=table(1)),
        # block counts whose specs' size would wrap (a heap overrun before)
        dict(first=(0, 0), last=(2**62 - 1, 0), stop=2**62),
    ):
        with pytest.raises(ValueError):
            call(**bad)


def test_a_short_run_on_one_worker_runs_its_tasks_in_the_caller(monkeypatch):
    """Under BACKGROUND_IMPACTS on one worker, the kernel runs the tasks in the
    calling thread (no thread to start and wake); a longer run, or two
    workers, in worker threads (the caller stays free for Ctrl-C and the
    progress bar). The same bits either way."""
    spy = Spy(monkeypatch)
    where = spy.in_main
    sc = _grid(samples=2000)  # 72 points: 144,000 impacts
    short = run(sc, seed=4)
    assert where == [True]
    where.clear()
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", 0)
    long = run(sc, seed=4)
    assert where == [False]
    where.clear()
    two = run(sc, seed=4, workers=2)
    assert where == [False, False]
    _same(short, long)
    _same(short, two)
