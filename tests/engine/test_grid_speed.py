"""The fast path of sweep grids: compact task results, rows instead of objects, the
summary from stacked arrays. Every shortcut is checked against the slow definition
it replaces (same bits)."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from engine_helpers import rough, scenario
from numpy.testing import assert_array_equal

from microimpact.engine import montecarlo, parallel
from microimpact.engine.accumulators import (
    E_BINS,
    E_EDGES,
    LATERAL_BINS,
    MU_BINS,
    Moments,
    PointAccumulator,
    histogram_quantile,
)
from microimpact.engine.montecarlo import build_plan, iter_blocks, run
from microimpact.engine.plan import BLOCK_SIZE
from microimpact.engine.result import SimulationResult
from microimpact.engine.summary import (
    Spans,
    Stacked,
    _histogram_quantiles_dense_search,
    _histogram_quantiles_numpy,
    histogram_quantiles,
)


def _grid(**kw):
    base = dict(
        surfaces=(rough(8.0), rough(15.0, name="rougher")),
        speeds_m_s=tuple(np.linspace(0.1, 1.0, 7)),
        angles_deg=(20.0, 50.0, 80.0),
        samples=3000,
    )
    base.update(kw)
    return scenario(**base)


def _bits(a):
    a = np.asarray(a)
    return a.view(np.uint64) if a.dtype == np.float64 else a


def _same_dataset(a, b):
    assert list(a.data_vars) == list(b.data_vars)
    for v in a.data_vars:
        assert a[v].dtype == b[v].dtype, v
        assert_array_equal(_bits(a[v].values), _bits(b[v].values), err_msg=v)
    skip = {
        "created",
        "history",  # a time stamp, like created
        "elapsed_s",
        "resumed_blocks",
        "total_blocks",
        "workers",
        "local_workers",
    }
    assert {k: str(v) for k, v in a.attrs.items() if k not in skip} == {
        k: str(v) for k, v in b.attrs.items() if k not in skip
    }


def _random_rows(rng, rows, size=E_BINS):
    out = []
    for _ in range(rows):
        d = np.zeros(size, dtype=np.int64)
        kind = rng.integers(0, 6)
        if kind == 1:
            d[rng.integers(0, size)] = rng.integers(1, 5)
        elif kind == 2:
            lo = rng.integers(0, size - 50)
            d[lo : lo + 50] = rng.integers(0, 3, 50)
        elif kind == 3:
            d[0], d[-1] = rng.integers(0, 100, 2)
            d[5:30] = rng.integers(0, 10**6, 25)
        elif kind == 4:
            np.add.at(d, rng.integers(0, size, 1000), 1)
        elif kind == 5:
            d[rng.integers(0, size, 3)] = rng.integers(1, 10**12, 3)
        out.append(d)
    return np.array(out)


# ------------------------------------------------------------------ summary
def test_histogram_quantiles_equal_the_definitions(rng):
    """The search on integer counts gives the bits of forming every cumulative
    fraction (the former vectorised code) and of the per-point oracle."""
    qs = [0.05, 0.5, 0.95, 1e-300, 1.0, 1 / 3, 1e-9, 1 - 1e-12]
    for _ in range(60):
        dense = _random_rows(rng, int(rng.integers(1, 40)))
        spans = Spans.of(
            [
                (
                    int(np.flatnonzero(r)[0]),
                    r[np.flatnonzero(r)[0] :][: np.ptp(np.flatnonzero(r)) + 1],
                )
                if r.any()
                else (0, r[:0])
                for r in dense
            ],
            E_BINS,
        )
        got = histogram_quantiles(spans, E_EDGES, qs)
        ref = _histogram_quantiles_dense_search(spans, E_EDGES, np.asarray(qs))
        assert_array_equal(_bits(got), _bits(ref))
        assert_array_equal(_bits(histogram_quantiles(dense, E_EDGES, qs)), _bits(got))
        oracle = np.array([histogram_quantile(r, E_EDGES, qs) for r in dense])
        assert_array_equal(_bits(got), _bits(oracle))
        if int(dense.max()) < 2**31:  # int32 counts, as tasks return them
            narrow = histogram_quantiles(spans.narrow(), E_EDGES, qs)
            assert_array_equal(_bits(narrow), _bits(got))


def _spans_of(dense):
    return Spans.of(
        [
            (
                int(np.flatnonzero(r)[0]),
                r[np.flatnonzero(r)[0] :][: np.ptp(np.flatnonzero(r)) + 1],
            )
            if r.any()
            else (0, r[:0])
            for r in dense
        ],
        dense.shape[1],
    )


def _numpy_form(spans, edges, qs):
    q = np.asarray(qs, dtype=float)
    return _histogram_quantiles_numpy(
        spans, edges, q, np.full((spans.rows, q.size), np.nan)
    )


@pytest.mark.skipif(
    __import__("microimpact.engine._compiled", fromlist=["x"]).ckernel is None,
    reason="the compiled kernel is not built",
)
@pytest.mark.parametrize("seed", range(6))
def test_compiled_span_quantiles_are_the_numpy_forms_bits(seed):
    """``_ckernel.span_quantiles`` (row by row, in C) against the NumPy form (all
    rows at once), bit for bit: every count dtype, rows with under/overflow and
    single bins, empty rows, rows of zero counts, q at 0 and 1, and a view of a
    larger table (a slice of rows)."""
    from microimpact.engine.accumulators import MU_EDGES

    rng = np.random.default_rng(seed)
    qs = [0.0, 1e-300, 0.05, 1 / 3, 0.5, 0.95, 1 - 1e-12, 1.0]
    for size, edges in ((E_BINS, E_EDGES), (MU_BINS, MU_EDGES)):
        dense = _random_rows(rng, 40, size)
        spans = _spans_of(dense)
        got = histogram_quantiles(spans, edges, qs)
        assert_array_equal(_bits(got), _bits(_numpy_form(spans, edges, qs)))
        # the per-point definition (dense, from bin 0) also, but at q = 0: it
        # takes the leading empty bins, the spans start at the first occupied one
        oracle = np.array([histogram_quantile(r, edges, qs[1:]) for r in dense])
        assert_array_equal(_bits(got[:, 1:]), _bits(oracle))
        small = np.minimum(dense, 200)  # every compact dtype, uint8 among them
        for dtype in (np.uint8, np.uint16, np.int32, np.uint32, np.int64):
            sp = _spans_of(small)
            sp = Spans(sp.offset, sp.length, sp.counts.astype(dtype), sp.size)
            assert_array_equal(
                _bits(histogram_quantiles(sp, edges, qs)),
                _bits(_numpy_form(sp, edges, qs)),
                err_msg=str(dtype),
            )
        part = spans.slice(7, 31)
        assert_array_equal(
            _bits(histogram_quantiles(part, edges, qs)), _bits(got[7:31])
        )
    # a stored row of zero counts has no quantiles (NaN), as an empty row
    zero = Spans(
        np.array([3, 0]), np.array([4, 2]), np.array([0, 0, 0, 0, 5, 1]), E_BINS
    )
    got = histogram_quantiles(zero, E_EDGES, qs)
    assert np.isnan(got[0]).all() and not np.isnan(got[1]).any()
    assert_array_equal(_bits(got), _bits(_numpy_form(zero, E_EDGES, qs)))


def test_span_quantiles_without_the_compiled_kernel_and_outside_unit_q(monkeypatch):
    """The NumPy form serves where there is no compiled kernel; q outside [0, 1]
    is refused by both (the compiled kernel itself too)."""
    from microimpact.engine import _compiled

    rng = np.random.default_rng(3)
    spans = _spans_of(_random_rows(rng, 20))
    qs = [0.05, 0.5, 0.95]
    with_kernel = histogram_quantiles(spans, E_EDGES, qs)
    for q in ([-0.5, 0.5], [0.5, 1.5], [np.nan]):
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            histogram_quantiles(spans, E_EDGES, q)
    if _compiled.ckernel is not None:
        with pytest.raises(ValueError, match="q in"):
            _compiled.ckernel.span_quantiles(
                spans.counts,
                "q",
                spans.start,
                spans.length,
                spans.offset,
                E_BINS,
                E_EDGES,
                np.array([1.5]),
                np.empty(spans.rows),
            )
    monkeypatch.setattr(_compiled, "ckernel", None)
    assert_array_equal(
        _bits(histogram_quantiles(spans, E_EDGES, qs)), _bits(with_kernel)
    )
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        histogram_quantiles(spans, E_EDGES, [2.0])


def _accumulators(rng, k):
    accs = []
    for e_row, mu_row, lat_row in zip(
        _random_rows(rng, k),
        _random_rows(rng, k, MU_BINS),
        _random_rows(rng, k, LATERAL_BINS),
        strict=True,
    ):
        e = Moments(int(rng.integers(0, 10**6)), *rng.normal(size=3).tolist())
        mu = Moments(int(rng.integers(0, 10**6)), *rng.normal(size=3).tolist())
        lat = Moments(int(rng.integers(0, 10**6)), *rng.normal(size=3).tolist())
        counts = rng.integers(0, 10**6, 5).tolist()
        accs.append(
            PointAccumulator(
                *counts,
                e=e,
                mu=mu,
                e_hist=e_row,
                mu_hist=mu_row,
                lateral=lat,
                lateral_hist=lat_row,
            )
        )
    return accs


def test_stacked_rows_round_trip_take_and_concat(rng):
    accs = _accumulators(rng, 25)
    st = Stacked.of(accs)
    assert len(st) == 25
    assert all(st.accumulator(i) == a for i, a in enumerate(accs))
    order = rng.permutation(25)[:17]
    taken = st.take(order)
    assert all(taken.accumulator(j) == accs[i] for j, i in enumerate(order))
    assert st.take(np.arange(25)) is st
    both = Stacked.concat([st, Stacked.of(accs[:3])])
    assert [both.accumulator(i) for i in range(28)] == accs + accs[:3]
    # the moments' counts come back as ints, the values bit for bit
    a = st.accumulator(4)
    assert type(a.e.n) is int and a.e == accs[4].e and a.mu == accs[4].mu
    assert type(a.lateral.n) is int and a.lateral == accs[4].lateral
    assert_array_equal(a.lateral_hist, accs[4].lateral_hist)
    assert_array_equal(st.narrow().accumulator(4).lateral_hist, a.lateral_hist)


# ------------------------------------------------------------------ the driver
def _accumulator_path(sc, seed):
    """The result built the old way: from the iter_blocks totals
    (PointAccumulator objects), one worker."""
    plan = build_plan(sc, seed=seed)
    totals = {
        (br.point, br.replicate): br.total
        for br in iter_blocks(sc, seed=seed)
        if br.done
    }
    return SimulationResult.from_accumulators(sc, plan, totals, elapsed=0.0)


def test_run_equals_the_accumulator_path():
    """run() builds the result from the tasks' rows; building it from the
    iter_blocks totals (PointAccumulator objects) gives the same bits."""
    sc = _grid()
    res = run(sc, seed=3)
    ref = _accumulator_path(sc, 3)
    _same_dataset(ref.dataset, res.dataset)
    plan = build_plan(sc, seed=3)
    assert len(res.accumulators) == len(plan.points)
    assert all(res.accumulators[k] == ref.accumulators[k] for k in ref.accumulators)
    with pytest.raises(KeyError):
        res.accumulators[len(plan.points)]


@pytest.mark.parametrize("workers", [1, 2])
def test_mixed_streams_are_gathered_in_key_order(monkeypatch, workers):
    """Points of one group (kept as rows) and of several groups (merged objects)
    in one run, packed in tasks that straddle points: the same bits as the
    accumulator path."""
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 3 * BLOCK_SIZE)
    sc = _grid(speeds_m_s=(0.2, 0.5), angles_deg=(30.0, 60.0), samples=5 * BLOCK_SIZE)
    sc_small = _grid(speeds_m_s=(0.2, 0.5), angles_deg=(30.0, 60.0), samples=BLOCK_SIZE)
    for s in (sc, sc_small):
        res = run(s, seed=9, workers=workers)
        _same_dataset(_accumulator_path(s, 9).dataset, res.dataset)


def test_qmc_replicates_pool_as_before():
    sc = _grid(sampling="qmc", qmc_replicates=4, samples=2048, speeds_m_s=(0.3, 0.6))
    res = run(sc, seed=2)
    _same_dataset(_accumulator_path(sc, 2).dataset, res.dataset)


def test_tasks_return_rows():
    sc = _grid(speeds_m_s=(0.2, 0.4), angles_deg=(30.0,))
    plan = build_plan(sc, seed=1)
    task = (((0, 0, 0, 3000),), ((1, 0, 0, 3000),))
    rows = parallel.run_task(plan, task)
    assert isinstance(rows, Stacked) and len(rows) == 2
    ref = parallel._simulate(plan, [g[0] for g in task])
    assert [rows.accumulator(i) for i in range(2)] == ref


def test_the_description_is_prepared_while_the_workers_run(monkeypatch):
    """The scenario's description (slow: quadratures) is computed in a thread
    during the run, once, for one worker, for worker processes and for worker
    threads that run the tasks inside the kernel (they never wait for the
    GIL); on worker threads that run tasks one by one from Python it waits for
    the end of the run in the caller (beside them it would make them wait for
    the GIL); an error in it reaches the caller."""
    import dataclasses

    sc = _grid()
    seen = []
    real = SimulationResult.prepare

    def prepare(scenario, **kw):
        seen.append(threading.current_thread() is threading.main_thread())
        return real(scenario, **kw)

    monkeypatch.setattr(SimulationResult, "prepare", staticmethod(prepare))
    # as for a long run (a short one prepares in the caller: test_engine.py)
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", 0)
    ref = run(sc, seed=4)
    assert seen == [False]
    seen.clear()
    two = run(sc, seed=4, workers=2)
    _same_dataset(ref.dataset, two.dataset)
    assert two.provenance["local_workers"] == "threads"
    assert seen == [False]  # the tasks inside the kernel
    seen.clear()
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", False)
    two = run(sc, seed=4, workers=2)
    _same_dataset(ref.dataset, two.dataset)
    assert seen == [True]
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", True)
    # worker processes (the NumPy kernel): in a thread, once the pool has forked
    seen.clear()
    real_plan = montecarlo.build_plan
    monkeypatch.setattr(
        montecarlo,
        "build_plan",
        lambda sc, seed=None: dataclasses.replace(
            real_plan(sc, seed=seed), kernel="numpy"
        ),
    )
    assert run(sc, seed=4, workers=2).provenance["local_workers"] == "processes"
    assert seen == [False]
    monkeypatch.setattr(montecarlo, "build_plan", real_plan)

    def broken(scenario, **kw):
        raise RuntimeError("describe failed")

    monkeypatch.setattr(SimulationResult, "prepare", staticmethod(broken))
    with pytest.raises(RuntimeError, match="describe failed"):
        run(sc, seed=4)


def test_stacked_kernel_path_is_the_accumulators_stacked():
    """kernel.simulate_specs_stacked (no object per block) gives exactly
    Stacked.of(simulate_specs(...)): every array, bit for bit, over points that
    capture everything, nothing, and some, with shadowing, and blocks of every
    size."""
    import dataclasses

    import numpy as np

    import microimpact as mi
    from microimpact.engine import kernel
    from microimpact.engine.plan import build_plan
    from microimpact.engine.summary import Stacked

    sc = mi.Scenario(
        name="g",
        particles=mi.lognormal_diameters(50.0, 1.6),
        coefficients=mi.ImpactCoefficients(
            k1=4.0, k2=0.05, v_c=mi.PowerLaw(0.2, -1.5, d_ref=50e-6), friction=0.15
        ),
        surfaces=(
            mi.SurfaceVariant("rough", mi.normal_angles(20.0)),
            mi.SurfaceVariant("smooth"),
        ),
        speeds_m_s=(0.01, 0.2, 1.0, 30.0),
        angles_deg=(5.0, 40.0, 90.0),
        seed=5,
    )
    plan = build_plan(sc, kernel="compiled")
    if plan.kernel != "compiled":
        import pytest

        pytest.skip("compiled kernel not built")
    specs = [
        (p, 0, b, n)
        for p in range(len(plan.points))
        for b, n in ((0, 1), (1, 777), (2, plan.block_size))
    ]
    fast = kernel.simulate_specs_stacked(plan, specs)
    slow = Stacked.of(kernel.simulate_specs(plan, specs))
    for f in dataclasses.fields(Stacked):
        a, b = getattr(fast, f.name), getattr(slow, f.name)
        if f.name.endswith("spans"):
            for g in ("offset", "length", "counts"):
                np.testing.assert_array_equal(getattr(a, g), getattr(b, g))
                assert getattr(a, g).dtype == getattr(b, g).dtype
            assert a.size == b.size
        else:
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(
                a.view(np.int64) if a.dtype.kind == "f" else a,
                b.view(np.int64) if b.dtype.kind == "f" else b,
            )
    assert (fast.counts[:, 2] == fast.counts[:, 0]).any()  # some point captures all


def test_compiled_skewness_power_is_math_pow_bit_for_bit(monkeypatch):
    """summary._skewness's M2^1.5 from _ckernel.pow_into is math.pow's, bit for
    bit, over magnitudes from subnormal to huge (and 1.0 where the skewness is
    not defined); without the compiled kernel the Python loop gives the same."""
    from microimpact.engine import _compiled, summary

    if getattr(_compiled.ckernel, "pow_into", None) is None:
        pytest.skip("no compiled kernel")
    rng = np.random.default_rng(7)
    m2 = np.concatenate(
        [
            10.0 ** rng.uniform(-310, 200, 4000),  # (math.pow overflows past ~1e205)
            rng.random(1000),
            [0.0, 5e-324, 1.0, np.nan, -1.0, -0.0],
        ]
    )
    n = rng.integers(0, 50, m2.size).astype(float)
    m3 = rng.normal(size=m2.size)
    m = np.column_stack([n, np.zeros_like(n), m2, m3])
    ok = (n >= 3) & (m2 > 0)
    oracle = summary._pow15_python(m2, ok)
    got = np.empty(m2.size)
    _compiled.ckernel.pow_into(m2, 1.5, got)
    assert_array_equal(np.where(ok, got, 1.0).view(np.uint64), oracle.view(np.uint64))
    with pytest.raises(ValueError, match="one length"):
        _compiled.ckernel.pow_into(m2, 1.5, np.empty(3))
    fast = summary._skewness(m)
    monkeypatch.setattr(_compiled, "ckernel", None)
    slow = summary._skewness(m)
    assert_array_equal(fast.view(np.uint64), slow.view(np.uint64))
