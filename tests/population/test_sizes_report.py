"""Tests for microimpact.population.sizes_report.describe_sizes."""

from __future__ import annotations

import json
import tomllib
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from microimpact import scenario_from_dict
from microimpact.population.sizes_report import describe_sizes

TAIL = "[coefficients]\nk1 = 4.0\nk2 = 0.05\nv_c = 0.2\n[sweep]\nspeed_m_s = [0.5]\n"


def _describe(d):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # truncation of the normal fit
        return describe_sizes(d)


def test_lognormal_sample_says_lognormal_fits_better():
    d = np.random.default_rng(2).lognormal(np.log(50), 0.5, 500)
    r = _describe(d)
    # independent oracle: AIC from scipy's log-likelihoods of the two MLEs
    ll_n = stats.norm.logpdf(d, d.mean(), d.std()).sum()
    ll_ln = stats.norm.logpdf(np.log(d), np.log(d).mean(), np.log(d).std()).sum()
    ll_ln -= np.log(d).sum()  # Jacobian of d -> ln d
    assert_allclose(r.delta_aic, (4 - 2 * ll_n) - (4 - 2 * ll_ln), rtol=1e-9)
    assert r.delta_aic > 10 and r.better_fit == "lognormal"
    assert r.chi2_normal.reject and not r.chi2_lognormal.reject
    assert r.recommended == "lognormal"
    assert "log-normal fits better than the normal" in r.verdict
    sc = scenario_from_dict(tomllib.loads(r.particles_toml() + TAIL))
    assert sc.particles.kind == "lognormal"
    assert sc.particles.params["median_um"] == r.lognormal.params["median_um"]


def test_normal_sample_keeps_the_papers_gaussian():
    r = _describe(np.random.default_rng(3).normal(52.8, 8.0, 500))
    assert r.better_fit == "normal" and r.recommended == "normal"
    assert not r.chi2_normal.reject
    # the population recommended is the normal fit itself, not the measured one
    assert r.recommended_distribution.kind == "normal"
    assert r.recommended_distribution.params["mean_um"] == r.normal.params["mean_um"]


def test_the_json_particles_table_refers_to_the_measured_file_and_column():
    rng = np.random.default_rng(4)
    r = _describe(np.r_[rng.normal(20, 1.5, 300), rng.normal(80, 3, 300)])
    assert r.recommended == "empirical"
    toml = r.to_dict(file="m.csv", column="d_um", unit="um")["particles_toml"]
    table = tomllib.loads(toml)["particles"]
    assert table == {
        "distribution": "empirical", "file": "m.csv", "column": "d_um", "unit": "um",
    }  # fmt: skip


def test_both_rejected_gives_the_empirical_population(tmp_path):
    rng = np.random.default_rng(4)
    d = np.r_[rng.normal(20, 1.5, 300), rng.normal(80, 3, 300)]  # bimodal
    r = _describe(d)
    assert r.chi2_normal.reject and r.chi2_lognormal.reject
    assert r.recommended == "empirical" and "rejects both" in r.verdict
    sc = scenario_from_dict(tomllib.loads(r.particles_toml() + TAIL))
    assert_allclose(np.sort(sc.particles.atoms), np.sort(d) * 1e-6, rtol=1e-12)


def test_sizes_json_is_standard_with_the_documented_keys():
    r = _describe(np.random.default_rng(5).lognormal(np.log(40), 0.3, 300))
    text = r.to_json()
    assert "NaN" not in text and "Infinity" not in text
    out = json.loads(text)
    assert set(out) == {
        "schema", "source", "n", "alpha", "normal", "lognormal", "better_fit",
        "delta_aic", "recommended", "verdict", "particles_toml",
    }  # fmt: skip
    assert out["schema"] == "microimpact.sizes/1"
    assert set(out["normal"]) == {"params", "stderr", "log_likelihood", "aic", "chi2"}
    assert set(out["lognormal"]["params"]) == {"median_um", "geometric_std"}
    assert set(out["normal"]["chi2"]) == {
        "statistic", "dof", "pvalue", "reject", "n_classes", "n_classes_initial",
    }  # fmt: skip


def test_too_few_diameters_is_a_value_error():
    with pytest.raises(ValueError, match="too few diameters"):
        _describe([10.0, 12.0, 13.0, 15.0, 11.0])


def test_sizes_json_is_indented_by_two_spaces():
    r = _describe(np.random.default_rng(5).lognormal(np.log(40), 0.3, 300))
    text = r.to_json()
    assert text.startswith('{\n  "schema": "microimpact.sizes/1",\n')
    assert r.to_json(indent=None).startswith('{"schema": "microimpact.sizes/1", ')
