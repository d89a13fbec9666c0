"""The first unreachable cell of an angle table (the ``"reject"`` cut and the
shadowed mass) found by the compiled kernel (``_ckernel.reach_cut``, issue 31:
a sweep's angles are set up before its workers start) is the NumPy form's, bit
for bit: every cell's reach at its start and end (``plan._reach``), the first
whose end is not positive.

The oracle is the NumPy form itself, which the distribution tests of
``test_sampling_tables.py`` (the conditional law under ``"reject"``, the exact
shadowed fraction under ``"none"``) hold to closed forms; here the compiled
search is held to it on random tables, at angles on and beside the cells'
edges, and on rows no sampler writes (zero spans, signed zeros, NaN).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from microimpact import SurfaceVariant
from microimpact.engine import _compiled
from microimpact.engine import plan as plan_module
from microimpact.surface.angles import angles_from_sample, normal_angles
from microimpact.surface.areal_angles import areal_angles_from_sample

pytestmark = pytest.mark.skipif(
    _compiled.ckernel is None, reason="the compiled kernel is not built"
)


def _numpy_form(st_, ct_, rows):
    """The oracle: every cell's reach, then the first blocked one."""
    a = plan_module._reach(st_, ct_, rows, 0.0)
    b = plan_module._reach(st_, ct_, rows, 1.0)
    return plan_module._first_blocked_of(rows, a, b)


def _bits(x) -> bytes:
    return np.float64(x).tobytes()


def _same(got, want):
    """The same cell, and the same bits of its reaches (any NaN for a NaN: its
    sign and payload carry nothing, and it is never positive)."""
    assert got[0] == want[0]
    for g, w in zip(got[1:], want[1:], strict=True):
        assert _bits(g) == _bits(w) or (math.isnan(g) and math.isnan(w))


def _angles(sampler, extra):
    """Apparent angles [deg] on and beside the table's cell edges, and `extra`."""
    edges = np.rad2deg(np.asarray(sampler.table.left, dtype=float))
    edges = edges[(edges > 0.0) & (edges <= 90.0)]
    near = [math.nextafter(e, 0.0) for e in edges[:20]]
    return [*edges[:20].tolist(), *near, *extra]


def _check_sampler(sampler, angles):
    for angle_deg in angles:
        theta = np.deg2rad(angle_deg)
        s, c = float(np.sin(theta)), float(np.cos(theta))
        _same(
            plan_module.first_blocked(s, c, sampler.rows),
            _numpy_form(s, c, sampler.rows),
        )


@settings(max_examples=60, deadline=None)
@given(
    std=st.floats(0.5, 40.0),
    mean=st.floats(-10.0, 10.0),
    angles=st.lists(st.floats(0.01, 90.0), min_size=1, max_size=8),
)
def test_normal_tables_agree_bit_for_bit(std, mean, angles):
    sampler = plan_module._surface_sampler(
        SurfaceVariant("n", normal_angles(std, mean_deg=mean)), None, "reject"
    )
    _check_sampler(sampler, _angles(sampler, angles))


@settings(max_examples=60, deadline=None)
@given(
    sample=st.lists(st.floats(-89.0, 89.0), min_size=1, max_size=60),
    angles=st.lists(st.floats(0.01, 90.0), min_size=1, max_size=8),
)
def test_empirical_tables_agree_bit_for_bit(sample, angles):
    sampler = plan_module._surface_sampler(
        SurfaceVariant("e", angles_from_sample(sample)), None, "reject"
    )
    _check_sampler(sampler, _angles(sampler, [*angles, *np.abs(sample)[:10]]))


@settings(max_examples=30, deadline=None)
@given(
    par=st.lists(st.floats(-80.0, 80.0), min_size=2, max_size=40),
    angles=st.lists(st.floats(0.01, 90.0), min_size=1, max_size=8),
)
def test_areal_tables_agree_bit_for_bit(par, angles):
    perp = np.linspace(-30.0, 30.0, len(par))
    sampler = plan_module._surface_sampler(
        SurfaceVariant("a", areal_angles_from_sample(par, perp)), None, "reject"
    )
    _check_sampler(sampler, _angles(sampler, angles))


_ENTRY = st.one_of(
    st.floats(-1.0, 1.0),
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, math.nan, math.inf]),
)


@settings(max_examples=150, deadline=None)
# a sine without span whose cosine has one: reachable at its start, not at its
# end, and a cell of zero span ends where it starts (reachable)
@example(cells=[(0.0, 0.0, 0.5, -1.0)], theta=math.pi / 4, width=6)
@example(cells=[(0.1, 0.0, 0.5, 0.1), (0.0, -0.0, 0.5, -1.0)], theta=0.8, width=7)
@given(
    cells=st.lists(st.tuples(_ENTRY, _ENTRY, _ENTRY, _ENTRY), min_size=0, max_size=12),
    theta=st.floats(0.0, math.pi / 2),
    width=st.integers(6, 9),
)
def test_any_rows_agree_bit_for_bit(cells, theta, width):
    """Rows no sampler writes: zero and signed-zero spans, NaN, infinities, and
    extra columns (the search reads only the sine and cosine pairs)."""
    rows = np.zeros((len(cells) + 1, width))
    for i, (s_lo, s_span, c_lo, c_span) in enumerate(cells):
        rows[i, plan_module.A_SIN : plan_module.A_SIN + 2] = s_lo, s_span
        rows[i, plan_module.A_COS : plan_module.A_COS + 2] = c_lo, c_span
    s, c = math.sin(theta), math.cos(theta)
    with np.errstate(invalid="ignore"):
        want = _numpy_form(s, c, rows)
    _same(plan_module.first_blocked(s, c, rows), want)


@pytest.mark.parametrize("shadowing", ["reject", "none"])
def test_angle_tables_are_those_of_the_numpy_form(monkeypatch, shadowing):
    """The tables a plan keeps (cut, shadowed mass, every facet shadowed) with
    the compiled search and without it (no compiled kernel installed)."""
    sampler = plan_module._surface_sampler(
        SurfaceVariant("n", normal_angles(12.0, mean_deg=3.0)), None, shadowing
    )
    angles = _angles(sampler, np.linspace(0.05, 90.0, 181).tolist())
    got = [plan_module._angle_tables(sampler, a, shadowing) for a in angles]
    monkeypatch.setattr(plan_module._compiled, "ckernel", None)
    want = [plan_module._angle_tables(sampler, a, shadowing) for a in angles]
    for g, w in zip(got, want, strict=True):
        assert (g.cut, g.count_shadowed) == (w.cut, w.count_shadowed)
        assert _bits(g.shadowed_mass) == _bits(w.shadowed_mass)
    # the search matters: some angles are cut inside the table, some not at all
    assert any(g.cut for g in got) or shadowing == "none"
    assert any(g.shadowed_mass == 0.0 for g in got)
    assert any(0.0 < g.shadowed_mass < 1.0 for g in got)


@pytest.mark.parametrize(
    "args",
    [
        (np.zeros(7), 7, 2, 4, 0.5, 0.5),  # only the sentinel: no cell
        (np.zeros(6 * 3), 5, 2, 4, 0.5, 0.5),  # not whole rows of 5
        (np.zeros(7 * 3), 7, 6, 4, 0.5, 0.5),  # the sine's span outside a row
        (np.zeros(7 * 3), 7, 2, -1, 0.5, 0.5),  # a negative column
        (np.zeros(0), 7, 2, 4, 0.5, 0.5),  # no sentinel
    ],
)
def test_reach_cut_refuses_bad_rows(args):
    ck = _compiled.ckernel
    rows, *rest = args
    if rows.size == 7:  # one row is the sentinel alone: no cell, none blocked
        assert ck.reach_cut(rows, *rest) == (-1, 0.0, 0.0)
        return
    with pytest.raises(ValueError, match="reach_cut"):
        ck.reach_cut(rows, *rest)
