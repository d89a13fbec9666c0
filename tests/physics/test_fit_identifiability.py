"""Tests that the coefficient fits refuse, or flag, what the data cannot identify,
and that the fitted laws are written as standard JSON and a scenario snippet."""

from __future__ import annotations

import json
import tomllib
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact import scenario_from_dict
from microimpact.errors import InputError
from microimpact.physics.fitting import (
    IdentifiabilityError,
    IdentifiabilityWarning,
    coefficient_laws_fit,
    fit_coefficient_laws,
    fit_impact_coefficients,
    fit_restitution,
)

UM = 1e-6


def _eq6(v, k1, k2, v_c):  # [Li 2000], Eq. 6 with p = q = 1, written out
    e = k1 / (k1 + v) * (1 - k2 / (k2 + np.abs(v - v_c)))
    return np.where(v > v_c, e, 0.0)


def _data(rng, diameters_um, n=30, noise=0.01):
    d_all, v_all, e_all = [], [], []
    for d_um in diameters_um:
        r = d_um / 50
        k1, k2, v_c = 4 * r**-0.5, 0.05 / r, 0.2 * r**-1.5
        v = np.linspace(1.3 * v_c, 3.0, n)
        d_all.append(np.full(n, d_um * UM))
        v_all.append(v)
        e_all.append(_eq6(v, k1, k2, v_c) + rng.normal(0, noise, n))
    return np.concatenate(d_all), np.concatenate(v_all), np.concatenate(e_all)


def test_every_point_at_one_speed_is_refused():
    # the example: one speed gave k1 = 11.2 m/s with SE NaN and exit 0
    d, v = np.full(10, 50 * UM), np.full(10, 1.0)
    e = np.linspace(0.5, 0.6, 10)
    with pytest.raises(IdentifiabilityError, match="1 distinct speed") as info:
        fit_impact_coefficients(d, v, e)
    assert isinstance(info.value, InputError)  # the CLI reports it, exit 2
    with pytest.raises(IdentifiabilityError, match="at least 3 distinct"):
        fit_restitution(np.r_[np.full(5, 0.5), np.full(5, 1.0)], e)


def test_a_group_at_one_speed_among_good_ones_is_skipped_with_a_warning(rng):
    d, v, e = _data(rng, [30, 50, 80])
    d = np.r_[d, np.full(8, 65 * UM)]
    v = np.r_[v, np.full(8, 1.0)]
    e = np.r_[e, np.full(8, 0.7)]
    with pytest.warns(IdentifiabilityWarning, match="skipping diameter group 65 um"):
        table = fit_impact_coefficients(d, v, e)
    assert_allclose(table["diameter_um"], [30, 50, 80], rtol=1e-12)


def test_unconstrained_parameters_are_nan_and_flagged():
    # no capture and no transition: e = R(v) only, so k2 and v_c are not identified
    v = np.linspace(0.5, 3.0, 12)
    e = 4.0 / (4.0 + v) + np.random.default_rng(1).normal(0, 0.005, v.size)
    with pytest.warns(IdentifiabilityWarning, match="reported as NaN") as info:
        fit = fit_restitution(v, e)
    message = str(info[0].message)
    assert "k2 (" in message and "v_c (" in message and "k1 (" not in message
    assert fit.identified == {"k1": True, "k2": False, "v_c": False}
    assert np.isnan([fit.k2, fit.k2_se, fit.v_c, fit.v_c_se]).all()
    assert np.isfinite([fit.k1, fit.k1_se]).all()
    assert_allclose(fit.k1, 4.0, rtol=0.05)


def test_identified_data_raise_no_warning(rng):
    d, v, e = _data(rng, [30, 40, 50, 65, 80])
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        table = fit_impact_coefficients(d, v, e)
    for name in ("k1", "k2", "v_c"):
        assert table[f"{name}_identified"].all()
        assert np.isfinite(table[f"{name}_se"]).all()


def test_laws_use_only_identified_groups_and_refuse_too_few(rng):
    d, v, e = _data(rng, [30, 50, 80])
    table = fit_impact_coefficients(d, v, e)
    table.loc[1, ["k2_m_s", "k2_se"]] = np.nan
    table.loc[1, "k2_identified"] = False
    result = coefficient_laws_fit(table)
    assert result.used == {"k1": 3, "k2": 2, "v_c": 3}
    table.loc[0, "k2_identified"] = False
    with pytest.raises(IdentifiabilityError, match="k2 is identified at 1 distinct"):
        fit_coefficient_laws(table)
    # a constant law needs one diameter only
    laws = fit_coefficient_laws(table, form={"k2": "constant"})
    assert_allclose(laws.k2(80 * UM), table.loc[2, "k2_m_s"], rtol=1e-12)


def test_exactly_determined_law_warns_that_it_has_no_errors(rng):
    d, v, e = _data(rng, [30, 80])
    table = fit_impact_coefficients(d, v, e).drop(columns=["k1_se"])
    with pytest.warns(IdentifiabilityWarning, match="k1 is fitted on 2"):
        result = coefficient_laws_fit(table)
    out = json.loads(result.to_json())
    assert out["coefficients"]["k1"]["standard_errors"] == {"a": None, "b": None}


def test_coefficient_laws_json_is_standard_and_the_snippet_loads_back(rng):
    d, v, e = _data(rng, [30, 40, 50, 65, 80])
    result = coefficient_laws_fit(fit_impact_coefficients(d, v, e), friction=0.15)
    text = result.to_json()
    assert "NaN" not in text and "Infinity" not in text
    out = json.loads(text)
    assert out["schema"] == "microimpact.coefficient_laws/1"
    assert set(out["coefficients"]) == {"k1", "k2", "v_c"}
    k1 = out["coefficients"]["k1"]
    assert set(k1) == {
        "law", "form", "parameters", "standard_errors", "residual_std",
        "n_diameters", "weighted",
    }  # fmt: skip
    assert k1["law"]["law"] == "power" and k1["n_diameters"] == 5
    assert len(out["by_diameter"]) == 5
    assert out["by_diameter"][0]["k1_identified"] is True
    scenario = (
        '[particles]\ndistribution = "monodisperse"\ndiameter_um = 50\n'
        + out["scenario_toml"]
        + "[sweep]\nspeed_m_s = [0.5]\n"
    )
    back = scenario_from_dict(tomllib.loads(scenario)).coefficients
    dd = np.linspace(20e-6, 90e-6, 8)
    for name in ("k1", "k2", "v_c"):
        assert_allclose(
            getattr(back, name)(dd), getattr(result.laws, name)(dd), rtol=1e-10
        )
    assert back.friction == 0.15
    # friction inf is written as TOML inf, and JSON null
    inf = coefficient_laws_fit(fit_impact_coefficients(d, v, e))
    assert json.loads(inf.to_json())["friction"] is None
    assert "friction = inf" in inf.toml()
