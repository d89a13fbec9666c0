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
from calibration_data import calibration_scenario
from scipy import stats

import microimpact
from microimpact.analysis.bayes_data import (
    Likelihood,
    gaussian_loglik,
    read_calibration_data,
    same_impact_pairs,
)
from microimpact.analysis.compare import experiments_from_summary
from microimpact.analysis.model import ScenarioModel
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

STD = "surfaces.rough.std_deg"


def _scenario(angles=(30.0, 60.0)):
    return calibration_scenario(angles, std=12.0, samples=300, name="pairs")


def test_the_pair_likelihood_is_the_bivariate_normal_density():
    rng = np.random.default_rng(4)
    resid = rng.normal(size=5)
    var = rng.uniform(0.5, 2.0, size=5)
    pairs = np.array([[0, 3], [1, 4]])
    rho = np.array([0.9, -0.4])
    cov = rho * np.sqrt(var[pairs[:, 0]] * var[pairs[:, 1]])
    want = 0.0
    for (i, j), c in zip(pairs, cov, strict=True):
        m = [[var[i], c], [c, var[j]]]
        want += stats.multivariate_normal([0, 0], m).logpdf([resid[i], resid[j]])
    want += stats.norm(0, np.sqrt(var[2])).logpdf(resid[2])
    assert gaussian_loglik(resid, var, pairs, cov) == pytest.approx(want, rel=1e-12)
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
    assert same_impact_pairs(rows).tolist() == [[0, 1]]


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
    s_exp = table["se"].to_numpy()
    var = s_exp**2 + s_sim**2
    r = m - table["mean"].to_numpy()
    want = 0.0
    for (i, j), rho in zip(like.pairs, like.rho, strict=True):
        # measurement and Monte Carlo errors, each correlated by rho
        c = rho * (s_exp[i] * s_exp[j] + s_sim[i] * s_sim[j])
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


def test_least_squares_weighs_a_pair_by_its_full_covariance():
    """The least-squares residuals, whitened per pair: their sum of squares is the
    generalised chi-squared r' C^-1 r with C the pairs' covariance (measurement and
    Monte Carlo errors, each correlated by rho), computed here with numpy."""
    from microimpact.analysis.calibration import _Model, _Objective

    y = np.array([0.5, 0.2, 0.7, 0.1])
    s_exp = np.array([0.02, 0.03, 0.01, 0.05])
    s_sim = np.array([0.005, 0.004, 0.003, 0.0])
    m = np.array([0.52, 0.18, 0.69, 0.16])

    class Stub(_Model):
        def __init__(self):
            self.pairs = np.array([[0, 1]])
            self.rho = np.array([0.9])

        def points(self, summary):
            return m, s_sim

    obj = _Objective(Stub(), y, s_exp, s_sim, [0], [0.0], np.array([1.0]), None)
    r = obj.residual_of(None)
    var = s_exp**2 + s_sim**2
    cov = np.diag(var)
    cov[0, 1] = cov[1, 0] = 0.9 * (s_exp[0] * s_exp[1] + s_sim[0] * s_sim[1])
    d = m - y
    assert r @ r == pytest.approx(d @ np.linalg.solve(cov, d), rel=1e-12)


def test_least_squares_records_its_pairs(tmp_path):
    from microimpact.analysis.calibration import calibrate

    data = _scenario(angles=(45.0,))
    truth = scenario_from_dict(with_values(data, {STD: 12.0}))
    s = microimpact.run(truth, samples=300, seed=3, progress=False).summary
    exp = experiments_from_summary(s, ("e", "mu"), by_surface=False)
    res = calibrate(
        data, exp, {STD: (4.0, 20.0)}, samples=300, seed=2, bootstrap=0, band_draws=0
    )
    (pair,) = res.info["same_impact_pairs"]
    assert 0.5 < pair["rho"] < 1.0


def test_each_evaluation_takes_rho_at_its_own_parameters():
    """rho moves with the spread (near 1 the pair's information goes with
    1 - rho^2), so the posterior at theta uses the correlation of the model's
    impacts at theta, not at the start."""
    from microimpact.analysis.bayes import LogPosterior
    from microimpact.analysis.bayes_data import pair_correlations
    from microimpact.analysis.priors import uniform_prior

    data = _scenario()
    s = microimpact.run(
        scenario_from_dict(with_values(data, {STD: 12.0})),
        samples=300,
        seed=3,
        progress=False,
    ).summary
    exp = experiments_from_summary(s, ("e", "mu"), by_surface=False)
    model = ScenarioModel(data, [STD], samples=2000, seed=2)
    like = Likelihood(read_calibration_data(exp), 2000)
    post = LogPosterior(model, like, [uniform_prior(STD, 2, 30)])
    lp, _ = post(np.array([12.0]))
    at = {
        t: pair_correlations(model, [t], like.pairs, like.match_means) for t in (8, 12)
    }
    assert np.all(np.abs(at[8] - at[12]) > 0.005)
    want, _ = like.evaluate(model.run([12.0]), at[12])
    assert lp - post.log_prior([12.0]) == pytest.approx(want, rel=1e-12)


def test_correlated_draws_have_the_pairs_correlation_and_whitening_undoes_it():
    """correlate (the bootstrap's and the posterior predictive's draws): over 20,000
    draws each pair's sample correlation is r within 4 standard errors, the other
    points stay independent; whiten is its exact inverse."""
    from microimpact.analysis.pairs import correlate, whiten

    rng = np.random.default_rng(9)
    pairs = np.array([[0, 2]])
    r = np.array([0.8])
    z = rng.standard_normal((20_000, 3))
    zc = correlate(z.copy(), pairs, r)
    seen = np.corrcoef(zc.T)
    se = (1 - 0.8**2) / np.sqrt(20_000)
    assert abs(seen[0, 2] - 0.8) < 4 * se
    assert abs(seen[0, 1]) < 4 / np.sqrt(20_000)
    np.testing.assert_allclose(whiten(zc, pairs, r), z, rtol=0, atol=1e-12)
