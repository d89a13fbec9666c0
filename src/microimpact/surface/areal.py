r"""Areal roughness: levelling, ISO 25178 parameters, facet angles at the contact
scale, and synthetic Gaussian surfaces.

A height map (:class:`~microimpact.io.areal.HeightMap`) has rows along ``y`` and
columns along ``x``. The facet a particle strikes has two slopes: along the impact
direction and across it. With the impact frame ``(t, b, n)`` of
``docs/conventions.md`` (the particle travels towards ``-t``; ``b = n x t``),

.. math:: \phi_\parallel = \arctan(\partial h/\partial t), \qquad
          \phi_\perp = \arctan(\partial h/\partial b),

so the facet normal is :math:`n' \propto (-\tan\phi_\parallel, -\tan\phi_\perp, 1)`
as in :func:`microimpact.apparent_rebound`. The impact azimuth :math:`\alpha` is the
angle from the map's ``+x`` axis to ``t``, counter-clockwise (towards ``+y``): with
:math:`\alpha = 0` a particle travels towards ``-x`` and
:math:`\phi_\parallel = \arctan(\partial h/\partial x)`, the profile convention
of :mod:`microimpact.surface.roughness`.

Facet angles at the contact scale
---------------------------------
As the paper does along a profile [1]_, the heights are first averaged over the
contact area, a disc (or a square) of the contact diameter :math:`L`; then the
slopes are taken between neighbouring contact patches, :math:`L` apart along ``x``
and along ``y``:

.. math:: g_x = \frac{\bar H(x + L, y) - \bar H(x, y)}{L}, \qquad
          g_y = \frac{\bar H(x, y + L) - \bar H(x, y)}{L},

the plane through three patch centres; along one axis this is the profile
``"slope"`` method. The slope vector is rotated into the impact frame,
:math:`(s_t, s_b) = (g_x\cos\alpha + g_y\sin\alpha,\ -g_x\sin\alpha + g_y\cos\alpha)`.

Parameters (ISO 25178-2 [2]_)
-----------------------------
``Sq`` (RMS height), ``Sdq`` (RMS gradient), ``Sdr`` (developed interfacial area
ratio), ``Sal`` (autocorrelation length) and ``Str`` (texture aspect ratio), from
the levelled map; gradients by central differences.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] ISO 25178-2:2012, Geometrical product specifications (GPS) -- Surface texture:
   Areal -- Part 2: Terms, definitions and surface texture parameters, §4.1.1
   (Sq), §4.2.1-4.2.2 (Sal, Str), §4.3.1 (Sdq), §4.3.2 (Sdr).
.. [3] R. J. Adler, *The Geometry of Random Fields*, Wiley, 1981, ch. 2 (spectral
   moments: the slope variance of a stationary field is :math:`-C''(0)`).
.. [4] C. R. Dietrich and G. N. Newsam, "Fast and exact simulation of stationary
   Gaussian processes through circulant embedding of the covariance matrix," *SIAM
   J. Sci. Comput.* 18:1088-1107, 1997.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core.validation import check_choice, check_int, check_positive
from ..io.areal import HeightMap
from ..units import deg_to_rad, rad_to_deg, um_to_m
from .contact import hertz_contact_diameter

__all__ = [
    "ArealParameters",
    "FacetAngleStatistics",
    "FacetAngles",
    "areal_parameters",
    "autocorrelation",
    "contact_patch_means",
    "facet_angle_statistics",
    "facet_angles",
    "gaussian_areal_surface",
    "level_plane",
    "plane_fit",
]

PATCH_SHAPES = ("disc", "square")


def _as_height_map(height_map) -> HeightMap:
    if not isinstance(height_map, HeightMap):
        raise TypeError(
            f"`height_map` must be a HeightMap; got {type(height_map).__name__}."
        )
    return height_map


# ------------------------------------------------------------------ levelling


def plane_fit(height_map):
    """Least-squares plane ``z = c0 + cx x + cy y`` through the measured points.

    Returns
    -------
    tuple of float
        ``(c0 [m], cx [-], cy [-])``.
    """
    hm = _as_height_map(height_map)
    ok = hm.valid
    yy, xx = np.nonzero(ok)
    x, y, z = xx * hm.dx, yy * hm.dy, hm.z[ok]
    if z.size < 3:
        raise ValueError("a plane fit needs at least 3 measured points.")
    xm, ym = x.mean(), y.mean()
    a = np.column_stack([np.ones_like(x), x - xm, y - ym])
    (c0, cx, cy), *_ = np.linalg.lstsq(a, z, rcond=None)
    return float(c0 - cx * xm - cy * ym), float(cx), float(cy)


def level_plane(height_map) -> HeightMap:
    """Remove the least-squares plane (the form of a tilted specimen).

    The plane is fitted to the measured points only; missing points stay NaN. The
    result has zero mean and no residual tilt; the removed coefficients are in its
    metadata (``levelled_plane``: intercept [m], x and y slopes).
    """
    hm = _as_height_map(height_map)
    c0, cx, cy = plane_fit(hm)
    plane = c0 + cx * hm.x[None, :] + cy * hm.y[:, None]
    return hm.with_heights(hm.z - plane, levelled_plane=(c0, cx, cy))


# ------------------------------------------------------------------ parameters


@dataclass(frozen=True)
class ArealParameters:
    """ISO 25178-2 parameters of a levelled height map (SI).

    Attributes
    ----------
    Sq : float
        Root-mean-square height :math:`\\sqrt{\\overline{z^2}}` [m].
    Sdq : float
        Root-mean-square gradient
        :math:`\\sqrt{\\overline{z_x^2 + z_y^2}}` [-].
    Sdq_x, Sdq_y : float
        Its parts along x and y, :math:`\\sqrt{\\overline{z_x^2}}` and
        :math:`\\sqrt{\\overline{z_y^2}}` [-].
    Sdr : float
        Developed interfacial area ratio
        :math:`\\overline{\\sqrt{1 + z_x^2 + z_y^2}} - 1` [-] (ISO quotes it in %).
    Sal : float
        Autocorrelation length [m]: the shortest distance, over all directions, at
        which the normalised autocorrelation falls to `s` (0.2).
    Str : float
        Texture aspect ratio, ``Sal`` over the longest such distance [-]: 1 for an
        isotropic surface, towards 0 for a strongly directional one. NaN where the
        autocorrelation does not fall to `s` within the map in some direction.
    texture_direction_deg : float
        Direction (from +x, counter-clockwise, in [0, 180)) of the slowest decay of
        the autocorrelation, i.e. the lay of the texture [deg].
    """

    Sq: float
    Sdq: float
    Sdq_x: float
    Sdq_y: float
    Sdr: float
    Sal: float
    Str: float
    texture_direction_deg: float


def _gradients(hm: HeightMap):
    """Central-difference gradients (NaN where a neighbour is missing)."""
    z = hm.z
    zx = np.full(z.shape, np.nan)
    zy = np.full(z.shape, np.nan)
    zx[:, 1:-1] = (z[:, 2:] - z[:, :-2]) / (2.0 * hm.dx)
    zy[1:-1, :] = (z[2:, :] - z[:-2, :]) / (2.0 * hm.dy)
    return zx, zy


def autocorrelation(height_map):
    """Normalised areal autocorrelation of the (mean-removed) heights.

    Missing points are left out: the ACF at lag ``(kx, ky)`` is the mean of
    ``z(x) z(x + lag)`` over the pairs where both are measured, divided by its
    value at lag 0. Computed with zero-padded FFTs (no wrap-around).

    Returns
    -------
    acf : ndarray, shape (2 ny - 1, 2 nx - 1)
        Lag ``(0, 0)`` at the centre ``[ny - 1, nx - 1]``.
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.signal import fftconvolve

    hm = _as_height_map(height_map)
    ok = hm.valid
    z = np.where(ok, hm.z - np.nanmean(hm.z), 0.0)
    m = ok.astype(float)
    num = fftconvolve(z, z[::-1, ::-1], mode="full")
    cnt = fftconvolve(m, m[::-1, ::-1], mode="full")
    with np.errstate(invalid="ignore", divide="ignore"):
        acf = np.where(cnt > 0.5, num / np.maximum(cnt, 1.0), np.nan)
    return acf / acf[hm.ny - 1, hm.nx - 1]


def _decay_lengths(acf, dx, dy, s, n_directions=180):
    """Distance to the first fall of `acf` below `s` along rays in [0, 180) deg."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.ndimage import map_coordinates

    cy, cx = (acf.shape[0] - 1) // 2, (acf.shape[1] - 1) // 2
    # rays reach half the map (where enough pairs remain for a stable estimate)
    r_max = 0.5 * min(cx * dx, cy * dy)
    step = 0.25 * min(dx, dy)
    r = np.arange(0.0, r_max + step, step)
    angles = np.arange(n_directions) * (np.pi / n_directions)
    filled = np.where(np.isfinite(acf), acf, -1.0)
    out = np.full(n_directions, np.nan)
    for k, a in enumerate(angles):
        col = cx + r * np.cos(a) / dx
        row = cy + r * np.sin(a) / dy
        prof = map_coordinates(filled, [row, col], order=1, mode="nearest")
        below = np.nonzero(prof <= s)[0]
        if below.size:
            j = below[0]
            if j == 0:
                out[k] = 0.0
            else:  # linear interpolation of the crossing
                f0, f1 = prof[j - 1], prof[j]
                out[k] = r[j - 1] + (f0 - s) / (f0 - f1) * (r[j] - r[j - 1])
    return angles, out


def areal_parameters(height_map, *, level_first=True, s=0.2) -> ArealParameters:
    """ISO 25178-2 Sq, Sdq, Sdr, Sal and Str of a height map [2]_.

    Parameters
    ----------
    height_map : HeightMap
    level_first : bool, default True
        Remove the least-squares plane first (:func:`level_plane`); else only the mean.
    s : float, default 0.2
        Threshold of the autocorrelation for Sal and Str (ISO default 0.2).

    Returns
    -------
    ArealParameters

    Notes
    -----
    The gradients are central differences; points next to a missing one are left
    out of Sdq and Sdr. Sal and Str follow ISO 25178-2 §4.2: along rays from the
    origin of the autocorrelation (:func:`autocorrelation`) in 180 directions, the
    distance where it first falls to `s`; ``Sal`` is the shortest, ``Str`` the
    shortest over the longest. The rays reach half the map's smaller side.
    """
    hm = _as_height_map(height_map)
    s = float(s)
    if not 0.0 < s < 1.0:
        raise ValueError(f"`s` must lie in (0, 1); got {s!r}.")
    hm = level_plane(hm) if level_first else hm.with_heights(hm.z - np.nanmean(hm.z))
    z = hm.z[hm.valid]
    zx, zy = _gradients(hm)
    both = np.isfinite(zx) & np.isfinite(zy)
    if not both.any():
        raise ValueError("the map is too small for gradients (needs 3 x 3 points).")
    gx2, gy2 = zx[both] ** 2, zy[both] ** 2
    angles, decay = _decay_lengths(autocorrelation(hm), hm.dx, hm.dy, s)
    sal = float(np.nanmin(decay)) if np.isfinite(decay).any() else math.nan
    if np.isnan(decay).any():
        str_, lay = math.nan, math.nan
    else:
        k = int(np.argmax(decay))
        str_, lay = sal / float(decay[k]), float(rad_to_deg(angles[k]))
    return ArealParameters(
        Sq=float(np.sqrt(np.mean(z * z))),  # [2], §4.1.1
        Sdq=float(np.sqrt(np.mean(gx2 + gy2))),  # [2], §4.3.1
        Sdq_x=float(np.sqrt(np.mean(gx2))),
        Sdq_y=float(np.sqrt(np.mean(gy2))),
        Sdr=float(np.mean(np.sqrt(1.0 + gx2 + gy2)) - 1.0),  # [2], §4.3.2
        Sal=sal,  # [2], §4.2.1
        Str=str_,  # [2], §4.2.2
        texture_direction_deg=lay,
    )


# ------------------------------------------------------------------ facet angles


def _patch_kernel(length, dx, dy, shape):
    """Unit-sum averaging kernel of a disc or square of diameter `length`.

    The kernel spans ``round(length/dx)`` x ``round(length/dy)`` grid points (at
    least 1), so that a square patch holds exactly the points of one contact-length
    segment along each axis, as the profile ``"slope"`` method; a disc keeps the
    points whose centres lie within ``length/2`` of the kernel's centre.
    """
    nx = max(1, round(length / dx))
    ny = max(1, round(length / dy))
    i = (np.arange(nx) - 0.5 * (nx - 1)) * dx
    j = (np.arange(ny) - 0.5 * (ny - 1)) * dy
    if shape == "disc":
        k = (i[None, :] ** 2 + j[:, None] ** 2) <= (0.5 * length) ** 2 * (1 + 1e-9)
    else:
        k = np.ones((ny, nx), dtype=bool)
    return k.astype(float) / k.sum()


def contact_patch_means(
    height_map, *, contact_diameter, patch="disc", min_coverage=0.5
):
    """Heights averaged over a contact patch centred on every grid point.

    Parameters
    ----------
    height_map : HeightMap
    contact_diameter : float
        Diameter (disc) or side (square) of the contact patch [m].
    patch : {'disc', 'square'}
    min_coverage : float, default 0.5
        Smallest fraction of measured points inside a patch; below it the patch
        mean is NaN.

    Returns
    -------
    ndarray, shape (ny, nx)
        Patch means [m], stored at the patch's centre point (for an even number of
        points across, the one just before the centre); NaN where the patch leaves
        the map or is too sparsely measured.
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.signal import fftconvolve

    hm = _as_height_map(height_map)
    length = float(check_positive(contact_diameter, "contact_diameter"))
    check_choice(patch, "patch", PATCH_SHAPES)
    kernel = _patch_kernel(length, hm.dx, hm.dy, patch)
    ky, kx = kernel.shape
    if ky > hm.ny or kx > hm.nx:
        raise ValueError(
            f"the contact patch ({length * 1e6:.4g} µm) is larger than the map "
            f"({_extent_um(hm)})."
        )
    ok = hm.valid
    z = np.where(ok, hm.z, 0.0)
    num = fftconvolve(z, kernel, mode="valid")
    cov = fftconvolve(ok.astype(float), kernel, mode="valid")
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(cov >= min_coverage - 1e-12, num / cov, np.nan)
    out = np.full(hm.shape, np.nan)
    oy, ox = (ky - 1) // 2, (kx - 1) // 2
    out[oy : oy + mean.shape[0], ox : ox + mean.shape[1]] = mean
    return out


class FacetAnglePairs:
    """What every set of facet-angle pairs ``phi_par``, ``phi_perp`` [rad] offers
    (:class:`FacetAngles`, :class:`~microimpact.surface.areal_angles.ArealAngles`):
    the angles in degrees and their statistics."""

    @property
    def phi_par_deg(self) -> np.ndarray:
        """:attr:`phi_par` in degrees."""
        return rad_to_deg(self.phi_par)

    @property
    def phi_perp_deg(self) -> np.ndarray:
        """:attr:`phi_perp` in degrees."""
        return rad_to_deg(self.phi_perp)

    def statistics(self) -> FacetAngleStatistics:
        """Means, covariance and anisotropy of ``(phi_par, phi_perp)``
        (:func:`facet_angle_statistics`; needs 2 pairs)."""
        return facet_angle_statistics(self.phi_par, self.phi_perp)


@dataclass(frozen=True, eq=False)
class FacetAngles(FacetAnglePairs):
    """Joint samples of the facet angles at the contact scale (SI: radians).

    Attributes
    ----------
    phi_par, phi_perp : ndarray
        In-plane and out-of-plane facet angles [rad] in the impact frame: the
        ``roughness_angle_deg`` and ``out_of_plane_angle_deg`` of
        :func:`microimpact.apparent_rebound` (after conversion to degrees).
    azimuth : ndarray
        Impact azimuth of each sample [rad] (from +x to t, counter-clockwise).
    slope_x, slope_y : ndarray
        The facet slopes along the map's x and y axes [-].
    contact_diameter : float
        Patch diameter [m].
    patch : str
        ``'disc'`` or ``'square'``.
    """

    phi_par: np.ndarray
    phi_perp: np.ndarray
    azimuth: np.ndarray
    slope_x: np.ndarray
    slope_y: np.ndarray
    contact_diameter: float
    patch: str

    def __len__(self) -> int:
        return int(self.phi_par.size)


@dataclass(frozen=True)
class FacetAngleStatistics:
    """Moments of the joint facet angles ``(phi_par, phi_perp)`` [rad].

    Attributes
    ----------
    n : int
        Number of samples.
    mean : ndarray, shape (2,)
        Means of ``phi_par`` and ``phi_perp`` [rad].
    covariance : ndarray, shape (2, 2)
        Sample covariance (``ddof=1``) [rad²].
    correlation : float
        Correlation coefficient of ``phi_par`` and ``phi_perp``.
    principal_std : ndarray, shape (2,)
        Square roots of the covariance's eigenvalues, largest first [rad].
    anisotropy : float
        ``principal_std[1] / principal_std[0]`` in [0, 1]: 1 when the angles spread
        alike in every direction.
    principal_direction_deg : float
        Direction of the largest spread, from the ``phi_par`` axis towards
        ``phi_perp``, in (-90, 90] [deg].
    """

    n: int
    mean: np.ndarray
    covariance: np.ndarray
    correlation: float
    principal_std: np.ndarray
    anisotropy: float
    principal_direction_deg: float


def facet_angle_statistics(phi_par, phi_perp) -> FacetAngleStatistics:
    """Means, covariance, correlation and anisotropy of joint facet angles [rad]."""
    a = np.asarray(phi_par, dtype=float).ravel()
    b = np.asarray(phi_perp, dtype=float).ravel()
    if a.shape != b.shape or a.size < 2:
        raise ValueError("need two equally long samples of at least 2 angles.")
    cov = np.cov(np.vstack([a, b]), ddof=1)
    w, v = np.linalg.eigh(cov)  # ascending
    w = np.clip(w, 0.0, None)
    major = v[:, 1]
    direction = math.degrees(math.atan2(major[1], major[0]))
    if direction <= -90.0:
        direction += 180.0
    elif direction > 90.0:
        direction -= 180.0
    std = np.sqrt(w[::-1])
    return FacetAngleStatistics(
        n=int(a.size),
        mean=np.array([a.mean(), b.mean()]),
        covariance=cov,
        correlation=float(cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1])),
        principal_std=std,
        anisotropy=float(std[1] / std[0]) if std[0] > 0 else math.nan,
        principal_direction_deg=direction,
    )


def _contact_length(contact_diameter_um, hertz):
    if (contact_diameter_um is None) == (hertz is None):
        raise ValueError(
            "give either `contact_diameter_um` or `hertz` (a dict with diameter, "
            "density, contact_modulus and normal_speed in SI, passed to "
            "microimpact.surface.contact.hertz_contact_diameter)."
        )
    if contact_diameter_um is not None:
        return float(
            um_to_m(check_positive(contact_diameter_um, "contact_diameter_um"))
        )

    need = ("diameter", "density", "contact_modulus", "normal_speed")
    missing = [k for k in need if k not in hertz]
    extra = [k for k in hertz if k not in need]
    if missing or extra:
        raise ValueError(
            f"`hertz` needs exactly the keys {list(need)}; missing {missing}, "
            f"unknown {extra}."
        )
    length = float(np.asarray(hertz_contact_diameter(**hertz)))
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"the Hertz contact diameter is {length!r} m; it must be > 0.")
    return length


_REMEDY = (
    "allowed: a smaller contact diameter, a lower min_coverage, or a map with "
    "fewer missing points."
)


def _extent_um(hm) -> str:
    return f"{hm.nx * hm.dx * 1e6:.4g} x {hm.ny * hm.dy * 1e6:.4g} µm"


def _coverage(min_coverage) -> str:
    return f"measured over at least min_coverage = {min_coverage:g} of its area"


def facet_angles(
    height_map,
    *,
    contact_diameter_um=None,
    hertz=None,
    patch="disc",
    azimuth_deg=0.0,
    step_um=None,
    level_first=True,
    min_coverage=0.5,
    rng=None,
) -> FacetAngles:
    r"""
    Joint facet angles :math:`(\phi_\parallel, \phi_\perp)` at the contact scale.

    The heights (levelled by a least-squares plane unless ``level_first=False``)
    are averaged over a disc or square of the contact diameter :math:`L`
    (:func:`contact_patch_means`); the slopes between neighbouring patches, ``L``
    apart along x and along y, give the facet slope vector :math:`(g_x, g_y)` at
    each patch of a lattice of spacing `step_um` (default ``L``: non-overlapping
    patches, as the paper's segments). It is rotated into the impact frame of the
    azimuth :math:`\alpha`:

    .. math::

        \tan\phi_\parallel = g_x\cos\alpha + g_y\sin\alpha, \qquad
        \tan\phi_\perp = -g_x\sin\alpha + g_y\cos\alpha .

    Parameters
    ----------
    height_map : HeightMap
    contact_diameter_um : float, optional
        Contact diameter :math:`L` [µm] (the paper: 20 µm for SST76 spheres).
    hertz : dict, optional
        Instead of `contact_diameter_um`: ``diameter`` [m], ``density``
        [kg m⁻³], ``contact_modulus`` [Pa] and ``normal_speed`` [m s⁻¹] of
        :func:`~microimpact.surface.contact.hertz_contact_diameter`.
    patch : {'disc', 'square'}
        Shape of the contact patch.
    azimuth_deg : float, array_like or None, default 0
        Impact azimuth [deg]: the angle from the map's +x axis to ``t`` (the
        particle travels towards ``-t``). An array gives one azimuth per sample
        (broadcast). ``None`` draws an independent uniform azimuth in [0, 360) for
        every sample (with `rng`), to sample an anisotropic surface from all
        directions.
    step_um : float, optional
        Spacing of the sampled patches [µm]; default ``L``. A smaller step gives
        more, overlapping (correlated) samples.
    level_first : bool, default True
        Remove the least-squares plane first.
    min_coverage : float, default 0.5
        See :func:`contact_patch_means`; samples touching a sparser patch are
        dropped.
    rng : None, int or numpy.random.Generator
        For ``azimuth_deg=None``.

    Returns
    -------
    FacetAngles
        Samples in row-major lattice order.
    """
    hm = _as_height_map(height_map)
    length = _contact_length(contact_diameter_um, hertz)
    spacing = max(hm.dx, hm.dy)
    if length < spacing * (1 - 1e-9):
        raise ValueError(
            f"the contact diameter {length * 1e6:.6g} µm is smaller than the map's "
            f"spacing (dx = {hm.dx * 1e6:.6g} µm, dy = {hm.dy * 1e6:.6g} µm): a "
            "contact patch would be one pixel; allowed: a contact diameter of at "
            f"least {spacing * 1e6:.6g} µm (the contact length or diameter is in "
            "µm), or a map sampled more finely."
        )
    if level_first:
        hm = level_plane(hm)
    means = contact_patch_means(
        hm, contact_diameter=length, patch=patch, min_coverage=min_coverage
    )
    sx = max(1, round(length / hm.dx))  # L in grid steps
    sy = max(1, round(length / hm.dy))
    if 2 * sx > hm.nx or 2 * sy > hm.ny:  # the patches (sy x sx points) fit
        raise ValueError(
            f"the map ({_extent_um(hm)}) is smaller than two contact patches "
            f"({length * 1e6:.4g} µm) along x or y; allowed: a contact diameter "
            "below half the map's width and height."
        )
    h00 = means[:-sy, :-sx]
    gx = (means[:-sy, sx:] - h00) / (sx * hm.dx)  # neighbour patch along x
    gy = (means[sy:, :-sx] - h00) / (sy * hm.dy)  # neighbour patch along y
    step = (
        length
        if step_um is None
        else float(um_to_m(check_positive(step_um, "step_um")))
    )
    px = max(1, round(step / hm.dx))
    py = max(1, round(step / hm.dy))
    # start the lattice at the first complete patch
    ok_rows = np.nonzero(np.isfinite(h00).any(axis=1))[0]
    ok_cols = np.nonzero(np.isfinite(h00).any(axis=0))[0]
    if ok_rows.size == 0:
        raise ValueError(
            f"no contact patch ({length * 1e6:.4g} µm) is {_coverage(min_coverage)} "
            f"on the map ({_extent_um(hm)}, {hm.valid_fraction:.3g} of it measured); "
            f"{_REMEDY}"
        )
    gx = gx[ok_rows[0] :: py, ok_cols[0] :: px].ravel()
    gy = gy[ok_rows[0] :: py, ok_cols[0] :: px].ravel()
    keep = np.isfinite(gx) & np.isfinite(gy)
    gx, gy = gx[keep], gy[keep]
    if gx.size == 0:
        raise ValueError(
            "no pair of neighbouring contact patches "
            f"({length * 1e6:.4g} µm) is each {_coverage(min_coverage)} on the map "
            f"({_extent_um(hm)}, {hm.valid_fraction:.3g} of it measured); {_REMEDY}"
        )
    if azimuth_deg is None:
        alpha = np.random.default_rng(rng).uniform(0.0, 2.0 * np.pi, gx.size)
    else:
        alpha = np.broadcast_to(deg_to_rad(np.asarray(azimuth_deg, float)), gx.shape)
        alpha = np.array(alpha)
    c, s = np.cos(alpha), np.sin(alpha)
    return FacetAngles(
        phi_par=np.arctan(gx * c + gy * s),
        phi_perp=np.arctan(-gx * s + gy * c),
        azimuth=alpha,
        slope_x=gx,
        slope_y=gy,
        contact_diameter=length,
        patch=patch,
    )


# ------------------------------------------------------------------ synthetic


#: Largest synthetic areal surface (points): its FFTs then need about 2.7 GB.
MAX_SYNTHETIC_POINTS = 2**26


def gaussian_areal_surface(
    nx, ny, *, dx_um, dy_um=None, rms_um, corr_x_um, corr_y_um=None, seed=None
) -> HeightMap:
    r"""
    Gaussian random surface with a Gaussian autocorrelation, by spectral synthesis.

    The autocorrelation is

    .. math:: C(\tau_x, \tau_y) = \sigma^2
              \exp\!\left(-\frac{\tau_x^2}{\ell_x^2} - \frac{\tau_y^2}{\ell_y^2}\right),

    (the convention of :func:`~microimpact.surface.synthetic.gaussian_profile`:
    :math:`\ell` is the lag where it falls to :math:`1/e`), isotropic for
    :math:`\ell_x = \ell_y`. The heights are white noise filtered in Fourier space
    by the square root of the spectrum: with :math:`\lambda` the 2-D DFT of
    :math:`C` at the wrapped lags of the grid, :math:`z = \mathrm{IFFT2}(\sqrt{
    \lambda}\,\mathrm{FFT2}(w))`, :math:`w \sim N(0, 1)`, whose circulant covariance
    is :math:`C` at those lags [4]_ (exactly, where no :math:`\lambda < 0` had to
    be clipped). The surface is periodic; keep ``n dx`` much larger than
    :math:`\ell`.

    Expected values: RMS height :math:`\sigma`; RMS slope along x
    :math:`\sqrt{-\partial^2 C/\partial\tau_x^2(0)}/\sigma\cdot\sigma =
    \sqrt2\,\sigma/\ell_x` and along y :math:`\sqrt2\,\sigma/\ell_y` [3]_; a forward
    difference over ``h`` has the variance :math:`2[C(0) - C(h)]/h^2`; Str is
    :math:`\ell_{min}/\ell_{max}` and the autocorrelation falls to 0.2 at
    :math:`\ell\sqrt{\ln 5}`.

    Parameters
    ----------
    nx, ny : int
        Points along x (columns) and y (rows).
    dx_um, dy_um : float
        Grid spacing [µm]; `dy_um` defaults to `dx_um`.
    rms_um : float
        RMS height :math:`\sigma` [µm].
    corr_x_um, corr_y_um : float
        Correlation lengths :math:`\ell_x, \ell_y` [µm]; `corr_y_um` defaults to
        `corr_x_um` (isotropic).
    seed : None, int or numpy.random.Generator

    Returns
    -------
    HeightMap
        Heights [m] (mean not removed).
    """
    nx = check_int(nx, "nx", minimum=2)
    ny = check_int(ny, "ny", minimum=2)
    if nx * ny > MAX_SYNTHETIC_POINTS:  # the FFTs need ~40 bytes per point
        raise ValueError(
            f"`nx` x `ny` = {nx * ny:,} points; at most {MAX_SYNTHETIC_POINTS:,} "
            "(e.g. 8192 x 8192)"
        )
    dx = float(um_to_m(check_positive(dx_um, "dx_um")))
    dy = dx if dy_um is None else float(um_to_m(check_positive(dy_um, "dy_um")))
    sigma = float(um_to_m(check_positive(rms_um, "rms_um")))
    lx = float(um_to_m(check_positive(corr_x_um, "corr_x_um")))
    ly = (
        lx
        if corr_y_um is None
        else float(um_to_m(check_positive(corr_y_um, "corr_y_um")))
    )
    rng = np.random.default_rng(seed)
    i, j = np.arange(nx), np.arange(ny)
    tx = np.minimum(i, nx - i) * dx  # wrapped lags
    ty = np.minimum(j, ny - j) * dy
    acf = sigma**2 * np.exp(-((tx[None, :] / lx) ** 2) - (ty[:, None] / ly) ** 2)
    lam = np.clip(np.fft.rfft2(acf).real, 0.0, None)
    w = rng.standard_normal((ny, nx))
    z = np.fft.irfft2(np.sqrt(lam) * np.fft.rfft2(w), s=(ny, nx))
    meta = {
        "synthetic": "gaussian_areal_surface",
        "rms_height": sigma,
        "correlation_length_x": lx,
        "correlation_length_y": ly,
    }
    return HeightMap(z, dx, dy, meta)
