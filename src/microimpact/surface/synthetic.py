r"""Synthetic rough-surface profiles.

* :func:`gaussian_profile`: a stationary Gaussian random profile with a Gaussian
  autocorrelation function :math:`C(\tau) = \sigma^2 \exp(-\tau^2/\ell^2)` (or any
  given power spectral density), made by filtering white noise with the FFT. Its
  RMS height is :math:`\sigma` and its RMS slope :math:`\sqrt{2}\,\sigma/\ell`.
* :func:`weierstrass_mandelbrot_profile`: the random-phase Weierstrass-Mandelbrot
  fractal profile of Majumdar & Bhushan [1]_,

  .. math:: z(x) = G^{D-1} \sum_{n=n_1}^{n_2}
            \frac{\cos(2\pi\gamma^n x + \varphi_n)}{\gamma^{(2-D)n}},
            \qquad 1 < D < 2,\ \gamma > 1,

  whose power spectrum falls as :math:`\omega^{-(5-2D)}` and whose structure
  function :math:`\langle[z(x+\tau)-z(x)]^2\rangle` grows as :math:`\tau^{4-2D}`.
* :func:`ripple_profile`: an asymmetric (saw-tooth) ripple: ramps that rise steeply
  over a fraction :math:`w` of each period at the angle :math:`\alpha` and fall
  gently over the rest, with random periods. Its slopes are :math:`\tan\alpha`
  (a fraction :math:`w` of the length) and :math:`-\tan\alpha\,w/(1-w)` (the
  rest): a profile whose slope distribution is asymmetric, which no Gaussian
  (or other time-reversible) profile has.
* :func:`formica_profile`: the shipped SYNTHETIC Formica-like profile set (10 scans x
  8,000 points at 0.5 µm; see ``surface/data/make_formica_profile.py``).

References
----------
.. [1] A. Majumdar and B. Bhushan, "Fractal model of elastic-plastic contact between
   rough surfaces," *J. Tribology* 113:1-11, 1991.
"""

from __future__ import annotations

import math
from importlib import resources

import numpy as np

from .._core.validation import as_float_array, check_int, check_positive, check_scalar
from ..io.profiles import Profile, ProfileSet, read_profiles

__all__ = [
    "formica_profile",
    "gaussian_profile",
    "ripple_profile",
    "weierstrass_mandelbrot_profile",
]

FORMICA_FILE = "formica_synthetic_profile.csv"


def gaussian_profile(
    n, dx, *, rms_height=None, correlation_length=None, psd=None, rng=None
) -> Profile:
    r"""
    Gaussian random profile by FFT filtering of white noise.

    With `rms_height` :math:`\sigma` and `correlation_length` :math:`\ell`, the
    autocorrelation is :math:`C(\tau) = \sigma^2\exp(-\tau^2/\ell^2)` and the
    circulant covariance of the ``n`` samples has exactly this autocorrelation at
    the wrapped lags: the eigenvalues :math:`\lambda_k` are the DFT of
    :math:`C(j\,dx)`, and :math:`z = \mathrm{IFFT}(\sqrt{\lambda_k}\,\mathrm{FFT}(w))`
    for white noise :math:`w \sim N(0, 1)`. Analytic values: RMS height
    :math:`\sigma`, RMS slope :math:`\sqrt{2}\sigma/\ell`. The profile is periodic
    over its length, so keep ``n * dx`` much larger than :math:`\ell`.

    Alternatively give `psd`, a callable returning the two-sided power spectral
    density :math:`S(k) = \int C(\tau) e^{-ik\tau} d\tau` [m³] at wavenumbers
    :math:`k` [rad m⁻¹]; then :math:`\lambda_k = S(k)/dx`.

    Parameters
    ----------
    n : int
        Number of points.
    dx : float
        Sampling interval [m].
    rms_height : float, optional
        :math:`\sigma` [m].
    correlation_length : float, optional
        :math:`\ell` [m] (the lag where the ACF falls to :math:`1/e`).
    psd : callable, optional
        ``psd(k) -> S`` [m³], instead of `rms_height` and `correlation_length`.
    rng : None, int or numpy.random.Generator

    Returns
    -------
    Profile
        ``x = arange(n) * dx`` [m], ``z`` [m] (mean not removed).
    """
    n = check_int(n, "n", minimum=2)
    dx = float(check_positive(dx, "dx"))
    rng = np.random.default_rng(rng)
    if psd is None:
        if rms_height is None or correlation_length is None:
            raise ValueError(
                "give `rms_height` and `correlation_length`, or a `psd` callable."
            )
        sigma = float(check_positive(rms_height, "rms_height"))
        ell = float(check_positive(correlation_length, "correlation_length"))
        j = np.arange(n)
        lag = np.minimum(j, n - j) * dx
        acf = sigma**2 * np.exp(-((lag / ell) ** 2))
        lam = np.fft.rfft(acf).real
        meta = {"rms_height": sigma, "correlation_length": ell}
    else:
        if rms_height is not None or correlation_length is not None:
            raise ValueError(
                "give either `psd` or `rms_height` and `correlation_length`."
            )
        if not callable(psd):
            raise TypeError(f"`psd` must be callable; got {psd!r}.")
        k = 2.0 * np.pi * np.fft.rfftfreq(n, d=dx)
        lam = np.asarray(psd(k), dtype=float) / dx
        if lam.shape != k.shape or not np.all(np.isfinite(lam)):
            raise ValueError("`psd(k)` must return finite values, one per wavenumber.")
        meta = {"psd": getattr(psd, "__name__", repr(psd))}
    lam = np.clip(lam, 0.0, None)
    w = rng.standard_normal(n)
    z = np.fft.irfft(np.sqrt(lam) * np.fft.rfft(w), n=n)
    meta["synthetic"] = "gaussian_profile"
    return Profile(np.arange(n) * dx, z, meta)


def ripple_profile(
    n, dx, *, period, rise_fraction, rise_angle, period_shape=4.0, rng=None
) -> Profile:
    r"""
    Asymmetric saw-tooth ripple with random periods.

    Each period :math:`P_k` (independent, gamma distributed with shape
    `period_shape` and mean `period`) rises linearly over :math:`w P_k` at the
    angle :math:`\alpha` (`rise_angle`, :math:`0 < \alpha < 90°`) and falls
    linearly over :math:`(1 - w) P_k` back to its start, so the profile is
    continuous, its amplitude :math:`h_k = w P_k \tan\alpha` varies with the
    period, and exactly two slopes occur: :math:`\tan\alpha` on a fraction
    :math:`w` of the length and :math:`-\tan\alpha\, w/(1-w)` on the rest (mean
    slope zero). The first period starts at a uniformly random phase. A positive
    slope rises along :math:`+x`: with particles travelling in :math:`-x`
    (``docs/conventions.md``) the steep faces point away from them; negate `z` (or
    reverse `x`) for the mirror image.

    Parameters
    ----------
    n : int
        Number of points.
    dx : float
        Sampling interval [m].
    period : float
        Mean period [m].
    rise_fraction : float
        :math:`w`, the fraction of each period that rises, 0 < w < 1.
    rise_angle : float
        :math:`\alpha` [rad], 0 < alpha < pi/2.
    period_shape : float
        Shape of the gamma distribution of the periods (their coefficient of
        variation is ``1/sqrt(period_shape)``).
    rng : None, int or numpy.random.Generator

    Returns
    -------
    Profile
        ``x = arange(n) * dx`` [m], ``z`` [m] (mean not removed).
    """
    n = check_int(n, "n", minimum=2)
    dx = float(check_positive(dx, "dx"))
    mean_p = float(check_positive(period, "period"))
    w = check_scalar(rise_fraction, "rise_fraction")
    if not 0.0 < w < 1.0:
        raise ValueError(f"`rise_fraction` must lie in (0, 1); got {w!r}.")
    alpha = check_scalar(rise_angle, "rise_angle")
    if not 0.0 < alpha < 0.5 * np.pi:
        raise ValueError(f"`rise_angle` must lie in (0, pi/2) rad; got {alpha!r}.")
    shape = float(check_positive(period_shape, "period_shape"))
    rng = np.random.default_rng(rng)
    length = n * dx
    # enough periods to cover the profile after a random phase, with a margin
    k = int(np.ceil(2.0 * length / mean_p)) + 8
    while True:
        p = rng.gamma(shape, mean_p / shape, size=k)
        if p.sum() > length + p[0]:
            break
        k *= 2
    start = np.concatenate([[0.0], np.cumsum(p)]) - rng.uniform(0.0, p[0])
    x = np.arange(n) * dx
    i = np.searchsorted(start, x, side="right") - 1
    u = x - start[i]  # position within its period
    rise = w * p[i]
    tan_a = math.tan(alpha)
    z = np.where(u < rise, u * tan_a, (p[i] - u) * tan_a * w / (1.0 - w))
    meta = {
        "synthetic": "ripple_profile",
        "period": mean_p,
        "rise_fraction": w,
        "rise_angle": alpha,
        "period_shape": shape,
    }
    return Profile(x, z, meta)


def weierstrass_mandelbrot_profile(
    x, *, fractal_dimension, G, gamma=1.5, n_low=None, n_high=None, rng=None
):
    r"""
    Random-phase Weierstrass-Mandelbrot fractal profile (Majumdar & Bhushan [1]_).

    .. math:: z(x) = G^{D-1} \sum_{n=n_1}^{n_2}
              \frac{\cos(2\pi\gamma^n x + \varphi_n)}{\gamma^{(2-D)n}}

    with independent uniform phases :math:`\varphi_n \in [0, 2\pi)`. The spatial
    frequencies are :math:`\gamma^n` [m⁻¹]; by default they span from the inverse
    profile length (:math:`n_1 = \lfloor \log(1/L)/\log\gamma \rfloor`) to the
    Nyquist frequency (:math:`n_2 = \lceil \log(1/(2\,dx))/\log\gamma \rceil`). The
    PSD is :math:`S(\omega) = G^{2(D-1)}/(2\ln\gamma\,\omega^{5-2D})` and the
    structure function grows as :math:`\tau^{4-2D}` between the two cut-offs.

    Parameters
    ----------
    x : array_like
        Positions [m].
    fractal_dimension : float
        :math:`D`, with 1 < D < 2.
    G : float
        Fractal roughness :math:`G` [m].
    gamma : float
        Frequency ratio :math:`\gamma > 1` (1.5 in [1]_).
    n_low, n_high : int, optional
        First and last frequency index.
    rng : None, int or numpy.random.Generator

    Returns
    -------
    ndarray
        Heights [m], shaped like `x`.
    """
    x = as_float_array(x, "x")
    d = check_scalar(fractal_dimension, "fractal_dimension")
    if not 1.0 < d < 2.0:
        raise ValueError(f"`fractal_dimension` must lie in (1, 2); got {d!r}.")
    g = check_scalar(G, "G", minimum=0, strict=True)
    gamma = check_scalar(gamma, "gamma", minimum=0, strict=True)
    if not gamma > 1.0:
        raise ValueError(f"`gamma` must be > 1; got {gamma!r}.")
    rng = np.random.default_rng(rng)
    xs = np.sort(x.ravel())
    if n_low is None or n_high is None:
        if xs.size < 2 or not xs[-1] > xs[0]:
            raise ValueError("give `n_low` and `n_high` when `x` has no extent.")
        dx = float(np.min(np.diff(xs)[np.diff(xs) > 0]))
        span = float(xs[-1] - xs[0])
        lg = math.log(gamma)
        if n_low is None:
            n_low = math.floor(math.log(1.0 / span) / lg)
        if n_high is None:
            n_high = math.ceil(math.log(1.0 / (2.0 * dx)) / lg)
    if isinstance(n_low, bool) or not isinstance(n_low, (int, np.integer)):
        raise ValueError(f"`n_low` must be an integer; got {n_low!r}.")
    if isinstance(n_high, bool) or not isinstance(n_high, (int, np.integer)):
        raise ValueError(f"`n_high` must be an integer; got {n_high!r}.")
    if n_high < n_low:
        raise ValueError(f"`n_high` ({n_high}) must be >= `n_low` ({n_low}).")
    ns = np.arange(int(n_low), int(n_high) + 1)
    phases = rng.uniform(0.0, 2.0 * np.pi, size=ns.size)
    freq = gamma ** ns.astype(float)
    amp = g ** (d - 1.0) * gamma ** (-(2.0 - d) * ns.astype(float))  # [1]
    flat = x.ravel()
    z = np.zeros_like(flat)
    for f, a, ph in zip(freq, amp, phases, strict=True):
        z += a * np.cos(2.0 * np.pi * f * flat + ph)
    return z.reshape(x.shape)[()]


def formica_profile() -> ProfileSet:
    """
    The shipped SYNTHETIC Formica-like profile set.

    Ten scans of 8,000 points at 0.5 µm (4 mm each): Gaussian waviness
    (correlation length 500 µm) plus an asymmetric saw-tooth ripple
    (:func:`ripple_profile`: rising at 35° over 10 % of each period of mean
    250 µm), height standard deviation 45 µm (the paper's value for its Formica
    scan), generated by ``microimpact/surface/data/make_formica_profile.py``
    from a fixed seed; its parameters were chosen against the paper's statements
    (``docs/figures/formica_search.py``). It is not a measurement: it stands in
    for the paper's (unpublished) profilometer data.

    Returns
    -------
    ProfileSet
    """
    ref = resources.files("microimpact").joinpath("surface", "data", FORMICA_FILE)
    with resources.as_file(ref) as path:
        return read_profiles(path, unit="um")
