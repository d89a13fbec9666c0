"""The reduced speed axis of the wall law (issue 23, item 5) against oracles.

On a ``speed_axis = "reduced"`` table the speed nodes are v = r v_c(d), with v_c
the scenario's critical (capture) speed law (paper Eq. 5), evaluated here
directly. On normal roughness under the 'reject' rule the capture probability
has the closed form P(v sin(theta - phi) <= v_c(d) | phi < theta) (the oracle of
test_wall_law.py), which at v = r v_c(d) depends on r and theta only: so the
nodes must match it, and a query between two diameter nodes at a node's r must
too (the sampler computes r = v / v_c(d) per query). Between r nodes the
sampler's capture is the trilinear mix in (log d, log r, theta), computed here.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import microimpact as mi
from microimpact.cli import main
from microimpact.errors import ScenarioError
from microimpact.wall_law import (
    WallLaw,
    WallLawSpec,
    build_wall_law,
    critical_speed_m_s,
    openfoam_coefficients,
)

sys.path.insert(0, str(Path(__file__).parent))
from test_wall_law import (
    ROUGH,
    ROUGH_DEG,
    _closed_form_capture,
    _scenario,
    _toml,
    _trilinear_capture,
    _v_c,
)

RATIOS = (0.7, 1.0, 1.4, 2.0, 4.0)
SPEC = WallLawSpec(
    diameters_um=(3.0, 10.0, 30.0),
    speeds_m_s=None,
    angles_deg=(40.0, 70.0, 90.0),
    reservoir=64,
    speed_axis="reduced",
    reduced_speeds=RATIOS,
)
SAMPLES = 2000


@pytest.fixture(scope="module")
def law():
    return build_wall_law(_scenario(ROUGH, samples=SAMPLES), SPEC)


def test_nodes_are_at_r_v_c_and_match_the_closed_form(law):
    ds = law.dataset.isel(surface=0)
    v_c = np.array([_v_c(d) for d in SPEC.diameters_um])
    np.testing.assert_allclose(ds.critical_speed_m_s.values, v_c, rtol=1e-15)
    np.testing.assert_allclose(
        ds.speed_m_s.values, v_c[:, None] * np.array(RATIOS)[None, :], rtol=1e-15
    )
    assert law.speed_axis == "reduced" and ds.attrs["speed_axis"] == "reduced"
    described = json.loads(ds.attrs["scenario_description"])
    assert described["reduced_speeds"] == list(RATIOS)
    assert described["speeds_m_s"] == "r v_c(d): the variable speed_m_s"
    z = []
    for i, d in enumerate(SPEC.diameters_um):
        for r in RATIOS:
            for a in SPEC.angles_deg:
                node = ds.sel(diameter_um=d, reduced_speed=r, angle_deg=a)
                p = _closed_form_capture(d, r * v_c[i], a, ROUGH_DEG)
                p_hat = float(node.capture_probability)
                if p in (0.0, 1.0):
                    assert p_hat == p
                    continue
                z.append((p_hat - p) / math.sqrt(p * (1 - p) / int(node.n_impacts)))
    z = np.array(z)
    assert len(z) >= 10
    assert np.max(np.abs(z)) < 4.5, z
    assert np.mean(z**2) < 2.5, z
    # common random numbers along the capture edge: capture depends on d only
    # through v / v_c(d), so every diameter has the same counts at an (r, angle)
    n_cap = ds.n_captured.values
    assert np.array_equal(n_cap[0], n_cap[1]) and np.array_equal(n_cap[1], n_cap[2])


def test_between_diameter_nodes_the_sampler_follows_the_edge(law):
    # at a node's r but between diameter nodes: the closed form, not a smear
    n = 200_000
    rng = np.random.default_rng(5)
    for d, r, a in ((5.0, 1.4, 70.0), (17.0, 1.0, 90.0), (17.0, 1.4, 90.0)):
        v = r * _v_c(d)
        p = _closed_form_capture(d, v, a, ROUGH_DEG)
        s = law.sample(np.full(n, d), v, a, rng=rng)
        assert not s.clamped.any()
        se = math.sqrt(p * (1 - p) / SAMPLES) * 4.5 + 5 * math.sqrt(p * (1 - p) / n)
        assert abs(s.captured.mean() - p) <= se + 1e-12, (d, r, a, p)


def test_between_all_nodes_capture_is_the_reduced_trilinear_mix(law):
    n = 200_000
    rng = np.random.default_rng(6)
    seen = []
    for d, v, a in ((5.0, 1.2, 55.0), (17.0, 0.30, 80.0), (4.0, 1.85, 45.0)):
        p = _trilinear_capture(law, d, v, a)
        seen.append(p)
        s = law.sample(np.full(n, d), v, a, rng=rng)
        assert not s.clamped.any()
        se = math.sqrt(max(p * (1 - p), 0.0) / n)
        assert abs(s.captured.mean() - p) < 5 * se + 1e-12, (d, v, a, p)
    assert all(0.02 < p < 0.98 for p in seen), seen  # on the edge, not at 0 or 1


def test_queries_on_the_nodes_are_not_clamped_and_outside_are(law):
    ds = law.dataset
    d = np.repeat(ds.diameter_um.values, len(RATIOS))
    v = ds.speed_m_s.values.ravel()  # r v_c(d), rounded: an ulp off at the ends
    s = law.sample(d, v, 90.0, rng=1)
    assert not s.clamped.any()
    s = law.sample([10.0, 10.0], [0.69 * _v_c(10.0), 4.1 * _v_c(10.0)], 90.0, rng=1)
    assert s.clamped.all()


def test_netcdf_csv_and_binary_round_trip(tmp_path, law):
    law.write(tmp_path)
    back = WallLaw.open(tmp_path)
    assert back.speed_axis == "reduced"
    u = np.random.default_rng(2).random((5000, 5))
    d = np.exp(np.random.default_rng(3).uniform(0, 3.5, 5000))
    v = 1.3 * np.array([_v_c(x) for x in d])
    a, b = law.sample_uniform(d, v, 60.0, u), back.sample_uniform(d, v, 60.0, u)
    np.testing.assert_array_equal(a.captured, b.captured)
    np.testing.assert_array_equal(a.velocity, b.velocity)
    frame = np.genfromtxt(tmp_path / "wall_law.csv", delimiter=",", names=True)
    np.testing.assert_allclose(
        frame["speed_m_s"],
        frame["reduced_speed"] * np.array([_v_c(x) for x in frame["diameter_um"]]),
        rtol=1e-8,
    )
    binary = mi.wall_law.read_binary(tmp_path / "c" / "wall_law.swl")
    np.testing.assert_array_equal(
        binary.critical_speed_m_s.values, law.dataset.critical_speed_m_s.values
    )


def test_openfoam_fallback_picks_the_diameters_speed_node(law):
    d = SPEC.diameters_um[1]
    v = 2.1 * _v_c(d)  # nearest the r = 2 node of this diameter
    cond, _ = openfoam_coefficients(law, diameter_um=d, speed_m_s=v, angle_deg=70.0)
    assert cond["speed_m_s"] == pytest.approx(2.0 * _v_c(d), rel=1e-12)
    with pytest.raises(ValueError, match="speed_m_s"):
        openfoam_coefficients(law, diameter_um=d, speed_m_s=5.0 * _v_c(d))


def test_toml_reduced_axis(tmp_path):
    from microimpact.scenario.file import wall_law_from_toml

    path = _toml(
        tmp_path,
        "[wall_law]\ndiameter_um = [5, 20]\n"
        'reduced_speed = {start = 0.5, stop = 2, num = 3, spacing = "log"}',
    )
    spec = wall_law_from_toml(path)
    assert spec.speed_axis == "reduced" and spec.speeds_m_s is None
    np.testing.assert_allclose(spec.reduced_speeds, (0.5, 1.0, 2.0))
    assert spec.shape == (2, 3, 2)
    absolute = wall_law_from_toml(_toml(tmp_path, "[wall_law]\ndiameter_um = [5]"))
    assert absolute.speed_axis == "absolute" and absolute.reduced_speeds is None


@pytest.mark.parametrize(
    ("table", "field", "shown"),
    [
        ('speed_axis = "reduce"\nreduced_speed = [1]', "wall_law.speed_axis", "reduce"),
        ('speed_axis = "reduced"', "wall_law.reduced_speed", "missing"),
        ("reduced_speed = [0.5, 0]", "wall_law.reduced_speed", "0"),
        ('speed_axis = "absolute"\nreduced_speed = [1]', "wall_law.reduced_speed", ""),
        ("reduced_speed = [1]\nspeed_m_s = [1, 2]", "wall_law.speed_m_s", "[1.0, 2.0]"),
        ("speed_axis = 3", "wall_law.speed_axis", "3"),
    ],
)
def test_cli_refuses_bad_speed_axis_values(tmp_path, capsys, table, field, shown):
    path = _toml(tmp_path, f"[wall_law]\ndiameter_um = [5, 20]\n{table}")
    rc = main(["wall-law", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "study.toml" in err and field in err and shown in err
    assert "Traceback" not in err


def test_a_critical_speed_of_zero_is_refused():
    scenario = mi.Scenario(
        name="zero",
        particles=mi.lognormal_diameters(10.0, 1.5),
        coefficients=mi.ImpactCoefficients(k1=4.0, k2=0.05, v_c=0.0),
        surfaces=ROUGH,
        seed=1,
        samples=10,
    )
    with pytest.raises(ScenarioError, match="v_c") as err:
        build_wall_law(scenario, SPEC)
    assert err.value.field == "wall_law.speed_axis"
    with pytest.raises(ScenarioError):
        critical_speed_m_s(scenario, [1.0])


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    # distinct in log (the spec refuses e.g. 80 and 79.99999999999999: one node)
    ratios=st.lists(
        st.floats(min_value=0.05, max_value=20.0),
        min_size=1,
        max_size=4,
        unique_by=math.log,
    ),
    diameters=st.lists(
        st.floats(min_value=1.0, max_value=80.0),
        min_size=1,
        max_size=3,
        unique_by=math.log,
    ),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_reduced_tables_build_and_sample(ratios, diameters, seed):
    spec = WallLawSpec(
        diameters_um=diameters,
        speeds_m_s=None,
        angles_deg=(60.0, 90.0),
        reservoir=8,
        speed_axis="reduced",
        reduced_speeds=ratios,
    )
    law = build_wall_law(_scenario(ROUGH, samples=60, seed=seed), spec)
    ds = law.dataset
    p = ds.capture_probability.values
    assert np.all((p >= 0) & (p <= 1))
    # below r = 1 at normal incidence every impact is captured (v_n <= v_c)
    r = ds.reduced_speed.values
    assert np.all(p[0, :, r <= 1.0, -1] == 1.0)
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.5, 100.0, 200)
    v = rng.uniform(0.01, 30.0, 200)
    s = law.sample(d, v, rng.uniform(1.0, 90.0, 200), rng=rng)
    assert s.valid.all()
    speed_out = np.linalg.norm(s.velocity, axis=1)
    assert np.all(speed_out <= v * (1 + 1e-12))


# ------------------------------------------- the documented spacing (benchmark)
BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "wall_law.py"


def _bench():
    import importlib.util

    spec = importlib.util.spec_from_file_location("microimpact_bench_wall_law", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_expected_capture_of_the_benchmark_is_the_samplers(law):
    # the benchmark's written-out expectation of the sampler's capture equals the
    # sampler's capture fraction (so the benchmark measures the sampler)
    bench = _bench()
    rng = np.random.default_rng(8)
    n = 200_000
    for d, v, k in ((5.0, 1.2, 0), (17.0, 0.30, 1), (25.0, 0.25, 2)):
        p = float(bench.expected_capture(law, [d], [v], k)[0])
        s = law.sample(np.full(n, d), v, SPEC.angles_deg[k], rng=rng)
        se = math.sqrt(max(p * (1 - p), 0.0) / n)
        assert abs(s.captured.mean() - p) < 5 * se + 1e-12, (d, v, k, p)


@pytest.mark.slow
def test_the_documented_reduced_spacing_keeps_capture_within_0_05():
    # docs/wall-law.md: reduced_speed nodes at the documented ratio keep the
    # capture probability within 0.05 of a direct computation between the nodes
    # (both presets, normal and oblique incidence), measured as the benchmark does
    bench = _bench()
    rows = bench.capture_interpolation(schemes=(bench.DOCUMENTED_SCHEME,), quiet=True)
    assert len(rows) == 2 * 4  # two presets, four angles (20 to 90 deg)
    worst = max(r["capture_max_err"] for r in rows)
    assert worst <= 0.05, rows


def test_cli_condition_flags_on_a_reduced_axis(tmp_path, capsys):
    # --speed-m-s is checked against the chosen diameter's speeds r v_c(d) before
    # the build (v_c = 0.4 m/s here: nodes 0.2 ... 0.8 m/s)
    path = _toml(tmp_path, "[wall_law]\ndiameter_um = [10]\nreduced_speed = [0.5, 2]")
    out = tmp_path / "out"
    argv = ["wall-law", str(path), "--out", str(out), "--quiet", "--speed-m-s"]
    rc = main([*argv, "3"])
    err = capsys.readouterr().err
    assert rc == 2 and "--speed-m-s" in err and "[0.2, 0.8]" in err, err
    assert "the speeds r v_c(d) of the 10 um diameter node" in err, err
    assert not (out / "wall_law.nc").exists()
    assert main([*argv, "0.7"]) == 0
    text = (out / "openfoam" / "localInteractionCoeffs").read_text()
    assert "speed 0.8 m/s" in text


def test_a_reduced_netcdf_file_is_cf_compliant(tmp_path, law):
    pytest.importorskip("compliance_checker")
    sys.path.insert(0, str(Path(__file__).parents[1] / "pipeline"))
    from test_cf_compliance import _cf_messages

    law.write(tmp_path, c=False, openfoam=False)
    errors, warnings = _cf_messages(tmp_path / "wall_law.nc", tmp_path)
    assert errors == [] and warnings == []


def test_open_refuses_a_reduced_table_without_critical_speeds(tmp_path, law):
    from microimpact.errors import DataFormatError

    bad = law.dataset.drop_vars("critical_speed_m_s")
    with pytest.raises(DataFormatError, match="critical_speed_m_s"):
        WallLaw(bad)
    zero = law.dataset.copy(deep=True)
    zero["critical_speed_m_s"][0] = 0.0
    with pytest.raises(DataFormatError, match="critical_speed_m_s"):
        WallLaw(zero)
