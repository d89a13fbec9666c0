"""Scenario files: the surface, particle-roughness and profile tables.

Part of :mod:`microimpact.scenario.file`, split out to keep modules small.
"""

from __future__ import annotations

from .._core.files import check_delimiter
from .._core.validation import did_you_mean
from ..io.areal import FORMATS, read_height_map
from ..io.profiles import read_profiles
from ..surface import angles as ang
from ..surface import areal_angles as aa
from ..surface import synthetic
from ..units import um_to_m
from ._file_base import (
    ANGLE_METHODS,
    AREAL_FILE_KEYS,
    AREAL_LEVEL,
    AREAL_PATCHES,
    AREAL_SYNTHETIC_KEYS,
    DETREND,
    SURFACE_KEYS,
    SYNTHETIC_PROFILES,
    _Ctx,
    _join,
    _show,
)
from .parts import SurfaceVariant


def _exactly_one(ctx, t, where, keys):
    present = [k for k in keys if k in t]
    if len(present) != 1:
        raise ctx.error(
            _join(where, keys[0]),
            f"give exactly one of {' or '.join(repr(k) for k in keys)}"
            + ("; got both" if len(present) > 1 else ""),
        )


# ---------------------------------------------------------------------- surfaces
def _angles(ctx: _Ctx, t, where):
    """An angle distribution from a surface table, or None (molecularly smooth)."""

    kind = ctx.kind(t, where, "kind", SURFACE_KEYS, also=("name",))

    def num(key, **kw):
        return ctx.get_number(t, where, key, **kw)

    if kind == "smooth":
        return None
    if kind == "areal":
        return _areal(ctx, t, where)
    if kind == "normal":
        mean = num("mean_deg")
        if mean is not None and not -90 < mean < 90:
            raise ctx.error(
                _join(where, "mean_deg"),
                f"must be in (-90, 90); got {_show(t['mean_deg'])}",
            )
        return ctx.build(
            where,
            t,
            ang.normal_angles,
            num("std_deg", low=0),
            mean_deg=0.0 if mean is None else mean,
        )
    if kind == "angles":
        _exactly_one(ctx, t, where, ("file", "angles_deg"))
        if "file" in t:
            path = ctx.path(t["file"], _join(where, "file"))
            return ctx.build(_join(where, "file"), t, ang.angles_from_file, path)
        a = ctx.numbers(t["angles_deg"], _join(where, "angles_deg"))
        return ctx.build(_join(where, "angles_deg"), t, ang.angles_from_sample, a)
    if kind == "scipy":
        # deferred: this SciPy submodule loads only when it is used (import time)
        from scipy import stats

        name = ctx.string(t["distribution"], _join(where, "distribution"))
        gen = getattr(stats, name, None)
        if not isinstance(gen, stats.rv_continuous):
            names = [
                n
                for n in dir(stats)
                if isinstance(getattr(stats, n), stats.rv_continuous)
            ]
            raise ctx.error(
                _join(where, "distribution"),
                f"{name!r} is not a continuous scipy.stats distribution"
                f"{did_you_mean(name, names)}",
            )
        shapes = ctx.numbers(t.get("shapes", []), _join(where, "shapes"), minimum=0)
        loc = num("loc_deg") or 0.0
        scale = num("scale_deg", low=0, strict=True) or 1.0
        frozen = ctx.build(where, t, gen, *shapes, loc=loc, scale=scale)
        return ctx.build(where, t, ang.scipy_angles, frozen, unit="deg")
    # profile or synthetic: angles over the contact length
    length = num("contact_length_um", low=0, strict=True)
    method = ctx.choice(t.get("method", "slope"), _join(where, "method"), ANGLE_METHODS)
    detrend = ctx.choice(t.get("detrend", "line"), _join(where, "detrend"), DETREND)
    cutoff = num("cutoff_um", low=0, strict=True)
    if kind == "profile":
        profiles = _read_profiles(ctx, t, where)
    else:
        profiles = _synthetic(ctx, t, where)
    return ctx.build(
        where,
        t,
        ang.angles_from_profile,
        profiles,
        contact_length_um=length,
        method=method,
        detrend=None if detrend == "none" else detrend,
        cutoff_um=cutoff,
    )


def _areal(ctx, t, where):
    """Joint facet angles of an areal surface: a height-map file or a seeded
    Gaussian areal surface, at the contact diameter, for a fixed or random impact
    azimuth (docs/scenarios.md)."""

    _exactly_one(ctx, t, where, ("file", "synthetic"))
    _exactly_one(ctx, t, where, ("contact_diameter_um", "contact_length_um"))
    contact_key = (
        "contact_diameter_um" if "contact_diameter_um" in t else ("contact_length_um")
    )
    contact = ctx.number(t[contact_key], _join(where, contact_key), low=0, strict=True)
    if "azimuth_deg" in t and "azimuth" in t:
        raise ctx.error(
            _join(where, "azimuth"), "give either 'azimuth_deg' or 'azimuth', not both"
        )
    azimuth = 0.0
    if "azimuth" in t:
        ctx.choice(t["azimuth"], _join(where, "azimuth"), ("random",))
        azimuth = None
    elif "azimuth_deg" in t:
        azimuth = ctx.number(t["azimuth_deg"], _join(where, "azimuth_deg"))
    if "azimuth_seed" in t and azimuth is not None:
        raise ctx.error(
            _join(where, "azimuth_seed"), "only allowed with azimuth = 'random'"
        )
    patch = ctx.choice(t.get("patch", "disc"), _join(where, "patch"), AREAL_PATCHES)
    step = ctx.get_number(t, where, "step_um", low=0, strict=True)
    if "synthetic" in t:
        for key in (*AREAL_FILE_KEYS, "level", "min_coverage", "azimuth_seed"):
            if key in t:
                raise ctx.error(_join(where, key), "only allowed with 'file'")
        syn_where = _join(where, "synthetic")
        syn = ctx.table(t["synthetic"], syn_where)
        required, optional = AREAL_SYNTHETIC_KEYS
        ctx.keys(syn, syn_where, (*required, *optional), required)
        n = {k: ctx.integer(syn[k], _join(syn_where, k), low=2) for k in ("nx", "ny")}
        seed = ctx.integer(syn["seed"], _join(syn_where, "seed"))
        lengths = {
            k: ctx.number(syn[k], _join(syn_where, k), low=0, strict=True)
            for k in ("rms_um", "corr_x_um", "dx_um", *optional)
            if k in syn
        }
        return ctx.build(
            where,
            t,
            aa.gaussian_areal_angles,
            **n,
            **lengths,
            seed=seed,
            contact_diameter_um=contact,
            azimuth_deg=azimuth,
            patch=patch,
            step_um=step,
        )

    path = ctx.path(t["file"], _join(where, "file"))
    kw = {}
    for key in ("dx_um", "dy_um"):
        if key in t:
            kw[key] = ctx.number(t[key], _join(where, key), low=0, strict=True)
    if "z_unit" in t:
        kw["z_unit"] = ctx.string(t["z_unit"], _join(where, "z_unit"))
    if "delimiter" in t:
        delimiter = ctx.string(t["delimiter"], _join(where, "delimiter"))
        kw["delimiter"] = ctx.build(where, t, check_delimiter, delimiter)
    if "format" in t:
        kw["format"] = ctx.choice(t["format"], _join(where, "format"), FORMATS)
    level = ctx.choice(t.get("level", "plane"), _join(where, "level"), AREAL_LEVEL)
    cover = ctx.get_number(t, where, "min_coverage", low=0, strict=True, high=1)
    seed = None
    if azimuth is None:  # reproducible by default: the random azimuths of seed 0
        seed = 0
        if "azimuth_seed" in t:
            seed = ctx.integer(t["azimuth_seed"], _join(where, "azimuth_seed"))
    hm = ctx.build(_join(where, "file"), t, read_height_map, path, **kw)
    return ctx.build(
        where,
        t,
        aa.areal_angles_from_height_map,
        hm,
        contact_diameter_um=contact,
        azimuth_deg=azimuth,
        patch=patch,
        step_um=step,
        level_first=level == "plane",
        min_coverage=0.5 if cover is None else cover,
        seed=seed,
        source=str(path),
    )


def _read_profiles(ctx, t, where):

    files = t["file"]
    key = _join(where, "file")
    if isinstance(files, list):
        if not files:
            raise ctx.error(key, "must be a file name or a non-empty array of them")
        paths = [ctx.path(f, f"{key}[{i}]") for i, f in enumerate(files)]
    else:
        paths = [ctx.path(files, key)]
    kw = {}
    for col in ("x_column", "z_column", "scan_column"):
        if col in t:
            kw[col] = ctx.column(t[col], _join(where, col))
    for u in ("unit", "x_unit", "z_unit"):
        if u in t:
            kw[u] = ctx.unit(t[u], _join(where, u))
    if "dx_um" in t:
        kw["dx_um"] = ctx.number(t["dx_um"], _join(where, "dx_um"), low=0, strict=True)
    return ctx.build(key, t, read_profiles, paths, **kw)


def _synthetic(ctx, t, where):

    kind = ctx.choice(
        t.get("profile", "formica"), _join(where, "profile"), SYNTHETIC_PROFILES
    )
    extra = ("n_points", "dx_um", "rms_height_um", "correlation_length_um", "seed")
    if kind == "formica":
        for key in extra:
            if key in t:
                raise ctx.error(
                    _join(where, key), "only allowed with profile = 'gaussian'"
                )
        return ctx.build(where, t, synthetic.formica_profile)
    ctx.keys(t, where, t.keys(), extra[:4])
    n = ctx.integer(t["n_points"], _join(where, "n_points"), low=2)
    seed = ctx.integer(t["seed"], _join(where, "seed")) if "seed" in t else None

    def length(key):  # a positive length in um, returned in m
        return float(um_to_m(ctx.number(t[key], _join(where, key), low=0, strict=True)))

    return ctx.build(
        where,
        t,
        synthetic.gaussian_profile,
        n,
        length("dx_um"),
        rms_height=length("rms_height_um"),
        correlation_length=length("correlation_length_um"),
        rng=seed,
    )


def _surfaces(ctx: _Ctx, data) -> tuple:
    if "surfaces" in data and "surface" in data:
        raise ctx.error("surface", "give either [surface] or [[surfaces]], not both")
    if "surface" in data:
        tables = [(ctx.table(data["surface"], "surface"), "surface")]
    elif "surfaces" in data:
        items = data["surfaces"]
        if not isinstance(items, list) or not items:
            raise ctx.error(
                "surfaces", "must be a non-empty array of tables ([[surfaces]])"
            )
        tables = [
            (ctx.table(s, f"surfaces[{i}]"), f"surfaces[{i}]")
            for i, s in enumerate(items)
        ]
    else:
        return (SurfaceVariant("smooth"),)
    out, seen = [], {}

    def one(t, key):
        name = t.get("name", t.get("kind") if isinstance(t.get("kind"), str) else None)
        name = ctx.string(name, _join(key, "name"))
        if name in seen:
            raise ctx.error(
                _join(key, "name"),
                f"duplicate surface name {name!r} (also used by {seen[name]})",
            )
        seen[name] = key
        return SurfaceVariant(name, ctx.cached(key, t, _angles, t, key))

    for t, key in tables:  # each surface checked, its problems gathered
        variant = ctx.attempt(one, t, key)
        if variant is not None:
            out.append(variant)
    return tuple(out) if out else (SurfaceVariant("smooth"),)
