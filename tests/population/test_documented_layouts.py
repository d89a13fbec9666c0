"""The size reports' `to_dict` against the layouts docs/populations.md documents.

Oracle: the key tables of ``sizes.json`` (``microimpact.sizes/1``) and of binned
``sizes.json`` (``microimpact.sizes.binned/1``) as written in the docs, read
here from the Markdown: every documented top-level key is present and nothing
undocumented is, so a key renamed, dropped or added in the code (or the docs)
turns these red. Then what the documented keys promise, against values computed
here independently of the report.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from microimpact.population import (
    BinnedSizes,
    describe_binned_sizes,
    describe_sizes,
)

DOC = Path(__file__).resolve().parents[2] / "docs" / "populations.md"


def _documented_keys(heading: str) -> set:
    """Top-level keys of the table under `heading` (first cell's backticked
    names; ``normal.params.mean_um`` -> ``normal``; ``<fit>.x`` is both fits)."""
    text = DOC.read_text(encoding="utf-8")
    start = text.index(heading)
    table = []
    for line in text[start:].splitlines()[1:]:
        if line.startswith("|"):
            table.append(line)
        elif table:
            break
    keys = set()
    for row in table[2:]:  # after the header and the rule
        first = row.split("|")[1]
        for name in re.findall(r"`([^`]+)`", first):
            top = name.split(".")[0]
            if top == "<fit>":
                keys |= {"normal", "lognormal"}
            elif top:  # ".dof" and friends continue the row's first key
                keys.add(top)
    return keys


def _bimodal(n=400):
    rng = np.random.default_rng(7)
    half = n // 2
    return np.concatenate([rng.normal(20.0, 1.0, half), rng.normal(60.0, 2.0, half)])


def test_sizes_json_keys_are_the_documented_ones():
    doc = _documented_keys("### `sizes.json` (schema `microimpact.sizes/1`)")
    assert {"schema", "verdict", "particles_toml", "better_fit"} <= doc
    r = describe_sizes(np.random.default_rng(1).lognormal(np.log(50.0), 0.4, 300))
    assert set(r.to_dict()) == doc


def test_binned_sizes_json_keys_are_the_documented_ones():
    heading = "### `sizes.json` of bins (schema `microimpact.sizes.binned/1`)"
    doc = _documented_keys(heading)
    assert {"schema", "verdict", "aerosol", "notes", "comparison"} <= doc
    edges = np.geomspace(1.0, 100.0, 11)
    counts = np.array([1, 4, 12, 30, 52, 60, 45, 25, 9, 2], dtype=float)
    r = describe_binned_sizes(BinnedSizes(edges, counts, "dN", counted=True))
    d = r.to_dict()
    assert set(d) == doc
    assert d["verdict"] == r.verdict and d["comparison"] == "aic"
    assert d["n_bins"] == 10 and d["total"] == pytest.approx(240.0)


def test_the_recommended_normal_is_the_normal_ml_fit():
    """Normal data: the recommended population is the normal of the ML estimates
    (mean, std with ddof 0), as docs/populations.md states, in the report and in
    its [particles] snippet."""
    x = np.random.default_rng(1).normal(50.0, 5.0, 400)
    r = describe_sizes(x)
    assert r.recommended == "normal"
    snippet = tomllib.loads(r.to_dict()["particles_toml"])["particles"]
    assert snippet["distribution"] == "normal"
    assert snippet["mean_um"] == pytest.approx(x.mean(), rel=1e-12)
    assert snippet["std_um"] == pytest.approx(x.std(), rel=1e-12)
    desc = r.recommended_distribution.describe()
    assert desc["kind"] == "normal", desc


def test_an_empirical_recommendation_points_at_the_users_file_and_column():
    """Two modes: both fits rejected, the measured diameters are recommended, and
    the snippet names the file and the column the user gave."""
    r = describe_sizes(_bimodal())
    assert r.recommended == "empirical"
    text = r.to_dict(file="sizes.csv", column="d_um", unit="um")["particles_toml"]
    snippet = tomllib.loads(text)["particles"]
    assert snippet["distribution"] == "empirical"
    assert snippet["file"] == "sizes.csv"
    assert snippet["column"] == "d_um"


def test_binned_summary_says_whether_the_values_are_counts():
    edges = np.geomspace(1.0, 100.0, 11)
    values = np.array([1, 4, 12, 30, 52, 60, 45, 25, 9, 2], dtype=float)
    counted = describe_binned_sizes(BinnedSizes(edges, values, "dN", counted=True))
    density = describe_binned_sizes(
        BinnedSizes(edges, values, "dN/dlogDp", counted=False)
    )
    first = counted.summary().splitlines()[0]
    assert first == "10 bins, 1 to 100 um, values dN, total 240 particles"
    first = density.summary().splitlines()[0]
    assert first.startswith("10 bins, 1 to 100 um, values dN/dlogDp, total ")
    assert first.endswith(" (not counts)")


def test_describe_echoes_the_users_arguments_and_the_truncated_moments():
    """`describe()` of each factory: its params are the arguments as given (the
    provenance a result records), and the moments of a truncated population are
    those of scipy's own truncated distributions (an independent computation)."""
    from scipy import stats

    from microimpact.population import (
        lognormal_diameters,
        normal_diameters,
        uniform_diameters,
    )

    d = normal_diameters(50.0, 5.0, min_um=40.0, max_um=60.0).describe()
    assert d["kind"] == "normal"
    assert d["params"] == {
        "mean_um": 50.0,
        "std_um": 5.0,
        "min_um": 40.0,
        "max_um": 60.0,
    }
    t = stats.truncnorm(-2.0, 2.0, loc=50.0, scale=5.0)
    assert d["mean_um"] == pytest.approx(t.mean(), rel=1e-12)
    assert d["std_um"] == pytest.approx(t.std(), rel=1e-9)
    assert d["truncated_mass"] == pytest.approx(2 * stats.norm.sf(2.0), rel=1e-9)
    assert d["support_um"] == pytest.approx((40.0, 60.0), rel=1e-12)

    d = lognormal_diameters(50.0, 1.5, max_um=200.0).describe()
    assert d["params"] == {
        "median_um": 50.0,
        "geometric_std": 1.5,
        "min_um": None,
        "max_um": 200.0,
    }
    ln = stats.lognorm(np.log(1.5), scale=50.0)
    kept = ln.cdf(200.0)
    mean = ln.expect(lambda x: x, ub=200.0, conditional=True)
    assert d["truncated_mass"] == pytest.approx(1.0 - kept, rel=1e-9)
    assert d["mean_um"] == pytest.approx(mean, rel=1e-7)

    d = uniform_diameters(10.0, 20.0).describe()
    assert d["params"] == {"min_um": 10.0, "max_um": 20.0}
    assert d["std_um"] == pytest.approx(10.0 / np.sqrt(12.0), rel=1e-12)
