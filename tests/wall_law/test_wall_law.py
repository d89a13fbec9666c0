"""The stochastic wall law (issue 13) against independent oracles.

* a smooth surface: every node is deterministic and equals the rigid-body model
  of :func:`microimpact.rebound` (paper Eqs. 1-6), evaluated here directly;
* normal roughness: the capture probability has the closed form
  P(v sin(theta - phi) <= v_c(d) | phi < theta) under the 'reject' shadowing rule;
* direct runs of the engine at the node (another seed): capture by a two-sample
  z test, the distributions of e_n, e_t and the rebound angle by two-sample KS;
* the sampler: at a node it draws that node's distribution; between nodes its
  capture fraction is the trilinear interpolation of the nodes' (computed here).
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import stats

import microimpact as mi
from microimpact.cli import main
from microimpact.errors import DataFormatError, ScenarioError
from microimpact.wall_law import WallLaw, WallLawSpec, build_wall_law

K1, FRICTION = 4.0, 0.2


def _coefficients():
    return mi.ImpactCoefficients(
        k1=K1,
        k2=mi.PowerLaw(a=0.05, b=-1.5, d_ref=10e-6),
        v_c=mi.PowerLaw(a=0.5, b=-1.0, d_ref=10e-6),
        friction=FRICTION,
    )


def _scenario(surfaces, *, seed=11, samples=2000, **kw):
    return mi.Scenario(
        name="wall",
        particles=mi.lognormal_diameters(10.0, 1.5),
        coefficients=_coefficients(),
        surfaces=surfaces,
        seed=seed,
        samples=samples,
        **kw,
    )


SMOOTH = (mi.SurfaceVariant("smooth"),)
ROUGH_DEG = 8.0
ROUGH = (mi.SurfaceVariant("rough", mi.normal_angles(ROUGH_DEG)),)
SPEC = WallLawSpec(
    diameters_um=(3.0, 10.0, 30.0),
    speeds_m_s=(0.3, 1.0, 3.0, 10.0),
    angles_deg=(15.0, 40.0, 70.0, 90.0),
    reservoir=128,
)


@pytest.fixture(scope="module")
def rough_law():
    return build_wall_law(_scenario(ROUGH), SPEC)


def _v_c(d_um):
    return float(_coefficients().evaluate(np.array([d_um * 1e-6])).v_c[0])


# ---------------------------------------------------------------- oracles
def test_smooth_nodes_are_the_rigid_body_model():
    law = build_wall_law(_scenario(SMOOTH, samples=50), SPEC)
    ds = law.dataset.isel(surface=0)
    coeffs = _coefficients()
    for d in SPEC.diameters_um:
        k1, k2, v_c = (float(a[0]) for a in coeffs.evaluate(np.array([d * 1e-6])))
        for v in SPEC.speeds_m_s:
            for a in SPEC.angles_deg:
                th = math.radians(a)
                r = mi.rebound(
                    -v * math.sin(th),
                    -v * math.cos(th),  # travels towards -t (docs/conventions.md)
                    k1=k1,
                    k2=k2,
                    v_c=v_c,
                    friction=FRICTION,
                )
                node = ds.sel(diameter_um=d, speed_m_s=v, angle_deg=a)
                p = float(node.capture_probability)
                assert p == float(bool(r.captured))
                if r.captured:
                    assert int(node.reservoir_count) == 0
                    continue
                e = float(r.e)
                np.testing.assert_allclose(node.e_n_quantile, e, rtol=1e-6)
                np.testing.assert_allclose(node.mu_quantile, float(r.mu), rtol=1e-6)
                if a < 90:
                    e_t = float(r.V_t) / (-v * math.cos(th))
                    np.testing.assert_allclose(node.e_t_quantile, e_t, rtol=1e-6)
                else:
                    assert np.isnan(node.e_t_mean)
                angle = math.degrees(math.atan2(e * v * math.sin(th), -float(r.V_t)))
                np.testing.assert_allclose(
                    node.rebound_angle_deg_quantile, angle, rtol=1e-6, atol=1e-9
                )
                # the sampler at the node rebuilds the model's velocity
                s = law.sample(d, v, a, rng=1)
                np.testing.assert_allclose(
                    s.velocity[0], [-float(r.V_t), 0.0, float(r.V_n)], atol=1e-9
                )


def _closed_form_capture(d_um, v, angle_deg, std_deg):
    """P(v sin(theta - phi) <= v_c | phi < theta), phi ~ N(0, std) on (-90, 90)."""
    phi = stats.norm(0.0, std_deg)
    cdf = lambda x: phi.cdf(np.clip(x, -90.0, 90.0))  # noqa: E731
    reach = cdf(angle_deg) - cdf(-90.0)
    r = _v_c(d_um) / v
    if r >= 1:
        return 1.0
    a = math.degrees(math.asin(r))
    # theta - phi in (0, a] or [180 - a, theta + 90): sin(theta - phi) <= r
    low = cdf(angle_deg) - cdf(angle_deg - a)
    high = cdf(angle_deg - 180.0 + a) - cdf(-90.0)
    return float((low + max(high, 0.0)) / reach)


def test_capture_matches_the_closed_form_on_normal_roughness(rough_law):
    ds = rough_law.dataset.isel(surface=0)
    z = []
    for d in SPEC.diameters_um:
        for v in SPEC.speeds_m_s:
            for a in SPEC.angles_deg:
                node = ds.sel(diameter_um=d, speed_m_s=v, angle_deg=a)
                p = _closed_form_capture(d, v, a, ROUGH_DEG)
                n = int(node.n_impacts)
                p_hat = float(node.capture_probability)
                if p in (0.0, 1.0):
                    assert p_hat == p
                    continue
                z.append((p_hat - p) / math.sqrt(p * (1 - p) / n))
                # and the Wilson interval is honest about it (k = 4 SE margin)
                assert node.capture_ci_low - 1e-3 <= p <= node.capture_ci_high + 1e-3
    z = np.array(z)
    assert len(z) >= 8
    assert np.max(np.abs(z)) < 4.5, z
    assert np.mean(z**2) < 2.5, z


def test_nodes_match_direct_runs_of_the_engine(rough_law):
    ds = rough_law.dataset.isel(surface=0)
    for d, v, a in ((10.0, 1.0, 40.0), (3.0, 3.0, 70.0), (30.0, 10.0, 15.0)):
        direct = _scenario(ROUGH, seed=999, samples=4000).with_options(
            particles=mi.monodisperse(d), speeds_m_s=(v,), angles_deg=(a,)
        )
        out = mi.sample_point(direct, 0, 4000)
        node = ds.sel(diameter_um=d, speed_m_s=v, angle_deg=a)
        n1, p1 = int(node.n_impacts), float(node.capture_probability)
        n2 = int(np.count_nonzero(~out["shadowed"]))
        p2 = float(np.count_nonzero(out["captured"] & ~out["shadowed"])) / n2
        pool = (p1 * n1 + p2 * n2) / (n1 + n2)
        se = math.sqrt(max(pool * (1 - pool), 1e-12) * (1 / n1 + 1 / n2))
        assert abs(p1 - p2) < 4.5 * se + 1e-12
        reb = ~out["captured"] & ~out["shadowed"]
        e_m, mu_m = out["e_m"][reb], out["mu_m"][reb]
        th = math.radians(a)
        e_t = 1.0 - mu_m * (1.0 + e_m) * math.tan(th)
        ang = np.degrees(np.arctan2(e_m * math.sin(th), e_t * math.cos(th)))
        k = int(node.reservoir_count)
        assert k == min(SPEC.reservoir, int(node.n_rebounds))
        res_e = node.reservoir_e_n.values[:k]
        res_et = node.reservoir_e_t.values[:k]
        assert stats.ks_2samp(res_e, e_m).pvalue > 1e-3
        assert stats.ks_2samp(res_et, e_t).pvalue > 1e-3
        res_ang = np.degrees(np.arctan2(res_e * math.sin(th), res_et * math.cos(th)))
        assert stats.ks_2samp(res_ang, ang).pvalue > 1e-3
        # the quantiles of the node against the direct run's (two-sample KS on the
        # full node: its quantiles lie inside the direct run's DKW band)
        eps = math.sqrt(math.log(2 / 1e-4) / (2 * len(e_m)))
        for q, x in zip(node["quantile"].values, node.e_n_quantile.values, strict=True):
            assert abs(np.mean(e_m <= x) - q) < eps + 2.5 * math.sqrt(
                q * (1 - q) / int(node.n_rebounds)
            )
        qa = node.rebound_angle_deg_quantile.values
        assert abs(np.median(ang) - qa[list(node["quantile"].values).index(0.5)]) < 3.0


# ---------------------------------------------------------------- the sampler
def test_node_statistics_are_those_of_the_nodes_rebounds():
    """With a reservoir as large as the samples, each node's reservoir holds all
    of its rebounds: the node's mean and standard deviation are theirs (NumPy on
    the reservoir, ddof 1), and the standard deviation is NaN where a node has
    fewer than 2 rebounds (a rough wall near v_c: nodes with 0 to 6 of 6)."""
    sc = mi.scenario_from_dict(
        {
            "name": "few",
            "seed": 5,
            "samples": 10,
            "particles": {"distribution": "monodisperse", "diameter_um": 10.0},
            "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.5, "friction": 0.2},
            "surfaces": [{"name": "rough", "kind": "normal", "std_deg": 15}],
            "sweep": {"speed_m_s": [1.0], "angle_deg": [45.0]},
        }
    )
    spec = WallLawSpec(
        diameters_um=(10.0,),
        speeds_m_s=tuple(np.linspace(0.5, 0.7, 9)),
        angles_deg=tuple(np.linspace(40.0, 90.0, 11)),
        samples=6,
        reservoir=6,
    )
    ds = build_wall_law(sc, spec, seed=1).dataset
    n = ds["n_rebounds"].values
    assert set(np.unique(n)) >= {0, 1, 2, 6}  # the cases this test is about
    np.testing.assert_array_equal(ds["reservoir_count"].values, n)
    for name in ("e_n", "mu", "e_t"):  # a 2-D wall: no lateral angle
        res = ds[f"reservoir_{name}"].values
        mean, std = ds[f"{name}_mean"].values, ds[f"{name}_std"].values
        for i in np.ndindex(n.shape):
            x = res[i][: n[i]]
            if n[i] == 0 or np.isnan(x).all():  # e_t at normal incidence: none
                assert np.isnan(mean[i]) and np.isnan(std[i])
                continue
            assert mean[i] == pytest.approx(x.mean(), rel=1e-12, abs=1e-12)
            if n[i] < 2:
                assert np.isnan(std[i]), (name, i)
            else:
                assert std[i] == pytest.approx(x.std(ddof=1), rel=1e-9, abs=1e-12)


def test_sampling_at_a_node_draws_that_node(rough_law):
    ds = rough_law.dataset.isel(surface=0).sel(diameter_um=10.0, speed_m_s=1.0)
    node = ds.sel(angle_deg=40.0)
    n = 200_000
    s = rough_law.sample(10.0, 1.0, 40.0, rng=np.random.default_rng(5))
    s = rough_law.sample(np.full(n, 10.0), 1.0, 40.0, rng=np.random.default_rng(5))
    p = float(node.capture_probability)
    assert abs(s.captured.mean() - p) < 5 * math.sqrt(p * (1 - p) / n) + 1e-12
    reb = ~s.captured
    e_n = s.velocity[reb, 2] / math.sin(math.radians(40.0))
    k = int(node.reservoir_count)
    # every rebound is one of the node's reservoir samples
    assert np.isin(np.round(e_n, 9), np.round(node.reservoir_e_n.values[:k], 9)).all()
    assert not s.clamped.any() and s.valid.all()


def _trilinear_capture(law, d, v, a):
    """The sampler's expected capture: the trilinear mix of the corners' capture in
    (log d, log v, angle); on a reduced speed axis in (log d, log(v / v_c(d)),
    angle), v_c(d) from the coefficient law (a power law, so log v_c is linear in
    log d as the sampler interpolates it)."""
    ds = law.dataset.isel(surface=0)
    if "reduced_speed" in ds.dims:
        speed = (ds.reduced_speed.values, v / _v_c(d), True)
    else:
        speed = (ds.speed_m_s.values, v, True)
    axes = []
    for coord, x, log in (
        (ds.diameter_um.values, d, True),
        speed,
        (ds.angle_deg.values, a, False),
    ):
        c = np.log(coord) if log else coord
        x = math.log(x) if log else x
        i = int(np.clip(np.searchsorted(c, x) - 1, 0, len(c) - 2))
        axes.append((i, (x - c[i]) / (c[i + 1] - c[i])))
    p = ds.capture_probability.values
    total = 0.0
    for bits in range(8):
        w, idx = 1.0, []
        for ax, (i, t) in enumerate(axes):
            up = (bits >> ax) & 1
            w *= t if up else 1 - t
            idx.append(i + up)
        total += w * p[tuple(idx)]
    return total


def test_between_nodes_capture_is_the_trilinear_mix(rough_law):
    n = 400_000
    rng = np.random.default_rng(9)
    for d, v, a in ((5.0, 0.6, 30.0), (17.0, 2.0, 80.0), (4.0, 5.0, 55.0)):
        p = _trilinear_capture(rough_law, d, v, a)
        s = rough_law.sample(np.full(n, d), v, a, rng=rng)
        assert abs(s.captured.mean() - p) < 5 * math.sqrt(p * (1 - p) / n) + 1e-12


def test_queries_outside_the_table_are_clamped_and_flagged(rough_law):
    s = rough_law.sample([1.0, 10.0, 10.0], [1.0, 50.0, 1.0], [40.0, 40.0, 5.0], rng=2)
    assert s.clamped.tolist() == [True, True, True]
    inside = rough_law.sample(10.0, 1.0, 40.0, rng=2)
    assert not inside.clamped.any()


def test_rebounds_never_gain_energy(rough_law):
    rng = np.random.default_rng(3)
    n = 50_000
    d = np.exp(rng.uniform(np.log(3), np.log(30), n))
    v = np.exp(rng.uniform(np.log(0.3), np.log(10), n))
    a = rng.uniform(15, 90, n)
    s = rough_law.sample(d, v, a, rng=rng)
    speed = np.linalg.norm(s.velocity, axis=1)
    assert np.all(speed <= v * (1 + 1e-9))
    assert np.all(s.velocity[s.captured] == 0.0)
    assert np.all(s.velocity[:, 1] == 0.0)  # profile roughness: no lateral scatter


def test_sample_argument_errors(rough_law):
    with pytest.raises(ValueError, match="angle_deg"):
        rough_law.sample(10.0, 1.0, 95.0, rng=1)
    with pytest.raises(ValueError, match="diameter_um"):
        rough_law.sample(-1.0, 1.0, 45.0, rng=1)
    with pytest.raises(ValueError, match="unknown surface"):
        rough_law.sample(10.0, 1.0, 45.0, rng=1, surface="glass")
    with pytest.raises(ValueError, match=r"shape \(N, 5\)"):
        rough_law.sample_uniform(10.0, 1.0, 45.0, np.zeros((3, 4)))


# ------------------------------------------------------ reproducibility, files
def test_seed_reproduces_the_table_for_any_worker_count(rough_law):
    again = build_wall_law(_scenario(ROUGH), SPEC, workers=2)
    for v in rough_law.dataset.data_vars:
        np.testing.assert_array_equal(
            again.dataset[v].values, rough_law.dataset[v].values
        )
    other = build_wall_law(_scenario(ROUGH, seed=12), SPEC)
    assert not np.array_equal(
        other.dataset.reservoir_e_n.values, rough_law.dataset.reservoir_e_n.values
    )


def test_an_interrupted_build_resumes_only_what_is_left(tmp_path, rough_law):
    calls = []

    def stop_after_two(done, total):
        calls.append(done)
        if done == 2:
            raise KeyboardInterrupt

    folder = tmp_path / "ckpt"
    with pytest.raises(KeyboardInterrupt):
        build_wall_law(
            _scenario(ROUGH), SPEC, progress=stop_after_two, checkpoint=folder
        )
    calls.clear()
    law = build_wall_law(
        _scenario(ROUGH), SPEC, progress=lambda d, t: calls.append(d), checkpoint=folder
    )
    assert calls == [3]  # only the third diameter was simulated again
    for v in law.dataset.data_vars:
        np.testing.assert_array_equal(
            law.dataset[v].values, rough_law.dataset[v].values
        )
    assert not folder.exists()


def test_netcdf_and_csv_round_trip(tmp_path, rough_law):
    rough_law.write(tmp_path, c=False, openfoam=False)
    back = WallLaw.open(tmp_path / "wall_law.nc")
    ds = back.dataset
    assert ds.attrs["Conventions"] == "CF-1.10"
    for key in ("frame", "angle_convention", "interpolation", "seed", "scenario"):
        assert key in ds.attrs
    for v in ds.data_vars:
        assert ds[v].attrs["units"] and ds[v].attrs["long_name"], v
    assert ds.n_captured.dtype.kind == "i"
    u = np.random.default_rng(4).random((1000, 5))
    a = rough_law.sample_uniform(7.0, 2.0, 33.0, u)
    b = back.sample_uniform(7.0, 2.0, 33.0, u)
    np.testing.assert_array_equal(a.velocity, b.velocity)
    import pandas as pd

    table = pd.read_csv(tmp_path / "wall_law.csv")
    assert len(table) == SPEC.nodes
    row = table[
        (table.diameter_um == 10) & (table.speed_m_s == 1) & (table.angle_deg == 40)
    ]
    node = ds.isel(surface=0).sel(diameter_um=10.0, speed_m_s=1.0, angle_deg=40.0)
    np.testing.assert_allclose(row.capture_probability, node.capture_probability)
    np.testing.assert_allclose(
        row.e_n_p50, node.e_n_quantile.sel(quantile=0.5), rtol=1e-8
    )


def test_open_refuses_what_is_not_a_wall_law(tmp_path):
    with pytest.raises(DataFormatError, match="no such file"):
        WallLaw.open(tmp_path / "missing.nc")
    bad = tmp_path / "bad.nc"
    bad.write_text("not netcdf")
    with pytest.raises(DataFormatError, match=r"bad\.nc"):
        WallLaw.open(bad)


# ---------------------------------------------------------------- inputs
def test_spec_validation_names_the_key():
    with pytest.raises(ScenarioError, match=r"wall_law\.angle_deg"):
        WallLawSpec(diameters_um=(1.0,), speeds_m_s=(1.0,), angles_deg=(0.0,))
    with pytest.raises(ScenarioError, match=r"wall_law\.reservoir"):
        WallLawSpec(
            diameters_um=(1.0,), speeds_m_s=(1.0,), angles_deg=(9.0,), reservoir=0
        )
    s = WallLawSpec(diameters_um=(5.0, 1.0, 5.0), speeds_m_s=(1.0,), angles_deg=(9.0,))
    assert s.diameters_um == (1.0, 5.0)  # sorted, each once


def _toml(tmp_path, wall_law: str, extra=""):
    path = tmp_path / "study.toml"
    path.write_text(
        f"""name = "w"
seed = 3
samples = 300
{extra}
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
friction = 0.2
[[surfaces]]
name = "rough"
kind = "normal"
std_deg = 5
[sweep]
speed_m_s = [1.0, 2.0]
angle_deg = [30, 90]
{wall_law}
"""
    )
    return path


def test_toml_wall_law_table(tmp_path):
    from microimpact.scenario.file import wall_law_from_toml

    path = _toml(
        tmp_path,
        '[wall_law]\ndiameter_um = {start = 1, stop = 100, num = 3, spacing = "log"}\n'
        "reservoir = 16",
    )
    spec = wall_law_from_toml(path)
    assert spec.diameters_um == (1.0, 10.0, 100.0)
    assert spec.speeds_m_s == (1.0, 2.0) and spec.angles_deg == (30.0, 90.0)
    assert spec.reservoir == 16
    bad = _toml(
        tmp_path,
        '[wall_law]\ndiameter_um = {start = 0, stop = 1, num = 3, spacing = "log"}',
    )
    with pytest.raises(ScenarioError, match=r"study.toml.*wall_law.diameter_um.start"):
        wall_law_from_toml(bad)
    bad = _toml(tmp_path, "[wall_law]\ndiameter_um = [10]\nreservior = 3")
    with pytest.raises(ScenarioError, match="reservior"):
        mi.Scenario.from_toml(bad)


def test_cli_wall_law_end_to_end(tmp_path, capsys):
    path = _toml(tmp_path, "[wall_law]\ndiameter_um = [5, 20]\nreservoir = 16")
    out = tmp_path / "out"
    assert (
        main(
            [
                "wall-law",
                str(path),
                "--out",
                str(out),
                "--quiet",
                "--no-c",
                "--no-openfoam",
            ]
        )
        == 0
    )
    law = WallLaw.open(out)
    assert law.dataset.sizes["diameter_um"] == 2
    assert (out / "wall_law.csv").is_file()
    no_table = _toml(tmp_path, "")
    assert main(["wall-law", str(no_table), "--out", str(out), "--quiet"]) == 2
    assert "[wall_law]" in capsys.readouterr().err


# ------------------------------------------------------ property-based, the user path
@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    d=st.lists(st.floats(1.0, 100.0), min_size=1, max_size=3),
    v=st.lists(st.floats(0.05, 30.0), min_size=1, max_size=3),
    a=st.lists(st.floats(1.0, 90.0), min_size=1, max_size=3),
    std=st.sampled_from([0.0, 3.0, 20.0]),
    reservoir=st.integers(1, 40),
    seed=st.integers(0, 2**32),
)
def test_random_valid_tables_build_and_sample(d, v, a, std, reservoir, seed):
    surfaces = SMOOTH if std == 0 else (mi.SurfaceVariant("r", mi.normal_angles(std)),)
    spec = WallLawSpec(
        diameters_um=d, speeds_m_s=v, angles_deg=a, reservoir=reservoir, samples=64
    )
    law = build_wall_law(_scenario(surfaces, seed=seed), spec)
    ds = law.dataset
    p = ds.capture_probability.values
    assert np.all((p >= 0) & (p <= 1))
    assert np.all((ds.capture_ci_low.values <= p) & (p <= ds.capture_ci_high.values))
    assert np.all(
        ds.reservoir_count.values == np.minimum(reservoir, ds.n_rebounds.values)
    )
    rng = np.random.default_rng(seed)
    n = 500
    s = law.sample(
        rng.uniform(0.5, 150, n),
        rng.uniform(0.01, 50, n),
        rng.uniform(0.5, 90, n),
        rng=rng,
    )
    assert s.valid.all()
    assert np.all(np.isfinite(s.velocity))
    if std == 0:  # a smooth wall: 0 <= e <= 1, nothing goes back into the wall
        assert not s.reimpact.any()
        e = ds.e_n_quantile.values
        assert np.all((e[~np.isnan(e)] >= 0) & (e[~np.isnan(e)] <= 1))


def test_spec_replace_keeps_validation():
    with pytest.raises(ScenarioError):
        dataclasses.replace(SPEC, reservoir=-3)


def test_cli_condition_flags_are_checked_before_the_build(tmp_path, capsys):
    path = _toml(tmp_path, "[wall_law]\ndiameter_um = [5, 20]\nreservoir = 8")
    out = tmp_path / "out"
    for flags, field in (
        (["--diameter-um", "500"], "--diameter-um"),
        (["--speed-m-s", "0.01"], "--speed-m-s"),
        (["--angle-deg", "89"], "--angle-deg"),
    ):
        rc = main(
            ["wall-law", str(path), "--out", str(out), "--quiet", "--no-c", *flags]
        )
        assert rc == 2
        assert field in capsys.readouterr().err
    assert not (out / "wall_law.nc").exists()  # refused before anything was built


def _axis_toml(draw_values, spacing_log):
    lo, hi = min(draw_values), max(draw_values)
    # a log axis of 3 nodes between two numbers one ulp apart would hold nodes
    # with equal logarithms, which WallLawSpec refuses (not a valid table)
    if spacing_log and math.log(hi) - math.log(lo) > 1e-6:
        return f'{{ start = {lo!r}, stop = {hi!r}, num = 3, spacing = "log" }}'
    return "[" + ", ".join(repr(v) for v in draw_values) + "]"


def _log_distinct(values) -> bool:
    """Valid log-axis nodes: equal, or with different logarithms (WallLawSpec
    refuses distinct numbers whose logarithms are equal, e.g. 200 and 200 - 1 ulp)."""
    logs = {}
    for x in values:
        logs.setdefault(math.log(x), set()).add(x)
    return all(len(xs) == 1 for xs in logs.values())


@settings(
    max_examples=6,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    d=st.lists(st.floats(0.5, 200.0), min_size=1, max_size=3).filter(_log_distinct),
    v=st.lists(st.floats(0.01, 50.0), min_size=1, max_size=3).filter(_log_distinct),
    a=st.lists(st.floats(0.5, 90.0), min_size=1, max_size=3),
    log=st.booleans(),
    std=st.sampled_from([1.0, 15.0, 40.0]),
    shadowing=st.sampled_from(["reject", "weighted", "none"]),
    reduced=st.booleans(),
)
def test_random_wall_law_files_run_end_to_end_through_the_cli(
    tmp_path_factory, d, v, a, log, std, shadowing, reduced
):
    """Random valid [wall_law] tables through `microimpact wall-law`: exit 0 and
    every output (NetCDF, CSV, C, OpenFOAM), readable back; on either speed axis
    (`v` the ratios v / v_c(d) of a reduced one)."""
    speeds = "reduced_speed" if reduced else "speed_m_s"
    tmp = tmp_path_factory.mktemp("wl")
    path = tmp / "s.toml"
    path.write_text(
        f"""name = "p"
seed = 1
samples = 40
shadowing = "{shadowing}"
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = {{law = "power", a_m_s = 0.05, b = -1.5, d_ref_um = 10}}
v_c = {{law = "power", a_m_s = 0.5, b = -1.0, d_ref_um = 10}}
friction = 0.2
[[surfaces]]
name = "rough"
kind = "normal"
std_deg = {std}
[sweep]
speed_m_s = [1.0]
[wall_law]
diameter_um = {_axis_toml(d, log)}
{speeds} = {_axis_toml(v, log)}
angle_deg = {_axis_toml(a, False)}
reservoir = 8
"""
    )
    out = tmp / "out"
    assert main(["wall-law", str(path), "--out", str(out), "--quiet"]) == 0
    for name in (
        "wall_law.nc",
        "wall_law.csv",
        "c/swl.c",
        "c/wall_law.swl",
        "c/fluent_udf.c",
    ):
        assert (out / name).is_file(), name
    law = WallLaw.open(out)
    assert law.speed_axis == ("reduced" if reduced else "absolute")
    binary = mi.wall_law.read_binary(out / "c" / "wall_law.swl")
    assert binary.attrs["speed_axis"] == law.speed_axis
    s = law.sample(float(np.mean(d)), float(np.mean(v)), float(np.mean(a)), rng=0)
    assert s.captured.shape == (1,)
    assert not list(out.glob(".*.tmp"))


def test_areal_surface_fills_the_lateral_angle():
    """On an areal surface the lateral angle is the rebound's deflection out of the
    plane of incidence: checked against microimpact.apparent_rebound with the
    out-of-plane angle, per impact, converted to the wall frame (y = z x x = -b)."""
    from microimpact.surface.areal_angles import gaussian_areal_angles
    from microimpact.wall_law.build import node_outcomes

    angles = gaussian_areal_angles(
        nx=96,
        ny=96,
        dx_um=1.0,
        rms_um=1.0,
        corr_x_um=6.0,
        contact_diameter_um=3.0,
        seed=4,
        azimuth_deg=None,
    )
    scenario = _scenario((mi.SurfaceVariant("areal", angles),), samples=3000)
    spec = WallLawSpec(diameters_um=(10.0,), speeds_m_s=(2.0,), angles_deg=(35.0,))
    law = build_wall_law(scenario, spec)
    node = law.dataset.isel(surface=0, diameter_um=0, speed_m_s=0, angle_deg=0)
    k = int(node.reservoir_count)
    lateral = node.reservoir_lateral_angle_deg.values[:k]
    assert np.std(lateral) > 1.0  # real out-of-plane scatter
    assert abs(np.mean(lateral)) < 4 * np.std(lateral) / math.sqrt(k)  # isotropic
    # per impact, against the physics function (an independent implementation)
    sc = scenario.with_options(
        particles=mi.monodisperse(10.0), speeds_m_s=(2.0,), angles_deg=(35.0,)
    )
    out = mi.sample_point(sc, 0, 2000)
    reb = ~out["captured"] & ~out["shadowed"]
    v_c = _v_c(10.0)
    r = mi.apparent_rebound(
        2.0,
        35.0,
        np.degrees(out["roughness_angle"][reb]),
        out_of_plane_angle_deg=np.degrees(out["out_of_plane_angle"][reb]),
        k1=K1,
        k2=float(_coefficients().evaluate(np.array([10e-6])).k2[0]),
        v_c=v_c,
        friction=FRICTION,
    )
    u_x, u_y, u_z = -r.V_t, -r.V_b, r.V_n  # wall frame: x = -t, y = -b, z = n
    expected = np.degrees(np.arctan2(u_y, np.hypot(u_x, u_z)))
    got = node_outcomes(
        out["e_m"][reb], out["mu_m"][reb], 35.0, out["lateral_angle_deg"][reb]
    )
    np.testing.assert_allclose(got["lateral_angle_deg"], expected, atol=1e-6)
    np.testing.assert_allclose(
        got["speed_ratio"], np.sqrt(u_x**2 + u_y**2 + u_z**2) / 2.0, rtol=1e-6
    )
    # and the sampler rebuilds that lateral velocity
    s = law.sample(np.full(4000, 10.0), 2.0, 35.0, rng=3)
    assert np.std(s.velocity[~s.captured, 1]) > 0


def test_a_bad_node_value_is_named_plainly():
    """The value in the message is the number the user wrote (no NumPy repr)."""
    with pytest.raises(ScenarioError) as err:
        WallLawSpec(diameters_um=(-1.0,), speeds_m_s=(1.0,), angles_deg=(9.0,))
    assert "value -1 is outside (0, inf)" in str(err.value)
    assert "np.float64" not in str(err.value)


def test_cli_wall_law_scheduler_goes_through_the_engines_dask_connection(
    tmp_path, capsys, monkeypatch
):
    """``--scheduler ADDRESS`` alone still means Dask (as before ``--backend``
    existed for this verb); an unreachable scheduler is the user's error: exit 2,
    one line naming the address."""
    from microimpact.engine import parallel

    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(parallel, "DASK_CONNECT_TIMEOUT", 1)
    path = _toml(tmp_path, "[wall_law]\ndiameter_um = [5, 20]\nreservoir = 16")
    argv = ["wall-law", str(path), "--out", str(tmp_path / "out"), "--quiet"]
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "127.0.0.1:9" in err


# ------------------------------------------- the build on the compiled kernel (24)
def _areal_and_rough():
    from microimpact.surface.areal_angles import gaussian_areal_angles

    areal = gaussian_areal_angles(
        nx=64,
        ny=64,
        dx_um=1.0,
        rms_um=1.0,
        corr_x_um=6.0,
        contact_diameter_um=3.0,
        seed=4,
        azimuth_deg=None,
    )
    return (*ROUGH, mi.SurfaceVariant("areal", areal))


SMALL = WallLawSpec(
    diameters_um=(3.0, 30.0),
    speeds_m_s=(0.3, 3.0),
    angles_deg=(15.0, 60.0, 90.0),
    reservoir=64,
)


def _same_tables(a, b):
    for v in a.dataset.data_vars:
        np.testing.assert_array_equal(a.dataset[v].values, b.dataset[v].values, v)


def test_table_bits_do_not_depend_on_kernel_workers_or_executor(monkeypatch):
    """The compiled kernel (one worker, two worker threads, an executor) and the
    NumPy kernel (its per-impact output, the same impacts) give the same table."""
    from concurrent.futures import ThreadPoolExecutor

    from microimpact.engine import kernel

    sc = _scenario(_areal_and_rough(), samples=1500)
    one = build_wall_law(sc, SMALL)
    _same_tables(one, build_wall_law(sc, SMALL, workers=2))
    with ThreadPoolExecutor(2) as ex:
        _same_tables(one, build_wall_law(sc, SMALL, executor=ex))
    monkeypatch.setenv("MICROIMPACT_KERNEL", "numpy")
    _same_tables(one, build_wall_law(sc, SMALL, workers=2))
    if kernel.KERNEL != "compiled":  # pragma: no cover - no C compiler
        pytest.skip("the compiled kernel is not built")


def test_node_groups_on_threads_do_not_change_the_table(monkeypatch):
    """On several threads a diameter's nodes run as groups of a few nodes
    (``_group_nodes``), joined in order: the table is the same bits as one worker
    running whole diameters, with the groups split down to one node, into
    TASKS_PER_WORKER groups per worker, to a size that leaves a short last group,
    and not at all."""
    from microimpact.wall_law import build

    sc = _scenario(_areal_and_rough(), samples=1500)
    one = build_wall_law(sc, SMALL)
    seen = []
    real = build._node_rows

    def spy(plan, points, *a, **k):
        seen.append(len(points))
        return real(plan, points, *a, **k)

    monkeypatch.setattr(build, "_node_rows", spy)
    made = []
    real_plan = build._diameter_plan

    def plan_spy(plan, scenario, spec, j, *a):
        made.append(j)
        return real_plan(plan, scenario, spec, j, *a)

    monkeypatch.setattr(build, "_diameter_plan", plan_spy)
    nodes = 2 * 2 * 3  # surfaces x speeds x angles
    # 2 workers, 2 diameters: TASKS_PER_WORKER = 4 wants 4 groups per diameter
    # (the last groups shrink toward the end: at most the nodes left over
    # TAIL_SPLIT x workers, down to the floor)
    for floor, per_worker, sizes in (
        (1, 12, {1}),
        (1, 4, {3, 2, 1}),
        (1500 * 5, 4, {5, 2}),
        (10**9, 4, {nodes}),
    ):
        monkeypatch.setattr(build, "MIN_GROUP_IMPACTS", floor)
        monkeypatch.setattr(build, "TASKS_PER_WORKER", per_worker)
        seen.clear()
        _same_tables(one, build_wall_law(sc, SMALL, workers=2))
        assert set(seen) == sizes, (floor, seen)
        assert sum(seen) == nodes * len(SMALL.diameters_um)
        # each diameter's plan made once
        assert sorted(made) == list(range(len(SMALL.diameters_um)))
        made.clear()


def test_group_items_shrink_toward_the_end():
    """16 diameters of 256 nodes on 2 workers at 2,000 impacts: whole diameters
    until the nodes left fall below TAIL_SPLIT x 2 of them, then smaller groups
    down to the floor (65 nodes); in order, every node once; one worker keeps
    whole diameters."""
    from microimpact.wall_law.build import MIN_GROUP_IMPACTS, _group_items

    items = _group_items(range(16), 256, 256, 2000, 2)
    floor = MIN_GROUP_IMPACTS // 2000
    assert [(j, lo) for j, lo, _ in items][:13] == [(j, 0) for j in range(13)]
    sizes = [hi - lo for _, lo, hi in items]
    assert sizes[:13] == [256] * 13 and len(items) > 16
    # below the floor only a diameter's remainder: the last groups are short
    assert all(
        s >= floor for (_, _, hi), s in zip(items, sizes, strict=True) if hi < 256
    )
    assert max(sizes[-4:]) <= floor
    for j in range(16):  # each diameter's groups tile its nodes in order
        los = [(lo, hi) for jj, lo, hi in items if jj == j]
        assert los[0][0] == 0 and los[-1][1] == 256
        assert all(a[1] == b[0] for a, b in itertools.pairwise(los))
    assert _group_items(range(16), 256, 256, 2000, 1) == [
        (j, 0, 256) for j in range(16)
    ]


def test_group_nodes_arithmetic():
    """Groups of GROUP_IMPACTS worth of nodes on one worker; on several, at least
    TASKS_PER_WORKER groups per worker where MIN_GROUP_IMPACTS allows."""
    from microimpact.engine.montecarlo import TASKS_PER_WORKER
    from microimpact.wall_law.build import (
        GROUP_IMPACTS,
        MIN_GROUP_IMPACTS,
        _group_nodes,
    )

    assert _group_nodes(256, 2000) == 256  # GROUP_IMPACTS is 262 nodes: one group
    assert _group_nodes(256, 2000, 16, 1) == 256
    assert _group_nodes(1000, 2000) == GROUP_IMPACTS // 2000
    # 16 diameters on 16 workers: 4 groups per diameter (of 64 nodes, but the
    # floor is 65 nodes at 2,000 impacts: 65, 65, 65, 61)
    per = _group_nodes(256, 2000, 16, 16)
    assert per == max(64, MIN_GROUP_IMPACTS // 2000)
    assert 16 * -(-256 // per) >= TASKS_PER_WORKER * 16
    # 2 diameters on 4 workers at 10,000 impacts: 8 groups of 32 nodes each
    assert _group_nodes(256, 10_000, 2, 4) == 32
    # at 100 impacts the floor is 1,310 nodes: no split
    assert _group_nodes(256, 100, 2, 4) == 256
    # never below the floor: 64 workers would want groups of 16 nodes
    assert _group_nodes(256, 2000, 16, 64) == MIN_GROUP_IMPACTS // 2000
    # impacts per node above GROUP_IMPACTS: one node per group
    assert _group_nodes(10, GROUP_IMPACTS * 2, 1, 8) == 1


def test_node_statistics_against_numpy_per_node():
    """Each node's counts, quantiles (np.quantile, bit for bit), reservoir (its
    first rebounds in draw order, bit for bit) and mean/std (np.mean/np.std to
    round-off: another summation order) from the engine's per-impact output."""
    from microimpact.engine.montecarlo import iter_point_samples
    from microimpact.engine.plan import build_plan
    from microimpact.wall_law.build import _node_rows, node_outcomes

    sc = _scenario(_areal_and_rough(), samples=2500).with_options(
        particles=mi.monodisperse(10.0),
        speeds_m_s=(0.3, 3.0),
        angles_deg=(15.0, 60.0, 90.0),
    )
    plan = build_plan(sc, seed=4)
    points = range(len(plan.points))
    rows = _node_rows(plan, points, SMALL, 2500)
    q = np.asarray(SMALL.quantiles)
    for i in points:
        pt = plan.points[i]
        s = next(iter_point_samples(plan, i, 2500))
        reb = ~s["captured"] & ~s["shadowed"]
        psi = s["lateral_angle_deg"][reb] if pt.surface == 1 else None
        out = node_outcomes(s["e_m"][reb], s["mu_m"][reb], pt.angle_deg, psi)
        assert rows["n_rebounds"][i] == np.count_nonzero(reb)
        assert rows["n_captured"][i] == np.count_nonzero(s["captured"] & ~s["shadowed"])
        assert rows["n_reimpacts"][i] == np.count_nonzero(out["e_n"] < 0)
        k = min(SMALL.reservoir, int(np.count_nonzero(reb)))
        for name in ("e_n", "mu", "e_t", "speed_ratio"):
            got = rows[f"reservoir_{name}"][i][:k]
            np.testing.assert_allclose(got, out[name][:k], rtol=1e-15, err_msg=name)
        np.testing.assert_array_equal(rows["reservoir_e_n"][i][:k], out["e_n"][:k])
        for name in ("e_n", "e_t", "mu", "rebound_angle_deg", "lateral_angle_deg"):
            x = out[name]
            if np.isnan(x).all():
                assert np.isnan(rows[f"{name}_mean"][i])
                continue
            want = np.quantile(x, q)
            got = rows[f"{name}_quantile"][i]
            if name in ("e_n", "e_t", "mu"):  # the same values: the same bits
                np.testing.assert_array_equal(got, want, err_msg=name)
            np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-12)
            np.testing.assert_allclose(
                rows[f"{name}_mean"][i], np.mean(x), 1e-12, 1e-12
            )
            np.testing.assert_allclose(rows[f"{name}_std"][i], np.std(x, ddof=1), 1e-12)


def test_compiled_statistics_equal_their_numpy_form():
    """``_ckernel.wall_rows`` against its NumPy form on random impacts (rebounds,
    captures and shadowed impacts mixed, normal incidence, one impact, none
    rebounding): the same bits (profile rows), to round-off (areal rows: sin and
    tan of the lateral angle come from different libraries)."""
    from microimpact.engine import kernel
    from microimpact.wall_law.build import _wall_rows

    if kernel.KERNEL != "compiled":  # pragma: no cover - no C compiler
        pytest.skip("the compiled kernel is not built")
    rng = np.random.default_rng(3)
    p, n = 7, 300
    imp = {
        "e_m": rng.uniform(-0.2, 1.5, (p, n)),
        "mu_m": rng.normal(0.0, 0.4, (p, n)),
        "lateral_angle_deg": rng.choice([0.0, 180.0, -30.0, 75.0], (p, n))
        + rng.normal(0.0, 5.0, (p, n)) * (rng.random((p, n)) < 0.5),
        "outcome": rng.choice(np.array([0, 0, 0, 1, 2], np.int8), (p, n)),
    }
    imp["outcome"][4] = 1  # no rebound at all
    imp["outcome"][5, 1:] = 2  # one
    angles = [15.0, 40.0, 90.0, 60.0, 30.0, 45.0, 80.0]
    geom = np.array(
        [
            [
                math.sin(math.radians(a)),
                0.0 if a == 90 else math.cos(math.radians(a)),
                float(r % 2),
            ]
            for r, a in enumerate(angles)
        ]
    )
    out_c, st_c, _ = _wall_rows(imp, geom)
    out_n, st_n, _ = _wall_rows(imp, geom, force_numpy=True)
    profile = geom[:, 2] == 0
    np.testing.assert_array_equal(st_c[profile], st_n[profile])
    np.testing.assert_array_equal(out_c[:, profile], out_n[:, profile])
    np.testing.assert_allclose(st_c, st_n, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(out_c, out_n, rtol=1e-13, atol=1e-13)


def test_compiled_reservoirs_and_quantiles_equal_their_numpy_form():
    """``_ckernel.wall_rows``' reservoirs and ``_ckernel.wall_quantiles`` against
    the NumPy forms they replace (np.where/np.clip/np.minimum on the draw-order
    rows; _summary_rows, whose quantiles tests above hold to np.quantile): the
    same bits, for nodes with no rebound, one, fewer and more than the
    reservoir, quantiles at 0 and 1, NaN means, and +-inf values."""
    from microimpact.engine import _compiled, kernel
    from microimpact.wall_law.build import (
        _RESERVOIR_ROWS,
        _RESERVOIR_SLOTS,
        _summary_rows,
        _wall_rows,
    )
    from microimpact.wall_law.checks import MAX_LATERAL_DEG

    if kernel.KERNEL != "compiled":  # pragma: no cover - no C compiler
        pytest.skip("the compiled kernel is not built")
    rng = np.random.default_rng(11)
    p, n, R = 9, 200, 16
    imp = {
        "e_m": rng.uniform(-0.2, 1.5, (p, n)),
        "mu_m": rng.normal(0.0, 0.4, (p, n)),
        "lateral_angle_deg": rng.normal(0.0, 60.0, (p, n)),
        "outcome": rng.choice(np.array([0, 0, 0, 1, 2], np.int8), (p, n)),
    }
    imp["outcome"][4] = 1  # no rebound at all
    imp["outcome"][5, 1:] = 2  # one
    imp["outcome"][6, 10:] = 1  # fewer rebounds than the reservoir holds
    geom = np.array([[0.6, 0.8, float(r % 2)] for r in range(p)])
    geom[3] = (1.0, 0.0, 1.0)  # normal incidence: e_t is NaN, so is its mean
    res = np.empty((len(_RESERVOIR_ROWS), p, R))
    out, stats, filled = _wall_rows(imp, geom, reservoir=res)
    assert filled
    n_reb = stats[:, 2].astype(np.int64)
    k = np.minimum(R, n_reb)
    want = np.full_like(res, np.nan)
    keep = np.arange(R)[None, :] < k[:, None]
    want[:] = np.where(keep, out[list(_RESERVOIR_ROWS), :, :R], np.nan)
    for i, (_, kind) in enumerate(_RESERVOIR_SLOTS.tolist()):
        if kind == 1:
            np.clip(want[i], -MAX_LATERAL_DEG, MAX_LATERAL_DEG, out=want[i])
        elif kind == 2:
            np.minimum(want[i], 1.0, out=want[i])
    np.testing.assert_array_equal(res, want)
    assert np.isnan(res[:, 4]).all() and (~np.isnan(res[:, 0])).all()
    V = 5
    out[:V].sort(axis=2)
    out[1, 7, 0] = -np.inf  # an infinite value inside the rebounds
    q = np.array([0.0, 0.05, 0.5, 0.9, 0.95, 1.0])
    means, stds, quant = np.empty((V, p)), np.empty((V, p)), np.empty((V, p, q.size))
    _compiled.ckernel.wall_quantiles(p, n, V, out, stats, q, means, stds, quant)
    for got, exp in zip(
        (means, stds, quant), _summary_rows(out[:V], stats, n_reb, q), strict=True
    ):
        np.testing.assert_array_equal(got, exp)
    assert np.isnan(quant[:, 4]).all() and np.isnan(stds[:, 5]).all()
    assert np.isnan(means[1, 3])  # e_t at normal incidence
    with pytest.raises(ValueError):
        _compiled.ckernel.wall_quantiles(p, n, 6, out, stats, q, means, stds, quant)
    with pytest.raises(ValueError):
        _compiled.ckernel.wall_rows(
            p,
            n,
            imp["e_m"],
            imp["mu_m"],
            imp["lateral_angle_deg"],
            imp["outcome"],
            geom,
            out,
            stats,
            res,
            np.array([[9, 0]]),
            90.0,
        )


def test_fallback_at_in_the_file_sets_the_openfoam_condition(tmp_path, capsys):
    """[wall_law] fallback_at states the condition of the OpenFOAM fallback (issue
    33, item 5); a flag wins over it key by key; a bad value names the key."""
    from microimpact.wall_law.openfoam import LOCAL_INTERACTION_FILE

    law = "[wall_law]\ndiameter_um = [5, 20]\nreservoir = 8\nangle_deg = [30, 60, 90]"
    path = _toml(tmp_path, law + "\nfallback_at = { angle_deg = 55, diameter_um = 5 }")
    out = tmp_path / "out"
    args = ["wall-law", str(path), "--out", str(out), "--quiet", "--no-c"]
    assert main(args) == 0
    text = (out / "openfoam" / LOCAL_INTERACTION_FILE).read_text()
    assert "angle_deg given 55" in text and "diameter_um given 5" in text
    assert main([*args, "--angle-deg", "35"]) == 0
    text = (out / "openfoam" / LOCAL_INTERACTION_FILE).read_text()
    assert "angle_deg given 35" in text and "diameter_um given 5" in text
    capsys.readouterr()
    bad = _toml(tmp_path, law + "\nfallback_at = { angle_deg = 89 }")
    assert main(["wall-law", str(bad), "--out", str(tmp_path / "b"), "--no-c"]) == 2
    assert "wall_law.fallback_at.angle_deg" in capsys.readouterr().err
    typo = _toml(tmp_path, law + "\nfallback_at = { angle = 30 }")
    assert main(["wall-law", str(typo), "--out", str(tmp_path / "c"), "--no-c"]) == 2
    assert "fallback_at" in capsys.readouterr().err
