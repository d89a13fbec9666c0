"""What stays stuck: the Rock'n'Roll resuspension of a deposited population.

:func:`resuspend` takes a scenario with a ``[resuspension]`` table (or a
:class:`~microimpact.scenario.resuspension.ResuspensionSpec` beside it) and gives
the fraction of the deposited particles still on the surface after each step of a
friction-velocity ramp:

* ``source = "particles"``: the ``[particles]`` population, as deposited;
* ``source = "captured"``: the particles captured at each sweep point. The
  engine runs once per diameter class (a monodisperse population at the class's
  diameter, every other random input at its distribution), and the class's
  capture probability weights it in the deposited population.

The diameter classes are equiprobable: class k holds the particles between the
population's quantiles k/K and (k+1)/K and is represented by the diameter at
quantile (k+1/2)/K. Within a class the integral over the adhesion distribution is
the quadrature of :mod:`microimpact.physics.resuspension`, accurate to 1e-6.

With ``monte_carlo_samples = N`` each point also gets a per-particle Monte Carlo
estimate with its standard error: for a captured population, the engine's own
first N impacts at the point (the draws :func:`~microimpact.engine.run` makes for
this seed), of which the captured ones carry their diameters into resuspension;
for a deposited one, N particles drawn from ``[particles]``. Each particle draws
its own adhesion reduction factor from a :class:`numpy.random.Generator` keyed by
the seed and the sweep point (SPEC 7). It needs no diameter classes; the
quadrature is its oracle.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..engine.dataset import CONVENTIONS, history_line
from ..engine.montecarlo import iter_point_samples, run
from ..engine.plan import build_plan
from ..errors import ScenarioError
from ..physics import resuspension as rnr
from ..population.distributions import monodisperse
from ..scenario.file import (
    PRESETS,
    particles_from_dict,
    preset_path,
    read_toml_text,
)
from ..scenario.resuspension import ResuspensionSpec, resuspension_from_dict
from ..scenario.scenario import Scenario, scenario_file_from_dict
from ..units import m_to_um, um_to_m

__all__ = ["ResuspensionResult", "resuspend", "sample_remaining_fraction"]

#: Spawn-key tag of the resuspension Monte Carlo streams ("RS").
_STREAM = 0x5253


@dataclass(frozen=True)
class ResuspensionResult:
    """The remaining fraction after each step, per diameter class and in all.

    Attributes
    ----------
    dataset : xarray.Dataset
        CF-1.10: ``remaining_fraction`` (population) and
        ``remaining_fraction_class`` on ``step`` (and ``diameter_class``, and the
        sweep point's ``surface``, ``speed_m_s``, ``angle_deg`` for a captured
        population), the steps' ``friction_velocity_m_s`` and ``exposure_s``, the
        classes' ``diameter`` [m], weights and adhesion parameters.
    spec : ResuspensionSpec
    name : str
        The scenario's name.
    """

    dataset: object
    spec: ResuspensionSpec
    name: str

    @property
    def table(self):
        """The long table of ``resuspension.csv`` (a pandas DataFrame): one row per
        step for the population (``diameter_um`` empty) and one per step and
        diameter class, with ``friction_velocity_m_s`` and ``remaining_fraction``."""
        ds = self.dataset
        points = [d for d in ("surface", "speed_m_s", "angle_deg") if d in ds.dims]
        whole = ds[["remaining_fraction", *_mc_vars(ds)]].to_dataframe().reset_index()
        whole["diameter_um"] = np.nan
        per_class = ds["remaining_fraction_class"]
        if points:  # the same at every sweep point: one row per point
            per_class = per_class.broadcast_like(ds["remaining_fraction"])
        per = per_class.to_dataframe().reset_index()
        per = per.rename(columns={"remaining_fraction_class": "remaining_fraction"})
        per["diameter_um"] = m_to_um(ds["diameter"].values[per["diameter_class"]])
        # deferred: pandas is heavy and only the table needs it
        import pandas as pd

        out = pd.concat([whole, per.drop(columns="diameter_class")], ignore_index=True)
        steps = ds["step"].values
        out["friction_velocity_m_s"] = ds["friction_velocity_m_s"].values[
            np.searchsorted(steps, out["step"])
        ]
        out["exposure_s"] = ds["exposure_s"].values[np.searchsorted(steps, out["step"])]
        first = [*points, "step", "friction_velocity_m_s", "exposure_s", "diameter_um"]
        rest = [c for c in out.columns if c not in first]
        return (
            out[first + rest]
            .sort_values(
                [*points, "step", "diameter_um"], na_position="first", kind="stable"
            )
            .reset_index(drop=True)
        )

    def __repr__(self) -> str:
        r = self.dataset["remaining_fraction"].isel(step=-1).values
        return (
            f"ResuspensionResult({self.name!r}, source={self.spec.source!r}, "
            f"steps={len(self.spec.friction_velocities_m_s)}, "
            f"final remaining fraction {np.nanmin(r):.3g} to {np.nanmax(r):.3g})"
        )


def _mc_vars(ds):
    return [v for v in ("remaining_fraction_mc", "remaining_fraction_mc_se") if v in ds]


def _classes(particles, k):
    """Diameters [m] and weights of `k` equiprobable classes (one for a
    monodisperse population)."""
    atoms = getattr(particles, "atoms", None)
    if atoms is not None and np.unique(atoms).size == 1:
        return np.array([float(atoms[0])]), np.array([1.0])
    q = (np.arange(k) + 0.5) / k
    return np.asarray(particles.ppf(q), dtype=float), np.full(k, 1.0 / k)


def _step_rates(spec, radius, fprime):
    """Rates p [s-1] of particles of radii `radius` with reduction factors
    `fprime` (both (N,)), one row per step: shape (K, N)."""
    u = np.asarray(spec.friction_velocities_m_s)[:, None]
    radius = np.asarray(radius, float)[None, :]
    f = rnr.aerodynamic_forces(
        radius, u, spec.density_kg_m3, spec.kinematic_viscosity_m2_s
    )
    n = rnr.burst_frequency(u, spec.kinematic_viscosity_m2_s)
    fa = np.asarray(fprime)[None, :] * rnr.jkr_pull_off_force(
        radius, spec.surface_energy_j_m2
    )
    return rnr.quasi_static_rate(fa, f.mean_force, f.rms_force, n)


def sample_remaining_fraction(diameters, spec, *, rng=None):
    """Per-particle Monte Carlo estimate of the remaining fraction after each step.

    Each particle draws its own adhesion reduction factor f' (log-normal: the
    Biasi (2001) median and spread at its radius, or the spec's explicit ones)
    and survives the ramp with probability ``exp(-sum_{j<=k} p_j t_j)``; the
    estimate is the mean survival over the particles.

    Parameters
    ----------
    diameters : array_like or iterable of array_like
        Diameters [m] of the deposited particles, or blocks of them (bounded
        memory: each block is drawn from and forgotten).
    spec : ResuspensionSpec
        The ramp, the fluid and the adhesion.
    rng : None, int, SeedSequence or Generator
        SPEC 7: normalised with :func:`numpy.random.default_rng`; one standard
        normal per particle, in the order given.

    Returns
    -------
    mean, se : ndarray
        The estimate and its standard error per step (NaN with fewer than two
        particles).
    n : int
        The number of particles.

    Warns
    -----
    AdhesionRangeWarning
        With the Biasi (2001) correlation, where particles lie outside the
        diameters it was fitted to (their share and the range named).
    """
    rng = np.random.default_rng(rng)
    lo, hi = (2 * float(um_to_m(x)) for x in rnr.BIASI2001_FITTED_RADIUS_UM)
    outside = 0
    if isinstance(diameters, np.ndarray) or np.isscalar(diameters):
        diameters = [diameters]
    t = np.asarray(spec.exposures_s)
    s1 = np.zeros(t.size)
    s2 = np.zeros(t.size)
    n = 0
    for block in diameters:
        d = np.atleast_1d(np.asarray(block, float))
        if d.size == 0:
            continue
        radius = 0.5 * d
        if spec.adhesion_median is None:
            red = rnr.biasi2001_adhesion(radius, outside="ignore")
            median, spread = red.median, red.spread
            outside += int(np.count_nonzero((d < lo) | (d > hi)))
        else:
            median, spread = spec.adhesion_median, spec.adhesion_spread
        z = rng.standard_normal(d.size)
        fprime = median * np.exp(z * np.log(spread))
        rates = _step_rates(spec, radius, fprime)
        survival = np.exp(-np.cumsum(rates * t[:, None], axis=0))
        s1 += survival.sum(axis=1)
        s2 += (survival**2).sum(axis=1)
        n += d.size
    if outside:
        warnings.warn(
            f"{outside} of the {n} particles ({100 * outside / n:.3g} %) have "
            "diameters outside those the Biasi (2001) adhesion correlation was "
            f"fitted to ({m_to_um(lo):g} to {m_to_um(hi):g} µm); give adhesion = "
            "{ median, spread } if known",
            rnr.AdhesionRangeWarning,
            stacklevel=2,
        )
    if n < 2:
        return np.full(t.size, np.nan), np.full(t.size, np.nan), n
    mean = s1 / n
    var = np.maximum(s2 - n * mean**2, 0.0) / (n - 1)
    return mean, np.sqrt(var / n), n


#: Particles per block of the Monte Carlo estimate of a [particles] population.
_MC_BLOCK = 65536


def _particle_blocks(particles, n, rng):
    for start in range(0, n, _MC_BLOCK):
        yield particles.rvs(min(_MC_BLOCK, n - start), rng=rng)


def _captured_blocks(plan, point, n):
    for sample in iter_point_samples(plan, point, n):
        yield sample["diameter"][sample["captured"].astype(bool)]


def _check_mc_adhesion(spec, particles, where):
    """With Biasi adhesion, refuse a population whose tail reaches the radius
    where the correlation has no distribution (checked at quantile 1 - 1e-9, so
    the draws never meet it in practice)."""
    if spec.adhesion_median is not None or not spec.monte_carlo_samples:
        return
    top = float(np.nanmax(np.atleast_1d(particles.ppf(1.0 - 1e-9))))
    edge = 2 * float(um_to_m(rnr.BIASI2001_POSITIVE_RADIUS_UM))
    if top >= edge:
        raise ScenarioError(
            f"the population's tail reaches {float(m_to_um(top)):.4g} µm, beyond the "
            f"{float(m_to_um(edge)):.3g} µm where 'biasi2001' has no adhesion "
            "distribution; give adhesion = { median, spread } for the Monte Carlo "
            "estimate, or truncate the [particles] (max_um)",
            source=where,
            field="resuspension.monte_carlo_samples",
        )


def _open(scenario, resuspension):
    """``(text, data, source, spec, scenario or None)`` of what :func:`resuspend`
    got; a file is read once."""
    if isinstance(scenario, Scenario):
        if resuspension is None:
            raise ScenarioError(
                "a Scenario object carries no [resuspension] table; pass "
                "`resuspension` (a ResuspensionSpec or the table as a dict)",
                field="resuspension",
            )
        return None, None, scenario.source, resuspension, scenario
    path = Path(scenario)
    if isinstance(scenario, str) and not path.exists() and scenario in PRESETS:
        path = preset_path(scenario)
    text, data = read_toml_text(path)
    return text, data, str(path), resuspension, None


def resuspend(scenario, resuspension=None, *, samples=None, seed=None):
    """Resuspend a deposited population by a friction-velocity ramp.

    Parameters
    ----------
    scenario : str, path or Scenario
        A scenario file (or a preset's name) with a ``[resuspension]`` table, or a
        :class:`~microimpact.Scenario` (then `resuspension` is required). With
        ``source = "particles"`` the file needs only ``[particles]`` and
        ``[resuspension]``.
    resuspension : ResuspensionSpec or dict, optional
        Replaces the file's ``[resuspension]`` table (a dict is read as that
        table would be).
    samples : int, optional
        Impacts per sweep point and diameter class of the engine's runs
        (``source = "captured"``); default: the scenario's.
    seed : int, optional
        Root seed of the engine's runs and of the Monte Carlo estimate; default:
        the scenario's ``seed`` (else fresh entropy, recorded in the Dataset).

    Returns
    -------
    ResuspensionResult

    Raises
    ------
    ScenarioError
        A bad or missing table or value, named by file and key path.
    """
    text, data, source, spec, scen = _open(scenario, resuspension)
    # the file's [particles] and top-level keys first: a misspelt table is named
    particles = None if data is None else particles_from_dict(data, source=source)
    if isinstance(spec, dict):
        law = scen.coefficients.v_c if scen is not None else None
        spec = resuspension_from_dict(
            {**(data or {}), "resuspension": spec}, source=source, capture_law=law
        )
    elif spec is None:
        spec = resuspension_from_dict(data, source=source)
        if spec is None:
            raise ScenarioError(
                "has no [resuspension] table (see docs/resuspension.md)",
                source=source,
                field="resuspension",
            )
    elif not isinstance(spec, ResuspensionSpec):
        raise TypeError(
            "`resuspension` must be a ResuspensionSpec, a dict or None; got "
            f"{type(spec).__name__}."
        )
    if spec.source == "captured" and scen is None:
        missing = [t for t in ("coefficients", "sweep") if t not in data]
        if missing:
            raise ScenarioError(
                'source = "captured" resuspends what an impact run captured, and '
                f"this file has no [{'] or ['.join(missing)}] table; add the impact "
                'tables or use source = "particles"',
                source=source,
                field="resuspension.source",
            )
        base = Path(source).resolve().parent
        scen = scenario_file_from_dict(
            data, source=source, base_dir=base, text=text
        ).scenario
    if scen is not None:
        particles, name = scen.particles, scen.name
    else:
        name = str(data.get("name", Path(source).stem))
    root = seed if seed is not None else (scen.seed if scen is not None else None)
    if root is None and data is not None:
        root = data.get("seed")
    entropy = np.random.SeedSequence(root).entropy

    diameters, weights = _classes(particles, spec.diameter_classes)
    radii = 0.5 * diameters
    median, spread = spec.adhesion_parameters(
        radii, source=source, field="the population's diameter classes"
    )
    _check_mc_adhesion(spec, particles, source)
    per_class = spec.ramp_fractions(radii, median, spread)  # (class, step)
    capture = capture_se = coords = None
    if spec.source == "captured":
        capture, capture_se, coords = _capture_by_class(
            scen, diameters, samples, entropy
        )
        w = weights[:, None] * capture.reshape(radii.size, -1)  # (class, point)
    else:
        w = weights[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = w / w.sum(axis=0, keepdims=True)  # NaN where nothing was captured
    whole = np.einsum("cp,cs->ps", w, per_class)  # (point, step)
    mc = None
    if spec.monte_carlo_samples:
        mc = _monte_carlo(spec, particles, scen, entropy, whole.shape[0])
    ds = _dataset(
        spec, name, diameters, weights, median, spread, per_class, whole, w,
        capture, capture_se, coords, mc, entropy,
    )  # fmt: skip
    return ResuspensionResult(ds, spec, name)


def _monte_carlo(spec, particles, scenario, entropy, points):
    """(2, point, step): the per-particle estimate and its standard error. A
    [particles] population: `monte_carlo_samples` particles drawn from it. A
    captured one: the engine's own first `monte_carlo_samples` impacts at each
    point (the draws :func:`~microimpact.engine.run` makes for this seed), of
    which the captured ones carry their diameters into resuspension."""
    out = np.full((2, points, len(spec.friction_velocities_m_s)), np.nan)
    n = spec.monte_carlo_samples
    plan = build_plan(scenario, seed=entropy) if spec.source == "captured" else None
    for p in range(points):
        stream = np.random.default_rng(
            np.random.SeedSequence(entropy, spawn_key=(p, _STREAM))
        )
        if plan is None:
            blocks = _particle_blocks(particles, n, stream)
        else:
            blocks = _captured_blocks(plan, p, n)
        mean, se, _ = sample_remaining_fraction(blocks, spec, rng=stream)
        out[:, p] = mean, se
    return out


def _capture_by_class(scenario, diameters, samples, entropy):
    """Capture fraction and its standard error per diameter class and sweep
    point: one engine run per class (a monodisperse population)."""
    runs = [
        run(
            scenario.with_options(particles=monodisperse(float(m_to_um(d)))),
            samples=samples,
            seed=entropy,
        ).dataset
        for d in diameters
    ]
    capture = np.stack([r["capture_fraction"].values for r in runs])
    se = np.stack([r["capture_se"].values for r in runs])
    coords = {d: runs[0][d].values for d in ("surface", "speed_m_s", "angle_deg")}
    return capture, se, coords


def _dataset(
    spec, name, diameters, weights, median, spread, per_class, whole, w,
    capture, capture_se, coords, mc, entropy,
):  # fmt: skip
    # deferred: xarray is heavy and only the result needs it
    import xarray as xr

    steps = np.arange(len(spec.friction_velocities_m_s))
    one = {"units": "1"}
    point_dims = ["surface", "speed_m_s", "angle_deg"] if coords else []
    shape = [len(coords[d]) for d in point_dims] if coords else []

    def on_points(a, tail_dims):
        a = np.asarray(a)
        if not coords:
            return (tail_dims, a.reshape(a.shape[1:]) if a.shape[0] == 1 else a)
        return ([*point_dims, *tail_dims], a.reshape(shape + list(a.shape[1:])))

    data_vars = {
        "friction_velocity_m_s": (
            "step",
            np.asarray(spec.friction_velocities_m_s),
            {"units": "m s-1", "long_name": "friction velocity of the ramp step"},
        ),
        "exposure_s": (
            "step",
            np.asarray(spec.exposures_s),
            {"units": "s", "long_name": "duration of the ramp step"},
        ),
        "elapsed_s": (
            "step",
            np.cumsum(spec.exposures_s),
            {"units": "s", "long_name": "time since the flow started, end of step"},
        ),
        "diameter": (
            "diameter_class",
            diameters,
            {"units": "m", "long_name": "particle diameter representing the class"},
        ),
        "class_probability": (
            "diameter_class",
            weights,
            one
            | {"long_name": "probability of the class in the [particles] population"},
        ),
        "adhesion_median": (
            "diameter_class",
            median,
            one | {"long_name": "median adhesion reduction factor"},
        ),
        "adhesion_spread": (
            "diameter_class",
            spread,
            one | {"long_name": "geometric spread of the adhesion reduction factor"},
        ),
        "remaining_fraction_class": (
            ("diameter_class", "step"),
            per_class,
            one | {"long_name": "fraction of the class's particles remaining"},
        ),
    }
    dims, values = on_points(whole, ["step"])
    data_vars["remaining_fraction"] = (
        dims,
        values,
        one | {"long_name": "fraction of the deposited particles remaining"},
    )
    dims, values = on_points(w.T, ["diameter_class"])
    data_vars["deposited_probability"] = (
        dims,
        values,
        one | {"long_name": "probability of the class among the deposited particles"},
    )
    if capture is not None:
        for key, arr, what in (
            ("capture_fraction", capture, "fraction of the class's impacts captured"),
            ("capture_se", capture_se, "standard error of capture_fraction"),
        ):
            a = np.moveaxis(arr, 0, -1)
            data_vars[key] = (
                [*point_dims, "diameter_class"],
                a,
                one | {"long_name": what},
            )
    if mc is not None:
        for key, arr, what in (
            ("remaining_fraction_mc", mc[0], "per-particle Monte Carlo estimate"),
            ("remaining_fraction_mc_se", mc[1], "standard error of that estimate"),
        ):
            dims, values = on_points(arr, ["step"])
            data_vars[key] = (
                dims,
                values,
                one | {"long_name": f"remaining fraction: {what}"},
            )
    coord = {"step": ("step", steps, {"long_name": "ramp step"})}
    coord["diameter_class"] = (
        "diameter_class",
        np.arange(diameters.size),
        {"long_name": "equiprobable diameter class"},
    )
    if coords:
        coord["surface"] = (
            "surface",
            list(coords["surface"]),
            {"long_name": "surface variant"},
        )
        coord["speed_m_s"] = (
            "speed_m_s",
            coords["speed_m_s"],
            {"units": "m s-1", "long_name": "nominal incident speed"},
        )
        coord["angle_deg"] = (
            "angle_deg",
            coords["angle_deg"],
            {"units": "degree", "long_name": "apparent incidence angle from the wall"},
        )
    ds = xr.Dataset(data_vars, coords=coord)
    ds.attrs.update(
        {
            "Conventions": CONVENTIONS,
            "title": f"Rock'n'Roll resuspension of {name}",
            "institution": "microimpact",
            "source": f"microimpact {__version__}, quasi-static Rock'n'Roll model",
            "history": history_line("microimpact.resuspend"),
            "references": "Reeks & Hall (2001) J. Aerosol Sci. 32:1-31; Biasi et "
            "al. (2001) J. Aerosol Sci. 32:1175-1200",
            "scenario": name,
            "resuspension": json.dumps(spec.describe()),
            "seed": str(entropy),
        }
    )
    return ds
