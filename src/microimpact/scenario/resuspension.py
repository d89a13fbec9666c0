"""Scenario files: the ``[resuspension]`` table (see ``docs/resuspension.md``).

::

    [resuspension]
    source = "captured"                 # or "particles" (the [particles] as deposited)
    friction_velocity_m_s = [0.5, 1.0, 2.0]     # one value, or the steps of a ramp
    exposure_s = 1.0                    # one value for every step, or one per step
    adhesion = "biasi2001"              # or { median = 0.01, spread = 3.0 }
    surface_energy_j_m2 = 0.56          # optional with a thornton_ning v_c law
    fluid = { name = "air", temperature_k = 293.15, pressure_pa = 101325 }
    # or fluid = { density_kg_m3 = 1.2, kinematic_viscosity_m2_s = 1.5e-5 }
    diameter_classes = 8                # equiprobable diameter classes (optional)
    monte_carlo_samples = 0             # per-particle draws beside the quadrature

Part of the scenario configuration, split out to keep modules small. Every problem
is one :class:`~microimpact.errors.ScenarioError` naming the file and key path.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ScenarioError
from ..physics import resuspension as rnr
from ..physics.coefficients import ThorntonNingLaw, law_from_dict
from ..physics.resuspension import air_properties
from ..units import m_to_um
from ._file_base import _Ctx, _join, _show, _type_name

__all__ = [
    "ADHESION_MODELS",
    "RESUSPENSION_KEYS",
    "RESUSPENSION_SOURCES",
    "ResuspensionSpec",
    "resuspension_from_dict",
]

#: Keys of the ``[resuspension]`` table.
RESUSPENSION_KEYS = (
    "source",
    "friction_velocity_m_s",
    "exposure_s",
    "adhesion",
    "surface_energy_j_m2",
    "fluid",
    "diameter_classes",
    "monte_carlo_samples",
)
#: What is resuspended: the ``[particles]`` population as deposited, or the
#: particles captured at each sweep point of the engine's run.
RESUSPENSION_SOURCES = ("particles", "captured")
#: Named adhesion laws (the alternative is an explicit median and spread).
ADHESION_MODELS = ("biasi2001",)
#: Keys of a fluid given by its properties, and of air at a state.
FLUID_PROPERTY_KEYS = ("density_kg_m3", "kinematic_viscosity_m2_s")
FLUID_AIR_KEYS = ("name", "temperature_k", "pressure_pa")
#: Largest number of ramp steps and of diameter classes (each is quadratures).
MAX_STEPS, MAX_CLASSES = 1000, 200
#: Friction velocities above this are a unit mistake (a hurricane's is ~3 m/s).
MAX_FRICTION_VELOCITY_M_S = 100.0


@dataclass(frozen=True)
class ResuspensionSpec:
    """A validated ``[resuspension]`` table (SI inside, units in the names).

    Attributes
    ----------
    friction_velocities_m_s : tuple of float
        Friction velocity of each ramp step [m s⁻¹], >= 0.
    exposures_s : tuple of float
        Duration of each step [s], >= 0 (one per step).
    surface_energy_j_m2 : float
        Surface energy of the JKR pull-off force [J m⁻²], > 0.
    density_kg_m3, kinematic_viscosity_m2_s : float
        The fluid's density and kinematic viscosity, > 0.
    source : {"particles", "captured"}
    adhesion_median, adhesion_spread : float or None
        An explicit log-normal adhesion reduction factor (median > 0, spread > 1);
        None for the Biasi (2001) correlation.
    diameter_classes : int
        Equiprobable diameter classes resolving a polydisperse population.
    monte_carlo_samples : int
        Impacts per sweep point (captured) or particles (deposited) of the
        per-particle Monte Carlo estimate (0: none).
    fluid_description : str
        How the fluid was given, for the report.
    surface_energy_source : str
        Where ``surface_energy_j_m2`` came from: ``"given"`` (the table's key),
        or the scenario's ``thornton_ning`` capture law (its work of adhesion w,
        so that the pull-off force 1.5 pi w r is the one the capture model uses).
    """

    friction_velocities_m_s: tuple
    exposures_s: tuple
    surface_energy_j_m2: float
    density_kg_m3: float
    kinematic_viscosity_m2_s: float
    source: str = "particles"
    adhesion_median: float | None = None
    adhesion_spread: float | None = None
    diameter_classes: int = 8
    monte_carlo_samples: int = 0
    fluid_description: str = ""
    surface_energy_source: str = "given"

    def __post_init__(self):
        def bad(field, message):
            raise ScenarioError(message, field=f"resuspension.{field}")

        if self.source not in RESUSPENSION_SOURCES:
            bad(
                "source", f"must be one of 'particles', 'captured'; got {self.source!r}"
            )
        u = tuple(float(v) for v in self.friction_velocities_m_s)
        t = tuple(float(v) for v in self.exposures_s)
        if not 1 <= len(u) <= MAX_STEPS:
            bad("friction_velocity_m_s", f"must hold 1 to {MAX_STEPS} steps")
        if len(t) == 1 and len(u) > 1:
            t = t * len(u)
        if len(t) != len(u):
            bad(
                "exposure_s",
                f"must be one value or one per step ({len(u)}); got {len(t)} values",
            )
        for name, values, high in (
            ("friction_velocity_m_s", u, MAX_FRICTION_VELOCITY_M_S),
            ("exposure_s", t, math.inf),
        ):
            for v in values:
                if not (math.isfinite(v) and 0 <= v <= high):
                    limit = f"<= {high:g} " if math.isfinite(high) else ""
                    bad(name, f"must be finite numbers >= 0 {limit}; got {v:g}")
        object.__setattr__(self, "friction_velocities_m_s", u)
        object.__setattr__(self, "exposures_s", t)
        for name in (
            "surface_energy_j_m2",
            "density_kg_m3",
            "kinematic_viscosity_m2_s",
        ):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                bad(name, f"must be a finite number > 0; got {v:g}")
            object.__setattr__(self, name, v)
        if (self.adhesion_median is None) != (self.adhesion_spread is None):
            bad("adhesion", "give both median and spread, or 'biasi2001'")
        if self.adhesion_median is not None:
            if not (math.isfinite(self.adhesion_median) and self.adhesion_median > 0):
                bad("adhesion.median", f"must be > 0; got {self.adhesion_median:g}")
            if not (math.isfinite(self.adhesion_spread) and self.adhesion_spread > 1):
                bad("adhesion.spread", f"must be > 1; got {self.adhesion_spread:g}")
        for name, hi in (
            ("diameter_classes", MAX_CLASSES),
            ("monte_carlo_samples", 10**8),  # streamed in blocks
        ):
            v = getattr(self, name)
            low = 1 if name == "diameter_classes" else 0
            if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= hi:
                bad(name, f"must be an integer from {low} to {hi}; got {_show(v)}")

    @property
    def adhesion(self) -> str:
        """``"biasi2001"`` or ``"median M, spread S"``."""
        if self.adhesion_median is None:
            return "biasi2001"
        return f"median {self.adhesion_median:g}, spread {self.adhesion_spread:g}"

    def describe(self) -> dict:
        """Plain data for provenance (JSON-able)."""
        return {
            "source": self.source,
            "friction_velocity_m_s": list(self.friction_velocities_m_s),
            "exposure_s": list(self.exposures_s),
            "adhesion": self.adhesion,
            "surface_energy_j_m2": self.surface_energy_j_m2,
            "surface_energy_source": self.surface_energy_source,
            "density_kg_m3": self.density_kg_m3,
            "kinematic_viscosity_m2_s": self.kinematic_viscosity_m2_s,
            "fluid": self.fluid_description,
            "diameter_classes": self.diameter_classes,
            "monte_carlo_samples": self.monte_carlo_samples,
        }

    def adhesion_parameters(self, radius, *, source=None, field="resuspension"):
        """Median and spread of the adhesion reduction factor at each radius [m].

        The explicit ``{ median, spread }`` everywhere, or the Biasi (2001)
        correlation: a radius beyond the one where its median is not positive
        is refused (:class:`~microimpact.errors.ScenarioError` naming `source`,
        ``resuspension.adhesion`` and `field`, the diameter and the edge), and
        one outside the fitted range warns
        (:class:`~microimpact.physics.resuspension.AdhesionRangeWarning`, the
        range named in diameters and radii).
        """
        radii = np.atleast_1d(np.asarray(radius, dtype=float))
        if self.adhesion_median is not None:
            return (
                np.full(radii.shape, self.adhesion_median),
                np.full(radii.shape, self.adhesion_spread),
            )
        edge = rnr.BIASI2001_POSITIVE_RADIUS_UM
        r_um = m_to_um(radii)
        if np.any(r_um >= edge):
            raise ScenarioError(
                f"'biasi2001' cannot serve diameter {2 * float(r_um.max()):.4g} µm "
                f"({field}): at diameters beyond {2 * edge:.3g} µm the "
                "correlation's median adhesion reduction is not positive; give "
                "adhesion = { median, spread }",
                source=source,
                field="resuspension.adhesion",
            )
        lo, hi = rnr.BIASI2001_FITTED_RADIUS_UM
        out = (r_um < lo) | (r_um > hi)
        if np.any(out):
            span = f"{2 * r_um[out].min():.3g}"
            if r_um[out].max() > r_um[out].min():
                span += f" to {2 * r_um[out].max():.3g}"
            warnings.warn(
                f"diameter {span} µm ({field}) is outside the diameters the Biasi "
                f"(2001) adhesion correlation was fitted to ({2 * lo:g} to "
                f"{2 * hi:g} µm, radii {lo:g} to {hi:g} µm); give adhesion = "
                "{ median, spread } if known",
                rnr.AdhesionRangeWarning,
                stacklevel=3,
            )
        red = rnr.biasi2001_adhesion(radii, outside="ignore")
        return np.asarray(red.median, float), np.asarray(red.spread, float)

    def remaining_fraction(self, radius, *, source=None, field="resuspension"):
        """Fraction of particles of each radius [m] left after the whole ramp.

        The quadrature of
        :func:`~microimpact.physics.resuspension.remaining_fraction_ramp` at the
        last step, with this table's flow, fluid, surface energy and adhesion
        (:meth:`adhesion_parameters`: refusals and warnings name `field`).
        Returns an array of the shape of `radius`.
        """
        radii = np.asarray(radius, dtype=float)
        median, spread = self.adhesion_parameters(radii, source=source, field=field)
        return self.ramp_fractions(radii, median, spread)[..., -1]

    def ramp_fractions(self, radius, adhesion_median, adhesion_spread):
        """Fraction left after each step of the ramp, for particles of each radius
        [m] with the given adhesion medians and spreads (of
        :meth:`adhesion_parameters`): shape ``radius.shape + (steps,)``."""
        radii = np.asarray(radius, dtype=float)
        flat = radii.reshape(-1)
        median = np.broadcast_to(adhesion_median, radii.shape).reshape(-1)
        spread = np.broadcast_to(adhesion_spread, radii.shape).reshape(-1)
        out = np.array(
            [
                rnr.remaining_fraction_ramp(
                    flat[k],
                    self.friction_velocities_m_s,
                    self.exposures_s,
                    self.density_kg_m3,
                    self.kinematic_viscosity_m2_s,
                    self.surface_energy_j_m2,
                    adhesion_median=median[k],
                    adhesion_spread=spread[k],
                    outside="ignore",
                )
                for k in range(flat.size)
            ]
        )
        return out.reshape((*radii.shape, len(self.exposures_s)))


def _steps(ctx: _Ctx, value, key):
    if isinstance(value, list):
        return ctx.numbers(value, key, low=0)
    return [ctx.number(value, key, low=0)]


def _fluid(ctx: _Ctx, t) -> tuple[float, float, str]:
    where = "resuspension.fluid"
    if "fluid" not in t:
        raise ctx.error(
            where,
            "missing required key (a table: density_kg_m3 and "
            'kinematic_viscosity_m2_s, or name = "air" with temperature_k and '
            "pressure_pa)",
        )
    f = ctx.table(t["fluid"], where)
    if "name" in f or "temperature_k" in f or "pressure_pa" in f:
        ctx.keys(f, where, FLUID_AIR_KEYS, FLUID_AIR_KEYS)
        ctx.choice(f["name"], _join(where, "name"), ("air",))
        temp = ctx.number(
            f["temperature_k"], _join(where, "temperature_k"), low=0, strict=True
        )
        pres = ctx.number(
            f["pressure_pa"], _join(where, "pressure_pa"), low=0, strict=True
        )
        rho, nu = air_properties(temp, pres)
        return float(rho), float(nu), f"air at {temp:g} K and {pres:g} Pa"
    ctx.keys(f, where, FLUID_PROPERTY_KEYS, FLUID_PROPERTY_KEYS)
    rho = ctx.number(
        f["density_kg_m3"], _join(where, "density_kg_m3"), low=0, strict=True
    )
    nu = ctx.number(
        f["kinematic_viscosity_m2_s"],
        _join(where, "kinematic_viscosity_m2_s"),
        low=0,
        strict=True,
    )
    return rho, nu, f"density {rho:g} kg/m3, kinematic viscosity {nu:g} m2/s"


def _adhesion(ctx: _Ctx, t):
    where = "resuspension.adhesion"
    value = t.get("adhesion", "biasi2001")
    if isinstance(value, str):
        ctx.choice(value, where, ADHESION_MODELS)
        return None, None
    if not isinstance(value, dict):
        raise ctx.error(
            where,
            f"must be 'biasi2001' or a table {{ median, spread }}; got "
            f"{_type_name(value)} {_show(value)}",
        )
    ctx.keys(value, where, ("median", "spread"), ("median", "spread"))
    median = ctx.number(value["median"], _join(where, "median"), low=0, strict=True)
    spread = ctx.number(value["spread"], _join(where, "spread"), low=1, strict=True)
    return median, spread


#: Where a surface energy taken from the capture law comes from (the report's words).
FROM_CAPTURE_LAW = (
    "coefficients.v_c: the thornton_ning law's work of adhesion w (the pull-off "
    "force 1.5 pi w r of the capture model)"
)


def _surface_energy(ctx: _Ctx, t, data, capture_law):
    """``(gamma, where it came from)``: the table's ``surface_energy_j_m2``, else
    the work of adhesion of the scenario's ``thornton_ning`` v_c law (given, or
    from its materials' surface energies), which enters the JKR pull-off force
    1.5 pi w r exactly as gamma does here (docs/adhesion.md, section 2.1)."""
    key = "resuspension.surface_energy_j_m2"
    if "surface_energy_j_m2" in t:
        return ctx.number(t["surface_energy_j_m2"], key, low=0, strict=True), "given"
    law = capture_law
    if law is None:
        v_c = data.get("coefficients", {})
        v_c = v_c.get("v_c") if isinstance(v_c, dict) else None
        if isinstance(v_c, dict) and v_c.get("law") == "thornton_ning":
            law = law_from_dict(v_c, source=ctx.source, field="coefficients.v_c")
    if isinstance(law, ThorntonNingLaw) and law.work_of_adhesion > 0:
        return float(law.work_of_adhesion), FROM_CAPTURE_LAW
    raise ctx.error(
        key,
        "missing required key (gamma of the pull-off force 1.5 pi gamma r, J/m2): "
        "it can come from the materials only through a thornton_ning v_c law with "
        "a work of adhesion > 0, and this scenario has none",
    )


def _resuspension(ctx: _Ctx, data, capture_law=None):
    if "resuspension" not in data:
        return None
    where = "resuspension"
    t = ctx.table(data["resuspension"], where)
    ctx.keys(t, where, RESUSPENSION_KEYS, ("friction_velocity_m_s", "exposure_s"))
    source = ctx.choice(
        t.get("source", "particles"), "resuspension.source", RESUSPENSION_SOURCES
    )
    u = _steps(ctx, t["friction_velocity_m_s"], "resuspension.friction_velocity_m_s")
    e = _steps(ctx, t["exposure_s"], "resuspension.exposure_s")
    gamma, gamma_source = _surface_energy(ctx, t, data, capture_law)
    rho, nu, described = _fluid(ctx, t)
    median, spread = _adhesion(ctx, t)
    kw = {}
    for key, low in (("diameter_classes", 1), ("monte_carlo_samples", 0)):
        if key in t:
            kw[key] = ctx.integer(t[key], f"resuspension.{key}", low=low)
    try:
        return ResuspensionSpec(
            friction_velocities_m_s=tuple(u),
            exposures_s=tuple(e),
            surface_energy_j_m2=gamma,
            density_kg_m3=rho,
            kinematic_viscosity_m2_s=nu,
            source=source,
            adhesion_median=median,
            adhesion_spread=spread,
            fluid_description=described,
            surface_energy_source=gamma_source,
            **kw,
        )
    except ScenarioError as exc:
        raise ctx.error(exc.field, exc.message) from None


def resuspension_from_dict(data: dict, *, source=None, base_dir=None, capture_law=None):
    """The :class:`ResuspensionSpec` of parsed scenario data (its ``[resuspension]``
    table), or None if it has none. Errors name `source` and the key path.

    Without ``surface_energy_j_m2`` the surface energy is the work of adhesion of
    the capture law: `capture_law` (a v_c law, e.g. a Scenario's
    ``coefficients.v_c``), else the ``[coefficients]`` table's ``v_c`` when it
    is a ``thornton_ning`` law; with neither, the key is required."""
    ctx = _Ctx(source, base_dir)
    ctx.table(data, "(top level)")
    return _resuspension(ctx, data, capture_law)
