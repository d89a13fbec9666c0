r"""Surface-roughness characterisation: profile conditioning, local roughness angles,
ISO 4287 profile parameters and the empirical angle distribution of the paper [1]_.

Angle convention
----------------
The local roughness angle :math:`\phi` is the tilt of a surface facet from the
nominal plane (the paper's Fig. 3 and Eqs. 7-9). It is in radians inside the code
and in degrees at the interfaces (``*_deg`` names, files, plots). Particles travel
in the :math:`-x` direction (:math:`-t`), so a facet rising along :math:`+x`
(:math:`dz/dx > 0`) is tilted *away* from the particle:

.. math:: \phi = \arctan(dz/dx),

positive :math:`\phi`: facing away from the particle (it can be shadowed);
negative :math:`\phi`: facing the particle. Every function here follows it.

Two angle definitions (``method=``)
-----------------------------------
The heights are first averaged within each contact-length segment :math:`L`
(segments never straddle two scans), giving :math:`\bar H_i`. Then

* ``"paper"`` -- the paper's definition taken literally,
  :math:`\phi_i = \arctan(\bar H_i / L)`, with :math:`\bar H_i` measured from the
  scan's mean line (the paper: :math:`\arctan(\bar H/200{,}000)`, :math:`\bar H` in
  Å, :math:`L = 20` µm). It is a height-to-length ratio, not a slope: its spread
  grows with the height standard deviation and does not depend on how fast the
  heights vary along the scan;
* ``"slope"`` (default) -- the slope of the segment-averaged profile between
  neighbouring segments, :math:`\phi_i = \arctan((\bar H_{i+1} - \bar H_i)/L)`, the
  standard physical facet angle (a ramp of slope ``s`` gives :math:`\arctan s`).

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] ISO 16610-21:2011, Geometrical product specifications (GPS) -- Filtration --
   Part 21: Linear profile filters: Gaussian filters.
.. [3] ISO 4287:1997, GPS -- Surface texture: Profile method -- Terms, definitions
   and surface texture parameters.
.. [4] H. A. Sturges, "The choice of a class interval," *J. Am. Stat. Assoc.*
   21:65-66, 1926.
"""

from __future__ import annotations

import datetime
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write, data_lines, parse_number, read_lines
from .._core.json import dumps
from .._core.validation import as_float_array, check_choice, check_int, check_positive
from ..errors import DataFormatError, ProfileFormatError
from ..io.profiles import (
    UNIFORM_RTOL,
    Profile,
    ProfileSet,
    as_profiles,
    check_xz,
    sources_of,
)
from ..io.provenance import file_sha256
from ..units import m_to_um, rad_to_deg, um_to_m

__all__ = [
    "RoughnessCharacterisation",
    "characterise",
    "condition",
    "detrend",
    "gaussian_filter_profile",
    "profile_angles",
    "profile_parameters",
    "read_angle_file",
    "surface_angles",
    "write_angle_file",
]

#: Identifies the layout of :meth:`RoughnessCharacterisation.to_dict`.
ROUGHNESS_SCHEMA = "microimpact.roughness/1"
#: ISO 16610-21 Gaussian weighting constant, sqrt(ln 2 / pi).
GAUSSIAN_ALPHA = math.sqrt(math.log(2.0) / math.pi)
ANGLE_METHODS = ("slope", "paper")
DETREND_METHODS = ("line", "mean", None)


# ------------------------------------------------------------------ conditioning


def detrend(x, z, *, method="line"):
    """
    Remove a scan's form: its least-squares mean line or its mean height.

    Parameters
    ----------
    x, z : array_like, shape (n,)
        Positions and heights [m] of one scan (never several scans at once).
    method : {'line', 'mean'}
        ``'line'``: subtract the least-squares straight line (the ISO 4287 mean
        line of the primary profile); ``'mean'``: subtract the mean height.

    Returns
    -------
    ndarray, shape (n,)
        Heights about the mean line [m] (NaN stays NaN; the fit uses the measured
        points, with the trapezoidal weights of :func:`trapezoid_weights`: plain
        least squares on a uniform scan, the piecewise-linear profile's mean on a
        non-uniform one).
    """
    x, z = check_xz(x, z)
    check_choice(method, "method", ("line", "mean"))
    w = trapezoid_weights(x) * np.isfinite(z)
    zc = np.where(w > 0, z, 0.0)
    mean = (w * zc).sum() / w.sum()
    if method == "mean":
        return z - mean
    xm = (w * x).sum() / w.sum()
    xc = x - xm
    slope = (w * xc * (zc - mean)).sum() / (w * xc * xc).sum()
    return z - mean - slope * xc


def cell_weights(x) -> np.ndarray:
    """The length each sample of a scan stands for [m]: half the intervals to its
    neighbours (the whole interval at the two ends). Equal for a uniform scan, so
    weighted means are then plain means; for a non-uniform scan they make every
    mean a mean over the length of the scan, not over its points."""
    x = np.asarray(x, dtype=float)
    d = np.diff(x)
    if _is_uniform(x):
        return np.full(x.size, float(np.median(d)))
    w = np.empty(d.size + 1)
    w[0], w[-1] = d[0], d[-1]
    w[1:-1] = 0.5 * (d[:-1] + d[1:])
    return w


def _is_uniform(x) -> bool:
    d = np.diff(x)
    med = float(np.median(d))
    return bool(np.max(np.abs(d - med)) <= UNIFORM_RTOL * med)


def gaussian_filter_profile(x, z, *, cutoff):
    r"""
    ISO 16610-21 Gaussian profile filter: the roughness profile of one scan.

    The mean line is the convolution of the profile with

    .. math:: s(x) = \frac{1}{\alpha\lambda_c}
              \exp\!\left[-\pi\left(\frac{x}{\alpha\lambda_c}\right)^2\right],
              \qquad \alpha = \sqrt{\ln 2/\pi},

    whose transmission of a sinusoid of wavelength :math:`\lambda` is
    :math:`\exp[-\pi(\alpha\lambda_c/\lambda)^2]`, 50 % at the cutoff [2]_. The
    roughness profile ``z - mean line`` is returned. The weights are sampled on the
    grid, truncated at :math:`\pm\lambda_c` (where :math:`s` has fallen to
    :math:`6.5\times10^{-7}` of its peak) and renormalised to unit sum. Near the
    ends, where the window leaves the scan, the weights inside the scan are
    renormalised (zero-order end correction); the first and last
    :math:`\lambda_c/2` are less reliable.

    Parameters
    ----------
    x, z : array_like, shape (n,)
        Positions (uniformly spaced) and heights [m] of one scan.
    cutoff : float
        Cutoff wavelength :math:`\lambda_c` [m] (e.g. 0.8 mm).

    Returns
    -------
    ndarray, shape (n,)
        Roughness profile [m].
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.signal import fftconvolve

    x, z = check_xz(x, z)
    lam = float(check_positive(cutoff, "cutoff"))
    d = np.diff(x)
    dx = float(np.median(d))
    if not _is_uniform(x):
        raise ValueError(
            "the Gaussian filter (`cutoff`) needs a uniformly spaced scan; this one "
            f"has intervals from {m_to_um(d.min()):.4g} to {m_to_um(d.max()):.4g} µm: "
            "leave `cutoff` out (detrending works on any spacing)"
        )
    half = math.ceil(lam / dx)
    u = np.arange(-half, half + 1) * dx / (GAUSSIAN_ALPHA * lam)
    w = np.exp(-np.pi * u * u)  # [2], weighting function
    w /= w.sum()
    valid = np.isfinite(z)
    # missing points carry no weight: the mean line is the weighted mean of the
    # measured heights inside the window (as at the ends of the scan)
    mean_line = fftconvolve(np.where(valid, z, 0.0), w, mode="same")
    norm = fftconvolve(valid.astype(float), w, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(valid, z - mean_line / norm, np.nan)


def _condition_one(p: Profile, detrend_method, cutoff) -> Profile:
    z = p.z
    if detrend_method is not None:
        z = detrend(p.x, z, method=detrend_method)
    if cutoff is not None:
        if not p.is_uniform:
            d = np.diff(p.x)
            where = "" if p.scan is None else f" (scan {p.scan!r})"
            raise ProfileFormatError(
                "the Gaussian filter needs a uniformly spaced scan; this one"
                f"{where} has intervals from {m_to_um(d.min()):.4g} to "
                f"{m_to_um(d.max()):.4g} µm; allowed: no cutoff (leave `cutoff_um` "
                "out; detrending works on any spacing), or a uniformly resampled scan",
                source=p.source,
                field="cutoff_um",
            )
        z = gaussian_filter_profile(p.x, z, cutoff=cutoff)
    if z is p.z:
        return p
    meta = dict(p.metadata)
    meta["conditioning"] = {"detrend": detrend_method, "cutoff": cutoff}
    return Profile(p.x, z, meta)


def condition(profile_or_set, *, detrend="line", cutoff=None) -> ProfileSet:
    """
    Condition every scan separately: remove its form, optionally Gaussian-filter it.

    Parameters
    ----------
    profile_or_set : Profile, ProfileSet or list of Profile
    detrend : {'line', 'mean', None}
        Form removal per scan (see :func:`detrend`); ``None`` keeps the heights.
    cutoff : float, optional
        Gaussian filter cutoff [m] (see :func:`gaussian_filter_profile`); ``None``
        does not filter.

    Returns
    -------
    ProfileSet
    """
    check_choice(detrend, "detrend", DETREND_METHODS)
    if cutoff is not None:
        check_positive(cutoff, "cutoff")
    profiles = as_profiles(profile_or_set)
    return ProfileSet(tuple(_condition_one(p, detrend, cutoff) for p in profiles))


# ------------------------------------------------------------------ angles


def _segment_means(x, z, length, min_coverage=0.5):
    """Means of the heights in complete segments of `length`, from the scan start.

    Uniform scan: each sample stands for ``[x - dx/2, x + dx/2)``; segment ``k``
    holds the samples whose positions fall in ``[a + kL, a + (k+1)L)`` with ``a``
    the start of the first cell, and its mean is their mean. Non-uniform scan:
    the mean of the piecewise-linear profile through the real positions over
    ``[x0 + kL, x0 + (k+1)L)`` (:func:`_segment_means_nonuniform`). A segment with
    less than `min_coverage` of its length measured (missing points, gaps) gives
    ``nan``, as a height-map patch does.
    """
    if not _is_uniform(x):
        return _segment_means_nonuniform(x, z, length, min_coverage)
    w = cell_weights(x)
    start = x[0] - 0.5 * w[0]
    span = x[-1] + 0.5 * w[-1] - start
    nseg = math.floor(span / length + 1e-9)
    if nseg < 1:
        return np.empty(0)
    idx = np.floor((x - start) / length + 1e-9).astype(np.intp)
    keep = idx < nseg
    valid = keep & np.isfinite(z)
    covered = np.bincount(idx[valid], weights=w[valid], minlength=nseg)
    sums = np.bincount(idx[valid], weights=w[valid] * z[valid], minlength=nseg)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = sums / covered
    return np.where(covered >= min_coverage * length * (1 - 1e-9), means, np.nan)


def _segment_means_nonuniform(x, z, length, min_coverage):
    """Segment means of a non-uniform scan from its real positions: the mean of
    the piecewise-linear profile over ``[x0 + kL, x0 + (k+1)L)`` (exact for a
    ramp), over the intervals whose two ends are measured; ``nan`` where less than
    `min_coverage` of the segment is measured."""
    d = np.diff(x)
    a, b = z[:-1], z[1:]
    ok = np.isfinite(a) & np.isfinite(b)
    a0, b0, dd = np.where(ok, a, 0.0), np.where(ok, b, 0.0), np.where(ok, d, 0.0)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (a0 + b0) * d)])
    measured = np.concatenate([[0.0], np.cumsum(dd)])
    nseg = math.floor((x[-1] - x[0]) / length + 1e-9)
    if nseg < 1:
        return np.empty(0)
    edges = np.minimum(x[0] + np.arange(nseg + 1) * length, x[-1])
    i = np.clip(np.searchsorted(x, edges, side="right") - 1, 0, x.size - 2)
    t = (edges - x[i]) / d[i]
    at = integral[i] + d[i] * (a0[i] * t + 0.5 * (b0[i] - a0[i]) * t * t)
    cover = np.diff(measured[i] + dd[i] * t)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.diff(at) / cover
    return np.where(cover >= min_coverage * length * (1 - 1e-9), means, np.nan)


def _check_contact_length(x, length, *, source=None, scan=None):
    """A contact length shorter than the sampling interval averages nothing: each
    segment would hold one point or none. Refused, naming both numbers."""
    dx = float(np.median(np.diff(x)))
    if length < dx * (1 - 1e-9):
        where = f"scan {scan!r}" if scan is not None else "the profile"
        um = float(m_to_um(length))
        guess = ""
        if um < 1e-3:  # below 1 nm: a length in metres typed as micrometres
            guess = f" (was it given in metres? {um:g} m is {um * 1e6:g} µm)"
        raise ProfileFormatError(
            f"the contact length {um:.6g} µm{guess} is shorter than the "
            f"sampling interval {m_to_um(dx):.6g} µm of {where}: a segment would hold "
            "one point or none; allowed: a contact length of at least "
            f"{m_to_um(dx):.6g} µm (`contact_length_um`, in µm), or a scan sampled "
            "more finely",
            source=source,
            field="contact_length_um",
        )


def _angles(x, z, length, method, *, source=None, scan=None):
    _check_contact_length(x, length, source=source, scan=scan)
    h = _segment_means(x, z, length)
    need = 2 if method == "slope" else 1
    if np.count_nonzero(np.isfinite(h)) < need:
        span = x[-1] - x[0] + float(np.median(np.diff(x)))
        where = f"scan {scan!r}" if scan is not None else "profile"
        raise ProfileFormatError(
            f"{where} spans {m_to_um(span):.6g} µm ({x.size} points), shorter than "
            f"{need} contact length(s) of {m_to_um(length):.6g} µm needed by "
            f"method {method!r} (with at least half of each segment measured)",
            source=source,
        )
    if method == "paper":
        phi = np.arctan(h / length)  # [1]: phi = arctan(H_bar / L)
    else:
        phi = np.arctan(np.diff(h) / length)  # slope between neighbouring segments
    return phi[np.isfinite(phi)]


def profile_angles(x_um, z_um, *, contact_length_um, method="slope"):
    """
    Local roughness angles of one scan [degrees].

    The heights are averaged within each contact-length segment (complete segments
    from the scan start), then

    * ``method='slope'``: :math:`\\phi_i = \\arctan((\\bar H_{i+1}-\\bar H_i)/L)`,
      the slope between neighbouring segments; the heights are used as given (a
      tilted specimen shifts the angles: detrend first if that is not wanted);
    * ``method='paper'``: :math:`\\phi_i = \\arctan(\\bar H_i/L)` with
      :math:`\\bar H_i` measured from the scan's least-squares mean line, the
      paper's definition [1]_.

    Positive angles are facets rising along +x, tilted away from particles that
    travel in -x (see the module docstring).

    Parameters
    ----------
    x_um : array_like, shape (n,)
        Positions [µm], strictly increasing.
    z_um : array_like, shape (n,)
        Heights [µm].
    contact_length_um : float
        Contact length :math:`L` [µm] (the paper: 20 µm).
    method : {'slope', 'paper'}

    Returns
    -------
    ndarray
        Angles [deg]: ``n_segments - 1`` of them for ``'slope'``, ``n_segments``
        for ``'paper'``.

    Raises
    ------
    ProfileFormatError
        If the scan is shorter than the contact length (two for ``'slope'``).
    """
    x, z = check_xz(x_um, z_um)
    x, z = um_to_m(x), um_to_m(z)
    length = float(um_to_m(check_positive(contact_length_um, "contact_length_um")))
    check_choice(method, "method", ANGLE_METHODS)
    if method == "paper":
        z = detrend(x, z, method="line")
    return rad_to_deg(_angles(x, z, length, method))


def surface_angles(
    profile_or_set, *, contact_length, method="slope", detrend="line", cutoff=None
):
    """
    Local roughness angles of one or several scans [rad], segmented scan by scan.

    Each scan is conditioned (:func:`condition`), cut into complete segments of
    `contact_length` and turned into angles as in :func:`profile_angles`; the
    angles of all scans are concatenated in scan order. No segment or slope
    straddles two scans. For ``'paper'`` the heights are taken from each scan's
    mean after conditioning.

    Parameters
    ----------
    profile_or_set : Profile, ProfileSet or list of Profile
    contact_length : float
        Contact length [m].
    method : {'slope', 'paper'}
    detrend : {'line', 'mean', None}
        Per-scan form removal before segmenting.
    cutoff : float, optional
        Per-scan Gaussian filter cutoff [m].

    Returns
    -------
    ndarray
        Angles [rad].

    Raises
    ------
    ProfileFormatError
        Naming the file and scan, if a scan is shorter than the contact length(s).
    """
    length = float(check_positive(contact_length, "contact_length"))
    check_choice(method, "method", ANGLE_METHODS)
    out = []
    for p in condition(profile_or_set, detrend=detrend, cutoff=cutoff):
        z = detrend_mean(p) if method == "paper" else p.z
        out.append(_angles(p.x, z, length, method, source=p.source, scan=p.scan))
    return np.concatenate(out)


def detrend_mean(p: Profile) -> np.ndarray:
    """The heights of `p` about their (length-weighted) mean; NaN stays NaN."""
    return detrend(p.x, p.z, method="mean")


# ------------------------------------------------------------------ statistics


#: Local-slope formulas of :func:`profile_parameters`.
SLOPE_FORMULAS = ("interval", "iso7")


def _local_slope(x, z, formula="interval"):
    """Local slopes dz/dx and the length each stands for.

    ``'interval'``: the slope of each interval between neighbouring points,
    weighted by its length (the piecewise-linear profile through the measured
    points; SurfaceTopography's ``rms_slope_from_profile``), on any spacing.
    ``'iso7'``: the seven-point formula given with the ISO 4287 local slope [3]_,
    equal weights, on a uniform scan (a non-uniform scan falls back to
    ``'interval'``). Slopes touching a missing point are NaN.
    """
    if formula == "iso7" and _is_uniform(x):
        dx = float(np.median(np.diff(x)))
        if z.size < 7:
            s = np.gradient(z, x)
        else:
            s = (
                z[6:]
                - 9.0 * z[5:-1]
                + 45.0 * z[4:-2]
                - 45.0 * z[2:-4]
                + 9.0 * z[1:-5]
                - z[:-6]
            ) / (60.0 * dx)
        return s, np.ones_like(s)
    d = np.diff(x)
    return np.diff(z) / d, d


@dataclass(frozen=True)
class ProfileParameters:
    """ISO 4287 amplitude and slope parameters, pooled over all scans.

    Attributes
    ----------
    Ra : float
        Arithmetic mean deviation :math:`\\frac1n\\sum|z|` [m].
    Rq : float
        Root-mean-square deviation :math:`\\sqrt{\\frac1n\\sum z^2}` [m].
    Rsk : float
        Skewness :math:`\\frac{1}{Rq^3}\\frac1n\\sum z^3`.
    Rku : float
        Kurtosis :math:`\\frac{1}{Rq^4}\\frac1n\\sum z^4` (3 for Gaussian heights).
    Rdq : float
        RΔq, root-mean-square local slope :math:`\\sqrt{\\frac1n\\sum(dz/dx)^2}`.
    """

    Ra: float
    Rq: float
    Rsk: float
    Rku: float
    Rdq: float


def profile_parameters(
    profile_or_set, *, detrend="line", cutoff=None, slope="interval"
):
    """
    Ra, Rq, Rsk, Rku and RΔq (ISO 4287 [3]_), pooled over all scans.

    Each scan is conditioned separately (heights about its own mean line), then the
    moments are pooled over all scans by length: sample means over the measured
    points of a uniform scan, the exact integrals of the piecewise-linear profile
    of a non-uniform one (as SurfaceTopography); missing (NaN) points are left
    out. The local slopes are computed within each scan only: the
    slope of each interval (weighted by its length, the real positions), or the
    ISO seven-point formula on a uniform scan (`slope`).

    `slope` chooses the local slope of RΔq: ``'interval'`` (default), the slope
    of each interval between neighbouring points weighted by its length, the
    piecewise-linear profile on any spacing, as SurfaceTopography computes it;
    ``'iso7'``, the seven-point formula given with ISO 4287 (uniform scans), which
    smooths the slope over six intervals and so gives less on a profile with
    structure near the sampling interval (24 % less on a white-noise-like scan).

    Returns
    -------
    ProfileParameters
    """
    check_choice(slope, "slope", SLOPE_FORMULAS)
    scans = condition(profile_or_set, detrend=detrend, cutoff=cutoff)
    sums = np.zeros(5)  # length, and the integrals of |z|, z^2, z^3, z^4
    for p in scans:
        z = detrend_mean(p) if detrend is None else p.z
        sums += _moment_integrals(p.x, z)
    slopes = [_local_slope(p.x, p.z, slope) for p in scans]
    s = np.concatenate([a for a, _ in slopes])
    ws = np.concatenate([b for _, b in slopes])
    ok = np.isfinite(s)
    s, ws = s[ok], ws[ok]
    ra, m2, m3, m4 = sums[1:] / sums[0]
    rq = float(np.sqrt(m2))
    with np.errstate(invalid="ignore", divide="ignore"):
        rsk = float(m3 / rq**3)
        rku = float(m4 / rq**4)
        rdq = float(np.sqrt(np.sum(ws * s * s) / np.sum(ws))) if s.size else math.nan
    return ProfileParameters(Ra=float(ra), Rq=rq, Rsk=rsk, Rku=rku, Rdq=rdq)


def _moment_integrals(x, z) -> np.ndarray:
    """``[length, ∫|z|, ∫z², ∫z³, ∫z⁴]`` of one scan over its measured part.

    A uniform scan: sums over the measured points, each standing for one
    interval (the ISO 4287 sample means). A non-uniform scan: the exact
    integrals of the piecewise-linear profile over every interval whose two ends
    are measured (as SurfaceTopography's ``rms_height_from_profile``), so that
    densely sampled stretches do not outweigh sparse ones.
    """
    if _is_uniform(x):
        v = z[np.isfinite(z)]
        dx = float(np.median(np.diff(x)))
        return dx * np.array(
            [v.size, np.abs(v).sum(), (v * v).sum(), (v**3).sum(), (v**4).sum()]
        )
    a, b, d = z[:-1], z[1:], np.diff(x)
    ok = np.isfinite(a) & np.isfinite(b)
    a, b, d = a[ok], b[ok], d[ok]
    # ∫0^1 (a + (b - a) t)^n dt = sum_k a^k b^(n-k) / (n + 1)
    m2 = (a * a + a * b + b * b) / 3
    m3 = (a + b) * (a * a + b * b) / 4
    m4 = (a**4 + a**3 * b + a * a * b * b + a * b**3 + b**4) / 5
    same = a * b >= 0
    with np.errstate(invalid="ignore", divide="ignore"):
        m1 = np.where(
            same,
            0.5 * (np.abs(a) + np.abs(b)),
            (a * a + b * b) / (2 * np.abs(a - b)),
        )
    return np.array(
        [d.sum(), (d * m1).sum(), (d * m2).sum(), (d * m3).sum(), (d * m4).sum()]
    )


def trapezoid_weights(x) -> np.ndarray:
    """Weights whose sum with the heights is the integral of the piecewise-linear
    profile (trapezoidal rule); equal on a uniform scan (then plain means)."""
    x = np.asarray(x, dtype=float)
    d = np.diff(x)
    if _is_uniform(x):
        return np.full(x.size, float(np.median(d)))
    w = np.zeros(x.size)
    w[:-1] += 0.5 * d
    w[1:] += 0.5 * d
    return w


@dataclass(frozen=True, eq=False)
class RoughnessCharacterisation:
    """Result of :func:`characterise` (SI: angles in radians, lengths in metres).

    Attributes
    ----------
    angles : ndarray
        Local roughness angles [rad], scan by scan.
    method : str
        ``'slope'`` or ``'paper'``.
    contact_length : float
        Segment length [m].
    mean_angle, std_angle : float
        Mean and standard deviation (``ddof=1``) of the angles [rad].
    skewness_angle, kurtosis_angle : float
        Moment skewness and (Pearson, not excess) kurtosis of the angles
        (``scipy.stats.skew``, ``scipy.stats.kurtosis(fisher=False)``).
    profile : ProfileParameters
        Ra, Rq, Rsk, Rku, RΔq of the conditioned heights.
    pdf_density : ndarray
        Empirical PDF of the angles [rad⁻¹] (histogram density, Sturges' bins [4]_:
        ``ceil(log2 n) + 1`` equal bins over the range, as the paper cites).
    pdf_edges : ndarray
        Bin edges [rad].
    n_scans, n_segments : int
        Number of scans and of angles.
    conditioning : dict
        ``detrend`` and ``cutoff`` used.
    sources : list
        Files the scans came from.
    masked_fraction : float
        Share of missing (NaN) heights over all scans, left out of every mean.
    non_uniform_scans : int
        Scans whose positions are not uniformly spaced: their slopes and segments
        use the real positions (no resampling).
    """

    angles: np.ndarray
    method: str
    contact_length: float
    mean_angle: float
    std_angle: float
    skewness_angle: float
    kurtosis_angle: float
    profile: ProfileParameters
    pdf_density: np.ndarray
    pdf_edges: np.ndarray
    n_scans: int
    n_segments: int
    conditioning: dict = field(default_factory=dict)
    sources: list = field(default_factory=list)
    masked_fraction: float = 0.0
    non_uniform_scans: int = 0

    @property
    def angles_deg(self) -> np.ndarray:
        """The angles [deg]."""
        return rad_to_deg(self.angles)

    @property
    def pdf_edges_deg(self) -> np.ndarray:
        """Bin edges [deg]."""
        return rad_to_deg(self.pdf_edges)

    @property
    def pdf_density_per_deg(self) -> np.ndarray:
        """Empirical PDF [deg⁻¹]."""
        return self.pdf_density * (np.pi / 180.0)

    def to_dict(self, *, units=None) -> dict:
        """Plain data in interface units (µm, degrees), the layout of
        ``roughness.json`` (:data:`ROUGHNESS_SCHEMA`, documented in
        ``docs/roughness.md``). `units` (e.g. ``{"x_unit": ..., "z_unit": ...,
        "x_unit_from": ..., "z_unit_from": ...}`` from the profile metadata) is
        recorded as given."""
        p = self.profile
        cutoff = self.conditioning.get("cutoff")
        return {
            "schema": ROUGHNESS_SCHEMA,
            # names and hashes of the files: no folders of the user's machine
            "sources": [Path(str(x)).name for x in self.sources],
            "sources_sha256": [file_sha256(x) for x in self.sources],
            "units": dict(units or {}),
            "method": self.method,
            "contact_length_um": float(m_to_um(self.contact_length)),
            "n_scans": int(self.n_scans),
            "n_angles": int(self.n_segments),
            "angles": {
                "mean_deg": float(rad_to_deg(self.mean_angle)),
                "std_deg": float(rad_to_deg(self.std_angle)),
                "skewness": float(self.skewness_angle),
                "kurtosis": float(self.kurtosis_angle),
                "min_deg": float(rad_to_deg(self.angles.min())),
                "max_deg": float(rad_to_deg(self.angles.max())),
                "pdf_edges_deg": [float(x) for x in self.pdf_edges_deg],
                "pdf_density_per_deg": [float(x) for x in self.pdf_density_per_deg],
            },
            "profile": {
                "Ra_um": float(m_to_um(p.Ra)),
                "Rq_um": float(m_to_um(p.Rq)),
                "Rsk": float(p.Rsk),
                "Rku": float(p.Rku),
                "Rdq": float(p.Rdq),
                "Rdq_deg": float(rad_to_deg(np.arctan(p.Rdq))),
            },
            "conditioning": {
                "detrend": self.conditioning.get("detrend"),
                "cutoff_um": None if cutoff is None else float(m_to_um(cutoff)),
            },
            "data": {
                "masked_fraction": float(self.masked_fraction),
                "non_uniform_scans": int(self.non_uniform_scans),
                "positions": "real positions (no resampling)"
                if self.non_uniform_scans
                else "uniform spacing",
            },
        }

    def to_json(self, *, units=None, indent=2) -> str:
        """:meth:`to_dict` as standard JSON (NaN, e.g. the skewness of too few
        angles, is ``null``)."""

        return dumps(self.to_dict(units=units), indent=indent)

    def summary(self) -> str:
        """A short text report in interface units (µm, degrees)."""
        p = self.profile
        lines = [
            f"roughness angles: method={self.method!r}, contact length "
            f"{m_to_um(self.contact_length):.4g} µm, {self.n_segments} angles from "
            f"{self.n_scans} scan(s)",
            f"  mean {rad_to_deg(self.mean_angle):.3f}°, std "
            f"{rad_to_deg(self.std_angle):.3f}°, skewness {self.skewness_angle:.3f}, "
            f"kurtosis {self.kurtosis_angle:.3f}",
            f"profile: Ra {m_to_um(p.Ra):.4g} µm, Rq {m_to_um(p.Rq):.4g} µm, "
            f"Rsk {p.Rsk:.3f}, Rku {p.Rku:.3f}, RΔq {p.Rdq:.4g} "
            f"({rad_to_deg(np.arctan(p.Rdq)):.2f}°)",
            f"data: {100 * self.masked_fraction:.3g} % of the heights missing "
            "(masked)"
            + (
                f"; {self.non_uniform_scans} non-uniformly spaced scan(s): slopes "
                "and segments use the real positions (no resampling)"
                if self.non_uniform_scans
                else ""
            ),
        ]
        return "\n".join(lines)


def characterise(
    profile_or_set, *, contact_length, method="slope", detrend="line", cutoff=None
) -> RoughnessCharacterisation:
    """
    Characterise a rough surface from one or several profilometer scans.

    Computes the local roughness angles (:func:`surface_angles`), their mean,
    standard deviation, skewness and kurtosis, their empirical PDF (the paper's
    Fig. 4) and the ISO 4287 profile parameters (:func:`profile_parameters`).

    Parameters
    ----------
    profile_or_set : Profile, ProfileSet or list of Profile
    contact_length : float
        Contact length [m]; e.g. from
        :func:`~microimpact.surface.contact.hertz_contact_diameter`.
    method : {'slope', 'paper'}
        Angle definition (see the module docstring).
    detrend : {'line', 'mean', None}
        Per-scan form removal.
    cutoff : float, optional
        Per-scan Gaussian filter cutoff [m].

    Returns
    -------
    RoughnessCharacterisation
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy import stats

    phi = surface_angles(
        profile_or_set,
        contact_length=contact_length,
        method=method,
        detrend=detrend,
        cutoff=cutoff,
    )
    scans = as_profiles(profile_or_set)
    density, edges = np.histogram(phi, bins="sturges", density=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        skew = float(stats.skew(phi)) if phi.size > 2 else float("nan")
        kurt = float(stats.kurtosis(phi, fisher=False)) if phi.size > 3 else np.nan
    return RoughnessCharacterisation(
        angles=phi,
        method=method,
        contact_length=float(contact_length),
        mean_angle=float(phi.mean()),
        std_angle=float(phi.std(ddof=1)) if phi.size > 1 else float("nan"),
        skewness_angle=skew,
        kurtosis_angle=float(kurt),
        profile=profile_parameters(profile_or_set, detrend=detrend, cutoff=cutoff),
        pdf_density=density,
        pdf_edges=edges,
        n_scans=len(scans),
        n_segments=int(phi.size),
        conditioning={"detrend": detrend, "cutoff": cutoff},
        sources=sources_of(scans),
        masked_fraction=float(
            sum(np.count_nonzero(~p.valid) for p in scans)
            / sum(p.n_points for p in scans)
        ),
        non_uniform_scans=sum(not p.is_uniform for p in scans),
    )


# ------------------------------------------------------------------ angle files


def write_angle_file(path, angles_deg, *, n=4000, rng=None, metadata=None):
    """
    Write a sample of roughness angles, one per line in degrees, atomically.

    As in the paper [1]_, `n` angles are drawn at random (with replacement) from the
    empirical distribution `angles_deg`; ``n=None`` writes `angles_deg` as given.
    A ``#`` header records the provenance: tool and version, date, convention,
    units, the number of angles, the seed (if `rng` is an integer) and `metadata`.

    Parameters
    ----------
    path : str or path-like
        Destination; written to a temporary file in the same directory, then
        renamed over `path`.
    angles_deg : array_like
        Angles [deg], all finite and within (-90, 90).
    n : int or None
        Number of angles to draw (default 4000).
    rng : None, int or numpy.random.Generator
    metadata : dict, optional
        Extra ``key: value`` header lines.

    Returns
    -------
    ndarray
        The angles written [deg].
    """
    a = as_float_array(angles_deg, "angles_deg").ravel()
    if a.size == 0:
        raise ValueError("`angles_deg` is empty.")
    bad = ~np.isfinite(a) | (np.abs(a) >= 90.0)
    if bad.any():
        raise ValueError(
            f"`angles_deg` must be finite and within (-90, 90) deg; got {a[bad][0]!r}."
        )
    seed = rng if isinstance(rng, (int, np.integer)) else None
    if n is None:
        out = a
    else:
        n = check_int(n, "n", minimum=1)
        gen = np.random.default_rng(rng)
        out = gen.choice(a, size=n, replace=True)

    header = [
        "microimpact roughness-angle sample",
        f"microimpact version: {__version__}",
        f"created: {datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}",
        "units: degrees; one angle per line",
        "convention: phi = arctan(dz/dx); positive = facet tilted away from particles"
        " travelling in -x",
        f"n: {out.size}",
        f"drawn from: {a.size} angles"
        + (" (with replacement)" if n is not None else " (written as given)"),
    ]
    if seed is not None:
        header.append(f"seed: {int(seed)}")
    for k, v in (metadata or {}).items():
        header.append(f"{k}: {' '.join(str(v).split())}")
    text = "".join(f"# {h}\n" for h in header)
    text += "".join(f"{v:.6f}\n" for v in out)
    atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return out


def read_angle_file(path):
    """
    Read a roughness-angle file: one angle [deg] per line, ``#`` comments.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    ndarray
        The angles [deg].

    Raises
    ------
    DataFormatError
        One line naming the file and line: non-numeric or missing values, more than
        one value on a line, :math:`|\\phi| \\ge 90°`, or no angles at all.
    """
    path = os.fspath(path)
    lines = read_lines(path, error=DataFormatError)
    values = []
    for lineno, text in data_lines(lines, trailing_comments=True):
        cells = text.replace(",", " ").split()
        if len(cells) != 1:
            decimal = "; the decimal separator must be '.'" if "," in text else ""
            raise DataFormatError(
                f"expected one angle per line, found {len(cells)} values{decimal}",
                source=path,
                line=lineno,
            )
        v = parse_number(
            cells[0],
            source=path,
            line=lineno,
            allowed="an angle in degrees, -90 < angle < 90",
            what="angle",
        )
        if not abs(v) < 90.0:
            raise DataFormatError(
                f"angle {cells[0]} deg out of range; allowed -90 < angle < 90",
                source=path,
                line=lineno,
            )
        values.append(v)
    if not values:
        raise DataFormatError("no angles in the file", source=path)
    return np.asarray(values, dtype=float)
