"""Tests for microimpact._core.distributions: the one core behind sizes and angles.

Oracles are independent of the core: closed forms in ``scipy.special`` on the
standardised variable, mpmath at 50 digits (when installed), hand-computed sums for
the discrete core, and the other wrapper for the size/angle agreement.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import special, stats

from microimpact._core.distributions import DiscreteAtoms, TruncatedContinuous
from microimpact.population.distributions import (
    empirical_diameters,
    lognormal_diameters,
    monodisperse,
    normal_diameters,
    uniform_diameters,
)
from microimpact.surface.angles import (
    AngleDistribution,
    angles_from_sample,
    normal_angles,
    scipy_angles,
    smooth_surface,
)

UM = 1e-6  # metres per micrometre, for building test oracles only
DEG = math.pi / 180  # radians per degree, idem
TAIL_Q = np.array([1e-15, 1e-12, 1e-8, 1e-4, 0.01])


def _quiet(factory, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return factory(*args, **kwargs)


# ------------------------------------------------------------ continuous tails
def test_truncated_normal_tails_closed_form():
    """N(mu, s) on [0, inf): ppf(q) = mu + s ndtri(Phi(-mu/s) + q Phi(mu/s)) and
    isf(q) = mu - s ndtri(q Phi(mu/s)), both exact for tiny q."""
    mu, s = 52.8, 15.3  # the paper's SST65 fit [um]
    dist = normal_diameters(mu, s)
    z = mu / s
    ppf = mu + s * special.ndtri(special.ndtr(-z) + TAIL_Q * special.ndtr(z))
    isf = mu - s * special.ndtri(TAIL_Q * special.ndtr(z))
    # near d = 0 = mu - 3.45 s the difference cancels: absolute round-off of mu
    assert_allclose(dist.ppf(TAIL_Q), ppf * UM, rtol=1e-13, atol=1e-15 * mu * UM)
    assert_allclose(dist.isf(TAIL_Q), isf * UM, rtol=1e-13)
    # the survival function inverts isf in the far tail, relative to q
    assert_allclose(dist.sf(dist.isf(TAIL_Q)), TAIL_Q, rtol=1e-9)
    # ppf(1 - q) cannot: 1 - 3e-16 rounds to 1 - 3.33e-16, 11 % off in q
    assert abs(dist.sf(dist.isf(3e-16)) / 3e-16 - 1) < 1e-9
    assert abs(dist.sf(dist.ppf(1 - 3e-16)) / 3e-16 - 1) > 0.1


def test_truncated_lognormal_upper_tail_closed_form():
    """Kept only d >= median gsd**6 (P = Phi(-6)): S_t(d) = S(d) / Phi(-6)."""
    dist = _quiet(lognormal_diameters, 30, 1.5, min_um=30 * 1.5**6)
    s = math.log(1.5)
    isf = 30 * np.exp(-s * special.ndtri(TAIL_Q * special.ndtr(-6.0)))
    ppf = 30 * np.exp(-s * special.ndtri(special.ndtr(-6.0) * (1 - TAIL_Q)))
    assert_allclose(dist.isf(TAIL_Q), isf * UM, rtol=1e-13)
    assert_allclose(dist.ppf(TAIL_Q), ppf * UM, rtol=1e-13)
    assert_allclose(dist.sf(dist.isf(TAIL_Q)), TAIL_Q, rtol=1e-9)
    # near the finite lower limit a float d resolves the CDF only to ~ulp(a) pdf(a)
    assert_allclose(dist.cdf(dist.ppf(TAIL_Q)), TAIL_Q, rtol=1e-9, atol=1e-12)


def test_truncated_lognormal_lower_half_closed_form():
    """Kept only d <= 20 um < median (the parent's lower half): isf goes through the
    CDF, F_t(d) = F(d) / F(20 um)."""
    dist = _quiet(lognormal_diameters, 30, 1.4, max_um=20)
    s = math.log(1.4)
    fb = special.ndtr(math.log(20 / 30) / s)
    isf = 30 * np.exp(s * special.ndtri(fb * (1 - TAIL_Q)))
    ppf = 30 * np.exp(s * special.ndtri(fb * TAIL_Q))
    assert_allclose(dist.isf(TAIL_Q), isf * UM, rtol=1e-13)
    assert_allclose(dist.ppf(TAIL_Q), ppf * UM, rtol=1e-13)
    # sf near the upper limit: (F(b) - F(d)) / F(b), from the CDF side
    d = np.array([19.0, 19.99, 20.0]) * UM
    sf = 1 - special.ndtr(np.log(d / (30 * UM)) / s) / fb
    assert_allclose(dist.sf(d), sf, rtol=1e-10, atol=1e-16)


def test_truncated_lognormal_far_lower_tail_closed_form():
    """Kept only d <= median / gsd**6 (P = Phi(-6), S ~ 1 there): sf and isf must come
    from the CDF side, S_t(d) = 1 - F(d) / Phi(-6)."""
    dist = _quiet(lognormal_diameters, 30, 1.5, max_um=30 * 1.5**-6)
    s, fb = math.log(1.5), special.ndtr(-6.0)
    isf = 30 * np.exp(s * special.ndtri(fb * (1 - TAIL_Q)))
    assert_allclose(dist.isf(TAIL_Q), isf * UM, rtol=1e-13)
    p = np.array([0.1, 0.3, 0.5, 0.7, 0.9])
    d = 30 * UM * np.exp(s * special.ndtri(fb * p))  # F_t(d) = p
    assert_allclose(dist.sf(d), 1 - p, rtol=1e-12)
    assert_allclose(dist.cdf(d), p, rtol=1e-12)


def test_normal_angles_tails_closed_form():
    """N(0, 20 deg) on (-90, 90) deg: symmetric, S_b = Phi(-4.5)."""
    dist = normal_angles(20.0)
    s, beta = 20 * DEG, 4.5
    kept = special.ndtr(beta) - special.ndtr(-beta)
    isf = -s * special.ndtri(special.ndtr(-beta) + TAIL_Q * kept)
    assert_allclose(dist.isf(TAIL_Q), isf, rtol=1e-13)
    assert_allclose(dist.ppf(TAIL_Q), -isf, rtol=1e-13)
    assert_allclose(dist.truncated_mass, 2 * special.ndtr(-beta), rtol=1e-13)


def test_truncated_normal_isf_against_mpmath():
    """isf of N(mu, s) on [a, b] against a 50-digit root of the truncated survival
    function: S(x) = S(b) + q (S(a) - S(b)), S(x) = ncdf(-(x - mu) / s)."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 50
    cases = [(52.8, 15.3, 0.0, math.inf), (30.0, 1.7, 27.0, 33.0), (0, 1, 2.0, 9.0)]
    for mu, s, a, b in cases:
        core = TruncatedContinuous(stats.norm(mu, s), a, b)

        def sf(x, mu=mu, s=s):
            return mpmath.ncdf(-(x - mu) / s)

        sa, sb = sf(mpmath.mpf(a)), (0 if b == math.inf else sf(mpmath.mpf(b)))
        for q in TAIL_Q:
            target = sb + mpmath.mpf(q) * (sa - sb)
            x0 = float(core.isf(q))
            exact = mpmath.findroot(lambda x, t=target: sf(x) - t, x0)
            assert_allclose(x0, float(exact), rtol=5e-15, err_msg=f"{mu, s, a, b, q}")


def test_open_interval_and_scipy_unit_change():
    """Angles keep (-pi/2, pi/2) open; a distribution in degrees is rescaled."""
    d = scipy_angles(stats.uniform(-120, 240))  # degrees, 1/4 of it cut
    assert d.ppf(0.0) > -math.pi / 2 and d.isf(0.0) < math.pi / 2
    assert d.pdf(math.pi / 2) == 0.0 and d.pdf(-math.pi / 2) == 0.0
    assert_allclose(d.isf([0.25, 0.5]), [math.pi / 4, 0.0], atol=1e-15)
    assert_allclose(d.sf(math.pi / 4), 0.25, rtol=1e-14)
    with pytest.raises(ValueError, match="cuts away all of the probability"):
        scipy_angles(stats.uniform(100, 10))


# ---------------------------------------------------------------- discrete core
def test_weighted_atoms_hand_computed():
    # sorted: 1 (0.2), 2 (0.3), 2 (0.4), 3 (0.1); the weight-0 atom 7 is dropped
    core = DiscreteAtoms([3, 1, 2, 7, 2], [1, 2, 3, 0, 4])
    assert_allclose(core.atoms, [1, 2, 2, 3], rtol=0)
    assert_allclose(core.weights, [0.2, 0.3, 0.4, 0.1], rtol=1e-15)
    assert not core.is_equiprobable
    x = [0.5, 1, 1.5, 2, 2.5, 3, 4]
    assert_allclose(core.cdf(x), [0, 0.2, 0.2, 0.9, 0.9, 1, 1], rtol=1e-15)
    assert_allclose(core.sf(x), [1, 0.8, 0.8, 0.1, 0.1, 0, 0], rtol=1e-14)
    # left-continuous inverse: min{x : F(x) >= q}
    q = [0, 0.1, 0.2, 0.2001, 0.9, 0.95, 1]
    assert_allclose(core.ppf(q), [1, 1, 1, 2, 2, 3, 3], rtol=0)
    # min{x : S(x) <= q}
    assert_allclose(core.isf([0, 0.05, 0.1, 0.5, 0.8, 1]), [3, 3, 2, 2, 1, 1], rtol=0)
    assert_allclose(core.mean(), 0.2 * 1 + 0.7 * 2 + 0.1 * 3, rtol=1e-15)
    var = 0.2 * 0.9**2 + 0.7 * 0.1**2 + 0.1 * 1.1**2
    assert_allclose(core.std(), math.sqrt(var), rtol=1e-14)
    assert_allclose(core.pdf([1, 1.5, np.nan]), [np.inf, 0, np.nan])
    assert core.support() == (1.0, 3.0) and core.median() == 2.0
    # sampling: each atom with its weight (chi-square), the table from the weights
    draws = core.rvs(40_000, np.random.default_rng(7))
    counts = np.array([np.sum(draws == v) for v in (1, 2, 3)])
    assert stats.chisquare(counts, 40_000 * np.array([0.2, 0.7, 0.1])).pvalue > 1e-3
    values = core.table(1024).values
    assert_allclose(np.mean(values == 2), 0.7, atol=1 / 1024)


def test_weighted_atoms_upper_tail_is_summed_from_the_top():
    """A top atom of weight 1e-20: S = 1e-20 exactly, not 1 - 1 = 0."""
    core = DiscreteAtoms([0.0, 1.0], [1.0, 1e-20])
    assert_allclose(core.sf(0.0), 1e-20, rtol=1e-15)
    assert core.isf(1e-21) == 1.0 and core.isf(1e-19) == 0.0
    assert core.ppf(1.0) == 1.0 and core.ppf(1 - 1e-16) == 0.0


def test_equal_atoms_hand_computed_and_equal_weights_detected():
    core = DiscreteAtoms([4.0, 1.0, 3.0, 2.0])
    assert core.is_equiprobable
    assert_allclose(core.weights, 0.25, rtol=0)
    assert_allclose(core.ppf([0, 0.25, 0.26, 0.75, 1]), [1, 1, 2, 3, 4], rtol=0)
    assert_allclose(core.isf([0, 0.24, 0.25, 0.5, 1]), [4, 4, 3, 2, 1], rtol=0)
    assert_allclose(core.sf([0, 1, 2.5, 4]), [1, 0.75, 0.5, 0], rtol=0)
    same = DiscreteAtoms([4.0, 1.0, 3.0, 2.0], [2, 2, 2, 2])
    assert same.is_equiprobable
    assert_allclose(same.ppf(np.linspace(0, 1, 9)), core.ppf(np.linspace(0, 1, 9)))


@pytest.mark.parametrize(
    ("atoms", "weights", "match"),
    [
        ([], None, "non-empty"),
        ([1.0, np.nan], None, "finite"),
        ([1.0, 2.0], [1.0], "one value per atom"),
        ([1.0, 2.0], [0.0, 0.0], "not all 0"),
        ([1.0, 2.0], [1.0, -1.0], ">= 0"),
    ],
)
def test_discrete_atoms_validation(atoms, weights, match):
    with pytest.raises(ValueError, match=match):
        DiscreteAtoms(atoms, weights)


# ------------------------------------------------- sizes and angles agree
def test_size_and_angle_wrappers_agree_on_one_normal():
    """N(90, 40) um on [0, 180] um is N(0, 40) deg on (-90, 90) deg shifted by 90:
    the two wrappers give the same numbers in their own units."""
    size = _quiet(normal_diameters, 90, 40, max_um=180)
    angle = normal_angles(40.0)
    q = np.r_[1e-12, 1e-6, np.linspace(0.01, 0.99, 21)]
    assert_allclose(size.ppf(q) / UM - 90, angle.ppf(q) / DEG, rtol=1e-10, atol=1e-9)
    assert_allclose(size.isf(q) / UM - 90, angle.isf(q) / DEG, rtol=1e-10, atol=1e-9)
    x_deg = np.linspace(-85, 85, 18)
    xs, xa = (x_deg + 90) * UM, x_deg * DEG
    assert_allclose(size.cdf(xs), angle.cdf(xa), rtol=1e-10, atol=1e-15)
    assert_allclose(size.sf(xs), angle.sf(xa), rtol=1e-10, atol=1e-15)
    assert_allclose(size.pdf(xs) * UM, angle.pdf(xa) * DEG, rtol=1e-10)
    assert_allclose(size.mean() / UM - 90, angle.mean() / DEG, atol=1e-9)
    assert_allclose(size.std() / UM, angle.std() / DEG, rtol=1e-10)
    assert_allclose(size.truncated_mass, angle.truncated_mass, rtol=1e-12)
    assert size.is_discrete is angle.is_discrete is False
    assert size.atoms is None and angle.atoms is None and angle.weights is None


def test_size_and_angle_wrappers_agree_on_one_sample(rng):
    x = np.round(rng.normal(50, 12, 301).clip(1), 1)
    size = empirical_diameters(x)
    angle = angles_from_sample(x - 50)
    assert size.is_discrete and angle.is_discrete
    assert_allclose(size.atoms / UM - 50, angle.atoms / DEG, atol=1e-9)
    assert_allclose(size.weights, angle.weights, rtol=0)
    q = rng.random(200)
    assert_allclose(size.isf(q) / UM - 50, angle.isf(q) / DEG, atol=1e-9)
    assert_allclose(size.ppf(q) / UM - 50, angle.ppf(q) / DEG, atol=1e-9)


# ------------------------------------------------------------------ smooth
@pytest.mark.parametrize(
    "dist",
    [
        smooth_surface(),
        angles_from_sample([0.0, 0.0, -0.0]),
        normal_angles(0.0),
        AngleDistribution("empirical", {"name": "bumpy"}, 0.0, DiscreteAtoms([0.0])),
        AngleDistribution("x", {}, None, DiscreteAtoms([0.0, 0.3], [1.0, 0.0])),
    ],
)
def test_smooth_is_recognised_by_structure(dist):
    assert dist.is_smooth
    assert dist.is_discrete and dist.support() == (0.0, 0.0)
    assert dist.isf(1e-12) == 0.0 and dist.ppf(0.5) == 0.0


@pytest.mark.parametrize(
    "dist",
    [
        AngleDistribution("smooth", {}, 0.0, DiscreteAtoms([0.1])),  # the name lies
        angles_from_sample([0.0, 1e-9]),
        normal_angles(0.0, mean_deg=5.0),
        normal_angles(1e-6),
    ],
)
def test_not_smooth_whatever_the_name(dist):
    assert not dist.is_smooth


def test_size_wrapper_exposes_the_core_for_the_engine():
    mono = monodisperse(40)
    assert mono.is_discrete and mono.weights.tolist() == [1.0]
    assert mono.isf(0.3) == 40 * UM
    uni = uniform_diameters(10, 65)
    assert not uni.is_discrete and uni.weights is None
    assert_allclose(uni.isf([0, 0.5, 1]), [65 * UM, 37.5 * UM, 10 * UM], rtol=1e-14)
    assert np.isnan(uni.isf(1.5)) and np.isnan(uni.isf(np.nan))


# ------------------------------------------------------------- properties
PROPERTY = settings(max_examples=60, deadline=None, derandomize=True)
Q = np.linspace(1e-3, 1 - 1e-3, 41)


def _check_continuous(d):
    x = d.ppf(Q)
    assert np.all(np.diff(x) >= 0)  # monotone
    assert np.all(np.diff(d.isf(Q)) <= 0)
    assert_allclose(d.cdf(x), Q, atol=1e-9)  # ppf then cdf: the identity
    assert_allclose(d.sf(d.isf(Q)), Q, atol=1e-9)
    scale = d.ppf(0.75) - d.ppf(0.25)
    assert_allclose(d.isf(Q), d.ppf(1 - Q), rtol=1e-9, atol=1e-9 * scale)
    assert_allclose(d.cdf(x) + d.sf(x), 1.0, atol=1e-12)


@PROPERTY
@given(
    mean=st.floats(1, 200),
    std=st.floats(0.05, 100),
    lo=st.one_of(st.none(), st.floats(0, 1)),
    width=st.one_of(st.none(), st.floats(0.5, 4)),
)
def test_property_normal_diameters(mean, std, lo, width):
    min_um = None if lo is None else mean + (lo - 0.5) * std
    min_um = None if min_um is not None and min_um < 0 else min_um
    max_um = None if width is None else (min_um or 0) + width * std
    if max_um is not None and max_um <= mean - 8 * std:
        return  # nothing kept
    _check_continuous(_quiet(normal_diameters, mean, std, min_um=min_um, max_um=max_um))


@PROPERTY
@given(
    median=st.floats(0.5, 200),
    gsd=st.floats(1.01, 4),
    lo=st.one_of(st.none(), st.floats(-3, 5)),
)
def test_property_lognormal_diameters(median, gsd, lo):
    min_um = None if lo is None else median * gsd**lo
    _check_continuous(_quiet(lognormal_diameters, median, gsd, min_um=min_um))


@PROPERTY
@given(std=st.floats(0.1, 200), mean=st.floats(-80, 80))
def test_property_normal_angles(std, mean):
    _check_continuous(normal_angles(std, mean_deg=mean))


@PROPERTY
@given(
    atoms=st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=12),
    data=st.data(),
    q=st.floats(0, 1),
)
def test_property_discrete_atoms(atoms, data, q):
    n = len(atoms)
    w = data.draw(
        st.one_of(st.none(), st.lists(st.floats(0, 10), min_size=n, max_size=n))
    )
    if w is not None and not sum(w) > 0:
        w[0] = 1.0
    core = DiscreteAtoms(atoms, w)
    a = core.atoms
    # ppf: the smallest atom with F >= q; isf: the smallest atom with S <= q
    x, y = core.ppf(q), core.isf(q)
    assert core.cdf(x) >= q - 1e-12
    assert x == a[0] or core.cdf(a[a < x].max()) < q + 1e-12
    assert core.sf(y) <= q + 1e-12
    assert y == a[0] or core.sf(a[a < y].max()) > q - 1e-12
    assert np.all(np.diff(core.ppf(Q)) >= 0) and np.all(np.diff(core.isf(Q)) <= 0)
    assert_allclose(core.cdf(a) + core.sf(a), 1.0, atol=1e-12)
    assert_allclose(core.weights.sum(), 1.0, rtol=1e-12)
    assert_allclose(core.mean(), np.dot(core.weights, a), rtol=1e-9, atol=1e-9)
