"""Tasks described by arrays (engine/tasks.py, issue 31): the same groups, tasks,
kernel calls and bits as the driver's tuples, whose code stays the oracle."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from engine_helpers import correlated_areal_angles, rough
from engine_helpers import two_surface_grid as _grid
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal

from microimpact.engine import kernel, montecarlo, parallel, tasks
from microimpact.engine.montecarlo import _fixed_tasks, _Streams, run
from microimpact.engine.plan import build_plan
from microimpact.engine.tasks import BlockTask, block_tasks
from microimpact.scenario.grid import GridPoints, SweepGrid
from microimpact.scenario.scenario import SurfaceVariant

pytestmark = pytest.mark.skipif(
    kernel.KERNEL != "compiled", reason="array tasks need the compiled kernel"
)


def _tuples(streams) -> list:
    """The driver's tuple tasks for `streams` (the array path switched off)."""
    streams.array_tasks = False
    try:
        return [tuple(t) for t in _fixed_tasks(streams)]
    finally:
        streams.array_tasks = True


def _items(task) -> zip:
    """The ``(i, point, rep, first, last)`` items of _merge_rows for a task's
    groups (the oracle of the merge's array paths)."""
    return zip(
        range(len(task)),
        task.point.tolist(),
        [0] * len(task),
        task.first.tolist(),
        task.last.tolist(),
        strict=True,
    )


def _same_rows(a, b):
    for name in ("counts", "e", "mu", "lateral"):
        assert_array_equal(getattr(a, name), getattr(b, name))
    for name in ("e_spans", "mu_spans", "lateral_spans"):
        x, y = getattr(a, name), getattr(b, name)
        assert_array_equal(x.offset, y.offset)
        assert_array_equal(x.length, y.length)
        assert_array_equal(x.counts, y.counts)


# ---------------------------------------------------------------- the groups
@settings(max_examples=60, deadline=None)
@given(
    streams=st.integers(1, 40),
    cap_blocks=st.integers(1, 150),
    last=st.integers(1, 50),
    per_group=st.sampled_from([1, 2, 3, 8, 64]),
    task_blocks=st.integers(1, 40),
    task_groups=st.integers(1, 9),
    chunk=st.integers(1, 7),
    shrink=st.integers(0, 9),
    data=st.data(),
)
def test_block_tasks_are_the_drivers_tasks(
    streams, cap_blocks, last, per_group, task_blocks, task_groups, chunk, shrink, data
):
    """Against the driver's own rule written out per group (montecarlo._pack
    over groups cut at multiples of `per_group`): the same groups, packed into
    the same tasks, also across chunk boundaries and from resumed streams."""
    B = 50
    stop = cap_blocks
    starts = np.array(
        data.draw(st.lists(st.integers(0, stop), min_size=streams, max_size=streams))
    )
    ks = np.arange(streams) * 3  # any ascending streams

    def groups():
        for k, start in zip(ks.tolist(), starts.tolist(), strict=True):
            while start < stop:
                end = min((start // per_group + 1) * per_group, stop)
                g = tuple(
                    (k, 0, b, last if b == stop - 1 else B) for b in range(start, end)
                )
                yield g, sum(s[3] for s in g)
                start = end

    old = (montecarlo.TASK_IMPACTS, montecarlo.TASK_GROUPS, tasks.CHUNK_STREAMS)
    try:
        montecarlo.TASK_IMPACTS = task_blocks * B
        montecarlo.TASK_GROUPS = task_groups
        tasks.CHUNK_STREAMS = chunk
        # a fixed size, or one that shrinks with the impacts packed before
        # (montecarlo.task_sizes' form)
        size = task_blocks * B
        if shrink:
            size = lambda packed: max(B, task_blocks * B - packed // shrink)  # noqa: E731
        want = [tuple(t) for t in montecarlo._pack(groups(), task_impacts=size)]
        got = list(
            block_tasks(
                ks,
                starts,
                stop=stop,
                block_size=B,
                last_n=last,
                per_group=per_group,
                task_impacts=size,
                task_groups=task_groups,
            )
        )
    finally:
        montecarlo.TASK_IMPACTS, montecarlo.TASK_GROUPS, tasks.CHUNK_STREAMS = old
    assert [tuple(t) for t in got] == want
    for t in got:  # the arrays describe what the tuples say
        specs = list(t.specs())
        assert specs == [s for g in t for s in g]
        assert t.impacts().tolist() == [sum(s[3] for s in g) for g in t]
        assert t.lengths.tolist() == [len(g) for g in t]
        # whole: every group is a whole stream (its blocks 0 .. stop - 1)
        assert t.whole == all(g[0][2] == 0 and g[-1][2] == stop - 1 for g in t)


@pytest.mark.parametrize("samples", [3000, 70_001, 5 * 32768 * 64 + 7])
def test_fixed_tasks_as_arrays_equal_the_tuples(samples):
    """A sweep of small points, points of several blocks, points of several
    groups of 64 blocks: the driver's tasks, group for group."""
    sc = _grid(samples=samples, speeds_m_s=(0.5, 1.0), angles_deg=(30.0, 60.0))
    streams = _Streams(build_plan(sc, seed=3), samples, None, 0.95)
    got = list(_fixed_tasks(streams))
    assert all(isinstance(t, BlockTask) for t in got)
    assert [tuple(t) for t in got] == _tuples(streams)


def test_a_resumed_run_groups_as_the_tuples():
    sc = _grid(samples=40 * 32768)
    streams = _Streams(build_plan(sc, seed=3), sc.samples, None, 0.95)
    streams.next_block[[0, 5, 7]] = [3, 40, 39]
    streams.done[11] = True
    got = list(_fixed_tasks(streams))
    assert [tuple(t) for t in got] == _tuples(streams)
    assert 11 not in np.concatenate([t.point for t in got])


# ---------------------------------------------------------------- the kernel
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_array_specs_give_the_tuple_specs_bits(data):
    """Random specs (points, blocks, sizes, groups) through the kernel as arrays
    and as tuples: the same rows, bit for bit."""
    plan = _PLAN()
    n_points = len(plan.points)
    k = data.draw(st.integers(1, 30))
    specs = [
        (
            data.draw(st.integers(0, n_points - 1)),
            0,
            data.draw(st.integers(0, 5)),
            data.draw(st.integers(0, 700)),
        )
        for _ in range(k)
    ]
    cuts = (
        sorted(set(data.draw(st.lists(st.integers(1, k - 1), max_size=5))))
        if k > 1
        else []
    )
    groups = np.diff([0, *cuts, k])
    arrays = kernel.SpecArrays(
        np.array([s[0] for s in specs]),
        np.array([s[2] for s in specs]),
        np.array([s[3] for s in specs]),
    )
    want = kernel.simulate_specs_stacked(plan, specs, groups)
    _same_rows(kernel.simulate_specs_stacked(plan, arrays, groups), want)
    # the per-block accumulators and the per-impact outputs too
    assert kernel.simulate_specs(plan, arrays) == kernel.simulate_specs(plan, specs)
    a = kernel.simulate_specs_impacts(plan, arrays)
    b = kernel.simulate_specs_impacts(plan, specs)
    for name in a:
        assert_array_equal(a[name], b[name])


def _make_plan():
    plans = {}

    def get():
        if "p" not in plans:
            sc = _grid(
                surfaces=(
                    SurfaceVariant("smooth"),
                    rough(9.0),
                    SurfaceVariant("areal", correlated_areal_angles(400)),
                ),
                speed_spread=0.1,
            )
            plans["p"] = build_plan(sc, seed=9)
        return plans["p"]

    return get


_PLAN = _make_plan()


def test_the_parsed_points_and_the_per_task_points_agree(monkeypatch):
    """The plan's points parsed once (a capsule) and the points of each task
    parsed in its call (the path of surfaces with tables per angle) give the
    same bits; a weighted plan takes the second path."""
    sc = _grid(samples=2000)
    ref = run(sc, seed=4)
    assert kernel._plan_points(build_plan(sc, seed=4)) is not None
    monkeypatch.setattr(kernel, "_parse_plan_points", lambda plan: False)
    got = run(sc, seed=4)
    assert_array_equal(got.summary["e_mean"], ref.summary["e_mean"])
    for key in ref.accumulators:
        assert got.accumulators[key] == ref.accumulators[key]
    weighted = build_plan(_grid(shadowing="weighted"), seed=4)
    assert kernel._plan_points(weighted) is None


def _kernel_args(plan):
    """The compiled kernel and what every call of it reads of `plan`: its parsed
    points, entropy words and common arguments."""
    return (
        kernel._ckernel(),
        kernel._plan_points(plan),
        kernel.entropy_words(plan.entropy),
        kernel._common_args(plan),
    )


def test_array_specs_are_checked():
    plan = _PLAN()
    ck, heads, words, common = _kernel_args(plan)

    def call(items, k=1):
        return ck.specs(
            words,
            common,
            items,
            np.empty((k, 5), np.int64),
            np.empty((k, 12)),
            np.empty((k, 6), np.int64),
        )

    def arrays(which=0, point=0, block=0, n=10, speed=1.0, points=heads):
        i64 = lambda v: np.array([v], dtype=np.int64)  # noqa: E731
        return (points, i64(which), np.array([speed]), i64(point), i64(block), i64(n))

    assert len(call(arrays())) > 0
    for bad in (
        arrays(which=10**6),
        arrays(which=-1),
        arrays(point=-1),
        arrays(block=-2),
        arrays(n=-1),
    ):
        with pytest.raises(ValueError):
            call(bad)
    with pytest.raises(ValueError):  # lengths that disagree
        a = list(arrays())
        a[4] = np.zeros(2, dtype=np.int64)
        call(tuple(a))
    with pytest.raises(TypeError):
        call(arrays()[:5])
    with pytest.raises(TypeError):
        call(arrays(points=(1, 2)))
    with pytest.raises(TypeError):  # another capsule, or a list of non-tuples
        call(arrays(points=[[1, 2]]))
    with pytest.raises(TypeError):
        call({"not": "specs"})


# ---------------------------------------------------------------- the driver
@pytest.mark.parametrize("workers", [1, 2])
def test_runs_with_array_tasks_match_the_tuple_tasks(monkeypatch, workers):
    """Whole runs, small points and points of several groups, on 1 and 2
    workers: the same results as with the driver's tuples."""
    made = []
    orig_init = _Streams.__init__

    def tuples_only(self, *a, **k):
        orig_init(self, *a, **k)
        self.array_tasks = False
        made.append(self)

    for sc in (
        _grid(samples=3000),
        _grid(samples=70 * 32768 + 3, speeds_m_s=(1.0,), angles_deg=(40.0,)),
    ):
        monkeypatch.setattr(_Streams, "__init__", tuples_only)
        ref = run(sc, seed=6, workers=workers)
        monkeypatch.undo()
        got = run(sc, seed=6, workers=workers)
        assert made and not made[-1].array_tasks  # the tuple path was taken
        for key in ref.accumulators:
            assert got.accumulators[key] == ref.accumulators[key]


def test_the_first_groups_merge_in_one_step_as_group_by_group():
    """_merge_first_groups (slices, fancy indices) against _merge_rows (the
    oracle), and None where it does not apply."""
    sc = _grid(samples=3000)
    plan = build_plan(sc, seed=2)
    a, b = (_Streams(plan, sc.samples, None, 0.95) for _ in range(2))
    for task in list(_fixed_tasks(a)):
        rows = parallel.run_task(plan, task)
        # a sparse task (every other group) takes the fancy-index path
        for part in (
            BlockTask(
                task.point[::2],
                task.first[::2],
                task.last[::2],
                task.stop,
                task.block_size,
                task.last_n,
            ),
            BlockTask(
                task.point[1::2],
                task.first[1::2],
                task.last[1::2],
                task.stop,
                task.block_size,
                task.last_n,
            ),
        ):
            idx = np.searchsorted(task.point, part.point)
            sub = rows.take(idx)
            assert a._merge_first_groups(part, sub) == int(sub.counts[:, 0].sum())
            items = _items(part)
            b._merge_rows(items, sub)
    assert_array_equal(a.next_block, b.next_block)
    assert_array_equal(a.done, b.done)
    _same_rows(a.stacked(), b.stacked())
    # merged already: not first groups any more
    task = next(iter(_fixed_tasks(_Streams(plan, sc.samples, None, 0.95))))
    assert a._merge_first_groups(task, parallel.run_task(plan, task)) is None


# ---------------------------------------------------------------- the points
def test_grid_points_are_the_tuple_of_points():
    grid = SweepGrid(("a", "b"), (0.3, 1.0, 7.5), (10.0, 45.0, 90.0, 33.0))
    pts = GridPoints(grid)
    want = tuple(grid.points())
    assert len(pts) == len(want) == 24
    assert tuple(pts) == want
    assert [pts[i] for i in range(24)] == list(want)
    assert pts[-1] == want[-1] and pts[3:17:4] == want[3:17:4]
    assert pickle.loads(pickle.dumps(pts))[13] == want[13]
    s, v, a = pts.columns()
    assert s.tolist() == [p.surface for p in want]
    assert v.tolist() == [p.speed for p in want]
    assert a.tolist() == [p.angle_deg for p in want]
    table, keys = pts.tables()
    assert [keys[t] for t in table] == [(p.surface, p.angle_deg) for p in want]
    with pytest.raises(IndexError):
        pts[24]


def test_a_plan_with_other_points_has_its_own_columns():
    """dataclasses.replace(plan, points=...) (the wall law's reduced speed axis)
    must not reuse the columns of the plan it was made from."""
    import dataclasses

    plan = build_plan(_grid(), seed=1)
    before = plan.point_columns()[1].copy()
    points = tuple(dataclasses.replace(p, speed=2 * p.speed) for p in plan.points)
    other = dataclasses.replace(plan, points=points)
    assert_array_equal(other.point_columns()[1], 2 * before)
    assert_array_equal(plan.point_columns()[1], before)
    # read point by point, the same columns as the grid's own arrays
    listed = dataclasses.replace(plan, points=tuple(plan.points))
    for x, y in zip(listed.point_columns()[:4], plan.point_columns()[:4], strict=True):
        assert_array_equal(x, y)
    assert [listed.point_columns()[4][t] for t in listed.point_columns()[3]] == [
        plan.point_columns()[4][t] for t in plan.point_columns()[3]
    ]


def test_streams_of_some_points_take_array_tasks_too(monkeypatch):
    """The calibration batch of estimate_duration (streams of a subset of the
    points: their ids are not 0..n-1) as arrays and as tuples: the same rows."""
    plan = build_plan(_grid(), seed=8)
    specs = [(p, 0, 0, 500) for p in (1, 2, 3, 7, 30, 31, 50)]
    seen = []
    real = parallel.run_task

    def spy(p, task):
        seen.append(type(task).__name__)
        return real(p, task)

    monkeypatch.setattr(parallel, "run_task", spy)
    got = montecarlo._calibration_batch(plan, specs)
    assert seen and set(seen) == {"BlockTask"}
    orig_init = _Streams.__init__

    def tuples_only(self, *a, **k):
        orig_init(self, *a, **k)
        self.array_tasks = False

    monkeypatch.setattr(_Streams, "__init__", tuples_only)
    seen.clear()
    want = montecarlo._calibration_batch(plan, specs)
    assert "BlockTask" not in seen
    _same_rows(got, want)


@settings(max_examples=20, deadline=None)
@given(
    samples=st.sampled_from([1, 2, 99, 32767, 32768, 32769, 65 * 32768 + 1]),
    n_speeds=st.integers(1, 7),
    n_angles=st.integers(1, 5),
    workers=st.sampled_from([1, 2]),
)
def test_any_grid_runs_as_with_the_tuple_tasks(samples, n_speeds, n_angles, workers):
    """Random grids and sample counts (a block and one over, a group of 64 and
    one over) through ``run``: the array tasks give the tuple tasks' results."""
    if samples * n_speeds * n_angles > 3_000_000:
        samples = 32769
    sc = _grid(
        samples=samples,
        speeds_m_s=tuple(np.linspace(0.2, 3.0, n_speeds)),
        angles_deg=tuple(np.linspace(10.0, 90.0, n_angles)),
    )
    got = run(sc, seed=11, workers=workers)
    orig_init = _Streams.__init__

    def tuples_only(self, *a, **k):
        orig_init(self, *a, **k)
        self.array_tasks = False

    with pytest.MonkeyPatch.context() as m:
        m.setattr(_Streams, "__init__", tuples_only)
        want = run(sc, seed=11, workers=workers)
    for key in want.accumulators:
        assert got.accumulators[key] == want.accumulators[key]


# ------------------------------------------------------ one kernel call a task
def _same_narrow_rows(a, b):
    """:func:`_same_rows`, and the histogram counts of one dtype."""
    _same_rows(a, b)
    for name in ("e_spans", "mu_spans", "lateral_spans"):
        assert getattr(a, name).counts.dtype == getattr(b, name).counts.dtype


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_task_rows_are_the_stacked_rows_narrowed(data):
    """kernel.task_rows (``_ckernel.task``: blocks expanded, points looked up,
    rows laid out and narrowed in C) against the specs of the same task through
    simulate_specs_stacked and Stacked.narrow (the oracle): random groups of
    random points of a smooth, a rough and an areal surface, any block sizes."""
    plan = _PLAN()
    n_points = len(plan.points)
    G = data.draw(st.integers(0, 8))
    stop = data.draw(st.integers(1, 5))
    block_size = data.draw(st.integers(1, 900))
    last_n = data.draw(st.integers(1, block_size))
    point = np.array(
        data.draw(st.lists(st.integers(0, n_points - 1), min_size=G, max_size=G)),
        dtype=np.int64,
    )
    first = np.array(
        data.draw(st.lists(st.integers(0, stop - 1), min_size=G, max_size=G)),
        dtype=np.int64,
    )
    last = np.array(
        [data.draw(st.integers(int(f), stop - 1)) for f in first], dtype=np.int64
    )
    task = BlockTask(point, first, last, stop, block_size, last_n)
    want = kernel.simulate_specs_stacked(plan, task.specs(), task.lengths).narrow()
    _same_narrow_rows(kernel.task_rows(plan, task), want)


@pytest.mark.parametrize("block_size", [200, 3000, 70_000])
def test_task_rows_narrow_as_compact_counts(block_size):
    """Counts that need uint8, uint16 and int32: the bin of psi_f = 0 off an
    areal surface holds every rebound of a group, the others fewer."""
    plan = _PLAN()
    # a smooth point where nearly every impact rebounds, two where most stick
    point = np.array([3, 29, 40], dtype=np.int64)
    assert plan.points[29].surface_name == "smooth"
    task = BlockTask(
        point, np.zeros(3, np.int64), np.zeros(3, np.int64), 1, block_size, block_size
    )
    got = kernel.task_rows(plan, task)
    want = kernel.simulate_specs_stacked(plan, task.specs(), task.lengths).narrow()
    _same_narrow_rows(got, want)
    top = int(got.lateral_spans.counts.max())
    assert top >= 0.99 * block_size  # nearly every impact rebounds: one psi_f bin
    assert got.lateral_spans.counts.dtype.itemsize == (
        1 if top < 256 else 2 if top < 65536 else 4
    )


def test_task_rows_is_the_path_of_a_run(monkeypatch):
    """A fixed-size run task by task (not inside the kernel) takes task_rows
    (one kernel call a task), with the bits of the specs' path (task_rows
    switched off)."""
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", False)
    sc = _grid(samples=3000)
    calls = []
    real = kernel.task_rows

    def counted(plan, task):
        calls.append(len(task))
        return real(plan, task)

    monkeypatch.setattr(kernel, "task_rows", counted)
    got = run(sc, seed=5)
    assert sum(calls) == len(got.accumulators)
    monkeypatch.setattr(kernel, "task_rows", lambda plan, task: None)
    ref = run(sc, seed=5)
    for key in ref.accumulators:
        assert got.accumulators[key] == ref.accumulators[key]


def test_task_arguments_are_checked():
    plan = _PLAN()
    ck, points, words, common = _kernel_args(plan)
    i64 = lambda *v: np.array(v, dtype=np.int64)  # noqa: E731

    def call(point=(0,), first=(0,), last=(0,), stop=2, bs=10, last_n=5, pts=points):
        G = len(point)
        return ck.task(
            words,
            common,
            pts,
            i64(*point),
            i64(*first),
            i64(*last),
            stop,
            bs,
            last_n,
            np.empty((G, 5), np.int64),
            np.empty((3, G, 4)),
            np.empty((3, 2, G), np.int64),
        )

    assert len(call()) == 6
    n_points = len(plan.points)
    for bad in (
        dict(point=(n_points,)),
        dict(point=(-1,)),
        dict(first=(1,), last=(0,)),
        dict(last=(2,)),
        dict(first=(-1,)),
        dict(last_n=11),
        dict(last_n=0),
        dict(bs=0),
        dict(stop=0),
        dict(point=(0, 1)),  # lengths that disagree
        # a block count whose specs' size would wrap (a heap overrun before)
        dict(last=(2**62 - 1,), stop=2**62),
    ):
        with pytest.raises(ValueError):
            call(**bad)
    bare = ck.points([], False)  # parsed points without every point's table
    with pytest.raises(ValueError):
        call(pts=bare)
    with pytest.raises(TypeError):
        call(pts=(1, 2))
    with pytest.raises(ValueError):  # which must index the heads
        ck.points([], False, i64(0), np.zeros(1))
    with pytest.raises(ValueError):
        ck.points([], False, i64(), np.zeros(1))
    with pytest.raises(TypeError):
        ck.points([], False, i64())


@pytest.mark.parametrize("pending", [1, 3, 10_000])
def test_rows_held_back_are_in_the_table_when_it_is_read(monkeypatch, pending):
    """The driver keeps up to PENDING_TASKS tasks' rows before it copies them
    into its table: any number gives the same table, and the checkpoint state
    read between merges holds every merged row."""
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 3 * 3000)
    monkeypatch.setattr(montecarlo, "PENDING_TASKS", pending)
    monkeypatch.setattr(montecarlo, "PENDING_ROWS", 10**9)
    sc = _grid(samples=3000)
    plan = build_plan(sc, seed=2)
    a, b = (_Streams(plan, sc.samples, None, 0.95) for _ in range(2))
    tasks_ = list(_fixed_tasks(a))
    assert len(tasks_) > 4
    for i, task in enumerate(tasks_):
        rows = parallel.run_task(plan, task)
        a.merge_task(task, rows)
        items = _items(task)
        b._merge_rows(items, rows)
        # each reader of the table, with rows held back (unless pending is 1)
        if i == 1:
            k = int(task.point[0])
            assert a.acc(k) == b.acc(k) is not None
        elif i == 2:
            assert a.samples_done() == b.samples_done()
        elif i == 3:
            sa, sb = a.state(), b.state()
            assert_array_equal(sa.keys, sb.keys)
            assert_array_equal(sa.next_block, sb.next_block)
            _same_rows(sa.stacked, sb.stacked)
    _same_rows(a.stacked(), b.stacked())


def test_derived_plans_share_parsed_points_only_with_their_points():
    """A plan derived with dataclasses.replace shares its parent's parsed points
    (the wall law's plan per diameter) only where it keeps the parent's points:
    one with other speeds gets its own, and so its own speeds."""
    import dataclasses

    sc = _grid(samples=3000)
    plan = build_plan(sc, seed=3)
    grid = plan.points.grid
    faster = dataclasses.replace(
        plan,
        points=GridPoints(
            dataclasses.replace(grid, speeds_m_s=tuple(3 * v for v in grid.speeds_m_s))
        ),
    )
    same = dataclasses.replace(plan, entropy=plan.entropy + 1)
    assert kernel._plan_points(same) is kernel._plan_points(plan)
    assert kernel._plan_points(faster) is not kernel._plan_points(plan)
    P = len(plan.points)
    task = BlockTask(
        np.arange(P), np.zeros(P, np.int64), np.zeros(P, np.int64), 1, 3000, 3000
    )
    for p in (plan, faster, same):
        want = kernel.simulate_specs_stacked(p, task.specs(), task.lengths).narrow()
        _same_narrow_rows(kernel.task_rows(p, task), want)


def test_task_rows_store_the_impacts_of_the_specs():
    """task_rows with `store` writes each impact's outputs as
    simulate_specs_impacts writes those of the same blocks (the wall law's
    path), and the rows are unchanged by it."""
    plan = _PLAN()
    P = len(plan.points)
    point = np.array([0, 5, P - 1, 40], dtype=np.int64)
    task = BlockTask(point, np.array([0, 1, 0, 2]), np.array([2, 1, 0, 2]), 3, 500, 77)
    total = int(task.impacts().sum())
    store = (
        np.empty(total),
        np.empty(total),
        np.empty(total),
        np.empty(total, np.int8),
    )
    rows = kernel.task_rows(plan, task, store=store)
    _same_narrow_rows(rows, kernel.task_rows(plan, task))
    want = kernel.simulate_specs_impacts(plan, task.specs())
    for got, name in zip(
        store, ("e_m", "mu_m", "lateral_angle_deg", "outcome"), strict=True
    ):
        assert_array_equal(got, want[name])
    # simulate_specs_impacts takes the task itself (the wall law's call)
    got = kernel.simulate_specs_impacts(plan, task)
    for name in want:
        assert_array_equal(got[name], want[name])
    with pytest.raises(ValueError):  # too short for the task's impacts
        kernel.task_rows(plan, task, store=tuple(a[:-1] for a in store))


@pytest.mark.parametrize("samples", [3000, 70_001])
def test_whole_fresh_streams_merge_as_group_by_group(samples):
    """Tasks of whole streams never merged before (block_tasks' `whole`, the
    driver's shortcut) against _merge_rows (the oracle): the same table, the
    same samples merged; and a task of streams already merged is refused."""
    sc = _grid(samples=samples)
    plan = build_plan(sc, seed=2)
    a, b = (_Streams(plan, sc.samples, None, 0.95) for _ in range(2))
    todo = list(_fixed_tasks(a))
    assert any(t.whole for t in todo)
    for task in todo:
        rows = parallel.run_task(plan, task)
        items = _items(task)
        assert a.merge_task(task, rows) == b._merge_rows(items, rows)
    assert_array_equal(a.next_block, b.next_block)
    assert_array_equal(a.done, b.done)
    _same_rows(a.stacked(), b.stacked())
    again = [t for t in _fixed_tasks(_Streams(plan, sc.samples, None, 0.95)) if t.whole]
    assert (
        again
        and a._merge_first_groups(again[0], parallel.run_task(plan, again[0])) is None
    )
    # streams merged group by group, or restored from a checkpoint, are not
    # fresh: a whole task of them is refused too
    task, rows = todo[0], parallel.run_task(plan, todo[0])
    c, d = (_Streams(plan, sc.samples, None, 0.95) for _ in range(2))
    c._merge_rows([(0, int(task.point[0]), 0, 0, int(task.last[0]))], rows)
    assert c._merge_first_groups(task, rows) is None
    d.restore({(int(task.point[-1]), 0): (int(task.last[-1]) + 1, rows.accumulator(0))})
    assert d._merge_first_groups(task, rows) is None


def test_rows_held_back_are_bounded(monkeypatch):
    """The rows kept before the copy into the table are bounded in rows as well
    as in tasks (a sweep of small points packs 2,048 rows into a task)."""
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 3 * 3000)
    monkeypatch.setattr(montecarlo, "PENDING_ROWS", 5)
    sc = _grid(samples=3000)
    plan = build_plan(sc, seed=2)
    a = _Streams(plan, sc.samples, None, 0.95)
    most = 0
    for task in _fixed_tasks(a):
        a.merge_task(task, parallel.run_task(plan, task))
        most = max(most, sum(len(r) for _, r in a._pending))
    assert 0 < most < 5
