"""The compact per-point state and the streamed outputs of large sweeps (issue 31,
item 3) give exactly what the reference path gives.

The reference path is the definition: each point's blocks simulated one by one
(``kernel.simulate_block``) and merged in block order into a
:class:`~microimpact.engine.accumulators.PointAccumulator` (int64 histograms),
stacked with ``Stacked.of``, its statistics computed for all points at once, and
``summary.csv`` written by pandas. The run's path keeps the histograms in the
narrowest integer type, the totals in the driver's preallocated table, computes
the statistics a slice of points at a time and writes the CSV in chunks of rows.
"""

from __future__ import annotations

import functools
import io

import numpy as np
import pandas as pd
import pytest
from engine_helpers import rough, scenario
from numpy.testing import assert_array_equal

from microimpact.engine import dataset, kernel, montecarlo
from microimpact.engine.accumulators import E_EDGES
from microimpact.engine.montecarlo import run
from microimpact.engine.plan import BLOCK_SIZE, build_plan
from microimpact.engine.summary import (
    Stacked,
    compact_counts,
    histogram_quantiles,
    point_statistics,
)


def _sweep(**kw):
    base = dict(
        surfaces=(rough(8.0), rough(20.0, name="steep")),
        speeds_m_s=(0.05, 0.2, 0.6),
        angles_deg=(10.0, 45.0, 90.0),
    )
    base.update(kw)
    return scenario(**base)


def _reference(plan, samples) -> Stacked:
    """Every point's accumulator by the definition: its blocks one by one, merged
    in block order (int64 histograms)."""
    accs = []
    for sp in plan.points:
        blocks = []
        for b in range(-(-samples // BLOCK_SIZE)):
            n = min(BLOCK_SIZE, samples - b * BLOCK_SIZE)
            blocks.append(kernel.simulate_block(plan, sp.index, 0, b, n))
        accs.append(functools.reduce(lambda a, c: a.merge(c), blocks))
    return Stacked.of(accs)


def _drained(sc, samples, **kw) -> Stacked:
    job = montecarlo._Job(
        sc,
        samples=samples,
        seed=7,
        workers=kw.get("workers", 1),
        backend="process",
        executor=None,
        address=None,
        checkpoint=kw.get("checkpoint"),
        progress=False,
        plan=kw.get("plan"),
    )
    return job.drain()


def _same_rows(a: Stacked, b: Stacked):
    assert_array_equal(a.counts, b.counts)
    for x, y in ((a.e, b.e), (a.mu, b.mu), (a.lateral, b.lateral)):
        assert_array_equal(x.view(np.uint64), y.view(np.uint64))  # every bit
    for x, y in (
        (a.e_spans, b.e_spans),
        (a.mu_spans, b.mu_spans),
        (a.lateral_spans, b.lateral_spans),
    ):
        assert_array_equal(x.dense(np.int64), y.dense(np.int64))


def _same_columns(a: dict, b: dict):
    assert list(a) == list(b)
    for name in a:
        x, y = np.asarray(a[name]), np.asarray(b[name])
        assert x.dtype == y.dtype, name
        if x.dtype.kind == "f":  # every bit, NaN included
            assert_array_equal(x.view(np.uint64), y.view(np.uint64), err_msg=name)
        else:
            assert_array_equal(x, y, err_msg=name)


@pytest.mark.parametrize("samples", [300, 40_000])
def test_the_run_state_equals_the_reference_accumulators(samples):
    """300 impacts per point: uint8 histogram counts; 40,000: two blocks merged,
    counts beyond 255 (uint16). The table and spans equal the reference rows."""
    sc = _sweep()
    plan = build_plan(sc, seed=7)
    got = _drained(sc, samples, plan=plan)
    ref = _reference(plan, samples)
    _same_rows(got, ref)
    wanted = np.uint8 if samples == 300 else np.uint16
    assert got.e_spans.counts.dtype == wanted
    # statistics: the run's (compact, a few points at a time) against the
    # reference's (int64, all at once)
    _same_columns(
        point_statistics(got, 0.95, rows=4), point_statistics(ref, 0.95, rows=10**9)
    )


def test_statistics_by_slices_equal_all_at_once(rng):
    """Slices of 1, 3 and 64 rows, int64 and compact counts: the same bits."""
    sc = _sweep(speeds_m_s=tuple(np.geomspace(0.05, 2.0, 9)))
    ref = _drained(sc, 500)
    whole = point_statistics(ref, 0.9, rows=10**9)
    for rows in (1, 3, 64):
        _same_columns(point_statistics(ref, 0.9, rows=rows), whole)
    wide = Stacked(
        ref.counts,
        ref.e,
        ref.mu,
        *(
            type(s)(s.offset, s.length, s.counts.astype(np.int64), s.size)
            for s in (ref.e_spans, ref.mu_spans)
        ),
        ref.lateral,
        ref.lateral_spans,
    )
    _same_columns(point_statistics(wide, 0.9, rows=5), whole)


def test_compact_counts_keep_every_value():
    for top, dtype in ((0, np.uint8), (255, np.uint8), (256, np.uint16)):
        got = compact_counts(np.array([0, top, 1], dtype=np.int64))
        assert got.dtype == dtype
        assert_array_equal(got, [0, top, 1])
    for top, dtype in ((65_535, np.uint16), (65_536, np.int32), (2**31, np.int64)):
        got = compact_counts(np.array([top, 3], dtype=np.int64))
        assert got.dtype == dtype
        assert_array_equal(got, [top, 3])


def test_quantiles_and_tails_of_compact_counts():
    """uint8 spans whose sums exceed 255 (in the quantiles' cumulative counts, in
    the tails' under- plus overflow) give what int64 spans give."""
    from microimpact.engine.summary import Spans, tail_pull

    size = E_EDGES.size + 1
    dense = np.zeros((3, size), dtype=np.int64)
    dense[:, 300:310] = 200
    dense[1, 305] = 7
    dense[2, 0] = 200  # underflow
    dense[2, -1] = 200  # overflow: 400 out of range, beyond uint8
    spans = Spans.of(((0, row) for row in dense), size)
    narrow = spans.narrow()
    assert narrow.counts.dtype == np.uint8
    assert_array_equal(
        histogram_quantiles(narrow, E_EDGES), histogram_quantiles(spans, E_EDGES)
    )
    n = dense.sum(axis=1).astype(float)
    centre = E_EDGES[300] + 0.005
    moments = np.stack([n, np.full(3, centre), n * 0.3, np.zeros(3)], axis=1)
    for a, b in zip(
        tail_pull(moments, narrow, E_EDGES),
        tail_pull(moments, spans, E_EDGES),
        strict=True,
    ):
        assert_array_equal(a, b)


def _frame(rng, rows):
    bits = rng.integers(0, 2**64, rows, dtype=np.uint64).view(np.float64)
    special = np.array([np.nan, np.inf, -np.inf, -0.0, 0.1, 1e-5, 1e16, 1e15, 5e-324])
    x = np.resize(np.concatenate([special, bits]), rows)
    names = np.resize(np.array(["plain", "with,comma", 'with"quote', "ü"]), rows)
    return pd.DataFrame(
        {
            "surface": pd.Series(names).astype(str),
            "x": x,
            "normal": rng.normal(size=rows),
            "n": rng.integers(-(2**62), 2**62, rows),
        }
    )


def test_write_csv_is_byte_for_byte_what_pandas_writes(rng, tmp_path, monkeypatch):
    """Random bit patterns (every exponent, subnormals, NaN, infinities), quoted
    names, large integers, over several chunks of rows."""
    monkeypatch.setattr(dataset, "CSV_ROWS", 1000)
    df = _frame(rng, 2500)
    dataset.write_csv(tmp_path / "ours.csv", df)
    buf = io.StringIO()
    df.to_csv(buf, index=False)
    assert (tmp_path / "ours.csv").read_bytes() == buf.getvalue().encode()


def test_summary_csv_is_what_pandas_writes_of_the_summary(tmp_path, monkeypatch):
    """A fresh result writes summary.csv from its columns, without the table;
    a reopened one from its table: both are byte for byte pandas' file."""
    monkeypatch.setattr(dataset, "CSV_ROWS", 7)
    res = run(_sweep(), samples=300, seed=3)
    res.to_csv(tmp_path / "summary.csv")
    assert res._summary is None  # the columns were written, not the table
    expected = res.summary.to_csv(index=False).encode()
    assert (tmp_path / "summary.csv").read_bytes() == expected
    res.to_netcdf(tmp_path / "results.nc")
    from microimpact.engine.result import open_result

    back = open_result(tmp_path / "results.nc")
    back.to_csv(tmp_path / "again.csv")
    assert (tmp_path / "again.csv").read_bytes() == expected


def test_the_netcdf_keeps_the_reference_histograms(tmp_path, monkeypatch):
    """The ragged histograms written from compact counts (uint8) read back as the
    reference accumulators' dense histograms."""
    pytest.importorskip("netCDF4")
    from microimpact.engine.result import open_result

    monkeypatch.setattr(dataset, "DENSE_HISTOGRAM_CELLS", 0)  # ragged at any size
    sc = _sweep()
    res = run(sc, samples=300, seed=7)
    assert res.dataset.attrs["histograms"] == "ragged"
    assert res.dataset["e_hist_counts"].dtype == np.uint8
    res.to_netcdf(tmp_path / "results.nc")
    back = open_result(tmp_path / "results.nc")
    ref = _reference(build_plan(sc, seed=7), 300)
    for p in (0, 17, len(ref) - 1):
        for name, spans in (("e", ref.e_spans), ("mu", ref.mu_spans)):
            counts, _ = back.histogram(p, name)
            assert_array_equal(counts, spans.dense(np.int64)[p, 1:-1])


def test_the_state_of_a_small_point_is_a_few_hundred_bytes():
    """10,000 points at 100 impacts: the driver's state (counts, moments, spans)
    is under 400 B per point (issue 31: "well under 1 kB"; int32 bins were
    ~560 B, int64 ~1 kB)."""
    sc = _sweep(
        surfaces=(rough(8.0),),
        speeds_m_s=tuple(np.geomspace(0.05, 5.0, 100)),
        angles_deg=tuple(np.linspace(5.0, 90.0, 100)),
    )
    st = _drained(sc, 100)
    arrays = [st.counts, st.e, st.mu, st.lateral]
    for s in (st.e_spans, st.mu_spans, st.lateral_spans):
        arrays += [s.offset, s.length, s.counts]
    per_point = sum(a.nbytes for a in arrays) / len(st)
    assert per_point < 400, per_point


def test_results_nc_is_written_with_a_small_chunk_cache(tmp_path, monkeypatch):
    """netCDF-C keeps each variable's compressed chunks in a cache of 64 MiB
    until the file closes (~570 MiB at 10^6 points): the writer opens the file
    with a 1 MiB cache per variable and restores the setting after."""
    netCDF4 = pytest.importorskip("netCDF4")
    import xarray as xr

    seen = []
    real = xr.Dataset.to_netcdf

    def spy(self, *args, **kwargs):
        seen.append(netCDF4.get_chunk_cache()[0])
        return real(self, *args, **kwargs)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", spy)
    before = netCDF4.get_chunk_cache()
    run(_sweep(), samples=300, seed=3).to_netcdf(tmp_path / "results.nc")
    assert seen == [dataset.NETCDF_CHUNK_CACHE]
    assert netCDF4.get_chunk_cache() == before


def test_a_large_run_gives_its_freed_memory_back(monkeypatch):
    """A run of many blocks collects its garbage and trims the heap when it
    ends, and so do a large sweep's statistics (wiring: the thresholds lowered
    to this small sweep)."""
    from microimpact.engine import result as result_module

    calls = []
    monkeypatch.setattr(montecarlo, "RELEASE_BLOCKS", 18)
    monkeypatch.setattr(result_module, "TRIM_POINTS", 18)
    monkeypatch.setattr(
        montecarlo, "release_memory", lambda **kw: calls.append(("run", kw))
    )
    monkeypatch.setattr(
        result_module, "release_memory", lambda **kw: calls.append(("stats", kw))
    )
    res = run(_sweep(), samples=300, seed=3)  # 18 points of one block
    assert calls == [("run", {"collect": True})]
    assert len(res.summary) == 18
    assert calls[-1] == ("stats", {})
    monkeypatch.setattr(montecarlo, "RELEASE_BLOCKS", 19)
    calls.clear()
    run(_sweep(), samples=300, seed=3)
    assert calls == []
