"""The mean e and the mean mu measured on one set of impacts are correlated, and
the Bayesian likelihood says so (analysis/bayes_data.py, module notes).

Oracles: the bivariate normal density of scipy for the likelihood; for the claim
itself, the correlation of the two means across 150 independent repetitions of
the measurement (each a fresh engine run of 300 impacts), against the per-impact
correlation the likelihood uses.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

import microimpact
from microimpact.analysis.bayes_data import (
    Likelihood,
    _same_impact_pairs,
    gaussian_loglik,
    read_calibration_data,
)
from microimpact.analysis.compare import experiments_from_summary
from microimpact.analysis.model import ScenarioModel
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

STD = "surfaces.rough.std_deg"


def _scenario(angles=(30.0, 60.0)):
    return {
        "name": "pairs",
        "seed": 1,
        "samples": 300,
        "particles": {"distribution": "monodisperse", "diameter_um": 50.0},
        "coefficients": {
            "k1": 4.0,
            "k2": {"law": "power", "a_m_s": 0.05, "b": -1.58, "d_ref_um": 52.8},
            "v_c": {"law": "power", "a_m_s": 0.2, "b": -1.58, "d_ref_um": 52.8},
            "p": 1.0,
            "q": 1.0,
            "friction": 0.15,
        },
        "surfaces": [{"name": "rough", "kind": "normal", "std_deg": 12.0}],
        "sweep": {"speed_m_s": [1.0], "angle_deg": list(angles)},
    }


def test_the_pair_likelihood_is_the_bivariate_normal_density():
    rng = np.random.default_rng(4)
    resid = rng.normal(size=5)
    var = rng.uniform(0.5, 2.0, size=5)
    pairs = np.array([[0, 3], [1, 4]])
    rho = np.array([0.9, -0.4])
    want = 0.0
    for (i, j), r in zip(pairs, rho, strict=True):
        c = r * np.sqrt(var[i] * var[j])
        cov = [[var[i], c], [c, var[j]]]
        want += stats.multivariate_normal([0, 0], cov).logpdf([resid[i], resid[j]])
    want += stats.norm(0, np.sqrt(var[2])).logpdf(resid[2])
    assert gaussian_loglik(resid, var, pairs, rho) == pytest.approx(want, rel=1e-12)
    # no pairs: independent Gaussians
    alone = stats.norm(0, np.sqrt(var)).logpdf(resid).sum()
    assert gaussian_loglik(resid, var) == pytest.approx(alone, rel=1e-12)
    assert gaussian_loglik(resid, var, pairs, np.zeros(2)) == pytest.approx(
        alone, rel=1e-12
    )


def test_pairs_are_e_and_mu_of_one_table_at_one_point():
    rows = pd.DataFrame(
        {
            "statistic": ["e", "mu", "e", "mu", "e", "capture_fraction"],
            "speed_m_s": [1.0, 1.0, 1.0, 1.0, 2.0, 1.0],
            "angle_deg": [30.0, 30.0, 60.0, 60.0, 30.0, 30.0],
            "surface": [None] * 6,
            "impact_set": [0, 0, 0, 1, 0, 0],
        }
    )
    # (0, 1) one table, one point; e at 60 and mu at 60 come from two tables;
    # e at 2 m/s has no mu; a capture fraction is no pair
    assert _same_impact_pairs(rows).tolist() == [[0, 1]]


def test_the_means_of_one_set_of_impacts_are_correlated_as_the_impacts_are():
    """Across 150 repetitions of a measurement of 300 impacts (fresh seeds), the
    mean e and the mean mu at each point correlate as e_m and mu_m do per impact
    (the rho the likelihood takes from the model), within 4 standard errors."""
    data = _scenario()
    sc = scenario_from_dict(data)
    reps = 150
    means = np.empty((reps, 2, 2))  # repetition, point, (e, mu)
    for k in range(reps):
        s = microimpact.run(sc, samples=300, seed=1000 + k, progress=False).summary
        means[k, :, 0] = s["e_rebound_mean"].to_numpy()
        means[k, :, 1] = s["mu_mean"].to_numpy()
    exp = experiments_from_summary(s, ("e", "mu"), by_surface=False)
    like = Likelihood(read_calibration_data(exp), 300)
    model = ScenarioModel(data, [STD], samples=20_000, seed=7)
    like.setup(model.run([12.0]).summary)
    like.set_correlations(model, [12.0])
    assert len(like.pairs) == 2
    # the likelihood of the data is the product of the pairs' bivariate normals
    result = model.run([12.0])
    ll, _ = like.evaluate(result)
    m, s_sim = like.match_means(result.summary)
    table = like.data.means
    var = table["se"].to_numpy() ** 2 + s_sim**2
    r = m - table["mean"].to_numpy()
    want = 0.0
    for (i, j), rho in zip(like.pairs, like.rho, strict=True):
        c = rho * np.sqrt(var[i] * var[j])
        cov = [[var[i], c], [c, var[j]]]
        want += stats.multivariate_normal([0, 0], cov).logpdf([r[i], r[j]])
    assert ll == pytest.approx(want, rel=1e-10)
    for (i, _), rho in zip(like.pairs, like.rho, strict=True):
        point = int(like.match_means.rows[i][0])
        seen = np.corrcoef(means[:, point, 0], means[:, point, 1])[0, 1]
        se = (1.0 - rho**2) / np.sqrt(reps)
        assert rho > 0.5  # strongly correlated on this surface
        assert abs(seen - rho) < 4 * se, (point, seen, rho)


def test_a_calibration_records_its_pairs(tmp_path):
    """calibrate(method='bayes') on e and mu of one file: the info names the
    pairs by their lines and correlations (in (0, 1) here)."""
    from microimpact.analysis.calibration import calibrate

    data = _scenario(angles=(45.0,))
    truth = scenario_from_dict(with_values(data, {STD: 12.0}))
    s = microimpact.run(truth, samples=300, seed=3, progress=False).summary
    exp = experiments_from_summary(s, ("e", "mu"), by_surface=False)
    path = tmp_path / "exp.csv"
    microimpact.io.experiments.write_experiments(exp, path)
    res = calibrate(
        data,
        path,
        {STD: (4.0, 20.0)},
        method="bayes",
        samples=300,
        steps=6,
        seed=2,
        progress=False,
    )
    pairs = res.info["same_impact_pairs"]
    assert len(pairs) == 1
    assert 0.0 < pairs[0]["rho"] < 1.0
    assert len(pairs[0]["lines"]) == 2
