"""What :mod:`.sizes_report` (raw diameters) and :mod:`.binned_report` (size
bins) share when they compare the normal and log-normal fits of a sample: the AIC
of a two-parameter fit, the recommendation and the words of the report."""

from __future__ import annotations

#: Parameters of each candidate fit (normal: mean, std; log-normal: median, GSD).
N_PARAMS = 2


def aic(fit) -> float:
    """Akaike's information criterion ``2k - 2 ln L`` (k = 2) of a fit (a
    :class:`~.distributions.FitResult`)."""
    return 2.0 * N_PARAMS - 2.0 * fit.log_likelihood


def recommend(aic_normal, aic_lognormal, chi2_normal, chi2_lognormal, measured):
    """``(delta_aic, better_fit, recommended)`` of the two fits.

    ``delta_aic = aic_normal - aic_lognormal``; the better fit is the lower AIC
    (``"normal"`` on a tie, as the paper). Of the fits the chi-squared test does
    not reject the better one is recommended; if it rejects both, `measured` (the
    measured distribution: ``"empirical"``, ``"histogram"``). Without a test
    (``chi2_normal`` None) the better fit is recommended.
    """
    delta = aic_normal - aic_lognormal
    better = "lognormal" if delta > 0 else "normal"
    if chi2_normal is None:
        return delta, better, better
    tests = (("normal", chi2_normal), ("lognormal", chi2_lognormal))
    kept = [k for k, c in tests if not c.reject]
    recommended = better if len(kept) == 2 else (kept[0] if kept else measured)
    return delta, better, recommended


def fits_better(better) -> str:
    """The verdict's words on which fit has the lower AIC."""
    if better == "lognormal":
        return "the log-normal fits better than the normal"
    return "the normal fits better than (or as well as) the log-normal"


def outcome(c) -> str:
    """A test's outcome in the verdict: ``rejected (p = 0.012)``."""
    return f"{'rejected' if c.reject else 'not rejected'} (p = {c.pvalue:.3g})"


def chi2_line(c) -> str:
    """A test in a summary line: statistic, degrees of freedom, p-value, outcome."""
    word = "rejected" if c.reject else "not rejected"
    return f"chi2 {c.statistic:.3f}, dof {c.dof}, p = {c.pvalue:.4g}: {word}"


def fit_dict(fit, chi2, aic_value) -> dict:
    """A fit in a report's plain data: parameters, standard errors,
    log-likelihood, AIC and its test (`chi2`, already plain data or None)."""
    return {
        "params": dict(fit.params),
        "stderr": dict(fit.stderr),
        "log_likelihood": fit.log_likelihood,
        "aic": aic_value,
        "chi2": chi2,
    }
