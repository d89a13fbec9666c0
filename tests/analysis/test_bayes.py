"""Bayesian calibration (issue 36): the sampler and its diagnostics against
closed-form posteriors, priors against their densities, the likelihoods against
independent formulas, the engine-based posterior (prior-dominated friction, files,
CLI) and the coverage of the credible intervals (slow)."""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from calibration_data import calibration_scenario
from scipy import special, stats

import microimpact
from microimpact.analysis.bayes import diagnose, run_sampler
from microimpact.analysis.calibration import calibrate
from microimpact.analysis.compare import experiments_from_summary
from microimpact.analysis.priors import make_prior
from microimpact.errors import InputError
from microimpact.scenario.parameters import with_values
from microimpact.scenario.scenario import scenario_from_dict

pytestmark = pytest.mark.filterwarnings("ignore::FutureWarning")

STD = "surfaces.rough.std_deg"
FRICTION = "coefficients.friction"
VC = "coefficients.v_c.a_m_s"


def tiny(angles=(45.0,), speeds=(1.0,), *, std=10.0, samples=600):
    """A fast scenario: one-size particles on a normal-rough surface."""
    return calibration_scenario(angles, speeds, std=std, samples=samples)


def simulated(data, values, *, seed, samples, stats=("e",)):
    """Means with 95 % intervals simulated by the engine at `values`."""
    sc = scenario_from_dict(with_values(data, values))
    summary = microimpact.run(sc, samples=samples, seed=seed, progress=False).summary
    return experiments_from_summary(summary, stats, by_surface=False)


# ---------------------------------------------------------------------- priors
@pytest.mark.parametrize(
    ("spec", "x", "oracle"),
    [
        ({"distribution": "uniform", "low": 2.0, "high": 6.0}, 3.0, -math.log(4.0)),
        (
            {"distribution": "normal", "mean": 1.0, "std": 2.0},
            2.0,
            -0.5 * 0.25 - math.log(2.0 * math.sqrt(2 * math.pi)),
        ),
        (
            {"distribution": "lognormal", "median": 2.0, "sigma": 0.5},
            3.0,
            -0.5 * (math.log(1.5) / 0.5) ** 2
            - math.log(3.0 * 0.5 * math.sqrt(2 * math.pi)),
        ),
        (
            # a normal truncated to [0, inf) at its mean: twice the density
            {
                "distribution": "truncnormal",
                "mean": 0.0,
                "std": 1.0,
                "low": 0.0,
                "high": 1e9,
            },
            0.5,
            math.log(2.0) - 0.125 - 0.5 * math.log(2 * math.pi),
        ),
    ],
)
def test_prior_densities_match_closed_forms(spec, x, oracle):
    assert make_prior("k", spec).logpdf(x) == pytest.approx(oracle, rel=1e-12)


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        ({"distribution": "gamma"}, "allowed: uniform, normal, lognormal"),
        ({"distribution": "normal", "mean": 1.0}, "needs `std`"),
        ({"distribution": "normal", "mean": 1.0, "std": -1.0}, "`std` must be > 0"),
        ({"distribution": "uniform", "low": 3.0, "high": 1.0}, "must be below"),
        ({"distribution": "uniform", "low": 0.0, "high": 1.0, "sd": 1}, "sd"),
        ({"distribution": "normal", "mean": "a", "std": 1.0}, "finite number"),
    ],
)
def test_bad_priors_are_one_line_errors(spec, words):
    with pytest.raises(InputError) as err:
        make_prior("coefficients.friction", spec, source="s.toml")
    msg = str(err.value)
    assert words in msg and "\n" not in msg
    assert "s.toml" in msg and "coefficients.friction" in msg


# ---------------------------------------------------------------------- sampler
def _gaussian_posterior(y, sigma):
    """Flat prior, Gaussian data of known sigma: posterior N(mean y, sigma²/n)."""

    def log_prob(theta):
        return float(-0.5 * np.sum((y - theta[0]) ** 2) / sigma**2)

    return log_prob


def test_credible_intervals_of_a_conjugate_posterior_cover_the_truth():
    """Small version of the coverage study with a closed-form posterior: 10
    data sets of 5 draws from N(truth, 1); each run of the sampler must converge
    with R-hat <= 1.01, its 90 % interval must match the exact one (mean ± 1.645
    / sqrt 5) within 10 % of its width, and cover the truth in at least 7 of 10
    (P(X <= 6 | n = 10, p = 0.9) = 0.013)."""
    rng = np.random.default_rng(7)
    truth, hits = 3.0, 0
    for rep in range(10):
        y = truth + rng.standard_normal(5)
        p0 = rng.uniform(-10, 10, size=(8, 1))
        sampler, diag, _ = run_sampler(_gaussian_posterior(y, 1.0), p0, seed=rep)
        assert diag.converged, diag.reasons
        assert diag.r_hat[0] <= 1.01
        flat = sampler.get_chain(flat=True, discard=diag.burn_in)[:, 0]
        lo, hi = np.quantile(flat, [0.05, 0.95])
        half = 1.6448536 / math.sqrt(5)
        assert lo == pytest.approx(y.mean() - half, abs=0.1 * 2 * half)
        assert hi == pytest.approx(y.mean() + half, abs=0.1 * 2 * half)
        hits += lo <= truth <= hi
    assert hits >= 7, hits


def test_a_short_chain_is_not_called_converged_and_the_steps_it_needs_suffice():
    """A strongly correlated 2-D Gaussian run for 100 steps is refused, with the
    steps it still needs; a run of that length converges."""
    cov = np.array([[1.0, 0.97], [0.97, 1.0]])
    prec = np.linalg.inv(cov)

    def log_prob(x):
        return float(-0.5 * x @ prec @ x)

    p0 = np.random.default_rng(3).uniform(-4, 4, size=(8, 2))
    _, diag, done = run_sampler(log_prob, p0, steps=100, seed=1)
    assert done == 100 and not diag.converged
    assert diag.more_steps > 0 and diag.reasons
    sampler, diag2, _ = run_sampler(log_prob, p0, steps=100 + diag.more_steps, seed=1)
    assert diag2.converged, (diag.more_steps, diag2.reasons)
    flat = sampler.get_chain(flat=True, discard=diag2.burn_in)
    # the correlation of the sample against the truth (its SE ~ (1-r²)/sqrt(ESS))
    assert np.corrcoef(flat.T)[0, 1] == pytest.approx(0.97, abs=0.02)


def test_diagnostics_flag_chains_stuck_apart():
    """Two groups of walkers on two separate modes: R-hat far above 1.01."""
    rng = np.random.default_rng(0)
    chain = rng.standard_normal((400, 8, 1)) * 0.1
    chain[:, :4] += 5.0
    d = diagnose(chain)
    assert d.r_hat[0] > 1.5 and not d.converged and d.more_steps > 0


# ---------------------------------------------------------------------- likelihoods
def test_binomial_likelihood_is_the_exact_binomial():
    """The log-likelihood of capture counts alone equals log C(n, k) + k log p +
    (n - k) log(1 - p), p the simulated capture fraction (gammaln route)."""
    from microimpact.analysis.bayes_data import Likelihood, read_calibration_data

    data = tiny(angles=(60.0, 90.0), speeds=(0.235,), samples=800)
    result = microimpact.run(
        scenario_from_dict(data), samples=800, seed=4, progress=False
    )
    counts = pd.DataFrame(
        {
            "speed_m_s": [0.235, 0.235],
            "angle_deg": [60.0, 90.0],
            "captured": [30, 55],
            "n": [100, 120],
        }
    )
    like = Likelihood(read_calibration_data(counts), 800)
    ll, blob = like.evaluate(result)
    p = result.summary["capture_fraction"].to_numpy(float)
    assert 0 < p.min() and p.max() < 1  # the clipping plays no part
    k, n = np.array([30, 55]), np.array([100, 120])
    oracle = np.sum(
        special.gammaln(n + 1)
        - special.gammaln(k + 1)
        - special.gammaln(n - k + 1)
        + k * np.log(p)
        + (n - k) * np.log1p(-p)
    )
    assert ll == pytest.approx(oracle, rel=1e-12)
    np.testing.assert_allclose(blob, p)


def test_gaussian_likelihood_adds_the_model_variance():
    """Means: sum of log N(m_exp; m_sim, s_exp² + s_sim²) (written out here)."""
    from microimpact.analysis.bayes_data import Likelihood, read_calibration_data

    data = tiny(angles=(30.0, 60.0), samples=800)
    result = microimpact.run(
        scenario_from_dict(data), samples=800, seed=4, progress=False
    )
    s = result.summary
    exp = pd.DataFrame(
        {
            "angle_deg": [30.0, 60.0],
            "statistic": ["e", "e"],
            "mean": [0.6, 0.7],
            "ci_low": [0.55, 0.68],
            "ci_high": [0.65, 0.72],
        }
    )
    ll, _ = Likelihood(read_calibration_data(exp), 800).evaluate(result)
    m = s["e_rebound_mean"].to_numpy(float)
    se_sim = s["e_rebound_se"].to_numpy(float)
    se_exp = np.array([0.05, 0.02]) / stats.norm.ppf(0.975)
    var = se_exp**2 + se_sim**2
    oracle = np.sum(-0.5 * (m - [0.6, 0.7]) ** 2 / var - 0.5 * np.log(2 * np.pi * var))
    assert ll == pytest.approx(oracle, rel=1e-9)


def test_bad_count_files_are_one_line_errors(tmp_path):
    from microimpact.analysis.bayes_data import read_calibration_data

    f = tmp_path / "counts.csv"
    f.write_text("angle_deg,captured,n\n45,12,10\n")
    with pytest.raises(InputError, match=r"counts.csv:2: .*captured must be <= n"):
        read_calibration_data(f)
    f.write_text("angle_deg,captured,n\n45,1.5,10\n")
    with pytest.raises(InputError, match=r"1.5 is not a whole number >= 0"):
        read_calibration_data(f)


# ---------------------------------------------------------------------- engine
def test_friction_at_normal_incidence_is_prior_dominated():
    """Rebounds at normal incidence on a smooth surface do not depend on friction:
    its posterior is its prior (uniform 0.05-0.5), and the summary says so."""
    data = tiny(angles=(90.0,), samples=300)
    data["surfaces"] = [{"name": "rough", "kind": "smooth"}]
    data["particles"] = {"distribution": "normal", "mean_um": 50.0, "std_um": 5.0}
    exp = simulated(data, {}, seed=9, samples=3000)
    with pytest.warns(RuntimeWarning, match=r"use --samples (\d+)") as rec:
        res = calibrate(
            data,
            exp,
            {FRICTION: (0.05, 0.5)},
            method="bayes",
            steps=24,
            check_every=24,
            progress=False,
        )
    # the model (300 impacts) is 10 times noisier than the data (3,000): its
    # variance ratio is about 10, so 10 / 0.1 = 100 times the impacts are needed
    need = int(re.search(r"use --samples (\d+)", str(rec[0].message)).group(1))
    assert 0.8 * 30_000 < need < 1.25 * 30_000
    assert res.prior_dominated.tolist() == [True]
    assert any("posterior is its prior" in line for line in res.summary_lines())
    # the whole prior range is visited (uniform: the 95 % interval's ends)
    lo, hi = res.credible()
    assert lo[0] < 0.1 and hi[0] > 0.45


def test_outputs_files_and_cli(tmp_path, capsys):
    """A short run through the CLI: calibration.json with the issue's names,
    posterior.nc readable by ArviZ with its four groups, the figures; a short run
    is reported as not converged with the steps it needs."""
    import arviz as az

    from microimpact.cli import main

    data = tiny(angles=(30.0,), samples=300)
    exp = simulated(data, {STD: 12.0}, seed=21, samples=300, stats=("e", "mu"))
    scen = tmp_path / "s.toml"
    from microimpact._core.toml import to_toml

    scen.write_text(
        to_toml(data) + '\n[calibration.priors."surfaces.rough.std_deg"]\n'
        'distribution = "truncnormal"\nmean = 10.0\nstd = 5.0\n'
        "low = 0.0\nhigh = 30.0\n"
    )
    exp_path = tmp_path / "exp.csv"
    exp.to_csv(exp_path, index=False)
    impacts = tmp_path / "impacts.csv"  # per-impact rebounds, a second file
    impacts.write_text("angle_deg,e\n" + "".join(f"30,{v}\n" for v in (0.5, 0.6, 0.7)))
    out = tmp_path / "out"
    rc = main(
        [
            "calibrate",
            str(scen),
            str(exp_path),
            str(impacts),
            "--parameter",
            STD,
            "--method",
            "bayes",
            "--steps",
            "12",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "NOT converged" in text and "more steps" in text
    doc = json.loads((out / "calibration.json").read_text())
    p = doc["parameters"][STD]
    for name in ("posterior_median", "credible_low", "credible_high", "r_hat", "ess"):
        assert math.isfinite(p[name]), name
    assert p["prior"]["distribution"] == "truncnormal"
    assert doc["converged"] is False and doc["more_steps_needed"] > 0
    page = (out / "report.html").read_text(encoding="utf-8")  # the report section
    assert "<section" in page and "posterior_median" not in page
    assert STD in page
    idata = az.from_netcdf(out / "posterior.nc")
    assert {
        "posterior",
        "sample_stats",
        "observed_data",
        "posterior_predictive",
    } <= set(idata.groups())
    assert idata.posterior[STD].shape[0] == doc["walkers"]
    np.testing.assert_allclose(idata.observed_data["mean"].values, exp["mean"])
    np.testing.assert_allclose(idata.observed_data["e"].values, [0.5, 0.6, 0.7])
    assert idata.posterior_predictive["e_mean"].shape[-1] == 1
    for f in ("corner.png", "posterior_predictive.png"):
        assert (out / f).stat().st_size > 10_000, f
    assert "## Calibration (Bayesian)" in (out / "calibration.md").read_text()
    # the run report's section, from the folder: a table row per parameter, the
    # verdict, no Python artefact (read back by the standard library's HTML parser)
    from html.parser import HTMLParser

    from microimpact.analysis.bayes_output import section_html_of_folder

    class Cells(HTMLParser):
        def __init__(self):
            super().__init__()
            self.text, self.tags = [], []

        def handle_starttag(self, tag, attrs):
            self.tags.append(tag)

        def handle_data(self, data):
            self.text.append(data)

    parser = Cells()
    parser.feed(section_html_of_folder(out))
    text = " ".join(parser.text)
    assert STD in text and "NOT converged" in text and "truncnormal" in text
    assert parser.tags.count("tr") == 2 and parser.tags.count("img") == 2
    assert not re.search(r"None|nan|np\.|float64|\{", text)
    # least squares reads the same file, its [calibration] table left aside (its
    # fit of two points from 300 impacts is not the point here: no warning shown)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ls = calibrate(scen, exp_path, [STD], bootstrap=0, band_draws=0)
    assert ls.ci_low[0] < ls.ci_high[0]


def test_cli_refuses_bayes_options_with_least_squares(tmp_path, capsys):
    from microimpact.cli import main

    rc = main(
        [
            "calibrate",
            "x.toml",
            "a.csv",
            "--parameter",
            STD,
            "--steps",
            "10",
            "--out",
            str(tmp_path / "o"),
        ]
    )
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--method bayes" in err[0]


# ---------------------------------------------------------------------- wall law
def wall_law_scenario(tmp_path):
    """A small scenario file with a [wall_law] table."""
    path = tmp_path / "w.toml"
    path.write_text(
        'name = "w"\nseed = 3\nsamples = 300\n'
        '[particles]\ndistribution = "monodisperse"\ndiameter_um = 10\n'
        "[coefficients]\nk1 = 4.0\nk2 = 0.05\nfriction = 0.2\n"
        '[coefficients.v_c]\nlaw = "power"\na_m_s = 0.4\nb = -1.58\nd_ref_um = 52.8\n'
        '[[surfaces]]\nname = "rough"\nkind = "normal"\nstd_deg = 5\n'
        "[sweep]\nspeed_m_s = [1.0, 2.0]\nangle_deg = [30, 90]\n"
        "[wall_law]\ndiameter_um = [5, 20]\nspeed_m_s = [0.5, 2.0]\n"
        "angle_deg = [30, 90]\nreservoir = 16\n"
    )
    return path


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # nodes with no rebound
def test_posterior_wall_law_carries_the_stay_probability_of_its_captures(tmp_path):
    """With [resuspension] the mixture keeps ``stay_probability``: at the nodes,
    the Rock'n'Roll quadrature at each diameter (the same in every draw here:
    the surface energy is given); and the mixture weights each draw's stay
    probability by its captures, checked by hand on two altered draws."""
    import types

    import arviz as az

    from microimpact.analysis.wall_law_posterior import _mixture, posterior_wall_law
    from microimpact.physics.resuspension import (
        air_properties,
        remaining_fraction_ramp,
    )

    path = wall_law_scenario(tmp_path)
    path.write_text(
        path.read_text()
        + "[resuspension]\nfriction_velocity_m_s = [0.5, 1.0]\nexposure_s = 2.0\n"
        "surface_energy_j_m2 = 0.56\n"
        'fluid = { name = "air", temperature_k = 293.15, pressure_pa = 101325 }\n'
    )
    idata = az.from_dict(posterior={VC: np.array([[0.3, 0.8]])})
    mix = posterior_wall_law(path, idata, draws=2)
    q = mix.dataset["stay_probability"]
    rho, nu = air_properties(293.15, 101325.0)
    for j, d_um in enumerate((5.0, 20.0)):
        want = remaining_fraction_ramp(
            d_um * 0.5e-6, [0.5, 1.0], [2.0, 2.0], rho, nu, 0.56, outside="ignore"
        )[-1]
        np.testing.assert_allclose(q.isel(diameter_um=j).values, want, rtol=1e-6)
    # two draws with other stay probabilities and captures: weighted by captures
    a, b = mix.dataset.copy(deep=True), mix.dataset.copy(deep=True)
    a["n_captured"].values[...] = 30
    b["n_captured"].values[...] = 10
    a["stay_probability"].values[...] = 0.2
    b["stay_probability"].values[...] = 0.6
    pooled = _mixture([types.SimpleNamespace(dataset=x) for x in (a, b)])
    np.testing.assert_allclose(pooled["stay_probability"].values, 0.3)  # (6+6)/40
    b["n_captured"].values[...] = 0
    a["n_captured"].values[...] = 0
    pooled = _mixture([types.SimpleNamespace(dataset=x) for x in (a, b)])
    np.testing.assert_allclose(pooled["stay_probability"].values, 0.4)  # no capture


def test_posterior_wall_law_capture_is_the_average_over_draws(tmp_path):
    """The mixture table's capture probability at every node is the mean of the
    tables built separately (public build API) at each posterior draw."""
    import arviz as az

    from microimpact.analysis.wall_law_posterior import posterior_wall_law
    from microimpact.scenario.scenario import read_scenario
    from microimpact.wall_law import build_wall_law

    path = wall_law_scenario(tmp_path)
    a = np.array([[0.3, 0.5], [0.8, 0.4]])  # 2 walkers x 2 draws
    idata = az.from_dict(posterior={VC: a})
    mix = posterior_wall_law(path, idata, draws=4)
    file = read_scenario(path)
    ps = []
    for v in a.ravel():  # the draws in the posterior's flat order
        sc = scenario_from_dict(with_values(file.data, {VC: float(v)}), source=path)
        law = build_wall_law(sc, file.wall_law, seed=3)
        ps.append(law.dataset["capture_probability"].values)
    ps = np.array(ps)
    assert np.ptp(ps, axis=0).max() > 0.1  # the draws differ
    p = mix.dataset["capture_probability"].values
    np.testing.assert_allclose(p, ps.mean(axis=0), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(
        mix.dataset["capture_probability_draw_std"].values, ps.std(axis=0), atol=1e-12
    )
    # the sampler reads the mixture: its capture rate at a node is the node's p
    i = (0, 0, 0, 0)  # surface, 5 um, 0.5 m/s, 30 deg
    out = mix.sample(np.full(20_000, 5.0), 0.5, 30.0, rng=0)
    se = math.sqrt(p[i] * (1 - p[i]) / 20_000) + 1e-12
    assert abs(out.captured.mean() - p[i]) < 4 * se


# ---------------------------------------------------------------------- slow
def _two_parameter_data(seed, truth, samples):
    """e and mu at 1 m/s (30, 60 deg) and capture counts at 0.235 m/s."""
    data = tiny(angles=(30.0, 60.0), speeds=(0.235, 1.0))
    means = simulated(data, truth, seed=seed, samples=samples, stats=("e", "mu"))
    means = means[means["speed_m_s"] == 1.0].reset_index(drop=True)
    sc = scenario_from_dict(with_values(data, truth))
    s = microimpact.run(sc, samples=samples, seed=seed, progress=False).summary
    s = s[s["speed_m_s"] == 0.235]
    counts = pd.DataFrame(
        {
            "speed_m_s": s["speed_m_s"],
            "angle_deg": s["angle_deg"],
            "captured": np.rint(s["capture_fraction"] * s["n"]).astype(int),
            "n": s["n"].astype(int),
        }
    )
    return data, [means, counts]


@pytest.mark.slow
def test_credible_intervals_cover_the_truth_in_50_replications():
    """50 replications (data and model seeds differ in each) of a roughness spread
    and a v_c law coefficient from e, mu and capture counts (300 measured impacts
    per point, 3,000 simulated: the Monte Carlo variance ratio 0.1): every run
    converges with R-hat <= 1.01, and the 90 % credible interval covers the truth
    in at least 85 % of them for each parameter (P(X <= 41 | 50, 0.9) = 0.058;
    an interval too narrow by sqrt 2 covers ~74 %)."""
    truth = {STD: 12.0, VC: 0.2}
    hits = np.zeros(2, int)
    for rep in range(50):
        data, exp = _two_parameter_data(1000 + rep, truth, 300)
        res = calibrate(
            data,
            exp,
            {STD: (2.0, 30.0), VC: (0.1, 0.4)},
            method="bayes",
            samples=3000,
            seed=5000 + rep,
            confidence=0.9,
            progress=False,
            sampler_seed=rep,
        )
        assert res.diagnostics.converged, res.diagnostics.reasons
        assert (res.diagnostics.r_hat <= 1.01).all()
        lo, hi = res.credible()
        t = np.array([truth[STD], truth[VC]])
        hits += (lo <= t) & (t <= hi)
    assert (hits >= 43).all(), hits


@pytest.mark.slow
def test_near_gaussian_posterior_agrees_with_least_squares():
    """With 2,000 measured rebounds per point the posterior of the spread is
    near-Gaussian: its median and 95 % interval agree with least squares' estimate
    and interval within a fifth of their width (same data, same model seed)."""
    data = tiny(angles=(30.0, 45.0, 60.0), samples=4000)
    exp = simulated(data, {STD: 12.0}, seed=31, samples=2000, stats=("e", "mu"))
    ls = calibrate(data, exp, {STD: (2.0, 30.0)}, seed=8, bootstrap=0, band_draws=0)
    res = calibrate(
        data, exp, {STD: (2.0, 30.0)}, method="bayes", seed=8, progress=False
    )
    assert res.diagnostics.converged
    lo, hi = res.credible()
    width = ls.ci_high[0] - ls.ci_low[0]
    assert abs(res.posterior_median[0] - ls.estimate[0]) < 0.2 * width
    assert abs(lo[0] - ls.ci_low[0]) < 0.2 * width
    assert abs(hi[0] - ls.ci_high[0]) < 0.2 * width


@pytest.mark.slow
def test_binomial_capture_counts_alone_recover_a_vc_coefficient():
    """Capture counts (400 particles at each of 3 angles and 2 speeds near v_c)
    from the engine at a = 0.2 m/s: the 95 % credible interval of the v_c law's
    coefficient from the binomial likelihood alone holds the truth, and is narrow
    (under a fifth of the prior range)."""
    truth = {VC: 0.2}
    data = tiny(angles=(45.0, 60.0, 90.0), speeds=(0.22, 0.25), samples=4000)
    sc = scenario_from_dict(with_values(data, truth))
    s = microimpact.run(sc, samples=400, seed=77, progress=False).summary
    counts = pd.DataFrame(
        {
            "speed_m_s": s["speed_m_s"],
            "angle_deg": s["angle_deg"],
            "captured": np.rint(s["capture_fraction"] * s["n"]).astype(int),
            "n": s["n"].astype(int),
        }
    )
    res = calibrate(
        data, counts, {VC: (0.1, 0.4)}, method="bayes", seed=3, progress=False
    )
    assert res.diagnostics.converged
    lo, hi = res.credible()
    assert lo[0] <= 0.2 <= hi[0], (lo, hi)
    assert hi[0] - lo[0] < 0.2 * 0.3


def test_common_random_numbers_make_the_likelihood_continuous():
    """Two evaluations a hair apart in the spread give log-posteriors a hair
    apart (the same impacts, moved slightly); independent seeds would differ by
    the Monte Carlo noise of the whole likelihood (order 1)."""
    from microimpact.analysis.bayes import LogPosterior
    from microimpact.analysis.bayes_data import Likelihood, read_calibration_data
    from microimpact.analysis.model import ScenarioModel
    from microimpact.analysis.priors import uniform_prior

    data = tiny(angles=(30.0, 60.0), samples=400)
    exp = simulated(data, {STD: 12.0}, seed=5, samples=400, stats=("e", "mu"))
    model = ScenarioModel(data, [STD], samples=400, seed=2)
    post = LogPosterior(
        model, Likelihood(read_calibration_data(exp), 400), [uniform_prior(STD, 2, 30)]
    )
    a, _ = post(np.array([12.0]))
    b, _ = post(np.array([12.0 + 1e-7]))
    c, _ = post(np.array([12.5]))
    assert abs(a - b) < 1e-3
    assert a != c  # the likelihood does depend on the spread


def test_wall_law_cli_builds_the_posterior_mixture(tmp_path):
    """``wall-law --posterior posterior.nc --draws K`` writes the mixture table:
    the draws' spread is in it, and its capture probability is the API's."""
    import arviz as az
    import xarray as xr

    from microimpact.analysis.wall_law_posterior import posterior_wall_law
    from microimpact.cli import main

    path = wall_law_scenario(tmp_path)
    nc = tmp_path / "posterior.nc"
    az.from_dict(posterior={VC: np.array([[0.3, 0.5], [0.8, 0.4]])}).to_netcdf(nc)
    out = tmp_path / "law"
    argv = ["wall-law", str(path), "--posterior", str(nc), "--draws", "3"]
    assert main([*argv, "--out", str(out), "--no-c", "--no-openfoam", "--quiet"]) == 0
    with xr.open_dataset(out / "wall_law.nc") as ds:
        assert ds.attrs["posterior_draws"] == 3
        p = ds["capture_probability"].values
        assert "capture_probability_draw_std" in ds
    api = posterior_wall_law(path, nc, draws=3).dataset["capture_probability"].values
    np.testing.assert_array_equal(p, api)


def test_per_impact_likelihood_is_the_kernel_density_of_the_simulated_e():
    """Per-impact rebounds: the log-likelihood is the sum over impacts of the log
    of scipy's weighted gaussian_kde over the simulated e histogram (Silverman's
    bandwidth, recomputed here from the histogram's moments and quartiles) mixed
    with the stated uniform floor."""
    from scipy.stats import gaussian_kde

    from microimpact.analysis.bayes_data import Likelihood, read_calibration_data
    from microimpact.engine.accumulators import E_EDGES

    data = tiny(angles=(30.0, 60.0), samples=800)
    result = microimpact.run(
        scenario_from_dict(data), samples=800, seed=4, progress=False
    )
    e = np.array([0.55, 0.6, 0.62, 0.7, 0.75])
    impacts = pd.DataFrame({"angle_deg": 60.0, "speed_m_s": 1.0, "e": e})
    ll, blob = Likelihood(read_calibration_data(impacts), 800).evaluate(result)
    counts, _ = result.histogram(1, "e")
    counts = np.asarray(counts, float)
    centres = 0.5 * (E_EDGES[:-1] + E_EDGES[1:])
    n = counts.sum()
    mean = counts @ centres / n
    sd = math.sqrt(counts @ (centres - mean) ** 2 / (n - 1))
    rep = np.repeat(centres, counts.astype(int))
    iqr = np.subtract(*np.quantile(rep, [0.75, 0.25], method="inverted_cdf"))
    h = max(0.9 * min(sd, iqr / 1.34) * n**-0.2, 0.01)
    kde = gaussian_kde(centres[counts > 0], weights=counts[counts > 0])
    kde.set_bandwidth(h / math.sqrt(kde.covariance[0, 0] / kde.factor**2))
    eps, span = 0.5 / n, E_EDGES[-1] - E_EDGES[0]
    oracle = np.sum(np.log((1 - eps) * kde(e) + eps / span))
    assert ll == pytest.approx(oracle, rel=1e-6)
    assert blob[-1] == pytest.approx(mean, abs=1e-12)


def test_a_scenario_with_priors_runs_everywhere(tmp_path):
    """A [calibration] table (the Bayesian priors) does not stop the scenario's
    other verbs: read_scenario and `microimpact run` take the file as it is."""
    from microimpact.cli import main
    from microimpact.scenario.scenario import read_scenario

    path = tmp_path / "s.toml"
    path.write_text(
        'name = "p"\nseed = 1\nsamples = 200\n'
        '[particles]\ndistribution = "normal"\nmean_um = 52.8\nstd_um = 15.3\n'
        "[coefficients]\nk1 = 4.0\nk2 = 0.05\nv_c = 0.2\nfriction = 0.15\n"
        "[sweep]\nspeed_m_s = [0.5]\nangle_deg = [90]\n"
        '[calibration.priors."coefficients.friction"]\n'
        'distribution = "uniform"\nlow = 0.05\nhigh = 0.5\n'
    )
    assert read_scenario(path).scenario.name == "p"
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet", "--no-figures"]) == 0
    assert (out / "summary.csv").exists()


def test_walkers_run_in_forked_processes_with_the_one_worker_chain(monkeypatch):
    """On 2 workers emcee's walkers go to worker processes forked with the log
    posterior (parallel.fork_pool): the chain, the log posteriors and the
    predictions are those of one worker, bit for bit."""
    from microimpact.analysis import bayes
    from microimpact.engine import parallel

    # a thread another test left running (a Dask client's IO loop) would make
    # the pool refuse to fork; this test is about what happens when it can
    monkeypatch.setattr(parallel, "start_method", lambda: "fork")
    monkeypatch.setattr(parallel, "cap_workers", lambda w: w)
    calls = []
    real = bayes.map_held

    def held(pool, items, **kw):
        calls.append(len(items))
        return real(pool, items, **kw)

    monkeypatch.setattr(bayes, "map_held", held)
    data = tiny(samples=300)
    exp = simulated(data, {STD: 12.0}, seed=9, samples=3000)
    kw = dict(method="bayes", steps=8, check_every=8, progress=False, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = calibrate(data, exp, {STD: (2.0, 30.0)}, workers=1, **kw)
        assert not calls
        two = calibrate(data, exp, {STD: (2.0, 30.0)}, workers=2, **kw)
    assert calls and sum(calls) >= 8 * one.walkers // 2
    np.testing.assert_array_equal(one.chain, two.chain)
    np.testing.assert_array_equal(one.log_prob, two.log_prob)
    np.testing.assert_array_equal(one.blobs, two.blobs)
