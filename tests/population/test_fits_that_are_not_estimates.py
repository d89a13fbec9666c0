"""Binned fits that are not estimates say so, as docs/populations.md states.

"A log-normal fit that diverged (GSD beyond 1000, e.g. bins that ... hold two
separate modes) ... is flagged in a note and not recommended", "nor is a fit
held at a bound of its search (a location driven to RANGE_FLOOR scales below the
lowest edge: the bins are the tail of a population below the instrument's
range)". Two sets of bins show each, with the notes' whole text.
"""

from __future__ import annotations

import warnings

import numpy as np

from microimpact.population import (
    RANGE_FLOOR,
    BinnedSizes,
    describe_binned_sizes,
    fit_binned_lognormal,
    fit_binned_normal,
)

EDGES = np.geomspace(1.0, 100.0, 11)
TAIL = np.array([100, 50, 25, 12, 6, 3, 2, 1, 1, 1], dtype=float)  # falls from 1 um
TWO_MODES = np.array([9, 0, 0, 0, 0, 0, 0, 0, 0, 9], dtype=float)


def _floor(kind, where):
    return (
        f"the {kind} fit is held at its bound ({where} {RANGE_FLOOR:g} scales below "
        "the lowest edge): the bins look like the tail of a population whose bulk "
        "lies below the instrument's range, and its parameters are not estimates"
    )


def test_bins_falling_from_the_lowest_edge_hold_both_fits_at_their_bound():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ln, n = fit_binned_lognormal(EDGES, TAIL), fit_binned_normal(EDGES, TAIL)
        report = describe_binned_sizes(BinnedSizes(EDGES, TAIL, "count"))
    assert ln.notes == (_floor("log-normal", "median"),)
    assert n.notes == (_floor("normal", "mean"),)
    # the location really is far below the range: median well under 1 um
    assert ln.params["median_um"] < EDGES[0] * 1e-2
    assert report.recommended == "histogram"


def test_two_separate_modes_make_the_log_normal_fit_diverge():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ln = fit_binned_lognormal(EDGES, TWO_MODES)
        report = describe_binned_sizes(BinnedSizes(EDGES, TWO_MODES, "count"))
    assert ln.notes == (
        "the log-normal fit diverges (GSD beyond 1000 or median beyond 1e300 um; "
        "shown clipped there): the bins have no log-normal shape (they rise to the "
        "top of the range, or are split in separate modes), and its parameters are "
        "not estimates",
    )
    assert np.isclose(ln.params["geometric_std"], 1000.0, rtol=1e-12)
    assert report.recommended != "lognormal"


def test_well_shaped_bins_carry_no_note():
    """A log-normal population's own bins: no note on either fit."""
    from scipy import stats

    cdf = stats.lognorm(np.log(1.8), scale=10.0).cdf(EDGES)
    counts = np.round(np.diff(cdf) * 5000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert fit_binned_lognormal(EDGES, counts).notes == ()
        assert fit_binned_normal(EDGES, counts).notes == ()


def test_the_other_fit_is_recommended_only_where_its_test_does_not_reject_it():
    """docs/populations.md: a fit that is not a population is not recommended;
    "the other fit is, if it is a population and its test (if any) does not
    reject it, else the measured bins". Both branches, with fits as the binned
    fitters return them (the log-normal one diverged)."""
    from types import SimpleNamespace

    from microimpact.population.binned_report import _usable

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bad_ln = fit_binned_lognormal(EDGES, TWO_MODES)
        from scipy import stats

        counts = np.round(np.diff(stats.norm(30.0, 10.0).cdf(EDGES)) * 2000)
        normal = fit_binned_normal(EDGES, counts)
    assert normal.notes == ()  # a population: mean 30 um
    rejects = SimpleNamespace(reject=True)
    keeps = SimpleNamespace(reject=False)
    rec, notes = _usable("lognormal", normal, bad_ln, keeps, None)
    assert rec == "normal"
    rec, notes = _usable("lognormal", normal, bad_ln, rejects, None)
    assert rec == "histogram"
    assert notes[-1] == (
        "no fit is both a particle population and not rejected: the measured bins "
        "(a histogram population) are recommended instead"
    )
    assert _usable("lognormal", normal, bad_ln, None, None)[0] == "normal"
