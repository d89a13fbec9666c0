"""The driver's tasks, worker cap and duration estimate: wiring and invariants.

These tests follow the task-by-task driver (each task a kernel call from
Python, merged by the driver), which resumed, precision and Dask runs take;
a fresh run of whole streams runs its tasks inside the kernel instead
(``montecarlo.KERNEL_TASKS``: tests/engine/test_kernel_tasks.py), so it is
switched off here."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from engine_helpers import rough, same_runs, scenario

from microimpact.engine import kernel, montecarlo, parallel
from microimpact.engine.montecarlo import estimate_duration, iter_blocks, run
from microimpact.engine.plan import BLOCK_SIZE


@pytest.fixture(autouse=True)
def _task_by_task(monkeypatch):
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", False)


def _grid(**kw):
    base = dict(
        surfaces=(rough(8.0),),
        speeds_m_s=tuple(np.linspace(0.1, 1.0, 12)),
        angles_deg=(20.0, 50.0, 80.0),
        samples=3000,
    )
    base.update(kw)
    return scenario(**base)


class Recorder:
    """Records the tasks a runner is given."""

    def __init__(self, monkeypatch):
        self.tasks = []
        real = parallel.run_task

        def record(plan, task):
            self.tasks.append(task)
            return real(plan, task)

        monkeypatch.setattr(parallel, "run_task", record)

    @property
    def sizes(self) -> list[int]:
        """The impacts of each (array) task recorded."""
        return [int(np.sum(task.impacts())) for task in self.tasks]


def test_small_points_share_a_task(monkeypatch):
    """36 points of 3,000 impacts: one task, not one per point."""
    rec = Recorder(monkeypatch)
    run(_grid())
    assert len(rec.tasks) == 1
    assert [g[0][:3] for g in rec.tasks[0]] == [(p, 0, 0) for p in range(36)]


def test_tasks_hold_a_fixed_number_of_impacts(monkeypatch):
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 10_000)
    rec = Recorder(monkeypatch)
    run(_grid())
    assert len(rec.tasks) == 9  # 4 groups of 3,000 reach 10,000
    assert all(len(t) == 4 for t in rec.tasks)
    monkeypatch.setattr(montecarlo, "TASK_GROUPS", 5)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 10**9)
    rec.tasks.clear()
    run(_grid())
    assert [len(t) for t in rec.tasks] == [5] * 7 + [1]


def test_large_groups_are_tasks_of_their_own(monkeypatch):
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)
    rec = Recorder(monkeypatch)
    run(scenario(speeds_m_s=(0.2, 0.3), samples=5 * BLOCK_SIZE))
    assert all(sum(s[3] for g in t for s in g) <= 64 * BLOCK_SIZE for t in rec.tasks)
    groups = [g for t in rec.tasks for g in t]
    assert [[s[2] for s in g] for g in groups] == [[0, 1], [2, 3], [4]] * 2


@pytest.mark.parametrize("impacts", [1, 5_000, 10**9])
def test_packing_changes_no_bit(monkeypatch, impacts):
    """Tasks are transport: any packing gives the same bits, on 1 or 2 workers."""
    sc = _grid(speeds_m_s=(0.1, 0.4), samples=70_000)
    ref = run(sc)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", impacts)
    same_runs(ref, run(sc))
    same_runs(ref, run(sc, workers=2))


def _no_stacked(plan, specs, groups=None):
    return None  # as a kernel without the stacked path


def _no_task(plan, task):
    return None  # as a kernel without the one-call task path


def test_simulate_specs_is_used_when_the_kernel_has_it(monkeypatch):
    """One kernel call per task with all its block specs, and the same bits as
    simulate_block per spec."""
    sc = _grid()
    ref = run(sc)
    calls = []

    def simulate_specs(plan, specs):
        calls.append(list(specs))
        return [kernel.simulate_block(plan, *s) for s in specs]

    monkeypatch.setattr(kernel, "simulate_specs", simulate_specs, raising=False)
    # the per-accumulator path (the stacked one, tested against it in
    # tests/engine/test_grid_speed.py, is switched off here)
    monkeypatch.setattr(kernel, "simulate_specs_stacked", _no_stacked)
    monkeypatch.setattr(kernel, "task_rows", _no_task)
    same_runs(ref, run(sc))
    assert len(calls) == 1 and len(calls[0]) == 36


def test_the_stacked_kernel_path_is_one_call_per_task(monkeypatch):
    """Tasks of single-block groups go through kernel.simulate_specs_stacked, one
    call with all the task's specs, with the same bits."""
    sc = _grid()
    monkeypatch.setattr(kernel, "simulate_specs_stacked", _no_stacked)
    ref = run(sc)
    monkeypatch.undo()
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", False)  # (undone too)
    if kernel.KERNEL != "compiled":
        pytest.skip("compiled kernel not built")
    calls = []
    real = kernel.simulate_specs_stacked

    def stacked(plan, specs, groups=None):
        calls.append(list(specs))
        return real(plan, specs, groups)

    monkeypatch.setattr(kernel, "simulate_specs_stacked", stacked)
    monkeypatch.setattr(kernel, "task_rows", _no_task)
    same_runs(ref, run(sc))
    assert len(calls) == 1 and len(calls[0]) == 36


def test_merge_in_a_task_follows_block_order(monkeypatch):
    """A worker merges a group's blocks in block order: reversing them changes the
    moments' last bits (so the bit-identity tests can see a wrong order)."""
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 8)
    sc = scenario(
        surfaces=(rough(10.0),),
        speeds_m_s=(0.5,),
        angles_deg=(40.0,),
        samples=8 * BLOCK_SIZE,
    )
    ref = run(sc).accumulators[0]
    with pytest.MonkeyPatch.context() as m:  # the Python fold (no compiled kernel)
        m.setattr(kernel, "simulate_specs_stacked", _no_stacked)
        m.setattr(kernel, "task_rows", _no_task)
        real = parallel._simulate
        m.setattr(parallel, "_simulate", lambda p, s: real(p, s[::-1])[::-1])
        assert run(sc).accumulators[0] == ref  # same specs, same order of merging
        m.setattr(parallel, "_simulate", lambda p, s: real(p, s)[::-1])
        bad = run(sc).accumulators[0]
        assert bad.n == ref.n and bad.e != ref.e
    if kernel.KERNEL != "compiled":
        return
    # the compiled kernel's fold: the specs of each group handed over reversed
    real_stacked = kernel.simulate_specs_stacked

    def reversed_groups(p, specs, groups=None):
        specs, at = list(specs), 0
        for g in groups:
            specs[at : at + g] = specs[at : at + g][::-1]
            at += g
        return real_stacked(p, specs, groups)

    monkeypatch.setattr(kernel, "simulate_specs_stacked", reversed_groups)
    monkeypatch.setattr(kernel, "task_rows", _no_task)
    bad = run(sc).accumulators[0]
    assert bad.n == ref.n and bad.e != ref.e


def test_merge_order_is_the_documented_one():
    """Oracle for the merge order: blocks merged in order within groups of
    BLOCKS_PER_TASK (aligned), the groups merged in order, on 1 and 2 workers."""
    from microimpact.engine.montecarlo import build_plan

    sc = scenario(
        surfaces=(rough(10.0),), speeds_m_s=(0.5,), angles_deg=(40.0,), samples=140_000
    )
    plan = build_plan(sc)
    for T in (montecarlo.BLOCKS_PER_TASK, 2):
        blocks = [
            kernel.simulate_block(
                plan, 0, 0, b, min(BLOCK_SIZE, 140_000 - b * BLOCK_SIZE)
            )
            for b in range(5)
        ]
        expect = None
        for g in range(0, 5, T):
            acc = blocks[g]
            for b in blocks[g + 1 : g + T]:
                acc = acc.merge(b)
            expect = acc if expect is None else expect.merge(acc)
        with pytest.MonkeyPatch.context() as m:
            m.setattr(montecarlo, "BLOCKS_PER_TASK", T)
            assert run(sc).accumulators[0] == expect
            assert run(sc, workers=2).accumulators[0] == expect


# ---------------------------------------------------------------- worker cap
def test_workers_above_the_cores_are_capped(monkeypatch):
    monkeypatch.setattr(parallel, "available_cores", lambda: 1)
    sc = scenario(samples=1000)
    with pytest.warns(RuntimeWarning, match=r"workers=3 exceeds the 1 core"):
        res = run(sc, workers=3)
    assert res.provenance["workers"] == 1
    assert res.provenance["workers_requested"] == 3
    same_runs(run(sc), res)


def test_workers_within_the_cores_are_not_capped(monkeypatch):
    monkeypatch.setattr(parallel, "available_cores", lambda: 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = run(scenario(samples=1000), workers=2)
    assert res.provenance["workers"] == 2
    assert "workers_requested" not in res.provenance
    assert parallel.cap_workers(8, backend="dask", address="tcp://h:1") == 8


def test_available_cores_is_the_affinity():
    import os

    if hasattr(os, "sched_getaffinity"):
        assert parallel.available_cores() == len(os.sched_getaffinity(0))


# ------------------------------------------------------------------ estimate
def test_estimate_scales_the_timed_blocks(monkeypatch):
    """With a fake clock where a block of n impacts costs c + r n (and c0 more at a
    point not seen before), the estimate is exactly the run's cost."""
    c, r, c0 = 1e-3, 2e-8, 5e-3
    clock = [0.0]
    seen = set()

    def fake(plan, specs):
        for point, _rep, _b, n in specs:
            clock[0] += c + r * n + (c0 if point not in seen else 0.0)
            seen.add(point)
        return [None] * len(specs)

    monkeypatch.setattr(montecarlo, "_simulate", fake)
    monkeypatch.setattr(montecarlo, "_calibration_batch", fake)
    monkeypatch.setattr(montecarlo.time, "perf_counter", lambda: clock[0])
    sc = _grid(samples=100_000)  # 4 blocks per point, 36 points
    est = estimate_duration(sc)
    blocks = math.ceil(100_000 / BLOCK_SIZE)
    exact = 36 * (c0 + blocks * c + r * 100_000)
    assert est == pytest.approx(exact, rel=1e-9)
    monkeypatch.setattr(parallel, "available_cores", lambda: 2)
    seen.clear()
    assert estimate_duration(sc, workers=4) == pytest.approx(exact / 2, rel=1e-9)
    seen.clear()
    assert estimate_duration(sc, samples=10) == pytest.approx(
        36 * (c0 + c + r * 10), rel=1e-9
    )


def test_estimate_is_the_right_order_of_magnitude():
    sc = scenario(surfaces=(rough(10.0),), angles_deg=(30.0, 60.0), samples=400_000)
    est = estimate_duration(sc)
    import time

    run(sc, samples=1000)  # one-time costs (imports of pandas, xarray) first
    t = time.perf_counter()
    run(sc)
    actual = time.perf_counter() - t
    assert actual / 10 < est < actual * 10


def test_estimate_handles_a_precision_target():
    import microimpact as mi

    sc = scenario(precision=mi.scenario.Precision("capture_fraction", 0.01, 200_000))
    assert 0 < estimate_duration(sc) < 60
    with pytest.raises(ValueError, match="`workers`"):
        estimate_duration(sc, workers=0)


def test_iter_blocks_yields_every_group_in_key_order():
    monkey = _grid(speeds_m_s=(0.1, 0.2), angles_deg=(30.0,), samples=3 * BLOCK_SIZE)
    seen = [(br.point, br.block, br.done) for br in iter_blocks(monkey)]
    assert seen == [(0, 2, True), (1, 2, True)]


def test_entry_points_take_a_preset_name_or_a_scenario_file(tmp_path):
    """run, iter_blocks, sample_point, estimate_duration and convergence_study all
    normalise their scenario (a Scenario, a TOML path or a preset name)."""
    import microimpact as mi
    from microimpact.scenario.file import preset_path

    name = "sst65-silicon-normal"
    by_name = run(name, samples=300, seed=1)
    by_path = run(preset_path(name), samples=300, seed=1)
    same_runs(by_name, by_path)
    assert next(iter_blocks(name, samples=300, seed=1)).total.n == 300
    assert montecarlo.sample_point(name, 0, 50, seed=1)["e_m"].shape == (50,)
    assert estimate_duration(name, samples=300) > 0
    assert mi.convergence_study(name, n_max=100, seed=1).table["n"].iloc[-1] == 100


def test_a_precision_wave_gives_every_worker_a_task():
    """Waves of a precision target are short: their blocks are spread over tasks
    (transport only: the bits do not depend on it)."""
    import microimpact as mi
    from microimpact.engine.montecarlo import _precision_wave, _Streams, build_plan

    sc = scenario(precision=mi.scenario.Precision("capture_fraction", 0.001, 10**7))
    plan = build_plan(sc)
    streams = _Streams(plan, None, sc.precision, sc.confidence)
    wave = _precision_wave(streams, 4, 2)
    assert [[g[0][2] for g in t] for t in wave] == [[0], [1], [2], [3]]
    many = _Streams(build_plan(_grid(precision=sc.precision)), None, sc.precision, 0.95)
    wave = _precision_wave(many, 4, 2)
    assert len(wave) >= 8 and sum(len(t) for t in wave) == 36 * 4


def test_any_executor_gives_the_same_bits():
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    sc = _grid(speeds_m_s=(0.1, 0.4, 0.9), samples=300_000)
    ref = run(sc)
    with ThreadPoolExecutor(2) as ex:
        res = run(sc, executor=ex)
    same_runs(ref, res)
    assert res.provenance["backend"] == "executor"
    with ProcessPoolExecutor(2) as ex:
        same_runs(ref, run(sc, executor=ex))


def test_local_workers_are_threads_when_the_kernel_frees_the_gil():
    """Several local workers are threads for the compiled kernel's plans, Monte
    Carlo and QMC (it frees the GIL), processes for the NumPy kernel; the
    provenance says which."""
    import dataclasses

    from microimpact.engine.plan import build_plan

    sc = _grid(speeds_m_s=(0.3,), samples=2000)
    plan = build_plan(sc)
    if plan.kernel != "compiled":  # pragma: no cover - built without the C kernel
        pytest.skip("the compiled kernel is not built")
    runners = []
    try:
        runners.append(parallel.make_runner(plan, workers=2))
        assert type(runners[-1]) is parallel.ThreadRunner
        runners.append(
            parallel.make_runner(dataclasses.replace(plan, kernel="numpy"), workers=2)
        )
        assert type(runners[-1]) is parallel.PoolRunner
        runners.append(
            parallel.make_runner(dataclasses.replace(plan, sampling="qmc"), workers=2)
        )
        assert type(runners[-1]) is parallel.ThreadRunner
        assert type(parallel.make_runner(plan, workers=1)) is parallel.SerialRunner
    finally:
        for r in runners:
            r.close()
    res = run(sc, workers=2)
    assert res.provenance["local_workers"] == "threads"
    assert "local_workers" not in run(sc, workers=1).provenance


@pytest.mark.parametrize("kernel_name", ["compiled", "numpy"])
def test_threads_and_processes_give_the_bits_of_one_worker(kernel_name):
    """workers=2 (threads for the compiled kernel, a process pool for the NumPy
    kernel) merges every group exactly as one worker does, over many tasks."""
    from microimpact.engine.plan import build_plan

    sc = _grid(samples=5000)
    plan = build_plan(sc, kernel=kernel_name)
    one = {(b.point, b.replicate): b.total for b in iter_blocks(sc, plan=plan)}
    two = {
        (b.point, b.replicate): b.total
        for b in iter_blocks(sc, plan=build_plan(sc, kernel=kernel_name), workers=2)
    }
    assert one.keys() == two.keys() and len(one) == 36
    for k in one:
        assert one[k] == two[k], k


@pytest.mark.parametrize(
    ("remaining", "workers", "want"),
    [
        (10**9, 1, montecarlo.TASK_IMPACTS),  # one worker: always the full size
        (100, 1, montecarlo.TASK_IMPACTS),
        (10**9, 16, montecarlo.TASK_IMPACTS),  # enough tasks of the full size
        # a 60 x 60 grid at 8,000 per point: 28.8e6 / (4 x 16) = 450,000
        (28_800_000, 16, 450_000),
        (28_800_000, 256, montecarlo.MIN_TASK_IMPACTS),  # floored
        (400_000, 2, montecarlo.MIN_TASK_IMPACTS),
        (0, 4, montecarlo.MIN_TASK_IMPACTS),
    ],
)
def test_task_impacts_keep_the_workers_busy(remaining, workers, want):
    assert montecarlo.task_impacts(remaining, workers) == want


def test_task_sizes_shrink_toward_the_end_on_several_workers():
    """Guided sizes: task_impacts until the impacts left fall below TAIL_SPLIT x
    workers tasks of it, then what is left over that, floored; one worker and
    a Dask cluster keep one size."""
    M = montecarlo
    size = M.task_sizes(28_800_000, 16)
    assert size(0) == 450_000  # task_impacts(28.8e6, 16)
    split = M.TAIL_SPLIT * 16
    assert size(28_800_000 - 450_000 * split) == 450_000  # not yet
    assert size(28_800_000 - 200_000 * split) == 200_000
    assert size(28_800_000 - 1000) == M.MIN_TASK_IMPACTS  # the floor
    one = M.task_sizes(28_800_000, 1)
    assert one(0) == one(28_799_999) == M.TASK_IMPACTS
    far = M.task_sizes(64_000_000, 2, remote=True)
    assert far(0) == far(63_999_999) == M.task_impacts(64_000_000, 2, remote=True)


def test_a_grid_on_several_workers_ends_with_short_tasks(monkeypatch):
    """A grid's tasks on 2 workers shrink toward the end (the last ones hold
    MIN_TASK_IMPACTS, the first TASK_IMPACTS), with the bits of one worker."""
    rec = Recorder(monkeypatch)
    sc = _grid(
        speeds_m_s=tuple(np.linspace(0.2, 2.0, 12)),
        angles_deg=tuple(np.linspace(10.0, 80.0, 12)),
    )
    one = run(sc, samples=40_000, seed=3, workers=1)
    rec.tasks.clear()
    many = run(sc, samples=40_000, seed=3, workers=2)
    sizes = rec.sizes
    total = 144 * 40_000
    assert sum(sizes) == total
    assert sizes[0] >= montecarlo.TASK_IMPACTS
    # the last tasks: whole points up to a task of MIN_TASK_IMPACTS
    assert max(sizes[-3:]) < montecarlo.MIN_TASK_IMPACTS + 40_000
    assert sizes[-1] < sizes[0] / 3
    same_runs(one, many)


@pytest.mark.parametrize(
    ("remaining", "workers", "want"),
    [
        # 64 points of 10^6 on 2 Dask workers: 4 tasks each, of 8 points
        (64_000_000, 2, 8_000_000),
        (10**12, 2, montecarlo.DASK_TASK_IMPACTS),  # capped
        (64_000_000, 16, 1_000_000),
        (28_800_000, 16, montecarlo.TASK_IMPACTS),  # never below a thread's
        (100, 2, montecarlo.TASK_IMPACTS),
    ],
)
def test_task_impacts_on_a_dask_cluster(remaining, workers, want):
    """Dask tasks cost ~1-2 ms each to schedule and send: as large as make
    TASKS_PER_WORKER per worker, between TASK_IMPACTS and DASK_TASK_IMPACTS."""
    assert montecarlo.task_impacts(remaining, workers, remote=True) == want


def test_a_dask_run_packs_its_tasks_by_the_cluster_rule(monkeypatch):
    """The driver sizes a Dask run's tasks by the remote rule (a stand-in runner
    that reduces locally records them), with the bits of one local worker."""
    sizes = []

    class Reduced:
        background, local_workers, workers = "now", None, 2

        def __init__(self, plan, *, address=None, workers=2):
            self.plan = plan

        def reduced(self, tasks):
            for task in tasks:
                sizes.append(int(np.sum(task.impacts())))
                yield parallel.task_partial(self.plan, task)

        def close(self):
            pass

    monkeypatch.setattr(parallel, "DaskRunner", Reduced)
    # a thread's task holds one point of 200,000 (> 4 blocks); a Dask task two
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", montecarlo.MIN_TASK_IMPACTS)
    sc = _grid(speeds_m_s=(0.2, 0.5, 1.0, 2.0), angles_deg=(20.0, 40.0, 60.0, 80.0))
    one = run(sc, samples=200_000, seed=3, workers=1)
    many = run(sc, samples=200_000, seed=3, backend="dask", workers=2)
    size = montecarlo.task_impacts(16 * 200_000, 2, remote=True)
    assert size == 400_000
    assert sum(sizes) == 16 * 200_000
    # whole points are packed until a task holds `size` impacts
    assert all(s >= size for s in sizes[:-1])
    assert len(sizes) == montecarlo.TASKS_PER_WORKER * 2  # 8 tasks of 2 points
    same_runs(one, many)


@pytest.mark.parametrize("workers", [2, 3])
def test_small_runs_spread_over_the_workers(monkeypatch, workers):
    """A sweep of fewer impacts than one full task is packed into tasks of at
    least MIN_TASK_IMPACTS for several workers, so each gets work; the bits are
    those of one worker (whose tasks are the full size)."""
    rec = Recorder(monkeypatch)
    sc = _grid(speeds_m_s=(0.2, 0.5, 1.0, 2.0), angles_deg=(20.0, 40.0, 60.0, 80.0))
    one = run(sc, samples=30_000, seed=3, workers=1)
    assert len(rec.sizes) == 1  # 16 x 30,000 impacts: one task of the full size
    rec.tasks.clear()
    many = run(sc, samples=30_000, seed=3, workers=workers)
    sizes = rec.sizes
    # 480,000 impacts over 4 x workers tasks: floored at MIN_TASK_IMPACTS
    assert len(sizes) == math.ceil(480_000 / montecarlo.MIN_TASK_IMPACTS)
    assert sum(sizes) == 480_000
    assert all(s >= montecarlo.MIN_TASK_IMPACTS for s in sizes[:-1])
    same_runs(one, many)
