"""The heavy-tail rule (docs/outputs.md, "Heavy tails"): the share of the squared
deviations from the mean held by the 0.1 % of values farthest from it, computed from
the engine's streaming moments and histograms, against the same share computed from
the raw values (sorting them), and against closed forms for the normal and the
exponential law."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats

from microimpact.engine.accumulators import (
    E_EDGES,
    MU_EDGES,
    Moments,
    histogram_counts,
)
from microimpact.engine.summary import (
    TAIL_FRACTION,
    TAIL_SHARE_LIMIT,
    Spans,
    _span_of_dense,
    tail_share,
)


def exact_share(x, fraction=TAIL_FRACTION):
    """The oracle: sort the raw values by their distance from the mean."""
    x = np.asarray(x, dtype=float)
    d2 = np.sort((x - x.mean()) ** 2)[::-1]
    k = math.ceil(fraction * x.size)
    return d2[:k].sum() / d2.sum()


def engine_share(x, edges):
    m = Moments.of(np.asarray(x, dtype=float))
    spans = Spans.of([_span_of_dense(histogram_counts(x, edges))], edges.size + 1)
    return float(tail_share(m.as_array()[None, :], spans, edges)[0])


def test_normal_closed_form():
    """N(m, s): the 0.1 % farthest hold 2 [z phi(z) + Q(z)] of the variance, with
    Q(z) = 0.0005 (0.0128); e_m-like values inside the histogram's range."""
    z = stats.norm.isf(TAIL_FRACTION / 2)
    closed = 2 * (z * stats.norm.pdf(z) + stats.norm.sf(z))
    x = np.random.default_rng(1).normal(0.6, 0.1, 400_000)
    assert_allclose(engine_share(x, E_EDGES), closed, rtol=0.08)
    assert engine_share(x, E_EDGES) < TAIL_SHARE_LIMIT


def test_exponential_closed_form():
    """Exp(1): the farthest values are all above the mean, beyond c = ln(1000); they
    hold e^-c ((c-1)^2 + 2 (c-1) + 2) of the unit variance (0.0487)."""
    c = math.log(1.0 / TAIL_FRACTION)
    closed = math.exp(-c) * ((c - 1) ** 2 + 2 * (c - 1) + 2)
    x = np.random.default_rng(2).exponential(1.0, 400_000)
    assert_allclose(engine_share(x, MU_EDGES), closed, rtol=0.1)


def test_a_few_wild_values_are_flagged_even_out_of_range():
    """Three impacts at mu_m = 40, -35, 60 (out of the histogram's [-10, 10]) among
    4,000 ordinary ones hold most of the spread: the rule sees them through the
    moments, exactly as the raw values do."""
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(0.3, 0.2, 3997), [40.0, -35.0, 60.0]])
    got = engine_share(x, MU_EDGES)
    assert_allclose(got, exact_share(x), rtol=1e-3)
    assert got > TAIL_SHARE_LIMIT


def test_more_out_of_range_values_than_the_tail_gives_a_lower_bound():
    x = np.concatenate([np.zeros(1000), np.full(5, 20.0), np.full(5, 30.0)])
    got = engine_share(x, E_EDGES)
    assert got <= exact_share(x) + 1e-12
    assert got > 0.5 * exact_share(x)


@settings(max_examples=40, deadline=None)
@given(
    st.integers(50, 3000),
    st.floats(0.05, 3.0),
    st.floats(-1.0, 2.0),
    st.integers(0, 2**32 - 1),
)
def test_matches_the_raw_values(n, shape, loc, seed):
    """Any sample within or beyond the range: the binned share is the exact one up to
    the bins' resolution (each value moved by at most half a bin, 0.005)."""
    x = loc + stats.lognorm.rvs(shape, size=n, random_state=seed) - 1.0
    got = engine_share(x, E_EDGES)
    want = exact_share(x)
    d = np.abs(x - x.mean())
    k = math.ceil(TAIL_FRACTION * n)
    top = np.sort(d)[::-1][:k]
    # moving each value by <= 0.005 changes each squared distance by <= 2 d 0.005
    # + 0.005^2, both in the tail and in the total
    tol = (2 * 0.005 * top.sum() + k * 1e-4) / (d**2).sum() + want * (
        (2 * 0.005 * d.sum() + n * 1e-4) / (d**2).sum()
    )
    out_of_range = int(np.sum((x < E_EDGES[0]) | (x >= E_EDGES[-1])))
    if out_of_range >= k:  # documented lower bound
        assert got <= want + tol + 1e-9
    else:
        assert abs(got - want) <= tol + 1e-9


def test_undefined_without_spread():
    x = np.full(10, 0.5)
    assert math.isnan(engine_share(x, E_EDGES))
    m = np.zeros((1, 4))
    spans = Spans.of([(0, np.zeros(0, dtype=np.int64))], E_EDGES.size + 1)
    assert math.isnan(tail_share(m, spans, E_EDGES)[0])


@pytest.fixture(scope="module")
def heavy_and_light():
    """The rough spores of Fig. 11 through the engine."""
    from microimpact.config import load_preset
    from microimpact.engine.montecarlo import run

    return run(load_preset("lycopodium-formica-oblique"), samples=4000, seed=12345)


def test_summary_columns_at_the_end_and_the_flag(heavy_and_light):
    s = heavy_and_light.summary
    assert list(s.columns[-3:]) == ["e_tail_share", "mu_tail_share", "heavy_tail"]
    share = np.fmax(s["e_tail_share"], s["mu_tail_share"])
    assert ((share > TAIL_SHARE_LIMIT) == (s["heavy_tail"] == 1.0)).all()
    assert s["e_tail_share"].between(0, 1).all()
