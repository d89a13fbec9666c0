r"""Which population represents a measured diameter sample: normal, log-normal or
the measured diameters themselves.

[1]_ fits a Gaussian to each measured distribution and keeps it unless the
chi-squared test rejects it, in which case the measured (empirical) distribution is
used. Aerosol size distributions are often log-normal, so :func:`describe_sizes`
puts both candidates through the same test and compares them:

* both maximum-likelihood fits (:func:`~.distributions.fit_normal`,
  :func:`~.distributions.fit_lognormal`) with standard errors and log-likelihoods;
* Akaike's information criterion of each, :math:`AIC = 2k - 2\ln L` (k = 2 for
  both, densities in µm⁻¹, so the two are comparable), and their difference
  :math:`\Delta = AIC_{normal} - AIC_{lognormal}` (> 0: the log-normal fits better);
* the paper's chi-squared test (:func:`~.distributions.chi2_normality`) of the
  diameters (normal) and of their logarithms (log-normal: ``ln d`` is Gaussian
  exactly when ``d`` is log-normal; the test is location-scale invariant, so it
  is run on ``ln d`` shifted to positive values).

The recommendation: of the candidates the test does not reject, the one with the
lower AIC (the normal on a tie, as the paper); if the test rejects both, the
measured distribution (the paper's "empirical" decision).

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core.json import dumps
from .._core.toml import particles_snippet
from .._core.validation import as_float_array
from ._compare import aic, chi2_line, fit_dict, fits_better, outcome, recommend
from .distributions import (
    Chi2NormalityResult,
    FitResult,
    chi2_normality,
    empirical_diameters,
    fit_lognormal,
    fit_normal,
)

__all__ = ["SCHEMA", "SizesReport", "describe_sizes"]

#: Identifies the layout of :meth:`SizesReport.to_dict` (``docs/populations.md``).
SCHEMA = "microimpact.sizes/1"


@dataclass(frozen=True, eq=False)
class SizesReport:
    """Result of :func:`describe_sizes` (diameters in µm).

    Attributes
    ----------
    n : int
        Number of diameters.
    alpha : float
        Significance level of the chi-squared tests.
    normal, lognormal : FitResult
        The maximum-likelihood fits.
    chi2_normal : Chi2NormalityResult
        The paper's test of the diameters against their Gaussian.
    chi2_lognormal : Chi2NormalityResult
        The same test of ``ln d`` (its ``mean_um``/``std_um``/``edges_um`` are in
        shifted log units, not µm).
    aic_normal, aic_lognormal : float
        ``2k - 2 ln L`` (k = 2).
    delta_aic : float
        ``aic_normal - aic_lognormal``: > 0 when the log-normal fits better.
    better_fit : str
        ``"normal"`` or ``"lognormal"``: the lower AIC (``"normal"`` on a tie).
    recommended : str
        ``"normal"``, ``"lognormal"`` or ``"empirical"`` (see the module notes).
    recommended_distribution : SizeDistribution
        The recommended population.
    verdict : str
        One sentence saying all of the above.
    source : str or None
        The file the diameters came from, if given.
    """

    n: int
    alpha: float
    normal: FitResult
    lognormal: FitResult
    chi2_normal: Chi2NormalityResult
    chi2_lognormal: Chi2NormalityResult
    aic_normal: float
    aic_lognormal: float
    delta_aic: float
    better_fit: str
    recommended: str
    recommended_distribution: object
    verdict: str
    source: str | None = None

    def particles_toml(self, *, file=None, column=None, unit=None) -> str:
        """The recommended ``[particles]`` table as TOML text
        (:func:`microimpact.scenario.particles_snippet`); for an empirical
        recommendation `file` (and `column`, `unit`) refer to the measured file
        instead of listing every diameter."""

        return particles_snippet(self, file=file, column=column, unit=unit)

    def to_dict(self, *, file=None, column=None, unit=None) -> dict:
        """Plain data in the documented layout (``docs/populations.md``,
        :data:`SCHEMA`); non-finite numbers are left for the JSON writer."""

        def chi2(c: Chi2NormalityResult) -> dict:
            return {
                "statistic": c.statistic,
                "dof": c.dof,
                "pvalue": c.pvalue,
                "reject": bool(c.reject),
                "n_classes": int(c.expected.size),
                "n_classes_initial": int(c.n_classes_initial),
            }

        def fit(f: FitResult, c: Chi2NormalityResult, aic_value: float) -> dict:
            return fit_dict(f, chi2(c), aic_value)

        return {
            "schema": SCHEMA,
            "source": self.source,
            "n": self.n,
            "alpha": self.alpha,
            "normal": fit(self.normal, self.chi2_normal, self.aic_normal),
            "lognormal": fit(self.lognormal, self.chi2_lognormal, self.aic_lognormal),
            "better_fit": self.better_fit,
            "delta_aic": self.delta_aic,
            "recommended": self.recommended,
            "verdict": self.verdict,
            "particles_toml": self.particles_toml(file=file, column=column, unit=unit),
        }

    def to_json(self, *, indent=2, file=None, column=None, unit=None) -> str:
        """:meth:`to_dict` as standard JSON (no NaN or Infinity: ``null``)."""

        return dumps(self.to_dict(file=file, column=column, unit=unit), indent=indent)

    def summary(self) -> str:
        """A few lines of text for the terminal."""
        n, ln = self.normal, self.lognormal

        def pm(f, key):
            return f"{f.params[key]:.4g} ± {f.stderr[key]:.2g}"

        return "\n".join(
            [
                f"n = {self.n}",
                f"  normal     : mean {pm(n, 'mean_um')} um, std {pm(n, 'std_um')} um;"
                f" AIC {self.aic_normal:.2f}; {chi2_line(self.chi2_normal)}",
                f"  log-normal : median {pm(ln, 'median_um')} um, geometric std "
                f"{pm(ln, 'geometric_std')}; AIC {self.aic_lognormal:.2f}; "
                f"{chi2_line(self.chi2_lognormal)}",
                f"  {self.verdict}",
            ]
        )


def describe_sizes(diameters_um, *, alpha=0.05, source=None) -> SizesReport:
    """Fit, test and compare the normal and log-normal populations of a sample.

    Parameters
    ----------
    diameters_um : array_like
        Measured diameters [µm], finite and > 0.
    alpha : float
        Significance level of the chi-squared tests, in (0, 1).
    source : str or path-like, optional
        The file the diameters came from (recorded in the report).

    Returns
    -------
    SizesReport

    Raises
    ------
    ValueError
        Too few diameters for the chi-squared test (about 30 are needed), all
        diameters equal, non-finite or non-positive values, or a bad `alpha`.
    """
    d = as_float_array(diameters_um, "diameters_um").ravel()
    normal, lognormal = fit_normal(d), fit_lognormal(d)
    chi_n = chi2_normality(d, alpha=alpha)
    log_d = np.log(d)
    chi_ln = chi2_normality(log_d - log_d.min() + 1.0, alpha=alpha)  # invariant shift
    aic_n, aic_ln = aic(normal), aic(lognormal)
    delta, better, recommended = recommend(aic_n, aic_ln, chi_n, chi_ln, "empirical")
    dist = {
        "normal": normal.distribution,
        "lognormal": lognormal.distribution,
    }.get(recommended)
    if dist is None:
        dist = empirical_diameters(d)

    reason = {
        "empirical": "the test rejects both, so the measured distribution is used, "
        "as in the paper",
    }.get(recommended, "the better fit the test does not reject")
    verdict = (
        f"{fits_better(better)} (AIC {aic_n:.2f} vs {aic_ln:.2f}, difference "
        f"{delta:+.2f}); chi-squared at alpha = {float(alpha):g}: normal "
        f"{outcome(chi_n)}, log-normal {outcome(chi_ln)}; recommended: "
        f"{recommended} ({reason})."
    )
    return SizesReport(
        n=int(d.size),
        alpha=float(alpha),
        normal=normal,
        lognormal=lognormal,
        chi2_normal=chi_n,
        chi2_lognormal=chi_ln,
        aic_normal=aic_n,
        aic_lognormal=aic_ln,
        delta_aic=delta,
        better_fit=better,
        recommended=recommended,
        recommended_distribution=dist,
        verdict=verdict,
        source=None if source is None else str(source),
    )
