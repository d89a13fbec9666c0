"""Tests for the coefficient laws and their fits (physics.coefficients, .fitting).

Oracles: closed forms of each law, Eq. 6 of Li, Dunn & Brach (2000) written out
here, and synthetic data generated from known power laws, whose parameters the
fits must recover within their reported standard errors.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import ScenarioError
from microimpact.physics.adhesion import (
    contact_modulus,
    thornton_ning_sticking_velocity,
)
from microimpact.physics.coefficients import (
    COEFFICIENT_SETS,
    LAWS,
    CallableLaw,
    ConstantLaw,
    ImpactCoefficients,
    PolynomialLaw,
    PowerLaw,
    TableLaw,
    ThorntonNingLaw,
    law_from_dict,
)
from microimpact.physics.fitting import (
    _restitution,
    fit_coefficient_laws,
    fit_impact_coefficients,
    fit_law,
    fit_restitution,
)

UM = 1e-6


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


# ----------------------------------------------------------------------- laws
def test_power_law_closed_form_and_input_matrix():
    law = PowerLaw(0.2, -1.5, 50 * UM)
    d = np.array([25, 50, 100]) * UM
    assert_allclose(law(d), 0.2 * (d / (50 * UM)) ** -1.5, rtol=1e-14)
    assert np.ndim(law(50 * UM)) == 0
    assert law(np.ones((2, 3)) * UM).shape == (2, 3)
    assert_allclose(law([0.0, -1.0, np.nan, np.inf]), [np.nan] * 4, equal_nan=True)


def test_polynomial_law_and_negative_values():
    law = PolynomialLaw((1.0, -0.5), 10 * UM)
    assert_allclose(law([10 * UM, 20 * UM]), [0.5, 0.0], atol=1e-15)
    assert np.isnan(law(30 * UM))  # negative speed is impossible -> nan


def test_table_law_is_exact_for_power_law_tables():
    truth = PowerLaw(0.3, -1.2, 40 * UM)
    nodes = np.array([20, 40, 80]) * UM
    inside = np.geomspace(20, 80, 7) * UM
    outside = np.array([10, 160]) * UM
    clamp = TableLaw(tuple(nodes), tuple(truth(nodes)))
    loglin = TableLaw(tuple(nodes), tuple(truth(nodes)), "loglinear")
    assert_allclose(clamp(inside), truth(inside), rtol=1e-12)
    assert_allclose(loglin(outside), truth(outside), rtol=1e-12)
    assert_allclose(clamp(outside), truth(nodes[[0, -1]]), rtol=1e-12)


def test_constant_and_callable_laws():
    assert_allclose(ConstantLaw(0.2)([1 * UM, 0.0]), [0.2, np.nan], equal_nan=True)
    assert ConstantLaw(math.inf)(UM) == math.inf
    law = CallableLaw(lambda d: 1e-6 / d)
    assert_allclose(law([1 * UM, 2 * UM]), [1.0, 0.5], rtol=1e-14)
    with pytest.raises(ValueError, match="shape"):
        CallableLaw(lambda d: np.ones(3))([UM, 2 * UM])
    with pytest.raises(ValueError, match="finite"):
        CallableLaw(lambda d: -d)([UM])
    with pytest.raises(TypeError, match="`func`"):
        CallableLaw(3.0)


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: PowerLaw(-1.0, 1.0), "`a`"),
        (lambda: PowerLaw(1.0, np.nan), "`b`"),
        (lambda: PowerLaw(1.0, 1.0, 0.0), "`d_ref`"),
        (lambda: PolynomialLaw(()), "`coefficients`"),
        (lambda: TableLaw((2e-6, 1e-6), (1.0, 1.0)), "`diameters`"),
        (lambda: TableLaw((1e-6, 2e-6), (1.0, 0.0)), "`values`"),
        (lambda: TableLaw((1e-6, 2e-6), (1.0, 1.0), "linear"), "`extrapolation`"),
        (lambda: ConstantLaw(np.nan), "`value`"),
        (lambda: ImpactCoefficients(1, 1, 0, p=0.0), "`p`"),
        (lambda: ImpactCoefficients(1, 1, 0, friction=-1), "`friction`"),
    ],
)
def test_law_parameter_validation(build, match):
    with pytest.raises(ValueError, match=match):
        build()


@pytest.mark.parametrize(
    "law",
    [
        PowerLaw(0.05, -1.2, 50 * UM),
        PolynomialLaw((0.3, -0.1, 0.01), 50 * UM),
        TableLaw((20 * UM, 50 * UM, 80 * UM), (0.4, 0.2, 0.1), "loglinear"),
        ConstantLaw(0.2),
        ThorntonNingLaw(8000.0, 9.3e10, 0.4, particle="stainless_steel_304"),
    ],
)
def test_describe_round_trips_through_law_from_dict(law):
    rebuilt = law_from_dict(law.describe())
    d = np.array([20, 50, 90]) * UM
    assert_allclose(rebuilt(d), law(d), rtol=1e-12)


def test_law_from_dict_examples_and_units():
    law = law_from_dict({"law": "power", "a_m_s": 0.05, "b": -1.2, "d_ref_um": 50})
    assert_allclose(law(100 * UM), 0.05 * 2**-1.2, rtol=1e-14)
    table = law_from_dict(
        {"law": "table", "diameter_um": [20, 80], "value_m_s": [0.4, 0.1]}
    )
    assert_allclose(table(40 * UM), 0.2, rtol=1e-12)  # log-log midpoint


def test_law_from_dict_thornton_ning():
    law = law_from_dict(
        {
            "law": "thornton_ning",
            "particle": "stainless_steel",
            "surface": "silicon",
            "work_of_adhesion_J_m2": 0.4,
        }
    )
    e_star = contact_modulus(193e9, 0.29, 160e9, 0.22)
    expected = thornton_ning_sticking_velocity(50 * UM, 8000.0, e_star, 0.4)
    assert_allclose(law(50 * UM), expected, rtol=1e-12)
    # polystyrene has a sourced surface energy: w = 2 gamma for like solids
    ps = law_from_dict(
        {"law": "thornton_ning", "particle": "polystyrene", "surface": "ps"}
    )
    assert_allclose(ps.work_of_adhesion, 2 * 0.0407, rtol=1e-12)
    with pytest.raises(ScenarioError, match="work_of_adhesion_J_m2"):
        law_from_dict(
            {
                "law": "thornton_ning",
                "particle": "stainless_steel",
                "surface": "silicon",
            }
        )


@pytest.mark.parametrize(
    ("spec", "field", "match"),
    [
        ({"law": "powr", "a_m_s": 1, "b": 0}, "k1.law", "did you mean 'power'"),
        ({"a_m_s": 1}, "k1.law", "missing key 'law'"),
        ({"law": "power", "a_ms": 1, "b": 0}, "k1.a_ms", "did you mean 'a_m_s'"),
        ({"law": "power", "b": 0}, "k1.a_m_s", "missing required key"),
        ({"law": "power", "a_m_s": "x", "b": 0}, "k1.a_m_s", "'x'"),
        ({"law": "constant", "value_m_s": -1}, "k1.value_m_s", ">= 0"),
        ({"law": "constant", "value_m_s": True}, "k1.value_m_s", "numeric.*True"),
        ({"law": "constant", "value_m_s": "0.2"}, "k1.value_m_s", "numeric"),
        ({"law": "power", "a_m_s": 1, "b": math.nan}, "k1.b", r"\(finite\)"),
        (
            {"law": "table", "diameter_um": [1, [2]], "value_m_s": [1, 1]},
            "k1.diameter_um",
            "must be a scalar",
        ),
        (
            {"law": "table", "diameter_um": [2, 1], "value_m_s": [1, 1]},
            "k1.diameter_um",
            "increasing",
        ),
        (
            {"law": "thornton_ning", "particle": "steel2", "surface": "silicon"},
            "k1.particle",
            "known",
        ),
    ],
)
def test_law_from_dict_errors_name_key_path(spec, field, match):
    with pytest.raises(ScenarioError, match=match) as info:
        law_from_dict(spec, source="scenario.toml", field="k1")
    assert info.value.field == field
    assert str(info.value).startswith("scenario.toml: ")


def test_user_registered_law():
    LAWS["linear_um"] = lambda params: CallableLaw(lambda d: params["slope"] * d / UM)
    try:
        assert_allclose(
            law_from_dict({"law": "linear_um", "slope": 0.01})(20 * UM), 0.2
        )
    finally:
        del LAWS["linear_um"]


# ------------------------------------------------------------ ImpactCoefficients
def test_impact_coefficients_coerce_and_evaluate():
    c = ImpactCoefficients(5.0, PowerLaw(0.1, -1, 50 * UM), 0.2, friction=0.3)
    assert isinstance(c.k1, ConstantLaw)
    k1, k2, _ = c.evaluate([25 * UM, 0.0])
    assert_allclose(k1, [5.0, np.nan], equal_nan=True)
    assert_allclose(k2, [0.2, np.nan], equal_nan=True)
    assert c.describe()["k2"] == {
        "law": "power",
        "a_m_s": 0.1,
        "b": -1.0,
        "d_ref_um": 50.0,
    }


@pytest.mark.parametrize("name", sorted(COEFFICIENT_SETS))
def test_coefficient_sets_build_and_are_sourced(name):
    c = ImpactCoefficients.from_set(name)
    assert COEFFICIENT_SETS[name]["source"]
    assert np.all(np.isfinite(c.evaluate(np.array([20, 50, 100]) * UM)))


def test_li2000_illustrative_set_reproduces_quoted_capture_speeds():
    # Li, Dunn & Brach (2000), text: ~0.20 m/s (SST65, mean 52.8 um) and
    # ~0.13 m/s (SST125, taken as 70 um) at 50 % capture.
    c = ImpactCoefficients.from_set("li2000_sst_silicon_illustrative")
    assert_allclose(c.v_c([52.8 * UM, 70 * UM]), [0.20, 0.13], rtol=5e-3)


def test_from_dict_overrides_and_errors():
    c = ImpactCoefficients.from_dict({"set": "no_adhesion_illustrative", "k1": 3.0})
    assert c.k1.value == 3.0
    with pytest.raises(ScenarioError, match="did you mean") as info:
        ImpactCoefficients.from_dict({"set": "no_adhesion"}, source="s.toml")
    assert info.value.field == "coefficients.set"
    with pytest.raises(ScenarioError) as info:
        ImpactCoefficients.from_dict({"k1": 1, "k2": 1, "vc": 1})
    assert info.value.field == "coefficients.vc"
    with pytest.raises(ValueError, match="`name`"):
        ImpactCoefficients.from_set("nope")


# ------------------------------------------------------------------- fitting
def _eq6(v, k1, k2, v_c, p=1.0, q=1.0):
    """[Li 2000], Eqs. 4-6 written out here, with capture (e = 0) for |v| <= v_c."""
    s = np.abs(np.asarray(v, dtype=float))
    R = k1**p / (k1**p + s**p)  # Eq. 4
    rho = k2**q / (k2**q + np.abs(s - v_c) ** q)  # Eq. 5
    return np.where(s > v_c, R * (1.0 - rho), 0.0)  # Eq. 6


def test_model_matches_paper_eq6():
    v = np.linspace(0.0, 3.0, 31)
    k1, k2, v_c = 4.0, 0.05, 0.2
    eq6 = k1 / (k1 + v) * (1 - k2 / (k2 + np.abs(v - v_c)))  # [Li 2000], Eq. 6
    eq6[v <= v_c] = 0.0
    assert_allclose(_restitution(v, k1, k2, v_c, 1.0, 1.0), eq6, rtol=1e-14, atol=0)
    # general exponents p, q (Eqs. 4-5) and the sign of v ignored
    for p, q in ((2.5, 0.6), (0.7, 1.8)):
        assert_allclose(
            _restitution(-v, k1, k2, v_c, p, q),
            _eq6(v, k1, k2, v_c, p, q),
            rtol=1e-13,
            atol=1e-16,
        )


def test_fit_restitution_noiseless_recovers_exactly():
    v = np.linspace(0.05, 3.0, 40)
    e = _eq6(v, 4.0, 0.05, 0.2)
    fit = fit_restitution(v, e)
    assert_allclose([fit.k1, fit.k2, fit.v_c], [4.0, 0.05, 0.2], rtol=1e-5)
    assert fit.n == 40 and fit.residual_std < 1e-6


def test_fit_restitution_standard_errors_are_calibrated(rng):
    truth = np.array([4.0, 0.05, 0.2])
    v = np.linspace(0.25, 3.0, 40)
    z = []
    for _ in range(40):
        e = _eq6(v, *truth) + rng.normal(0, 0.01, v.size)
        f = fit_restitution(v, e)
        z.append((np.array([f.k1, f.k2, f.v_c]) - truth) / [f.k1_se, f.k2_se, f.v_c_se])
    z = np.array(z)
    # z-scores ~ N(0, 1): coverage of +-2 SE should be ~95 %; allow sampling noise
    assert np.mean(np.abs(z) < 2) > 0.85
    assert_allclose(z.std(axis=0), 1.0, atol=0.35)


def _synthetic(rng, diameters_um, n=60, noise=0.01):
    k1 = PowerLaw(4.0, -0.5, 50 * UM)
    k2 = PowerLaw(0.05, -1.0, 50 * UM)
    v_c = PowerLaw(0.2, -1.5, 50 * UM)
    d_all, v_all, e_all = [], [], []
    for d_um in diameters_um:
        d = d_um * UM
        v = np.linspace(1.3 * v_c(d), 3.0, n)
        e = _eq6(v, k1(d), k2(d), v_c(d)) + rng.normal(0, noise, n)
        d_all.append(np.full(n, d))
        v_all.append(v)
        e_all.append(e)
    return (
        (k1, k2, v_c),
        np.concatenate(d_all),
        np.concatenate(v_all),
        np.concatenate(e_all),
    )


def test_fit_impact_coefficients_then_laws_recover_power_laws(rng):
    (k1, k2, v_c), d, v, e = _synthetic(rng, [30, 40, 50, 65, 80])
    table = fit_impact_coefficients(d, v, e)
    assert list(table.columns) == [
        "diameter_um",
        "n",
        "k1_m_s",
        "k1_se",
        "k2_m_s",
        "k2_se",
        "v_c_m_s",
        "v_c_se",
        "rmse",
        "k1_identified",
        "k2_identified",
        "v_c_identified",
    ]
    assert_allclose(table["diameter_um"], [30, 40, 50, 65, 80], rtol=1e-12)
    dd = table["diameter_um"].to_numpy() * UM
    for name, law in (("k1", k1), ("k2", k2), ("v_c", v_c)):
        z = (table[f"{name}_m_s"] - law(dd)) / table[f"{name}_se"]
        assert np.all(np.abs(z) < 4), (name, z)
    for name, law in (("k1", k1), ("k2", k2), ("v_c", v_c)):
        fit = fit_law(
            dd, table[f"{name}_m_s"], sigma=table[f"{name}_se"], d_ref=50 * UM
        )
        z = (fit.parameters - [law.a, law.b]) / fit.standard_errors
        assert np.all(np.abs(z) < 4), (name, fit.parameters, fit.standard_errors)
    coefs = fit_coefficient_laws(table)
    assert_allclose(coefs.v_c(50 * UM), 0.2, rtol=0.05)
    assert coefs.p == 1.0 and coefs.q == 1.0


def test_fit_impact_coefficients_bins_and_skips_small_groups(rng):
    _, d, v, e = _synthetic(rng, [40, 41, 60], n=30)
    with pytest.warns(RuntimeWarning, match="skipping"):
        table = fit_impact_coefficients(
            d, v, e, groups=np.array([35, 45, 55, 70, 90]) * UM, min_points=31
        )
    assert len(table) == 1 and table["n"].iloc[0] == 60
    assert_allclose(table["diameter_um"].iloc[0], 40.5, rtol=1e-12)


def test_fit_law_power_standard_errors_are_calibrated(rng):
    d = np.geomspace(20, 100, 8) * UM
    truth = PowerLaw(0.2, -1.5, 50 * UM)
    sigma = 0.05 * truth(d)
    z = []
    for _ in range(200):
        values = truth(d) * np.exp(rng.normal(0, 0.05, d.size))
        f = fit_law(d, values, sigma=sigma, d_ref=50 * UM)
        z.append((f.parameters - [0.2, -1.5]) / f.standard_errors)
    z = np.array(z)
    assert_allclose(z.mean(axis=0), 0.0, atol=0.25)
    assert_allclose(z.std(axis=0), 1.0, atol=0.15)


def test_fit_law_polynomial_and_constant():
    d = np.array([20, 40, 60, 80]) * UM
    values = 0.3 - 0.1 * (d / (50 * UM)) + 0.02 * (d / (50 * UM)) ** 2
    f = fit_law(d, values, form="polynomial", degree=2, d_ref=50 * UM)
    assert_allclose(f.parameters, [0.3, -0.1, 0.02], rtol=1e-9)
    f = fit_law(d, [1.0, 2.0, 3.0, 4.0], form="constant", sigma=[1.0, 1.0, 1.0, 2.0])
    assert_allclose(f.law.value, (1 + 2 + 3 + 4 / 4) / 3.25, rtol=1e-12)
    assert_allclose(f.standard_errors, [1 / math.sqrt(3.25)], rtol=1e-12)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: fit_restitution([1, 2, 3], [0.5, 0.5, 0.5]), "at least 4"),
        (lambda: fit_restitution([1, 2, 3, 4], [0.5, 0.5]), "same length"),
        (lambda: fit_law([1e-6, 2e-6], [0.0, 1.0]), "> 0 for form='power'"),
        (lambda: fit_law([1e-6, 2e-6], [1.0, 1.0], form="spline"), "`form`"),
    ],
)
def test_fit_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()


_D4, _V4 = np.array([20, 40, 60, 80]) * UM, np.array([0.4, 0.3, 0.25, 0.2])
_VN, _E = np.linspace(0.3, 3.0, 8), np.linspace(0.1, 0.8, 8)
_TABLE = pd.DataFrame(
    {"diameter_um": [20.0, 40.0, 60.0, 80.0], "k1_m_s": 4.0, "k2_m_s": 0.05,
     "v_c_m_s": [0.4, 0.3, 0.25, 0.2]}
)  # fmt: skip


@pytest.mark.parametrize(
    ("call", "exc", "match"),
    [
        (lambda: fit_law(_D4, _V4, form="polynomial", degree=1.5), ValueError,
         "`degree`"),
        (lambda: fit_law(_D4, _V4, form="polynomial", degree=-1), ValueError,
         "`degree`"),
        (lambda: fit_law(_D4, _V4, sigma=[0.1, 0.0, 0.1, 0.1]), ValueError,
         "`sigma`.*0.0"),
        (lambda: fit_law(_D4, _V4, sigma=np.inf), ValueError, "`sigma`"),
        (lambda: fit_impact_coefficients(_D4, _V4, _V4, min_points=2.5),
         ValueError, "`min_points`"),
        (lambda: fit_impact_coefficients(_D4, _V4, _V4, min_points="5"),
         ValueError, "`min_points`"),
        (lambda: fit_restitution(_VN, _E, p0=1.0), TypeError, "`p0`"),
        (lambda: fit_restitution(_VN, _E, p0=(1.0, 0.1)), ValueError,
         r"`p0` must hold 3"),
        (lambda: fit_restitution(_VN, _E, p0=(1.0, "x", 0.1)), TypeError,
         r"`p0\[1\]`"),
        (lambda: fit_restitution(_VN, _E, p0=(1.0, np.nan, 0.1)), ValueError,
         r"`p0\[1\]`"),
        (lambda: fit_coefficient_laws(_TABLE, form={"k1": "power", "vc": "power"}),
         ValueError, "`form` has unknown key 'vc'.*did you mean 'v_c'"),
        (lambda: fit_law(_D4[:1].repeat(3), _V4[:3]), ValueError,
         "form='power' needs at least 2 distinct diameters; got 1"),
        (lambda: fit_law(_D4, _V4, form="polynomial", degree=4), ValueError,
         "degree 4 needs at least 5 distinct diameters; got 4"),
        (lambda: fit_law([], [], form="constant"), ValueError,
         "needs at least 1 distinct diameters; got 0"),
        (lambda: fit_coefficient_laws(_TABLE.iloc[:0]), ValueError,
         "`table` has no rows.*min_points"),
    ],
)  # fmt: skip
def test_fit_argument_errors_name_the_argument(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_fit_coefficient_laws_accepts_a_partial_form_dict(rng):
    _, d, v, e = _synthetic(rng, [30, 50, 80], n=30)
    table = fit_impact_coefficients(d, v, e)
    coefs = fit_coefficient_laws(table, form={"k1": "constant"})
    assert isinstance(coefs.k1, ConstantLaw)
    assert isinstance(coefs.k2, PowerLaw) and isinstance(coefs.v_c, PowerLaw)
