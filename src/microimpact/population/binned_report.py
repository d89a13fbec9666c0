r"""Which population represents a binned size distribution (an APS, SMPS or OPC
export), with the aerosol conventions: count median diameter and GSD, mass median
diameter, aerodynamic diameters.

:func:`describe_binned_sizes` is the binned counterpart of
:func:`~.sizes_report.describe_sizes`:

* both fits by the binned likelihood (:func:`~.binned.fit_binned_normal`,
  :func:`~.binned.fit_binned_lognormal`), their AIC (k = 2 each) and difference;
* when the bins hold counted particles (enough for the test: 4 bins with an
  expected count >= 5 after merging, else a note says there is none), the
  chi-squared test on the bins (:func:`~.binned.chi2_binned`) of each; the
  recommendation is then as in
  :func:`~.sizes_report.describe_sizes` (the better fit the test does not reject,
  else the measured bins as a ``histogram`` population). Concentrations
  (``dN/dlogDp`` in cm⁻³, or a number converted from mass) are not counts: no
  test is possible, and the better fit by likelihood is recommended, saying so;
* the count median diameter (CMD) and GSD of the log-normal fit and, read from the
  bins, the CMD and the mass median diameter (MMD, of the d³-weighted bins); the
  log-normal's MMD by Hatch-Choate (:func:`~.aerosol.hatch_choate_mass_median`);
* with a particle density, the aerodynamic diameters of the log-normal's CMD and
  Hatch-Choate MMD (:func:`~.aerosol.aerodynamic_diameter`; a monotone map, so the
  aerodynamic medians are the images of the medians).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

from .._core.json import dumps
from .._core.toml import particles_snippet
from ._compare import aic, chi2_line, fit_dict, fits_better, outcome, recommend
from .aerosol import aerodynamic_diameter, hatch_choate_mass_median
from .binned import (
    BinnedSizes,
    Chi2BinnedResult,
    binned_median,
    chi2_binned,
    fit_binned_lognormal,
    fit_binned_normal,
)
from .distributions import (
    PLAUSIBLE_DIAMETER_UM,
    FitResult,
    lognormal_diameters,
    normal_diameters,
)

__all__ = ["BINNED_SCHEMA", "BinnedSizesReport", "describe_binned_sizes"]

#: Identifies the layout of :meth:`BinnedSizesReport.to_dict` (docs/populations.md).
BINNED_SCHEMA = "microimpact.sizes.binned/1"


@dataclass(frozen=True, eq=False)
class BinnedSizesReport:
    """Result of :func:`describe_binned_sizes` (diameters in µm).

    Attributes
    ----------
    bins : BinnedSizes
        The bins analysed.
    alpha : float
        Significance level of the tests.
    normal, lognormal : FitResult
        The binned maximum-likelihood fits.
    chi2_normal, chi2_lognormal : Chi2BinnedResult or None
        The tests on the bins (None when the bins are not counts).
    aic_normal, aic_lognormal, delta_aic : float
        As in :class:`~.sizes_report.SizesReport`.
    better_fit, recommended : str
        ``"normal"``/``"lognormal"``; ``recommended`` may also be ``"histogram"``.
    recommended_distribution : SizeDistribution
        The recommended population.
    aerosol : dict
        ``count_median_um`` and ``geometric_std`` (log-normal fit),
        ``count_median_bins_um``, ``mass_median_bins_um`` (read from the bins),
        ``mass_median_hatch_choate_um``, and with a density ``density_kg_m3``,
        ``shape_factor``, ``aerodynamic_count_median_um``,
        ``aerodynamic_mass_median_um``.
    verdict : str
        One sentence saying the above.
    notes : tuple of str
        What was derived or assumed while reading and analysing.
    source : str or None
        The file, if given.
    """

    bins: BinnedSizes
    alpha: float
    normal: FitResult
    lognormal: FitResult
    chi2_normal: Chi2BinnedResult | None
    chi2_lognormal: Chi2BinnedResult | None
    aic_normal: float
    aic_lognormal: float
    delta_aic: float
    better_fit: str
    recommended: str
    recommended_distribution: object
    aerosol: dict
    verdict: str
    notes: tuple
    source: str | None = None

    @property
    def n(self) -> int:
        """The rounded total number in the bins."""
        return round(self.bins.total)

    def particles_toml(self, **_ignored) -> str:
        """The recommended ``[particles]`` table as TOML text (a histogram
        recommendation lists its edges and numbers)."""
        return particles_snippet(self)

    def to_dict(self, **_ignored) -> dict:
        """Plain data in the documented layout (:data:`BINNED_SCHEMA`)."""

        def chi2(c):
            if c is None:
                return None
            return {
                "statistic": c.statistic,
                "dof": c.dof,
                "pvalue": c.pvalue,
                "reject": bool(c.reject),
                "n_bins": int(c.expected.size),
                "n_bins_initial": c.n_bins_initial,
            }

        def fit(f, c, aic_value):
            return fit_dict(f, chi2(c), aic_value)

        b = self.bins
        return {
            "schema": BINNED_SCHEMA,
            "source": self.source,
            "values": b.values,
            "counted": b.counted,
            "n_bins": int(b.number.size),
            "total": b.total,
            "edges_um": b.edges_um.tolist(),
            "number": b.number.tolist(),
            "alpha": self.alpha,
            "normal": fit(self.normal, self.chi2_normal, self.aic_normal),
            "lognormal": fit(self.lognormal, self.chi2_lognormal, self.aic_lognormal),
            "better_fit": self.better_fit,
            "delta_aic": self.delta_aic,
            "comparison": "aic" if b.counted else "mean_log_likelihood",
            "recommended": self.recommended,
            "aerosol": dict(self.aerosol),
            "verdict": self.verdict,
            "notes": list(self.notes),
            "particles_toml": self.particles_toml(),
        }

    def to_json(self, *, indent=2, **_ignored) -> str:
        """:meth:`to_dict` as standard JSON (no NaN or Infinity: ``null``)."""
        return dumps(self.to_dict(), indent=indent)

    def summary(self) -> str:
        """A few lines of text for the terminal."""
        n, ln, a = self.normal, self.lognormal, self.aerosol

        def pm(f, key):
            se = f.stderr[key]
            return f"{f.params[key]:.4g}" + ("" if math.isnan(se) else f" ± {se:.2g}")

        def test(c):
            if c is None:
                if not self.bins.counted:
                    return "no chi2 test (not counts)"
                few = any(
                    t.startswith("no chi-squared test: too few bins")
                    for t in self.notes
                )
                return f"no chi2 test (too few {'bins' if few else 'particles'})"
            return chi2_line(c)

        def score(f, aic_value):
            if self.bins.counted:
                return f"AIC {aic_value:.2f}"
            return f"mean log-likelihood per particle {f.log_likelihood:.4f}"

        b = self.bins
        lines = [
            f"{b.number.size} bins, {b.edges_um[0]:.4g} to {b.edges_um[-1]:.4g} um, "
            f"values {b.values}, total {b.total:.6g}"
            + (" particles" if b.counted else " (not counts)"),
            f"  normal     : mean {pm(n, 'mean_um')} um, std {pm(n, 'std_um')} um;"
            f" {score(n, self.aic_normal)}; {test(self.chi2_normal)}",
            f"  log-normal : count median {pm(ln, 'median_um')} um, GSD "
            f"{pm(ln, 'geometric_std')}; {score(ln, self.aic_lognormal)}; "
            f"{test(self.chi2_lognormal)}",
            f"  count median from the bins {a['count_median_bins_um']:.4g} um; mass "
            f"median from the bins {a['mass_median_bins_um']:.4g} um, of the "
            f"log-normal (Hatch-Choate) {a['mass_median_hatch_choate_um']:.4g} um",
        ]
        if "aerodynamic_count_median_um" in a:
            how = (
                f"density {a['density_kg_m3']:g} kg/m3, shape factor "
                f"{a['shape_factor']:g}"
                if "density_kg_m3" in a
                else "as measured, from the bins"
            )
            lines.append(
                f"  aerodynamic ({how}): count median "
                f"{a['aerodynamic_count_median_um']:.4g} um, mass median "
                f"{a['aerodynamic_mass_median_um']:.4g} um"
            )
        lines += [f"  note: {t}" for t in self.notes]
        lines.append(f"  {self.verdict}")
        return "\n".join(lines)


def describe_binned_sizes(
    bins: BinnedSizes,
    *,
    alpha=0.05,
    density_kg_m3=None,
    shape_factor=1.0,
    source=None,
) -> BinnedSizesReport:
    """Fit, test and compare the normal and log-normal populations of binned data.

    Parameters
    ----------
    bins : BinnedSizes
        The bins (e.g. of :func:`microimpact.io.read_size_bins`).
    alpha : float
        Significance level of the chi-squared tests, in (0, 1).
    density_kg_m3 : float, optional
        Particle density [kg/m³]: adds the aerodynamic count and mass medians.
    shape_factor : float
        Dynamic shape factor for the aerodynamic diameter (1: spheres).
    source : str or path-like, optional
        The file the bins came from.

    Returns
    -------
    BinnedSizesReport

    Raises
    ------
    ValueError
        Fewer than 2 occupied bins.

    Notes
    -----
    Counts too few for the chi-squared test (fewer than 4 bins with an expected
    count >= 5 after merging) give no test (``chi2_* = None``) and a note; the
    standard errors are still reported.
    """
    e, number = bins.edges_um, bins.number
    # not counts: the likelihood of the bin fractions (scale-free; module notes)
    fitted = number if bins.counted else number / number.sum()
    normal, lognormal = fit_binned_normal(e, fitted), fit_binned_lognormal(e, fitted)
    notes = list(bins.notes) + list(normal.notes) + list(lognormal.notes)
    if number.size - 1 - 2 < 1:
        notes.append(
            f"only {number.size} bins: two parameters fitted to {number.size} bins "
            "leave no degree of freedom to check them, so the fits' parameters are "
            "poorly determined (and no chi-squared test is possible)"
        )
    too_few = None
    if bins.counted:
        try:
            chi_n = chi2_binned(e, number, normal, alpha=alpha)
            chi_ln = chi2_binned(e, number, lognormal, alpha=alpha)
        except ValueError as exc:  # too few bins or particles for the test
            chi_n = chi_ln = None
            too_few = str(exc)
            notes.append(
                f"no chi-squared test: {too_few.rstrip('.')}; the better fit by "
                "likelihood is recommended"
            )
    else:
        chi_n = chi_ln = None
        normal, lognormal = (
            replace(f, stderr=dict.fromkeys(f.stderr, math.nan))
            for f in (normal, lognormal)
        )
        notes.append(
            "the values are not counted particles, so there is no chi-squared test "
            "and no standard error; the better fit by likelihood is recommended"
        )
    if bins.counted:
        aic_n, aic_ln = aic(normal), aic(lognormal)
        delta, better, recommended = recommend(
            aic_n, aic_ln, chi_n, chi_ln, "histogram"
        )
        compared = (
            f"binned likelihood, AIC {aic_n:.2f} vs {aic_ln:.2f}, difference "
            f"{delta:+.2f}"
        )
    else:  # AIC is not defined: its size would follow the concentration unit
        aic_n = aic_ln = delta = math.nan
        _, better, recommended = recommend(
            -normal.log_likelihood, -lognormal.log_likelihood, None, None, "histogram"
        )
        compared = (
            "likelihood of the bin fractions, mean log-likelihood per particle "
            f"{normal.log_likelihood:.4f} vs {lognormal.log_likelihood:.4f}; AIC is "
            "not defined for values that are not counts"
        )
    recommended, unusable = _usable(recommended, normal, lognormal, chi_n, chi_ln)
    notes += unusable
    if chi_n is None:
        why = "the bins are not counts"
        if too_few:
            why = "too few bins" if "too few bins" in too_few else "too few particles"
        tests = f"no chi-squared test ({why})"
    else:
        tests = (
            f"chi-squared on the bins at alpha = {float(alpha):g}: normal "
            f"{outcome(chi_n)}, log-normal {outcome(chi_ln)}"
        )
    dist = {"normal": normal.distribution, "lognormal": lognormal.distribution}.get(
        recommended
    ) or bins.histogram()
    cmd, gsd = lognormal.params["median_um"], lognormal.params["geometric_std"]
    mid = bins.midpoints_um
    aerosol = {
        "count_median_um": cmd,
        "geometric_std": gsd,
        "count_median_bins_um": binned_median(e, number),
        "mass_median_bins_um": binned_median(e, number * mid**3),
        "mass_median_hatch_choate_um": hatch_choate_mass_median(cmd, gsd),
    }
    if bins.diameter == "aerodynamic":
        # the instrument measured aerodynamic diameters: they are the medians
        # themselves, never converted again (issue 30)
        aerosol["aerodynamic_count_median_um"] = aerosol["count_median_bins_um"]
        aerosol["aerodynamic_mass_median_um"] = aerosol["mass_median_bins_um"]
        if density_kg_m3 is not None:
            notes.append(
                f"the density {float(density_kg_m3):g} kg/m3 is not used: the "
                "diameters are aerodynamic already"
            )
    elif density_kg_m3 is not None:
        aerosol["density_kg_m3"] = float(density_kg_m3)
        aerosol["shape_factor"] = float(shape_factor)
        for key, d_um in (
            ("aerodynamic_count_median_um", cmd),
            ("aerodynamic_mass_median_um", aerosol["mass_median_hatch_choate_um"]),
        ):
            aerosol[key] = 1e6 * aerodynamic_diameter(
                d_um * 1e-6, density_kg_m3, shape_factor=shape_factor
            )
    verdict = (
        f"{fits_better(better)} ({compared}); {tests}; recommended: {recommended}."
    )
    return BinnedSizesReport(
        bins=bins,
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
        aerosol=aerosol,
        verdict=verdict,
        notes=tuple(notes),
        source=None if source is None else str(source),
    )


def _unphysical(kind, fit):
    """Why `fit` (``"normal"``/``"lognormal"``) is not a particle population a
    scenario accepts (its location <= 0 or outside
    :data:`~.distributions.PLAUSIBLE_DIAMETER_UM`), else None."""
    lo, hi = PLAUSIBLE_DIAMETER_UM
    key, name = ("mean_um", "mean") if kind == "normal" else ("median_um", "median")
    value = fit.params[key]
    ok = lo <= value <= hi
    if kind == "lognormal":
        ok = ok and fit.params["geometric_std"] > 1
    word = "normal" if kind == "normal" else "log-normal"
    if any("diverges" in t for t in fit.notes):
        return f"the {word} fit diverges; it is not recommended"

    if ok and any("held at its bound" in t for t in fit.notes):
        return (
            f"the {word} fit is held at a bound of its search ({name} "
            f"{value:.4g} um): it is not an estimate, and it is not recommended"
        )
    if ok:  # as a scenario builds it (e.g. a GSD so wide truncation cuts all)
        factory = normal_diameters if kind == "normal" else lognormal_diameters
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a cut is the scenario's to report
                factory(*fit.params.values())
        except ValueError as exc:
            return (
                f"the {word} fit is not a particle population a scenario accepts "
                f"({str(exc).rstrip('.')}); it is not recommended"
            )
        return None
    return (
        f"the {word} fit's {name} {value:.4g} um is not a particle population "
        f"(allowed: {lo:g} to {hi:g} um); it is not recommended"
    )


def _usable(recommended, normal, lognormal, chi_n, chi_ln):
    """``(recommended, notes)``: a fit that is not a particle population
    (:func:`_unphysical`) is never recommended; the other fit is, if it is one
    and its test (if any) does not reject it, else the measured bins."""
    fits = {"normal": (normal, chi_n), "lognormal": (lognormal, chi_ln)}
    bad = {k: _unphysical(k, f) for k, (f, _) in fits.items()}
    notes = [why for why in bad.values() if why]
    if recommended in fits and bad[recommended]:
        other = "lognormal" if recommended == "normal" else "normal"
        test = fits[other][1]
        good = not bad[other] and (test is None or not test.reject)
        recommended = other if good else "histogram"
        if recommended == "histogram":
            notes.append(
                "no fit is both a particle population and not rejected: the measured "
                "bins (a histogram population) are recommended instead"
            )
    return recommended, notes
