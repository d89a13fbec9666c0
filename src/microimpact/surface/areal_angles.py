r"""Joint facet-angle distributions of areal surfaces, for the Monte Carlo engine.

An :class:`ArealAngles` is the distribution of the facet angle *pair*
:math:`(\phi_\parallel, \phi_\perp)` [rad] of an areal surface (issue 14): equal-mass
joint samples, e.g. the contact-scale facet angles of a height map
(:func:`microimpact.surface.areal.facet_angles`). :math:`\phi_\parallel` is the
paper's roughness angle (in the plane of incidence), :math:`\phi_\perp` the tilt
across it; the facet normal is :math:`n' \propto (-\tan\phi_\parallel,
-\tan\phi_\perp, 1)` (``docs/conventions.md`` §8), the arguments
``roughness_angle_deg`` and ``out_of_plane_angle_deg`` of
:func:`microimpact.apparent_rebound`.

It is what a :class:`~microimpact.scenario.scenario.SurfaceVariant` holds for an areal
surface; the engine draws one pair per impact, with one uniform, from the table of
the pairs (:mod:`microimpact.engine.plan`, ``ArealSampler``). A profile surface
keeps its one-angle :class:`~microimpact.surface.angles.AngleDistribution`
(:math:`\phi_\perp = 0`).

Factories
---------
* :func:`areal_angles_from_sample`: from two arrays of angles [deg];
* :func:`areal_angles_from_facets`: from a
  :class:`~microimpact.surface.areal.FacetAngles`;
* :func:`areal_angles_from_height_map`: a height map's contact-scale facet angles;
* :func:`gaussian_areal_angles`: those of a seeded synthetic Gaussian areal surface
  (:func:`~microimpact.surface.areal.gaussian_areal_surface`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .._core.validation import as_float_array
from ..io.provenance import file_provenance
from ..units import deg_to_rad, rad_to_deg
from .angles import data_provenance
from .areal import FacetAnglePairs, facet_angles, gaussian_areal_surface

__all__ = [
    "ArealAngles",
    "areal_angles_from_facets",
    "areal_angles_from_height_map",
    "areal_angles_from_sample",
    "gaussian_areal_angles",
]

#: Largest representable angle strictly inside (-pi/2, pi/2).
_LIMIT = math.nextafter(0.5 * math.pi, 0.0)


@dataclass(frozen=True, eq=False)
class ArealAngles(FacetAnglePairs):
    r"""Equal-mass joint samples of the facet angles :math:`(\phi_\parallel,
    \phi_\perp)` [rad] of an areal surface.

    Build it with a factory (:func:`areal_angles_from_sample`, ...). The pairs are
    kept sorted by :math:`\phi_\parallel`, then :math:`\phi_\perp` (the order the
    engine's table uses); each carries the probability ``1/n``.

    Attributes
    ----------
    phi_par, phi_perp : ndarray
        The pairs [rad], read-only, in (-π/2, π/2).
    params : dict
        Provenance and defining parameters in interface units (µm, degrees).
    truncated_mass : float
        Fraction of the input pairs dropped because an angle was outside
        (-90°, 90°).
    kind : str
        ``'areal'`` (a label for reports).
    """

    phi_par: np.ndarray
    phi_perp: np.ndarray
    params: dict = field(default_factory=dict)
    truncated_mass: float = 0.0
    kind: str = "areal"

    #: The engine recognises a joint (two-angle) distribution by this flag.
    is_areal = True
    #: Equal-mass atoms (pairs).
    is_discrete = True

    def __post_init__(self):
        a = np.asarray(self.phi_par, dtype=float).ravel()
        b = np.asarray(self.phi_perp, dtype=float).ravel()
        if a.shape != b.shape or a.size == 0:
            raise ValueError(
                "`phi_par` and `phi_perp` must be non-empty arrays of the same "
                f"length; got {a.size} and {b.size}."
            )
        bad = ~(np.isfinite(a) & np.isfinite(b))
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"facet angle pair {i} is not finite: ({a[i]!r}, {b[i]!r}) rad."
            )
        if np.any(np.abs(a) > _LIMIT) or np.any(np.abs(b) > _LIMIT):
            raise ValueError("facet angles must lie inside (-pi/2, pi/2) rad.")
        order = np.lexsort((b, a))  # by phi_par, then phi_perp
        a, b = a[order], b[order]
        a.setflags(write=False)
        b.setflags(write=False)
        object.__setattr__(self, "phi_par", a)
        object.__setattr__(self, "phi_perp", b)

    # -- the protocol SurfaceVariant and the result layer read ------------------------
    def __len__(self) -> int:
        return int(self.phi_par.size)

    @property
    def n(self) -> int:
        """Number of pairs."""
        return len(self)

    @property
    def is_smooth(self) -> bool:
        """Every pair is exactly (0, 0): a molecularly smooth surface."""
        return not (np.any(self.phi_par) or np.any(self.phi_perp))

    def support(self) -> tuple[float, float]:
        """Range of :math:`\\phi_\\parallel` [rad] (the angle that decides
        shadowing)."""
        return float(self.phi_par[0]), float(self.phi_par[-1])

    def support_perp(self) -> tuple[float, float]:
        """Range of :math:`\\phi_\\perp` [rad]."""
        return float(self.phi_perp.min()), float(self.phi_perp.max())

    def ppf(self, q) -> np.ndarray:
        """Quantile function of the marginal of :math:`\\phi_\\parallel` [rad] (the
        equal-mass atoms' step function: the smallest atom with ``F >= q``)."""
        q = np.asarray(q, dtype=float)
        n = self.n
        k = np.clip(np.ceil(q * n).astype(np.int64) - 1, 0, n - 1)
        return self.phi_par[k]

    def mean(self) -> float:
        """Mean of :math:`\\phi_\\parallel` [rad]."""
        return float(self.phi_par.mean())

    def std(self) -> float:
        """Standard deviation of :math:`\\phi_\\parallel` [rad] (``ddof=0``)."""
        return float(self.phi_par.std())

    def describe(self) -> dict:
        """Summary in interface units (degrees) for reports and provenance."""

        def deg(x):
            return float(rad_to_deg(x))

        out = {
            "kind": self.kind,
            "params": dict(self.params),
            "n_pairs": self.n,
            "mean_deg": deg(self.phi_par.mean()),
            "std_deg": deg(self.phi_par.std()),
            "support_deg": tuple(deg(v) for v in self.support()),
            "perp_mean_deg": deg(self.phi_perp.mean()),
            "perp_std_deg": deg(self.phi_perp.std()),
            "perp_support_deg": tuple(deg(v) for v in self.support_perp()),
            "truncated_mass": float(self.truncated_mass),
        }
        if self.n >= 2 and self.phi_par.std() > 0 and self.phi_perp.std() > 0:
            st = self.statistics()
            out["correlation"] = float(st.correlation)
            out["anisotropy"] = float(st.anisotropy)
        return out

    def __repr__(self) -> str:
        return (
            f"ArealAngles(n={self.n}, std_par_deg={self.describe()['std_deg']:.4g}, "
            f"std_perp_deg={self.describe()['perp_std_deg']:.4g})"
        )


# --------------------------------------------------------------------- factories
def areal_angles_from_sample(phi_par_deg, phi_perp_deg, *, source=None, params=None):
    """Joint distribution of measured facet-angle pairs [deg] (equal mass each).

    Pairs with ``|angle| >= 90`` in either angle are dropped and their fraction is
    reported as :attr:`ArealAngles.truncated_mass`; NaN is an error.
    """
    a = as_float_array(phi_par_deg, "phi_par_deg").ravel()
    b = as_float_array(phi_perp_deg, "phi_perp_deg").ravel()
    if a.shape != b.shape:
        raise ValueError(
            f"`phi_par_deg` and `phi_perp_deg` need one value per pair; got "
            f"{a.size} and {b.size}."
        )
    if a.size == 0:
        raise ValueError("no facet angle pairs.")
    if np.isnan(a).any() or np.isnan(b).any():
        raise ValueError("the facet angles contain NaN.")
    keep = (np.abs(a) < 90.0) & (np.abs(b) < 90.0)
    if not keep.any():
        raise ValueError("no facet angle pair inside (-90, 90) deg.")
    p = {"n": int(keep.sum())}
    if params:
        p.update(params)
    if source is not None:
        p["source"] = str(source)
    return ArealAngles(
        np.clip(deg_to_rad(a[keep]), -_LIMIT, _LIMIT),
        np.clip(deg_to_rad(b[keep]), -_LIMIT, _LIMIT),
        p,
        float(1.0 - keep.mean()),
    )


def areal_angles_from_facets(facets, *, source=None, params=None) -> ArealAngles:
    """The pairs of a :class:`~microimpact.surface.areal.FacetAngles` (its
    ``phi_par``, ``phi_perp`` [rad], all in (-90°, 90°) by construction)."""
    p = {
        "contact_diameter_um": float(facets.contact_diameter * 1e6),
        "patch": facets.patch,
    }
    if params:
        p.update(params)
    return areal_angles_from_sample(
        rad_to_deg(facets.phi_par),
        rad_to_deg(facets.phi_perp),
        source=source,
        params=p,
    )


def _azimuth_param(azimuth_deg):
    if azimuth_deg is None:
        return "random"
    a = np.asarray(azimuth_deg, dtype=float)
    return float(a) if a.ndim == 0 else "array"


def areal_angles_from_height_map(
    height_map,
    *,
    contact_diameter_um,
    azimuth_deg=0.0,
    patch="disc",
    step_um=None,
    level_first=True,
    min_coverage=0.5,
    seed=None,
    source=None,
) -> ArealAngles:
    """The contact-scale facet-angle pairs of a height map
    (:func:`~microimpact.surface.areal.facet_angles` with these arguments;
    ``azimuth_deg=None`` draws a uniform azimuth per sample with `seed`)."""

    facets = facet_angles(
        height_map,
        contact_diameter_um=contact_diameter_um,
        patch=patch,
        azimuth_deg=azimuth_deg,
        step_um=step_um,
        level_first=level_first,
        min_coverage=min_coverage,
        rng=seed,
    )
    params = {"azimuth_deg": _azimuth_param(azimuth_deg)}
    if azimuth_deg is None and seed is not None:
        params["azimuth_seed"] = int(seed)
    if step_um is not None:
        params["step_um"] = float(step_um)
    if source is None:
        source = getattr(height_map, "source", None)
    meta = getattr(height_map, "metadata", {}) or {}
    if source is not None and os.path.exists(str(source)):
        prov = file_provenance(source)
        source = prov["file"]  # the name only: no folders in any output
        params["sha256"] = prov["sha256"]
    params.update(data_provenance(meta, ("xy_unit", "z_unit")))
    for key in ("dx", "dy"):
        if meta.get(f"{key}_from"):
            params[f"{key}_um"] = (
                f"{getattr(height_map, key) * 1e6:.6g} ({meta[f'{key}_from']})"
            )
    if meta.get("reader"):
        params["reader"] = f"{meta['reader']} ({meta.get('format')})"
    if "masked_fraction" in meta:
        params["masked_fraction"] = float(meta["masked_fraction"])
    return areal_angles_from_facets(facets, source=source, params=params)


def gaussian_areal_angles(
    *,
    nx,
    ny,
    dx_um,
    rms_um,
    corr_x_um,
    contact_diameter_um,
    corr_y_um=None,
    dy_um=None,
    seed=None,
    azimuth_deg=0.0,
    patch="disc",
    step_um=None,
) -> ArealAngles:
    """The contact-scale facet-angle pairs of a seeded Gaussian areal surface
    (:func:`~microimpact.surface.areal.gaussian_areal_surface`, then
    :func:`~microimpact.surface.areal.facet_angles`; for ``azimuth_deg=None`` the
    azimuths are drawn from a stream derived from `seed`,
    ``SeedSequence(seed, spawn_key=(1,))``)."""

    hm = gaussian_areal_surface(
        nx,
        ny,
        dx_um=dx_um,
        dy_um=dy_um,
        rms_um=rms_um,
        corr_x_um=corr_x_um,
        corr_y_um=corr_y_um,
        seed=seed,
    )

    # the azimuth draws (azimuth_deg=None) get a stream of their own
    az_rng = None if seed is None else np.random.SeedSequence(seed, spawn_key=(1,))
    facets = facet_angles(
        hm,
        contact_diameter_um=contact_diameter_um,
        patch=patch,
        azimuth_deg=azimuth_deg,
        step_um=step_um,
        rng=az_rng,
    )
    params = {"azimuth_deg": _azimuth_param(azimuth_deg)}
    if step_um is not None:
        params["step_um"] = float(step_um)
    out = areal_angles_from_facets(
        facets, source="gaussian_areal_surface", params=params
    )
    params = dict(out.params)
    params.update(
        synthetic="gaussian",
        nx=int(nx),
        ny=int(ny),
        dx_um=float(dx_um),
        dy_um=float(dx_um if dy_um is None else dy_um),
        rms_um=float(rms_um),
        corr_x_um=float(corr_x_um),
        corr_y_um=float(corr_x_um if corr_y_um is None else corr_y_um),
        seed=seed if seed is None else int(seed),
    )
    return ArealAngles(out.phi_par, out.phi_perp, params, out.truncated_mass)
