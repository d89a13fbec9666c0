"""Monte Carlo engine against independent oracles: closed forms, quadrature of the
same expectations, the reference physics function, and invariants."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, normal_diameters, rough, scenario
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from scipy import integrate, stats

import microimpact as mi
from microimpact.engine import montecarlo
from microimpact.engine.accumulators import Moments, PointAccumulator
from microimpact.engine.montecarlo import build_plan, iter_blocks, run, sample_point
from microimpact.errors import ScenarioError

K = 4.0  # statistical assertions sit within K standard errors


# --------------------------------------------------------------------- kernel
def _kernel_coefficients(s, coeffs):
    """The k1, k2, v_c the kernel used for each impact (interpolated in the
    diameter's table cell, as the diameter is), checked against the laws at the
    drawn diameter; older kernels evaluate the laws themselves."""
    laws = coeffs.evaluate(s["diameter"])
    if "v_c" not in s:
        return laws
    used = s["k1"], s["k2"], s["v_c"]
    for u, law in zip(used, laws, strict=True):
        assert_allclose(u, law, rtol=1e-4)
    return used


@pytest.mark.parametrize(
    "coeffs, shadowing, angle",
    [
        (PowerCoefficients(), "none", 30.0),
        (PowerCoefficients(friction=0.15, p=1.7, q=0.6), "none", 20.0),
        (PowerCoefficients(friction=0.3, k2=0.2, b=-1.5), "reject", 60.0),
        (PowerCoefficients(friction=0.05), "weighted", 12.0),
    ],
)
def test_kernel_matches_reference_physics(coeffs, shadowing, angle):
    """Every impact the kernel computes equals microimpact.apparent_rebound."""
    sc = scenario(
        coefficients=coeffs,
        surfaces=(rough(15.0, 3.0),),
        speeds_m_s=(0.35,),
        angles_deg=(angle,),
        shadowing=shadowing,
        speed_spread=0.1,
    )
    s = sample_point(sc, 0, 40_000)
    k1, k2, v_c = _kernel_coefficients(s, coeffs)
    ref = mi.apparent_rebound(
        s["speed"],
        angle,
        np.rad2deg(s["roughness_angle"]),
        k1=k1,
        k2=k2,
        v_c=v_c,
        p=coeffs.p,
        q=coeffs.q,
        friction=coeffs.friction,
    )
    assert_array_equal(s["shadowed"], ref.shadowed)
    assert_array_equal(s["captured"], ref.captured)
    assert_array_equal(s["reimpact"], ref.reimpact)
    # the kernel interpolates sin and cos of the angle within its table cell while
    # the angle it reports is interpolated linearly: the two agree to second order
    # in the cell width (measured up to 4e-5 relative); exact before the
    # bias-free tables
    rtol, atol = (1e-11, 1e-13) if "v_c" not in s else (1e-4, 1e-7)
    assert_allclose(s["e_m"], ref.e_m, rtol=rtol, atol=atol, equal_nan=True)
    assert_allclose(s["mu_m"], ref.mu_m, rtol=rtol, atol=atol, equal_nan=True)
    if shadowing != "none":
        assert not s["shadowed"].any()
    else:
        assert s["shadowed"].any()
    assert s["captured"].any() and (~s["captured"]).any()


def test_smooth_surface_gives_the_smooth_model():
    """phi = 0: e_m = e and mu_m = mu of rebound(), and 0 <= e <= 1."""
    coeffs = PowerCoefficients(friction=0.2)
    sc = scenario(coefficients=coeffs, speeds_m_s=(0.5,), angles_deg=(40.0,))
    s = sample_point(sc, 0, 20_000)
    k1, k2, v_c = _kernel_coefficients(s, coeffs)
    th = np.deg2rad(40.0)
    ref = mi.rebound(
        -0.5 * np.sin(th), -0.5 * np.cos(th), k1=k1, k2=k2, v_c=v_c, friction=0.2
    )
    assert_allclose(s["e_m"], ref.e, rtol=1e-13)
    assert_allclose(s["mu_m"], ref.mu, rtol=1e-13, equal_nan=True)
    assert np.all((s["e_m"] >= 0) & (s["e_m"] <= 1))


# --------------------------------------------------------------------- oracles
@pytest.mark.parametrize("speed", [0.12, 0.2, 0.3])
def test_capture_fraction_closed_form(speed):
    """Normal diameters, power-law v_c, normal incidence: P(capture) =
    P(v_c(d) >= v) = F_D(v_c^{-1}(v)) (v_c decreasing in d)."""
    coeffs = PowerCoefficients(vc_ref=0.2, b=-1.2)
    sc = scenario(coefficients=coeffs, speeds_m_s=(speed,), samples=50_000)
    row = run(sc).summary.iloc[0]
    d_star = coeffs.d_ref * (speed / coeffs.vc_ref) ** (1.0 / coeffs.b)
    mean, std = 52.8e-6, 15.3e-6
    dist = stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std)
    exact = dist.cdf(d_star)
    se = math.sqrt(exact * (1 - exact) / row["n"])
    assert abs(row["capture_fraction"] - exact) < K * se + 1e-4
    assert row["capture_ci_low"] <= exact + 1e-4
    assert exact - 1e-4 <= row["capture_ci_high"]


def _quadrature_e_mean(coeffs, speed, angle_deg, std_deg, shadowing):
    """E[e_m] over diameter x roughness angle by 2-D quadrature of the reference
    physics (captured counted as 0), for a normal angle distribution."""
    mean, std = 52.8e-6, 15.3e-6
    ddist = stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std)
    adist = stats.norm(0.0, np.deg2rad(std_deg))
    theta = np.deg2rad(angle_deg)
    # Gauss-Legendre grids on the bulk of each distribution
    xd, wd = np.polynomial.legendre.leggauss(200)
    d_lo, d_hi = ddist.ppf(1e-9), ddist.ppf(1 - 1e-9)
    d = 0.5 * (d_hi - d_lo) * xd + 0.5 * (d_hi + d_lo)
    wd = wd * 0.5 * (d_hi - d_lo) * ddist.pdf(d)
    phi_lo = adist.ppf(1e-9)
    phi_hi = min(adist.ppf(1 - 1e-9), theta)  # reachable facets only
    xa, wa = np.polynomial.legendre.leggauss(400)
    phi = 0.5 * (phi_hi - phi_lo) * xa + 0.5 * (phi_hi + phi_lo)
    wa = wa * 0.5 * (phi_hi - phi_lo) * adist.pdf(phi)
    if shadowing == "weighted":
        wa = wa * np.sin(theta - phi) / np.sin(theta)
    wa = wa / wa.sum()
    k1, k2, v_c = coeffs.evaluate(d)
    res = mi.apparent_rebound(
        speed,
        angle_deg,
        np.rad2deg(phi)[None, :],
        k1=k1[:, None],
        k2=k2[:, None],
        v_c=v_c[:, None],
        friction=coeffs.friction,
    )
    w = wd[:, None] * wa[None, :]
    return float((res.e_m * w).sum() / w.sum())


@pytest.mark.parametrize(
    "speed, angle, std_deg, shadowing, friction",
    [
        (0.3, 45.0, 10.0, "reject", math.inf),
        (1.0, 20.0, 12.0, "reject", 0.15),
        (0.5, 15.0, 8.0, "weighted", 0.3),
        (0.25, 80.0, 5.0, "weighted", math.inf),
    ],
)
def test_mean_apparent_restitution_matches_quadrature(
    speed, angle, std_deg, shadowing, friction
):
    coeffs = PowerCoefficients(friction=friction)
    sc = scenario(
        coefficients=coeffs,
        surfaces=(rough(std_deg),),
        speeds_m_s=(speed,),
        angles_deg=(angle,),
        shadowing=shadowing,
        samples=200_000,
    )
    row = run(sc).summary.iloc[0]
    exact = _quadrature_e_mean(coeffs, speed, angle, std_deg, shadowing)
    assert abs(row["e_mean"] - exact) < K * row["e_se"]


def test_shadowed_fraction_is_the_exact_mass():
    """'reject' removes P(phi >= theta); 'none' counts it, within sampling error."""
    theta, std = 10.0, 12.0
    exact = stats.norm(0, std).sf(theta)
    rej = run(
        scenario(
            surfaces=(rough(std),),
            angles_deg=(theta,),
            shadowing="reject",
            samples=1000,
        )
    ).summary.iloc[0]
    assert_allclose(rej["shadowed_fraction"], exact, atol=1e-4)  # exact, from table
    none = run(
        scenario(
            surfaces=(rough(std),),
            angles_deg=(theta,),
            shadowing="none",
            samples=100_000,
        )
    ).summary.iloc[0]
    se = math.sqrt(exact * (1 - exact) / 100_000)
    assert abs(none["shadowed_fraction"] - exact) < K * se


def test_weighted_angle_table_is_the_sommerfeld_huber_pdf():
    """The 'weighted' facet distribution has mean int phi f sin(th-phi) / int f sin."""
    theta, std = np.deg2rad(20.0), np.deg2rad(10.0)
    sc = scenario(surfaces=(rough(10.0),), angles_deg=(20.0,), shadowing="weighted")
    tables = build_plan(sc).angle_tables(0, 20.0)
    f = stats.norm(0, std).pdf
    num = integrate.quad(lambda p: p * f(p) * np.sin(theta - p), -10 * std, theta)[0]
    den = integrate.quad(lambda p: f(p) * np.sin(theta - p), -10 * std, theta)[0]
    assert_allclose(tables.phi.mean(), num / den, atol=1e-4)


# --------------------------------------------------------------------- invariants
def _same(a, b):
    cols = [c for c in a.summary.columns if c != "surface"]
    assert_array_equal(a.summary[cols].to_numpy(), b.summary[cols].to_numpy())
    for k in a.accumulators:
        assert_array_equal(a.accumulators[k].e_hist, b.accumulators[k].e_hist)


def _multi():
    return scenario(
        surfaces=(rough(10.0), rough(5.0, name="r2")),
        speeds_m_s=(0.2, 0.5),
        angles_deg=(30.0, 90.0),
        samples=100_000,
        shadowing="none",
        speed_spread=0.05,
    )


def test_bit_identical_across_workers_and_grouping(monkeypatch):
    sc = _multi()
    serial = run(sc)
    pooled = run(sc, workers=2)
    _same(serial, pooled)
    # the task size fixes the merge order: other sizes give the same counts and
    # histograms, moments equal to round-off, and again identical across workers
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 1)
    single = run(sc)
    _same(single, run(sc, workers=2))
    a, b = serial.summary, single.summary
    assert_array_equal(a["n"], b["n"])
    assert_array_equal(a["capture_fraction"], b["capture_fraction"])
    assert_allclose(a["e_mean"], b["e_mean"], rtol=1e-12)
    assert_allclose(a["mu_std"], b["mu_std"], rtol=1e-9)
    assert_array_equal(serial.dataset["e_hist"], single.dataset["e_hist"])
    other = run(sc, seed=999)
    assert not np.array_equal(other.summary["e_mean"], serial.summary["e_mean"])


def test_bit_identical_on_dask():
    pytest.importorskip("dask.distributed")
    sc = _multi()
    _same(run(sc), run(sc, backend="dask", workers=2))


def test_resume_from_checkpoint_is_bit_identical(tmp_path, monkeypatch):
    from microimpact.engine.checkpoint import Checkpoint

    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)  # several groups per point
    sc = scenario(
        surfaces=(rough(10.0),),
        speeds_m_s=(0.2, 0.4),
        angles_deg=(45.0,),
        samples=300_000,
    )
    full = run(sc)
    ck = tmp_path / "run.ckpt.npz"
    gen = iter_blocks(sc, checkpoint=Checkpoint(ck, interval=0.0))
    for _ in range(6):  # interrupt part-way: 5 groups of point 0, 1 of point 1
        next(gen)
    gen.close()
    assert ck.exists()
    resumed = run(sc, checkpoint=ck)
    # a rerun from scratch is bit-identical too: check that blocks were restored
    assert resumed.provenance["resumed_blocks"] == 10 + 2
    assert resumed.provenance["total_blocks"] == 20
    _same(full, resumed)
    again = run(sc, checkpoint=ck)  # a finished checkpoint reproduces too
    assert again.provenance["resumed_blocks"] == 20
    _same(full, again)


def test_precision_target_stops_deterministically():
    sc = scenario(
        speeds_m_s=(0.15, 0.25),
        precision=mi.scenario.Precision("capture_fraction", 0.005, 2_000_000),
    )
    a = run(sc)
    half = (a.summary["capture_ci_high"] - a.summary["capture_ci_low"]) / 2
    assert half.max() <= 0.005
    assert (a.summary["n"] < 2_000_000).all()
    _same(a, run(sc, workers=2))


def test_moments_merge_equals_one_shot(rng):
    x = rng.gamma(2.0, size=10_001)
    parts = np.array_split(x, [3, 500, 501, 7000])
    m = Moments()
    for p in parts:
        m = m.merge(Moments.of(p))
    assert m.n == x.size
    assert_allclose(m.mean, x.mean(), rtol=1e-13)
    assert_allclose(m.variance, x.var(ddof=1), rtol=1e-12)
    assert_allclose(m.skewness, stats.skew(x), rtol=1e-10)


def test_accumulator_roundtrip():
    acc = run(scenario(samples=5000)).accumulators[0]
    back = PointAccumulator.from_arrays(acc.to_arrays())
    assert back.n == acc.n and back.captured == acc.captured
    assert_array_equal(back.e_hist, acc.e_hist)


@pytest.mark.parametrize(
    "spans",
    [
        ((10, 5), (12, 30)),  # overlapping, second wider
        ((500, 3), (20, 4)),  # disjoint, second first
        ((0, 1201), (1200, 2)),  # full range and the overflow bin
        ((7, 0), (40, 6)),  # one empty
    ],
)
def test_accumulator_merge_adds_the_dense_histograms(rng, spans):
    """Compact histogram spans merge as the dense arrays add (an independent
    oracle: dense int64 addition), and the dense view has the documented length."""
    from microimpact.engine.accumulators import E_BINS, MU_BINS

    accs, dense = [], []
    for lo, width in spans:
        e = np.zeros(E_BINS, np.int64)
        mu = np.zeros(MU_BINS, np.int64)
        hi = min(lo + width, E_BINS)
        e[lo:hi] = rng.integers(1, 9, hi - lo)
        mu_lo = min(2 * lo, MU_BINS - width)
        mu[mu_lo : mu_lo + width] = rng.integers(1, 9, width)
        accs.append(PointAccumulator(n=5, e_hist=e, mu_hist=mu))
        dense.append((e, mu))
    m = accs[0].merge(accs[1])
    assert_array_equal(m.e_hist, dense[0][0] + dense[1][0])
    assert_array_equal(m.mu_hist, dense[0][1] + dense[1][1])
    assert m.e_hist.dtype == np.int64 and m.e_hist.shape == (E_BINS,)
    assert m.mu_hist.shape == (MU_BINS,)
    # the inputs are unchanged (merge returns a new accumulator)
    assert_array_equal(accs[0].e_hist, dense[0][0])
    assert_array_equal(accs[1].mu_hist, dense[1][1])
    lo, counts = m.e_span
    assert counts.size <= E_BINS and not counts.flags.writeable


def test_accumulators_hold_only_the_occupied_span():
    """Memory proportional to what is kept: a point's histograms are stored from
    their first to their last occupied bin, not as 3,202 dense int64 bins."""
    from microimpact.engine.accumulators import E_BINS, MU_BINS

    sc = scenario(surfaces=(rough(5.0),), angles_deg=(60.0,), speeds_m_s=(0.5,))
    acc = run(sc, samples=300).accumulators[0]
    for name in ("e", "mu"):
        dense = getattr(acc, f"{name}_hist")
        nz = np.flatnonzero(dense)
        lo, counts = getattr(acc, f"{name}_span")
        assert lo == nz[0] and lo + counts.size == nz[-1] + 1
    assert acc.nbytes < (E_BINS + MU_BINS) * 8 / 10


def test_bad_coefficients_are_named():
    sc = scenario(coefficients=PowerCoefficients(k1=-1.0))
    with pytest.raises(ScenarioError, match=r"coefficients\.k1"):
        run(sc)


def test_bad_run_arguments():
    sc = scenario()
    with pytest.raises(ValueError, match="`samples`"):
        run(sc, samples=0)
    with pytest.raises(ValueError, match="`backend`"):
        run(sc, backend="mpi")
    with pytest.raises(ValueError, match="`seed`"):
        run(sc, seed=-3)


def test_qmc_has_honest_error_bars_and_smaller_error():
    """Randomised QMC: replicate intervals cover the quadrature value, and the RMS
    error over scrambles is below plain MC's at equal N."""
    coeffs = PowerCoefficients()
    kw = dict(
        coefficients=coeffs,
        surfaces=(rough(8.0),),
        speeds_m_s=(0.5,),
        angles_deg=(45.0,),
    )
    exact = _quadrature_e_mean(coeffs, 0.5, 45.0, 8.0, "reject")
    n = 1 << 14
    qmc_err, mc_err = [], []
    for seed in range(6):
        q = run(
            scenario(sampling="qmc", qmc_replicates=8, seed=seed, **kw), samples=n
        ).summary.iloc[0]
        m = run(scenario(seed=seed, **kw), samples=n).summary.iloc[0]
        qmc_err.append(q["e_mean"] - exact)
        mc_err.append(m["e_mean"] - exact)
        assert abs(q["e_mean"] - exact) < K * q["e_se"] + 1e-6
    assert np.sqrt(np.mean(np.square(qmc_err))) < np.sqrt(np.mean(np.square(mc_err)))


def test_normal_diameters_helper_is_the_truncated_normal():
    t = normal_diameters().table()
    assert_allclose(
        t.mean(),
        stats.truncnorm(-52.8 / 15.3, np.inf, loc=52.8, scale=15.3).mean() * 1e-6,
        rtol=1e-4,
    )


def test_unreachable_dask_scheduler_is_a_user_error(monkeypatch):
    pytest.importorskip("dask.distributed")
    from microimpact.engine import parallel
    from microimpact.errors import InputError

    monkeypatch.setattr(parallel, "DASK_CONNECT_TIMEOUT", 1)
    with pytest.raises(InputError, match=r"address: cannot connect .*127\.0\.0\.1:9"):
        run(scenario(samples=1000), backend="dask", address="tcp://127.0.0.1:9")


@pytest.mark.parametrize("k, n", [(0, 10), (3, 10), (50, 100), (999, 1000), (7, 4000)])
def test_wilson_interval_solves_the_score_equation(k, n):
    """Wilson's limits are the roots of |k/n - p| = z sqrt(p (1 - p) / n)."""
    from scipy.optimize import brentq

    from microimpact.engine.statistics import wilson_interval

    z = stats.norm.ppf(0.975)
    p_hat = k / n

    def score(p):
        return abs(p_hat - p) - z * math.sqrt(p * (1 - p) / n)

    lo, hi = wilson_interval(k, n, 0.95)
    # brackets exclude p = p_hat, where the score vanishes trivially when k = 0, n
    inner_lo, inner_hi = max(p_hat, 1e-15), min(p_hat, 1 - 1e-15)
    expect_lo = 0.0 if k == 0 else brentq(score, 1e-15, inner_hi)
    expect_hi = 1.0 if k == n else brentq(score, inner_lo, 1 - 1e-15)
    assert_allclose([lo, hi], [expect_lo, expect_hi], atol=1e-12)
    if k == 0:  # closed form of the upper limit
        assert_allclose(hi, z * z / (n + z * z), rtol=1e-12)


# ------------------------------------------------ the result, lazily (issue 24)
@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"sampling": "qmc"},
        {"angles_deg": (30.0, 85.0)},  # the relative coefficients
        {
            "surfaces": (rough(5.0), mi.SurfaceVariant("smooth")),
            "speeds_m_s": (0.2, 1.0),
        },
    ],
)
def test_summary_from_the_columns_equals_the_datasets(kw):
    """A fresh run's summary comes from its columns without the Dataset: the same
    frame, exactly, as the one derived from the Dataset (built afterwards)."""
    import pandas as pd

    from microimpact.engine.dataset import summary_frame

    base = dict(surfaces=(rough(10.0),), speeds_m_s=(0.3,), angles_deg=(30.0, 60.0))
    base.update(kw)
    r = run(scenario(samples=3000, **base), seed=1)
    assert r._dataset is None  # not built yet
    fresh = r.summary
    want = summary_frame(r.dataset)
    want.attrs["confidence"] = r.confidence
    pd.testing.assert_frame_equal(fresh, want, check_exact=True)
    assert r.seed_entropy == int(r.dataset.attrs["seed_entropy"])


_COLUMNS_KW = [
    {},
    {"sampling": "qmc"},
    {"angles_deg": (30.0, 85.0)},  # the relative coefficients
    {
        "surfaces": (rough(5.0), mi.SurfaceVariant("smooth")),
        "speeds_m_s": (0.2, 1.0),
    },
]


@pytest.fixture(scope="module")
def column_runs():
    """Per scenario of :data:`_COLUMNS_KW`: the run's arguments and its summary
    (the oracle: every column, from the full statistics)."""
    out = []
    for kw in _COLUMNS_KW:
        base = dict(surfaces=(rough(10.0),), speeds_m_s=(0.3,), angles_deg=(30.0, 60.0))
        base.update(kw)
        sc = scenario(samples=2000, **base)
        out.append((sc, run(sc, seed=4).summary))
    return out


@settings(max_examples=25, deadline=None)
@given(which=st.integers(0, len(_COLUMNS_KW) - 1), data=st.data())
def test_summary_columns_are_the_summarys(column_runs, which, data):
    """``summary_columns`` of a fresh run computes only what its columns need
    (no table, no other statistics) and gives the summary's values, rows and
    dtypes, for any set of columns (the summary of the same run, made whole,
    is the oracle)."""
    sc, summary = column_runs[which]
    stats = [
        c for c in summary.columns if c not in ("surface", "speed_m_s", "angle_deg")
    ]
    names = data.draw(st.lists(st.sampled_from(stats), min_size=1, max_size=6))
    r = run(sc, seed=4)
    got = r.summary_columns(names)
    assert r._summary is None and r._columns_value is None  # nothing else made
    assert list(got) == list(
        dict.fromkeys(["surface", "speed_m_s", "angle_deg", *names])
    )
    for c, values in got.items():
        want = summary[c].to_numpy()
        assert values.dtype == want.dtype, c
        if want.dtype == object:
            assert values.tolist() == want.tolist()
        else:
            assert_array_equal(values, want, err_msg=c)
    # the same columns once the summary exists, and a column it lacks refused
    assert_array_equal(r.summary_columns(names[:1])[names[0]], summary[names[0]])
    with pytest.raises(KeyError, match="not summary columns: nope"):
        r.summary_columns(["nope"])


def test_summary_columns_name_what_is_wrong():
    """A misspelt column is named with the columns there are, even before the
    summary is made; one name given as a string is refused with the fix."""
    r = run(scenario(samples=500, surfaces=(rough(10.0),), speeds_m_s=(0.3,)), seed=4)
    # (every column the summary has, also those the request did not compute)
    with pytest.raises(
        KeyError, match=r"not summary columns: e_men; .*e_p50.*heavy_tail"
    ):
        r.summary_columns(["e_mean", "e_men"])
    with pytest.raises(TypeError, match=r"\['e_mean'\]"):
        r.summary_columns("e_mean")


def test_summary_columns_compute_only_what_they_need(monkeypatch):
    """The moments' columns alone need no histogram quantile or tail statistic."""
    from microimpact.engine import summary as summary_module

    r = run(scenario(samples=2000, surfaces=(rough(10.0),), speeds_m_s=(0.3,)), seed=4)
    for name in ("histogram_quantiles", "tail_pull"):
        monkeypatch.setattr(summary_module, name, _refuse)
    got = r.summary_columns(["e_mean", "capture_fraction", "mu_se"])
    assert np.isfinite(got["e_mean"]).all()


def test_the_optional_column_groups_are_the_datasets_variables():
    """The groups point_statistics computes only on demand name the Dataset's
    own variables: every lateral variable, the tail ones, the quantiles."""
    from microimpact.engine import dataset as dataset_module
    from microimpact.engine import summary as summary_module

    variables = dataset_module.VARIABLES
    lateral = tuple(k for k in variables if k.startswith("lateral_"))
    assert summary_module.LATERAL_COLUMNS == lateral
    assert set(summary_module.TAIL_COLUMNS) <= set(variables)
    assert {"e_tail_share", "heavy_tail"} <= set(summary_module.TAIL_COLUMNS)
    for names in summary_module.QUANTILE_COLUMNS.values():
        assert set(names) <= set(variables)


def _refuse(*args, **kwargs):
    raise AssertionError("computed a statistic no column asked for")


def test_a_run_and_its_summary_import_no_xarray():
    """What the engine does not need is deferred: microimpact.run and its summary
    in a fresh process leave xarray (and dask, which xarray imports where it is
    installed) unimported; the Dataset imports it on access."""
    import subprocess
    import sys

    code = (
        "import sys, microimpact as mi\n"
        "sc = mi.Scenario(name='m', particles=mi.normal_diameters(50, 10),\n"
        "    coefficients=mi.ImpactCoefficients(k1=4.0, k2=0.05, v_c=0.2),\n"
        "    surfaces=(mi.SurfaceVariant('r', mi.normal_angles(8.0)),), samples=2000)\n"
        "r = mi.run(sc, seed=1)\n"
        "r.summary\n"
        "print(sorted(m for m in ('xarray', 'dask') if m in sys.modules))\n"
        "r.dataset\n"
        "print('xarray' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split("\n")
    assert out[0] == "[]" and out[1] == "True", out


def test_qmc_capture_interval_at_full_and_no_capture_is_the_counts_wilson():
    """Where every replicate captures all (or none), their spread is 0: the QMC
    interval was [1, 1], claiming certainty 1,024 impacts cannot give. It is the
    pooled counts' Wilson interval there, and inside [0, 1] everywhere."""
    from microimpact.engine.statistics import wilson_interval

    n = 1 << 10
    sc = scenario(
        sampling="qmc",
        qmc_replicates=8,
        seed=2,
        speeds_m_s=(0.001, 0.5, 100.0),
        angles_deg=(90.0,),
    )
    s = run(sc, samples=n).summary
    full, none = s.iloc[0], s.iloc[2]
    assert full["capture_fraction"] == 1.0 and none["capture_fraction"] == 0.0
    for row in (full, none):
        lo, hi = wilson_interval(
            row["capture_fraction"] * row["n"], row["n"], confidence=0.95
        )
        assert row["capture_ci_low"] == pytest.approx(lo)
        assert row["capture_ci_high"] == pytest.approx(hi)
        assert row["capture_ci_high"] - row["capture_ci_low"] > 1e-3
        assert row["capture_se"] > 0
    assert (s["capture_ci_low"] >= 0).all() and (s["capture_ci_high"] <= 1).all()


def test_a_plan_given_to_run_is_used_and_checked():
    """run(..., plan=build_plan(scenario, seed=seed)) gives the bits of a run that
    builds its own; a plan of another seed, or not a plan, is refused by name."""
    sc = scenario(samples=2000)
    plan = build_plan(sc, seed=11)
    want = run(sc, seed=11).summary
    got = run(sc, seed=11, plan=plan).summary
    assert got.equals(want)
    with pytest.raises(ValueError, match="`plan` was built with another seed"):
        run(sc, seed=12, plan=plan)
    with pytest.raises(TypeError, match="`plan` must be a Plan"):
        run(sc, seed=11, plan="plan")


@pytest.mark.parametrize("threshold", [0, 2**62])
def test_short_runs_prepare_their_result_in_the_caller(monkeypatch, threshold):
    """The result's scenario-only work runs in a thread only for a run of at
    least ``BACKGROUND_IMPACTS`` impacts (a short run's caller waited for that
    thread's turn at the GIL); either way the result is the same."""
    started = []
    start = montecarlo._Background.start

    def record(self):
        started.append(self)
        start(self)

    monkeypatch.setattr(montecarlo._Background, "start", record)
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", threshold)
    sc = scenario(samples=2000, surfaces=(rough(10.0),), speeds_m_s=(0.3, 1.0))
    got = run(sc, seed=5, workers=1)
    # (start() is called at each stage that may start it; it starts once)
    assert len({id(b) for b in started}) == (1 if threshold == 0 else 0)
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", 2**62 - threshold)
    other = run(sc, seed=5, workers=1)
    assert got.summary.equals(other.summary)
    assert got.provenance["scenario"] == other.provenance["scenario"]


def test_a_short_runs_description_waits_until_it_is_read(monkeypatch):
    """A short run prepared in the caller describes its scenario (quadratures
    of truncated distributions) only when its provenance, an attribute or its
    Dataset is first read, once; the description is the scenario's own, as an
    eagerly described run's; a pickled result carries it."""
    import pickle

    sc = scenario(samples=2000, surfaces=(rough(10.0),), speeds_m_s=(0.3, 1.0))
    calls = []
    real = type(sc).describe

    def describe(self):
        calls.append(1)
        return real(self)

    monkeypatch.setattr(type(sc), "describe", describe)
    r = run(sc, seed=6)
    r.summary_columns(["e_mean"])
    assert len(r.summary) == 2
    assert calls == []  # a calibration's model run stops here
    assert r.seed_entropy == int(r.provenance["seed_entropy"])
    assert r.provenance["scenario"] == real(sc)
    assert len(calls) == 1
    assert json.loads(r.dataset.attrs["scenario"]) == json.loads(json.dumps(real(sc)))
    assert len(calls) == 1  # computed once, shared by the provenance and the file
    fresh = run(sc, seed=6)
    # an attribute read without the Dataset: the file's own string
    assert fresh._attr("scenario") == r.dataset.attrs["scenario"]
    fresh = run(sc, seed=6)
    back = pickle.loads(pickle.dumps(fresh))
    assert back.provenance["scenario"] == real(sc)
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", 0)  # eager, in a thread
    eager = run(sc, seed=6)
    assert eager.provenance["scenario"] == r.provenance["scenario"]
    assert eager.dataset.attrs["scenario"] == r.dataset.attrs["scenario"]
