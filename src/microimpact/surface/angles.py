r"""Distributions of the local roughness angle for the Monte Carlo engine.

An :class:`AngleDistribution` is the distribution of the roughness angle
:math:`\phi` in **radians** (the convention of
:mod:`microimpact.surface.roughness`: :math:`\phi = \arctan(dz/dx)`, positive for
facets tilted away from particles travelling in :math:`-x`). It offers the same
protocol as the population module's size distribution: vectorised ``ppf``, ``cdf``,
``pdf`` (where a density exists), ``rvs``, ``mean``, ``std``, ``kind``, ``params``
(interface units, degrees), ``describe()`` (a dict in degrees), ``median``,
``support``, ``is_discrete`` and ``table()``, which the engine turns
into a :class:`~microimpact._tables.QuantileTable`.

Every distribution is restricted to the open interval :math:`(-90°, 90°)`; the
probability mass cut off is reported in
:attr:`AngleDistribution.truncated_mass` (alias ``cut_mass``).

Factories
---------
* :func:`angles_from_sample`, :func:`angles_from_file`, :func:`angles_from_profile`:
  empirical distributions whose atoms are the measured angles (the paper [1]_ drew
  its 4,000 angles from such a distribution);
* :func:`normal_angles`: a normal distribution of the angle, as in the rough-wall
  model of Sommerfeld & Huber [2]_;
* :func:`scipy_angles`: any frozen ``scipy.stats`` distribution;
* :func:`smooth_surface`: :math:`\phi = 0` exactly.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, *Aerosol Sci. Technol.* 33:376-386, 2000.
.. [2] M. Sommerfeld and N. Huber, "Experimental analysis and modelling of
   particle-wall collisions," *Int. J. Multiphase Flow* 25:1457-1489, 1999.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._tables import TABLE_SIZE, EqualAtoms, QuantileTable
from .._validation import as_float_array, check_choice
from ..population.distributions import _scalar
from ..units import deg_to_rad, rad_to_deg

__all__ = [
    "AngleDistribution",
    "angles_from_file",
    "angles_from_profile",
    "angles_from_sample",
    "normal_angles",
    "scipy_angles",
    "smooth_surface",
]

_HALF_PI = 0.5 * math.pi
#: Largest representable angle strictly inside (-pi/2, pi/2).
_LIMIT = math.nextafter(_HALF_PI, 0.0)


class _Point:
    """All mass at one angle [rad]."""

    is_discrete = True

    def __init__(self, value):
        self.v = float(value)

    def ppf(self, q):
        return np.full(np.shape(q), self.v)

    def cdf(self, x):
        return (np.asarray(x) >= self.v).astype(float)

    def pdf(self, x):
        return np.where(np.asarray(x) == self.v, np.inf, 0.0)

    def support(self):
        return self.v, self.v

    def rvs(self, size, rng):
        return np.full(size, self.v)

    def mean(self):
        return self.v

    def std(self):
        return 0.0

    def table(self, size):
        return QuantileTable(np.full(size, self.v))


class _Continuous:
    """A frozen scipy distribution of ``phi / scale``, truncated to (-pi/2, pi/2).

    ``scale`` converts the distribution's unit to radians (pi/180 for degrees).
    """

    is_discrete = False

    def __init__(self, dist, scale):
        self.dist = dist
        self.scale = float(scale)
        lo, hi = -_HALF_PI / self.scale, _HALF_PI / self.scale
        self.lo, self.hi = lo, hi
        self.f_lo = float(dist.cdf(lo))
        self.f_hi = float(dist.cdf(hi))
        self.mass = self.f_hi - self.f_lo

    def ppf(self, q):
        u = self.f_lo + q * self.mass
        x = self.dist.ppf(u) * self.scale
        return np.clip(x, -_LIMIT, _LIMIT)

    def cdf(self, x):
        c = (self.dist.cdf(np.asarray(x) / self.scale) - self.f_lo) / self.mass
        return np.clip(c, 0.0, 1.0)

    def pdf(self, x):
        x = np.asarray(x, dtype=float)
        inside = np.abs(x) < _HALF_PI
        d = self.dist.pdf(x / self.scale) / (self.scale * self.mass)
        return np.where(inside, d, 0.0)

    def rvs(self, size, rng):
        return self.ppf(rng.random(size))

    def _moment(self, k):
        f = lambda t: t**k  # noqa: E731
        return float(self.dist.expect(f, lb=self.lo, ub=self.hi, conditional=True))

    def mean(self):
        return self._moment(1) * self.scale

    def std(self):
        m1 = self._moment(1)
        var = max(self._moment(2) - m1 * m1, 0.0)
        return math.sqrt(var) * self.scale

    def table(self, size):
        return QuantileTable.from_ppf(self.ppf, size=size)

    def support(self):
        lo, hi = self.dist.support()
        return (
            float(max(lo * self.scale, -_LIMIT)),
            float(min(hi * self.scale, _LIMIT)),
        )


@dataclass(frozen=True, eq=False)
class AngleDistribution:
    """Distribution of the local roughness angle [rad] on (-π/2, π/2).

    Build it with a factory (:func:`angles_from_sample`, :func:`normal_angles`, ...).

    Attributes
    ----------
    kind : str
        ``'empirical'``, ``'normal'``, ``'scipy'`` or ``'smooth'``.
    params : dict
        The defining parameters in interface units (degrees) and provenance.
    truncated_mass : float
        Probability mass of the source distribution outside (-90°, 90°) that was
        cut off (the fraction of sample angles dropped, for empirical ones); also
        available as :attr:`cut_mass`.

    Notes
    -----
    The discrete kinds (empirical, smooth) have no density: :meth:`pdf` returns
    ``inf`` at the atoms (a Dirac delta) and 0 elsewhere, as the population
    module's ``SizeDistribution`` does.
    """

    kind: str
    params: dict = field(default_factory=dict)
    truncated_mass: float = 0.0
    _impl: object = field(default=None, repr=False)

    @property
    def cut_mass(self) -> float:
        """Alias of :attr:`truncated_mass`."""
        return self.truncated_mass

    # -- protocol ---------------------------------------------------------------
    def ppf(self, q):
        """Quantile function: angle [rad] at probability `q`; ``nan`` outside [0, 1].

        For the discrete kinds this is the left-continuous inverse of the CDF.
        """
        q = as_float_array(q, "q")
        bad = ~((q >= 0) & (q <= 1))
        out = np.asarray(self._impl.ppf(np.where(bad, 0.5, q)), dtype=float)
        return np.where(bad, np.nan, out)[()]

    def cdf(self, x):
        """P(phi <= x) for angles `x` [rad]."""
        x = as_float_array(x, "x")
        out = np.asarray(self._impl.cdf(x), dtype=float)
        return np.where(np.isnan(x), np.nan, out)[()]

    def pdf(self, x):
        """Probability density [rad⁻¹] at `x` [rad] (``inf`` at discrete atoms)."""
        x = as_float_array(x, "x")
        out = np.asarray(self._impl.pdf(x), dtype=float)
        return np.where(np.isnan(x), np.nan, out)[()]

    @property
    def is_discrete(self) -> bool:
        """True for the empirical and smooth kinds (no density)."""
        return bool(self._impl.is_discrete)

    def rvs(self, size=None, *, rng=None):
        """Draw angles [rad] with the generator `rng` (SPEC 7)."""
        rng = np.random.default_rng(rng)
        out = np.asarray(self._impl.rvs(() if size is None else size, rng), float)
        return out[()]

    def mean(self) -> float:
        """Mean angle [rad]."""
        return self._impl.mean()

    def std(self) -> float:
        """Standard deviation of the angle [rad] (population, ``ddof=0``)."""
        return self._impl.std()

    def median(self) -> float:
        """Median angle [rad]."""
        return float(self.ppf(0.5))

    def support(self) -> tuple[float, float]:
        """(lower, upper) limits of the angle [rad]."""
        return self._impl.support()

    def table(self, size: int = TABLE_SIZE) -> QuantileTable:
        """Equiprobable atoms [rad] for the engine's sampler.

        Empirical distributions use :meth:`QuantileTable.from_sample`, so the atoms
        are the measured angles themselves; the others tabulate :meth:`ppf`.
        """
        return self._impl.table(size)

    def describe(self) -> dict:
        """Summary in interface units (degrees) for reports and provenance."""
        lo, hi = self.support()
        out = {
            "kind": self.kind,
            "params": dict(self.params),
            "mean_deg": float(rad_to_deg(self.mean())),
            "std_deg": float(rad_to_deg(self.std())),
            "median_deg": float(rad_to_deg(self.median())),
            "support_deg": (float(rad_to_deg(lo)), float(rad_to_deg(hi))),
            "truncated_mass": float(self.truncated_mass),
        }
        if isinstance(self._impl, EqualAtoms):
            out["n_atoms"] = int(self._impl.atoms.size)
        return out

    def __repr__(self) -> str:
        shown = ", ".join(
            f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v!r}"
            for k, v in self.params.items()
            if isinstance(v, int | float | str)
        )
        return (
            f"AngleDistribution(kind={self.kind!r}{', ' if shown else ''}{shown}, "
            f"truncated_mass={self.truncated_mass:.3g})"
        )


# --------------------------------------------------------------------- factories


def angles_from_sample(angles_deg, *, source=None) -> AngleDistribution:
    """
    Empirical distribution of measured angles (equal mass on each).

    Parameters
    ----------
    angles_deg : array_like
        Angles [deg]. Values with ``|angle| >= 90`` are dropped and their fraction is
        reported as :attr:`AngleDistribution.truncated_mass`.
    source : str, optional
        Provenance recorded in ``params``.

    Returns
    -------
    AngleDistribution
        ``kind='empirical'``.
    """
    a = as_float_array(angles_deg, "angles_deg").ravel()
    if a.size == 0:
        raise ValueError("`angles_deg` is empty.")
    if np.isnan(a).any():
        raise ValueError("`angles_deg` contains NaN.")
    keep = np.abs(a) < 90.0
    if not keep.any():
        raise ValueError("`angles_deg` has no angle inside (-90, 90) deg.")
    params = {"n": int(keep.sum())}
    if source is not None:
        params["source"] = str(source)
    rad = np.clip(deg_to_rad(a[keep]), -_LIMIT, _LIMIT)
    return AngleDistribution(
        "empirical", params, float(1.0 - keep.mean()), EqualAtoms(rad)
    )


def angles_from_file(path) -> AngleDistribution:
    """Empirical distribution of the angles in an angle file (see
    :func:`~microimpact.surface.roughness.read_angle_file`)."""
    from .roughness import read_angle_file

    return angles_from_sample(read_angle_file(path), source=str(path))


def angles_from_profile(
    profile_or_set,
    *,
    contact_length_um,
    method="slope",
    detrend="line",
    cutoff_um=None,
) -> AngleDistribution:
    """
    Empirical distribution of the local angles of one or several scans.

    Parameters
    ----------
    profile_or_set : Profile, ProfileSet or list of Profile
    contact_length_um : float
        Contact length [µm].
    method : {'slope', 'paper'}
        Angle definition (see :mod:`microimpact.surface.roughness`).
    detrend : {'line', 'mean', None}
        Per-scan form removal.
    cutoff_um : float, optional
        Per-scan Gaussian filter cutoff [µm].
    """
    from ..units import um_to_m
    from .roughness import surface_angles

    phi = surface_angles(
        profile_or_set,
        contact_length=float(um_to_m(contact_length_um)),
        method=method,
        detrend=detrend,
        cutoff=None if cutoff_um is None else float(um_to_m(cutoff_um)),
    )
    dist = angles_from_sample(rad_to_deg(phi))
    params = dict(dist.params)
    params.update(method=method, contact_length_um=float(contact_length_um))
    return AngleDistribution("empirical", params, dist.truncated_mass, dist._impl)


def normal_angles(std_deg, *, mean_deg=0.0) -> AngleDistribution:
    """
    Normally distributed roughness angle, truncated to (-90°, 90°).

    Sommerfeld & Huber [2]_ model the effective wall inclination as normal with
    zero mean and a standard deviation set by the roughness and the particle size.

    Parameters
    ----------
    std_deg : float
        Standard deviation of the untruncated normal [deg]; 0 gives a point mass.
    mean_deg : float
        Its mean [deg], within (-90, 90).
    """
    s = _scalar(std_deg, "std_deg", ">= 0")
    m = _scalar(mean_deg, "mean_deg")
    if not abs(m) < 90:
        raise ValueError(f"`mean_deg` must lie in (-90, 90); got {mean_deg!r}.")
    params = {"mean_deg": m, "std_deg": s}
    if s == 0:
        return AngleDistribution("normal", params, 0.0, _Point(deg_to_rad(m)))
    from scipy import stats

    impl = _Continuous(stats.norm(loc=deg_to_rad(m), scale=deg_to_rad(s)), 1.0)
    return AngleDistribution("normal", params, 1.0 - impl.mass, impl)


def scipy_angles(frozen_dist, *, unit="deg") -> AngleDistribution:
    """
    Roughness angle from a frozen ``scipy.stats`` continuous distribution.

    Parameters
    ----------
    frozen_dist : scipy.stats frozen distribution
        Distribution of the angle in `unit`; truncated to (-90°, 90°).
    unit : {'deg', 'rad'}
        Unit of `frozen_dist`'s variable.
    """
    check_choice(unit, "unit", ("deg", "rad"))
    for attr in ("ppf", "cdf", "pdf", "expect"):
        if not callable(getattr(frozen_dist, attr, None)):
            raise TypeError(
                "`frozen_dist` must be a frozen continuous scipy.stats distribution "
                f"(with .{attr}); got {frozen_dist!r}."
            )
    impl = _Continuous(frozen_dist, math.pi / 180.0 if unit == "deg" else 1.0)
    if not impl.mass > 0:
        raise ValueError("`frozen_dist` has no probability inside (-90, 90) deg.")
    name = getattr(getattr(frozen_dist, "dist", None), "name", "?")
    params = {
        "distribution": name,
        "args": tuple(getattr(frozen_dist, "args", ())),
        "kwds": dict(getattr(frozen_dist, "kwds", {})),
        "unit": unit,
    }
    return AngleDistribution("scipy", params, 1.0 - impl.mass, impl)


def smooth_surface() -> AngleDistribution:
    """A molecularly smooth surface: the roughness angle is exactly 0."""
    return AngleDistribution("smooth", {}, 0.0, _Point(0.0))
