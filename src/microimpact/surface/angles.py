r"""Distributions of the local roughness angle for the Monte Carlo engine.

An :class:`AngleDistribution` is the distribution of the roughness angle
:math:`\phi` in **radians** (the convention of
:mod:`microimpact.surface.roughness`: :math:`\phi = \arctan(dz/dx)`, positive for
facets tilted away from particles travelling in :math:`-x`). Like the population
module's size distribution it is a thin wrapper (``kind``, ``params`` in degrees,
``describe()`` in degrees) over the package's one distribution core
(:mod:`microimpact._core.distributions`): a truncated continuous distribution or
discrete atoms, with the same vectorised protocol in SI units, ``ppf``, ``isf``
(accurate in
the upper tail), ``cdf``, ``sf``, ``pdf`` (``inf`` at discrete atoms), ``rvs``,
``mean``, ``std``, ``median``, ``support``, ``is_discrete``, ``atoms``, ``weights``
and ``table()``. A molecularly smooth surface is recognised structurally by
:attr:`AngleDistribution.is_smooth` (a single atom at 0), never by its name.

Every distribution is restricted to the open interval :math:`(-90°, 90°)` through
its CDF; the probability mass cut off is reported in
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

from .._core.distributions import (
    CONTINUOUS_METHODS,
    CoreMethods,
    DiscreteAtoms,
    Rescaled,
    TruncatedContinuous,
)
from .._core.validation import as_float_array, check_choice, check_scalar
from ..io.profiles import as_profiles
from ..io.provenance import file_provenance
from ..units import deg_to_rad, rad_to_deg, um_to_m
from .roughness import read_angle_file, surface_angles

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


def _continuous(dist, what) -> TruncatedContinuous:
    """`dist` [rad] truncated to the open interval (-pi/2, pi/2)."""
    return TruncatedContinuous(
        dist,
        -_HALF_PI,
        _HALF_PI,
        open_interval=True,
        what=what,
        where="(-90, 90) deg",
    )


@dataclass(frozen=True, eq=False)
class AngleDistribution(CoreMethods):
    """Distribution of the local roughness angle [rad] on (-π/2, π/2).

    Build it with a factory (:func:`angles_from_sample`, :func:`normal_angles`, ...).
    The methods (``ppf``, ``isf``, ``cdf``, ``sf``, ``pdf``, ``rvs``, ``mean``,
    ``std``, ``median``, ``support``, ``table``) take and return angles in radians;
    they are those of :class:`microimpact._core.distributions.CoreMethods`, shared with
    :class:`~microimpact.population.distributions.SizeDistribution`.

    Attributes
    ----------
    kind : str
        ``'empirical'``, ``'normal'``, ``'scipy'`` or ``'smooth'``: a label for
        reports. Use :attr:`is_smooth`, never the kind or a name, to recognise a
        molecularly smooth surface.
    params : dict
        The defining parameters in interface units (degrees) and provenance.
    truncated_mass : float
        Probability mass of the source distribution outside (-90°, 90°) that was
        cut off (the fraction of sample angles dropped, for empirical ones); also
        available as :attr:`cut_mass`. By default the cut of the core.
    atoms, weights : ndarray or None
        Sorted atoms [rad] of a discrete distribution and their probabilities;
        ``None`` for a continuous one.
    is_discrete : bool
        True for a discrete distribution (empirical, smooth, zero-std normal).
    is_smooth : bool
        All the probability at exactly 0 rad.

    Notes
    -----
    The discrete kinds (empirical, smooth) have no density: :meth:`pdf` returns
    ``inf`` at the atoms (a Dirac delta) and 0 elsewhere, as
    ``SizeDistribution.pdf`` does.
    """

    kind: str
    params: dict = field(default_factory=dict)
    truncated_mass: float | None = None
    _core: object = field(default=None, repr=False)

    def __post_init__(self):
        if not isinstance(self._core, TruncatedContinuous | DiscreteAtoms):
            raise TypeError(
                "build an AngleDistribution with a factory (normal_angles, ...); "
                f"got core {self._core!r}."
            )
        if self.truncated_mass is None:
            object.__setattr__(self, "truncated_mass", float(self._core.truncated_mass))

    @property
    def cut_mass(self) -> float:
        """Alias of :attr:`truncated_mass`."""
        return self.truncated_mass

    @property
    def atoms(self):
        """Sorted atoms [rad] of a discrete distribution, else ``None``."""
        return self._core.atoms

    @property
    def is_smooth(self) -> bool:
        """True if the angle is exactly 0 with probability one (a molecularly smooth
        surface): a discrete distribution whose only atom is 0. Recognised from the
        distribution itself, whatever its kind or name."""
        return self.is_discrete and self.support() == (0.0, 0.0)

    def describe(self) -> dict:
        """Summary in interface units (degrees) for reports and provenance."""
        return self._describe(rad_to_deg, "deg")

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
        "empirical", params, float(1.0 - keep.mean()), DiscreteAtoms(rad)
    )


def angles_from_file(path) -> AngleDistribution:
    """Empirical distribution of the angles in an angle file (see
    :func:`~microimpact.surface.roughness.read_angle_file`)."""
    dist = angles_from_sample(read_angle_file(path))
    prov = file_provenance(path)  # the name and hash: no folders in any output
    params = {**dist.params, "source": prov["file"], "sha256": prov["sha256"]}
    return AngleDistribution("empirical", params, dist.truncated_mass, dist._core)


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
    params.update(profile_provenance(profile_or_set))
    return AngleDistribution("empirical", params, dist.truncated_mass, dist._core)


def data_provenance(metadata: dict, keys) -> dict:
    """``unit (origin)`` strings of the `keys` units of a reader's metadata, e.g.
    ``{"z_unit": "nm (file)"}``: every unit used, with where it came from."""
    out = {}
    for key in keys:
        unit = metadata.get(key)
        if unit is not None:
            origin = metadata.get(f"{key}_from")
            out[key] = f"{unit} ({origin})" if origin else str(unit)
    return out


def profile_provenance(profile_or_set) -> dict:
    """The files (names and SHA-256, no folders), units with their origin, reader,
    masked share and spacing of the scans, for a surface's description."""
    scans = as_profiles(profile_or_set)
    out = {}
    sources = []
    for p in scans:
        if p.source is not None and p.source not in sources:
            sources.append(p.source)
    if sources:
        prov = [file_provenance(src) for src in sources]
        out["files"] = ", ".join(f["file"] for f in prov)
        out["sha256"] = ", ".join(str(f["sha256"]) for f in prov)
    first = scans[0].metadata
    out.update(data_provenance(first, ("x_unit", "z_unit")))
    if first.get("reader"):
        out["reader"] = f"{first['reader']} ({first.get('format')})"
    n = sum(p.n_points for p in scans)
    out["masked_fraction"] = float(sum(np.count_nonzero(~p.valid) for p in scans) / n)
    irregular = sum(not p.is_uniform for p in scans)
    if irregular:
        out["spacing"] = (
            f"{irregular} non-uniform scan(s): real positions used (no resampling)"
        )
    return out


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
    s = check_scalar(std_deg, "std_deg", minimum=0)
    m = check_scalar(mean_deg, "mean_deg")
    if not abs(m) < 90:
        raise ValueError(f"`mean_deg` must lie in (-90, 90); got {mean_deg!r}.")
    params = {"mean_deg": m, "std_deg": s}
    if s == 0:
        return AngleDistribution("normal", params, 0.0, DiscreteAtoms([deg_to_rad(m)]))
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy import stats

    dist = stats.norm(loc=deg_to_rad(m), scale=deg_to_rad(s))
    return AngleDistribution(
        "normal", params, None, _continuous(dist, "the normal distribution")
    )


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
    for attr in CONTINUOUS_METHODS:
        if not callable(getattr(frozen_dist, attr, None)):
            raise TypeError(
                "`frozen_dist` must be a frozen continuous scipy.stats distribution "
                f"(with .{attr}); got {frozen_dist!r}."
            )
    dist = frozen_dist if unit == "rad" else Rescaled(frozen_dist, math.pi / 180.0)
    core = _continuous(dist, "`frozen_dist`")
    name = getattr(getattr(frozen_dist, "dist", None), "name", "?")
    params = {
        "distribution": name,
        "args": tuple(getattr(frozen_dist, "args", ())),
        "kwds": dict(getattr(frozen_dist, "kwds", {})),
        "unit": unit,
    }
    return AngleDistribution("scipy", params, None, core)


def smooth_surface() -> AngleDistribution:
    """A molecularly smooth surface: the roughness angle is exactly 0.

    The discrete distribution with a single atom at 0 rad; its
    :attr:`~AngleDistribution.is_smooth` is True, as is that of any distribution
    with all its probability at 0 (an all-zero sample, a zero-std normal).
    """
    return AngleDistribution("smooth", {}, 0.0, DiscreteAtoms([0.0]))
