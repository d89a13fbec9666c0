"""Scenario files: TOML -> validated objects, every table read once.

Every key, its unit, default and allowed values are documented in
``docs/scenarios.md``; the shipped presets in ``docs/presets.md``. In short::

    name = "sst65"                      # default: the file name without .toml
    seed = 2000
    samples = 4000
    [particles]
    distribution = "normal"
    mean_um = 52.8
    std_um = 15.3
    [coefficients]
    k1 = 4.0                            # a number [m/s] or a law table
    k2 = {law = "power", a_m_s = 0.05, b = -1.53, d_ref_um = 52.8}
    v_c = {law = "power", a_m_s = 0.20, b = -1.53, d_ref_um = 52.8}
    friction = 0.15
    [[surfaces]]
    name = "silicon"
    kind = "smooth"
    [sweep]
    speed_m_s = {start = 0.05, stop = 1.0, step = 0.01}
    angle_deg = [90]

Relative paths in a scenario file resolve from the folder holding that file. Every
problem raises one :class:`~microimpact.errors.ScenarioError` whose one-line message
names the file, the key path (``particles.std_um``, ``surfaces[1].kind``), the bad
value and what is allowed; an unknown key gets a "did you mean" suggestion.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._core.validation import did_you_mean
from ..errors import ScenarioError
from .parts import PRECISION_STATISTICS, Precision

__all__ = [
    "PAPER_PRESETS",
    "PRESETS",
    "PRESET_DIR",
    "ParsedScenario",
    "list_presets",
    "outputs_from_dict",
    "outputs_from_toml",
    "parse_scenario",
    "particles_from_dict",
    "preset_path",
    "read_toml",
    "read_toml_text",
    "wall_law_from_dict",
    "wall_law_from_toml",
]

from .._core.formats import FIGURE_FORMATS
from ..io.diameters import read_diameters
from ..io.size_bins import read_size_bins
from ..physics.coefficients import ImpactCoefficients
from ..population import distributions as pd_
from ..population.aerosol import count_median_diameter, hatch_choate_mass_median
from ..population.binned import BIN_VALUES
from ..units import m_to_um, um_to_m
from ._file_base import (
    _TOML_EOF,
    _TOML_POSITION,
    COEFFICIENT_KEYS,
    FALLBACK_KEYS,
    MAX_SWEEP_POINTS,
    OUTPUT_KEYS,
    PAPER_PRESETS,
    PARTICLE_KEYS,
    PRECISION_KEYS,
    PRESET_DIR,
    PRESETS,
    SPACINGS,
    SWEEP_KEYS,
    TOP_KEYS,
    WALL_LAW_KEYS,
    _Ctx,
    _join,
    _one_line,
    _show,
)
from ._file_surfaces import _angles, _exactly_one, _surfaces
from .outputs import Outputs
from .sensitivity import SensitivitySettings, sensitivity_from_dict
from .wall_law import SPEED_AXES, WallLawSpec

#: What stands in for a table that failed, so that the rest of the file is still
#: checked; never simulated (the file's problems are raised together).
_STAND_IN = {
    "particles": pd_.monodisperse(50.0),
    "coefficients": ImpactCoefficients.from_dict({"k1": 4.0, "k2": 0.05, "v_c": 0.2}),
}


def _file_keys(ctx: _Ctx, t, where):
    """``(path, column, unit)`` of the file a ``[particles]`` table reads (an
    empirical or histogram population): ``file`` checked, ``column`` and ``unit``
    checked if given (None: the reader's default, the header's unit else µm)."""
    path = ctx.path(t["file"], _join(where, "file"))
    column = t.get("column")
    if column is not None:
        column = ctx.column(column, _join(where, "column"))
    unit = t.get("unit")
    if unit is not None:
        unit = ctx.unit(unit, _join(where, "unit"))
    return path, column, unit


#: The medians a log-normal ``[particles]`` table may give (exactly one): the count
#: median, the mass median, or the mass median aerodynamic diameter (MMAD, with
#: ``density_kg_m3`` and an optional ``shape_factor``).
MEDIAN_KEYS = {"median_um": "count", "mass_median_um": "mass", "mmad_um": "mmad"}


def _lognormal(ctx: _Ctx, t, where, num, lim):
    """The log-normal population of a ``[particles]`` table, from its count
    median, mass median or MMAD and its GSD (Hatch-Choate and, for an MMAD, the
    Cunningham-corrected aerodynamic diameter: population.aerosol)."""
    _exactly_one(ctx, t, where, tuple(MEDIAN_KEYS))
    key = next(k for k in MEDIAN_KEYS if k in t)
    convention = MEDIAN_KEYS[key]
    median_um = num(key, low=0, strict=True)
    gsd = num("geometric_std", low=1, strict=True)
    density = shape = None
    if convention == "mmad":
        if "density_kg_m3" not in t:
            raise ctx.error(
                _join(where, "density_kg_m3"),
                "missing: an MMAD needs the particle density (kg/m3) to give the "
                "particles' own (volume-equivalent) diameters",
            )
        density = num("density_kg_m3", low=0, strict=True)
        shape = num("shape_factor", low=0, strict=True) if "shape_factor" in t else 1.0
    else:
        for bad in ("density_kg_m3", "shape_factor"):
            if bad in t:
                raise ctx.error(
                    _join(where, bad),
                    f"only allowed with 'mmad_um' ('{key}' is already the particles' "
                    "own diameter)",
                )
    cmd_m = count_median_diameter(
        um_to_m(median_um),
        gsd,
        convention=convention,
        density_kg_m3=density,
        shape_factor=shape if shape is not None else 1.0,
    )
    dist = ctx.build(
        where, t, pd_.lognormal_diameters, float(m_to_um(cmd_m)), gsd, **lim
    )
    # all three medians in the scenario's summary: the count median sampled, the
    # mass median (Hatch-Choate) and, where given, the MMAD with its density
    shown = {"mass_median_um": hatch_choate_mass_median(dist.params["median_um"], gsd)}
    if convention == "mmad":
        shown.update(mmad_um=median_um, density_kg_m3=density, shape_factor=shape)
    return replace(dist, params={**dist.params, **shown})


def _particles(ctx: _Ctx, data, where="particles"):

    t = ctx.table(data, where)
    kind = ctx.kind(t, where, "distribution", PARTICLE_KEYS)

    def num(key, **kw):
        return ctx.get_number(t, where, key, **kw)

    lim = {"min_um": num("min_um", low=0), "max_um": num("max_um", low=0, strict=True)}
    if kind == "normal":
        return ctx.build(
            where,
            t,
            pd_.normal_diameters,
            num("mean_um", low=0, strict=True),
            num("std_um", low=0, strict=True),
            **lim,
        )
    if kind == "lognormal":
        return _lognormal(ctx, t, where, num, lim)
    if kind == "uniform":
        return ctx.build(where, t, pd_.uniform_diameters, lim["min_um"], lim["max_um"])
    if kind == "monodisperse":
        return ctx.build(
            where, t, pd_.monodisperse, num("diameter_um", low=0, strict=True)
        )
    if kind == "empirical":
        _exactly_one(ctx, t, where, ("file", "diameters_um"))
        if "diameters_um" in t:
            if "column" in t or "unit" in t:
                bad = "column" if "column" in t else "unit"
                raise ctx.error(_join(where, bad), "only allowed with 'file'")
            d = ctx.numbers(
                t["diameters_um"], _join(where, "diameters_um"), low=0, strict=True
            )
        else:
            path, column, unit = _file_keys(ctx, t, where)
            d_m, _ = ctx.build(
                _join(where, "file"),
                t,
                read_diameters,
                path,
                column=column,
                unit=unit,
                syntax="toml",
            )
            d = m_to_um(d_m)
        return ctx.build(where, t, pd_.empirical_diameters, d, **lim)
    # histogram
    if "file" not in t:
        _exactly_one(ctx, t, where, ("file", "edges_um"))
    if "file" not in t:
        if "counts" not in t:
            raise ctx.error(_join(where, "counts"), "missing required key")
        for key in ("layout", "values", "column", "sample"):
            if key in t:
                raise ctx.error(_join(where, key), "only allowed with 'file'")
        if "unit" in t:
            raise ctx.error(
                _join(where, "unit"),
                "only allowed with 'file'; 'edges_um' are in micrometres (convert "
                "them, or put the bins in a file and give its unit)",
            )
        edges = ctx.numbers(t["edges_um"], _join(where, "edges_um"), low=0, minimum=2)
        counts = ctx.numbers(t["counts"], _join(where, "counts"), low=0)
        if len(counts) != len(edges) - 1:
            raise ctx.error(
                _join(where, "counts"),
                f"needs {len(edges) - 1} values (one per bin between the "
                f"{len(edges)} edges of edges_um); got {len(counts)}",
            )
    else:
        if "counts" in t:
            raise ctx.error(
                _join(where, "counts"),
                "only allowed with inline 'edges_um' (no 'file': the file holds the "
                "values)",
            )
        path, column, unit = _file_keys(ctx, t, where)
        layout = t.get("layout")
        if layout is not None:
            layout = ctx.choice(layout, _join(where, "layout"), ("edges", "midpoints"))
        values = t.get("values")
        if values is not None:
            values = ctx.choice(values, _join(where, "values"), tuple(BIN_VALUES))
        sample = t.get("sample")
        if sample is not None and (
            isinstance(sample, bool) or not isinstance(sample, str | int)
        ):
            raise ctx.error(
                _join(where, "sample"),
                'must be a Sample # (an integer), "mean", "sum", "A..B" or '
                f'"sum A..B"; got {sample!r}',
            )
        edges_um = t.get("edges_um")  # with a file: the sizes of its bin columns
        if edges_um is not None:
            edges_um = ctx.numbers(
                edges_um, _join(where, "edges_um"), low=0, strict=True, minimum=2
            )
        bins, _ = ctx.build(
            _join(where, "file"),
            t,
            read_size_bins,
            path,
            layout=layout,
            values=values,
            column=column,
            unit=unit,
            sample=sample,
            edges_um=edges_um,
            syntax="toml",
        )
        edges, counts = bins.edges_um, bins.number
    return ctx.build(where, t, pd_.histogram_diameters, edges, counts)


def _values(ctx: _Ctx, value, key) -> list:
    """A sweep value: a number, an array of numbers and range tables, or a range
    table ``{start, stop, num}`` / ``{start, stop, step}`` (both ends included),
    with ``spacing = "log"`` for ``num`` values evenly spaced in log."""
    if isinstance(value, dict):
        return _range(ctx, value, key)
    if isinstance(value, list):
        if not value:
            raise ctx.error(key, "must not be empty")
        out = []
        for i, v in enumerate(value):
            sub = f"{key}[{i}]"
            out.extend(
                _range(ctx, v, sub) if isinstance(v, dict) else [ctx.number(v, sub)]
            )
        return out
    return [ctx.number(value, key)]


def _range(ctx, t, key) -> list:
    ctx.keys(t, key, ("start", "stop", "num", "step", "spacing"), ("start", "stop"))
    start = ctx.number(t["start"], f"{key}.start")
    stop = ctx.number(t["stop"], f"{key}.stop")
    spacing = t.get("spacing", "linear")
    ctx.choice(spacing, f"{key}.spacing", SPACINGS)
    if ("num" in t) == ("step" in t):
        raise ctx.error(f"{key}.num", "give exactly one of 'num' or 'step'")
    if stop < start:
        raise ctx.error(f"{key}.stop", f"must be >= start ({start:g}); got {stop:g}")
    if spacing == "log":
        if "num" not in t:
            raise ctx.error(f"{key}.spacing", "'log' spacing needs 'num', not 'step'")
        if not start > 0:
            raise ctx.error(
                f"{key}.start", f"must be > 0 for 'log' spacing; got {start:g}"
            )
    if "num" in t:
        n = ctx.integer(t["num"], f"{key}.num", low=1)
        if n > MAX_SWEEP_POINTS:
            raise ctx.error(f"{key}.num", f"must be <= {MAX_SWEEP_POINTS}; got {n}")
        if n == 1:
            vals = np.array([start])
        elif spacing == "log":
            vals = np.geomspace(start, stop, n)
        else:
            vals = np.linspace(start, stop, n)
    else:
        step = ctx.number(t["step"], f"{key}.step", low=0, strict=True)
        n = math.floor((stop - start) / step * (1 + 1e-12) + 1e-9) + 1
        if n > MAX_SWEEP_POINTS:
            raise ctx.error(
                f"{key}.step", f"gives {n} values, more than {MAX_SWEEP_POINTS}"
            )
        vals = start + step * np.arange(n)
    return [float(v) for v in np.round(vals, 12)]


def _nth(i: int, n: int) -> str:
    """Where a value sits among the sweep's expanded values: ``the 2nd of 5 values``."""
    k = i + 1
    suffix = {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    if 10 <= k % 100 <= 20:
        suffix = "th"
    return f"the {k}{suffix} of {n} values"


def _sweep(ctx: _Ctx, data) -> dict:
    if "sweep" not in data:
        raise ctx.error("sweep", "missing required table [sweep] (with speed_m_s)")
    t = ctx.table(data["sweep"], "sweep")
    ctx.keys(t, "sweep", SWEEP_KEYS, ("speed_m_s",))
    speeds = _values(ctx, t["speed_m_s"], "sweep.speed_m_s")
    for i, v in enumerate(speeds):
        if not v > 0:
            raise ctx.error(
                "sweep.speed_m_s",
                f"speeds must be > 0 m/s; got {v:g} ({_nth(i, len(speeds))})",
            )
    angles = _values(ctx, t.get("angle_deg", [90.0]), "sweep.angle_deg")
    for i, v in enumerate(angles):
        if not 0 < v <= 90:
            raise ctx.error(
                "sweep.angle_deg",
                f"apparent incidence angles from the surface plane must be in "
                f"(0, 90] deg (90 = normal impact); got {v:g} ({_nth(i, len(angles))})",
            )
    spread = 0.0
    if "speed_spread" in t:
        spread = ctx.number(t["speed_spread"], "sweep.speed_spread", low=0, high=0.5)
    return {
        "speeds_m_s": tuple(speeds),
        "angles_deg": tuple(angles),
        "speed_spread": spread,
    }


# ---------------------------------------------------------------------- coefficients
def _coefficients(ctx: _Ctx, data):

    if "coefficients" not in data:
        raise ctx.error("coefficients", "missing required table [coefficients]")
    t = dict(ctx.table(data["coefficients"], "coefficients"))
    ctx.keys(
        t, "coefficients", COEFFICIENT_KEYS, () if "set" in t else ("k1", "k2", "v_c")
    )
    for key in ("k1", "k2", "v_c"):
        if key in t and not isinstance(t[key], dict):
            t[key] = ctx.number(t[key], f"coefficients.{key}", low=0, inf=key != "v_c")
    for key in ("p", "q"):
        if key in t:
            t[key] = ctx.number(t[key], f"coefficients.{key}", low=0, strict=True)
    if "friction" in t:
        f = t["friction"]
        if isinstance(f, str) and f.strip().lower() in ("inf", "infinity"):
            t["friction"] = math.inf
        elif isinstance(f, str):
            raise ctx.error(
                "coefficients.friction", f"must be a number >= 0 or 'inf'; got {f!r}"
            )
        else:
            t["friction"] = ctx.number(f, "coefficients.friction", low=0, inf=True)
    if "set" in t:
        ctx.string(t["set"], "coefficients.set")
    try:
        return ImpactCoefficients.from_dict(t, source=ctx.source, field="coefficients")
    except ScenarioError as exc:
        raise ctx.error(exc.field, exc.message.rstrip(".")) from None
    except (TypeError, ValueError) as exc:
        raise ctx.error("coefficients", str(exc)) from None


# ---------------------------------------------------------------------- top level
def _precision(ctx: _Ctx, data):
    if "precision" not in data:
        return None
    t = ctx.table(data["precision"], "precision")
    ctx.keys(t, "precision", PRECISION_KEYS)
    kw = {}
    if "statistic" in t:
        kw["statistic"] = ctx.choice(
            t["statistic"], "precision.statistic", PRECISION_STATISTICS
        )
    if "half_width" in t:
        kw["half_width"] = ctx.number(
            t["half_width"], "precision.half_width", low=0, strict=True
        )
    for key in ("max_samples", "min_samples"):
        if key in t:
            kw[key] = ctx.integer(t[key], f"precision.{key}", low=1)
    try:
        return Precision(**kw)  # checks min_samples <= max_samples
    except ScenarioError as exc:
        raise ctx.error(exc.field, exc.message) from None


def _outputs(ctx: _Ctx, data):
    """The ``[outputs]`` table as :class:`~microimpact.scenario.outputs.Outputs`."""
    t = ctx.table(data.get("outputs", {}), "outputs")
    ctx.keys(t, "outputs", OUTPUT_KEYS)
    kw = {}
    if "figures" in t:
        figures = t["figures"]
        if isinstance(figures, str):
            figures = [figures]
        if not isinstance(figures, list):
            raise ctx.error(
                "outputs.figures", "must be an array of formats, e.g. ['png']"
            )
        kw["figures"] = tuple(
            ctx.choice(f, f"outputs.figures[{i}]", FIGURE_FORMATS)
            for i, f in enumerate(figures)
        )
    if "report" in t:
        if not isinstance(t["report"], bool):
            raise ctx.error(
                "outputs.report", f"must be true or false; got {_show(t['report'])}"
            )
        kw["report"] = t["report"]
    if "distribution_speed_m_s" in t:
        kw["distribution_speed_m_s"] = ctx.number(
            t["distribution_speed_m_s"],
            "outputs.distribution_speed_m_s",
            low=0,
            strict=True,
        )
    exp = t.get("experiments", [])
    if isinstance(exp, str):
        kw["experiments"] = (ctx.path(exp, "outputs.experiments"),)
    elif isinstance(exp, list):
        kw["experiments"] = tuple(
            ctx.path(e, f"outputs.experiments[{i}]") for i, e in enumerate(exp)
        )
    else:
        raise ctx.error(
            "outputs.experiments", "must be a CSV file name or an array of them"
        )
    return Outputs(**kw)


def _read_table(read, data, source, base_dir):
    """``read(ctx, data)`` for one table of parsed scenario data; relative paths
    resolve from `base_dir` (default: the folder of `source`)."""
    if base_dir is None and source is not None:
        base_dir = Path(source).resolve().parent
    ctx = _Ctx(source, base_dir)
    ctx.table(data, "(top level)")
    return read(ctx, data)


def particles_from_dict(data: dict, *, source=None, base_dir=None):
    """The size distribution of parsed scenario data's ``[particles]`` table alone
    (a file that needs no impact tables, e.g. ``[resuspension]`` with
    ``source = "particles"``); its top-level keys are checked too."""

    def read(ctx, data):
        ctx.keys(data, "", TOP_KEYS, ("particles",))
        return _particles(ctx, data["particles"])

    return _read_table(read, data, source, base_dir)


def outputs_from_dict(data: dict, *, source=None, base_dir=None):
    """The :class:`~microimpact.pipeline.study.Outputs` of parsed scenario data (its
    ``[outputs]`` table; defaults where absent). Relative experiment paths resolve
    from `base_dir` (default: the folder of `source`)."""
    return _read_table(_outputs, data, source, base_dir)


def outputs_from_toml(path):
    """The :class:`~microimpact.pipeline.study.Outputs` of a scenario file."""
    path = Path(path)
    return _read_table(_outputs, read_toml(path), path, path.resolve().parent)


def _wall_law(ctx: _Ctx, data):
    """The ``[wall_law]`` table as :class:`~microimpact.scenario.wall_law.WallLawSpec`
    (None if absent). Speeds and angles default to the ``[sweep]``'s; with
    ``speed_axis = "reduced"`` (the default where ``reduced_speed`` is given) the
    speed nodes are the ratios ``reduced_speed`` = v / v_c(d) instead."""

    if "wall_law" not in data:
        return None
    t = ctx.table(data["wall_law"], "wall_law")
    ctx.keys(t, "wall_law", WALL_LAW_KEYS, ("diameter_um",))
    sweep = data.get("sweep", {}) if isinstance(data.get("sweep"), dict) else {}
    kw = {}
    axis = "reduced" if "reduced_speed" in t else "absolute"
    if "speed_axis" in t:
        axis = ctx.choice(t["speed_axis"], "wall_law.speed_axis", SPEED_AXES)
    kw["speed_axis"] = axis
    if "reduced_speed" in t:
        kw["reduced_speeds"] = _values(
            ctx, t["reduced_speed"], "wall_law.reduced_speed"
        )
    elif axis == "reduced":
        raise ctx.error(
            "wall_law.reduced_speed",
            'missing: speed_axis = "reduced" needs the ratios v / v_c(d) of its '
            "speed nodes (a list or a range table)",
        )
    axes = [("diameter_um", "diameters_um", None)]
    if axis == "absolute" or "speed_m_s" in t:  # a reduced axis refuses speed_m_s
        axes.append(("speed_m_s", "speeds_m_s", sweep.get("speed_m_s")))
    else:
        kw["speeds_m_s"] = None
    axes.append(("angle_deg", "angles_deg", sweep.get("angle_deg", [90.0])))
    for key, name, default in axes:
        where = f"wall_law.{key}" if key in t else f"sweep.{key}"
        value = t.get(key, default)
        if value is None:
            raise ctx.error(f"wall_law.{key}", "missing (and no [sweep] value to use)")
        kw[name] = _values(ctx, value, where)
    for key in ("reservoir", "samples"):
        if key in t:
            kw[key] = ctx.integer(t[key], f"wall_law.{key}", low=1)
    if "fallback_at" in t:
        at = ctx.table(t["fallback_at"], "wall_law.fallback_at")
        ctx.keys(at, "wall_law.fallback_at", FALLBACK_KEYS, ())
        kw["fallback_at"] = {
            k: ctx.number(at[k], f"wall_law.fallback_at.{k}", low=0, strict=True)
            for k in FALLBACK_KEYS
            if k in at
        }
    try:
        return WallLawSpec(**kw)
    except ScenarioError as exc:
        raise ctx.error(exc.field, exc.message) from None


def wall_law_from_dict(data: dict, *, source=None, base_dir=None):
    """The :class:`~microimpact.scenario.wall_law.WallLawSpec` of parsed scenario data
    (its ``[wall_law]`` table), or None if it has none."""
    return _read_table(_wall_law, data, source, base_dir)


def wall_law_from_toml(path):
    """The :class:`~microimpact.scenario.wall_law.WallLawSpec` of a scenario file, or
    None if it has no ``[wall_law]`` table."""
    path = Path(path)
    return _read_table(_wall_law, read_toml(path), path, path.resolve().parent)


@dataclass(frozen=True)
class ParsedScenario:
    """A scenario file's tables, each read and validated once: the keyword arguments
    of :class:`~microimpact.scenario.scenario.Scenario` (the physics), the output
    settings, the wall law's and the sensitivity study's tables, and where they came
    from. :func:`~microimpact.scenario.scenario.read_scenario` assembles the
    Scenario; this module stays below it."""

    arguments: dict
    outputs: Outputs
    wall_law: WallLawSpec | None
    sensitivity: SensitivitySettings | None
    data: dict
    source: str | None
    base_dir: Path
    #: Every problem found (checked table by table); the Scenario adds its own.
    problems: tuple = ()

    def error(self, field, message) -> ScenarioError:
        """A ScenarioError naming this file and the key path `field`."""
        return _Ctx(self.source, self.base_dir).error(field, message)


def parse_scenario(data: dict, *, source=None, base_dir=None, cache=None):
    """Read and validate every table of parsed scenario data (see
    ``docs/scenarios.md``) into a :class:`ParsedScenario`.

    Parameters
    ----------
    data : dict
        The scenario, as :func:`tomllib.load` returns it.
    source : str or path-like, optional
        The file `data` came from; named in every error message.
    base_dir : path-like, optional
        Folder that relative file names resolve from (default: the folder of
        `source`, else the current directory).
    cache : dict, optional
        Model objects built from earlier data, by table and content: a table whose
        content is unchanged gives back the same object (a size distribution, the
        coefficient laws, a surface's angles) instead of building it again. Used by
        :class:`~microimpact.analysis.model.ScenarioModel`, which parses the same
        file at many parameter values.

    Raises
    ------
    ScenarioError
        One line naming the file, the key path, the bad value and what is allowed.
    """
    if base_dir is None and source is not None:
        base_dir = Path(source).resolve().parent
    ctx = _Ctx(source, base_dir, cache=cache)
    ctx.table(data, "(top level)")
    ctx.attempt(ctx.keys, data, "", TOP_KEYS, ("particles",))
    kw = {}
    if "name" in data:
        kw["name"] = ctx.attempt(ctx.string, data["name"], "name", fallback="scenario")
    else:
        kw["name"] = Path(source).stem if source is not None else "scenario"
    if "description" in data:
        if isinstance(data["description"], str):
            kw["description"] = data["description"]
        else:
            ctx.problems.append(
                ctx.error(
                    "description",
                    f"must be a string; got {_show(data['description'])}",
                )
            )
    # plain values go to the Scenario as they are: it validates itself, and its
    # errors are mapped onto this file's key paths (one validation layer)
    for key in (
        "seed",
        "samples",
        "qmc_replicates",
        "shadowing",
        "sampling",
        "confidence",
        "capture_quantiles",
    ):
        if key in data:
            kw[key] = data[key]
    if "reference_angle_deg" in data:
        ref = data["reference_angle_deg"]
        kw["reference_angle_deg"] = None if ref is False else ref
    # each table is checked even where another one failed; a failed table's
    # stand-in (never simulated) lets the Scenario check the rest
    kw["precision"] = ctx.attempt(_precision, ctx, data)
    if "particles" in data:
        kw["particles"] = ctx.attempt(
            ctx.cached,
            "particles",
            data["particles"],
            _particles,
            data["particles"],
            fallback=_STAND_IN["particles"],
        )
    else:
        kw["particles"] = _STAND_IN["particles"]
    kw["coefficients"] = ctx.attempt(
        ctx.cached,
        "coefficients",
        data.get("coefficients"),
        _coefficients,
        data,
        fallback=_STAND_IN["coefficients"],
    )
    kw["surfaces"] = _surfaces(ctx, data)
    if "particle_roughness" in data:
        kw["particle_roughness"] = ctx.attempt(_particle_roughness, ctx, data)
    kw.update(
        ctx.attempt(
            _sweep,
            ctx,
            data,
            fallback={"speeds_m_s": (1.0,), "angles_deg": (90.0,)},
        )
    )
    kw["source"] = ctx.source
    return ParsedScenario(
        arguments=kw,
        outputs=ctx.attempt(_outputs, ctx, data, fallback=Outputs()),
        wall_law=ctx.attempt(_wall_law, ctx, data),
        sensitivity=ctx.attempt(sensitivity_from_dict, data, source=ctx.source)
        if "sensitivity" in data
        else None,
        data=data,
        source=ctx.source,
        base_dir=ctx.base_dir,
        problems=tuple(ctx.problems),
    )


def _particle_roughness(ctx, data):
    t = ctx.table(data["particle_roughness"], "particle_roughness")
    if "name" in t:
        raise ctx.error(
            "particle_roughness.name", "not allowed here (only for surfaces)"
        )
    return ctx.cached("particle_roughness", t, _angles, t, "particle_roughness")


def file_order(data: dict, problems) -> list:
    """`problems` in the order of the file: by the top-level key they are under
    (as the file lists them), then the entry of an array of tables."""
    keys = list(data) if isinstance(data, dict) else []

    def where(exc):
        field = exc.field or ""
        top = field.split(".")[0].split("[")[0]
        entry = field.split("[")[1].split("]")[0] if "[" in field.split(".")[0] else 0
        try:
            entry = int(entry)
        except ValueError:
            entry = 0
        return (keys.index(top) if top in keys else len(keys), entry)

    return sorted(problems, key=where)


def read_toml(path) -> dict:
    """Parse a TOML file; every problem is a ScenarioError naming the file."""
    return read_toml_text(path)[1]


def read_toml_text(path) -> tuple[str, dict]:
    """``(text, data)`` of a TOML file, read once; every problem is a ScenarioError
    naming the file."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError("scenario file not found", source=path) from None
    except IsADirectoryError:
        raise ScenarioError(
            "is a directory, not a scenario file", source=path
        ) from None
    except OSError as exc:
        raise ScenarioError(
            f"cannot read the file ({exc.strerror})", source=path
        ) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"not UTF-8 text (byte {exc.start})", source=path) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = _TOML_POSITION.search(msg)
        line = None
        if m:
            line = int(m.group(1))
            msg = f"{msg[: m.start()]} (column {m.group(2)})"
        else:
            msg = _TOML_EOF.sub(" (at the end of the file)", msg)
        raise ScenarioError(
            f"TOML syntax error: {_one_line(msg)}", source=path, line=line
        ) from None
    return text, data


# ---------------------------------------------------------------------- presets
def list_presets() -> list[str]:
    """Names of the shipped presets (see ``docs/presets.md``)."""
    return sorted(PRESETS)


def preset_path(name: str) -> Path:
    """The scenario file of preset `name`."""
    if name not in PRESETS:
        raise ValueError(
            f"`name` must be one of {', '.join(repr(p) for p in list_presets())}; "
            f"got {name!r}{did_you_mean(name, PRESETS)}."
        )
    return PRESET_DIR / PRESETS[name]
