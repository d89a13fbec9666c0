"""``describe_binned_sizes`` with too few counted particles for the chi-squared
test on the bins: the fits and their standard errors, no test, a note saying why
(issue 22, round two: counted concentrations of short periods)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from microimpact.population.binned import BinnedSizes, chi2_binned
from microimpact.population.binned_report import describe_binned_sizes

EDGES = 0.5 * 2 ** (np.arange(9) / 2)  # 8 bins, 0.5 to 8 um


def _bins(total):
    p = np.diff(stats.lognorm(np.log(1.6), scale=1.5).cdf(EDGES))
    return BinnedSizes(edges_um=EDGES, number=np.round(total * p), values="count")


def test_too_few_particles_give_no_test_but_the_fits_and_their_errors():
    bins = _bins(20)
    with pytest.raises(ValueError, match="too few particles"):  # the oracle
        chi2_binned(bins.edges_um, bins.number, stats.lognorm(0.47, scale=1.5e-6))
    report = describe_binned_sizes(bins)
    assert report.chi2_normal is None and report.chi2_lognormal is None
    assert report.recommended == report.better_fit
    assert all(math.isfinite(v) and v > 0 for v in report.lognormal.stderr.values())
    assert any(n.startswith("no chi-squared test: too few") for n in report.notes)
    assert "no chi2 test (too few particles)" in report.summary()
    assert "no chi-squared test (too few particles)" in report.verdict
    out = report.to_dict()
    assert out["counted"] is True and out["lognormal"]["chi2"] is None


def test_enough_particles_still_give_the_test():
    report = describe_binned_sizes(_bins(5000))
    assert report.chi2_lognormal is not None and report.chi2_lognormal.dof >= 1
    assert not any("no chi-squared test" in n for n in report.notes)


def test_the_report_as_plain_data_keeps_its_documented_keys():
    """`sizes --json` and scripts read these keys: the bins as given, and each
    test's numbers under their names (written after the fresh mutation sample
    found the keys unguarded)."""
    import json

    bins = _bins(5000)
    report = describe_binned_sizes(bins)
    out = json.loads(json.dumps(report.to_dict()))
    assert out["edges_um"] == bins.edges_um.tolist()
    assert out["number"] == bins.number.tolist()
    c = out["lognormal"]["chi2"]
    keys = {"statistic", "dof", "pvalue", "reject", "n_bins", "n_bins_initial"}
    assert set(c) == keys
    assert c["pvalue"] == report.chi2_lognormal.pvalue
    assert c["dof"] == report.chi2_lognormal.dof
