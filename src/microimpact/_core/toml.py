"""The one TOML writer: values, tables, whole documents, and the snippets ready to
paste into a scenario file (``docs/scenarios.md``).

``microimpact sizes`` and ``microimpact fit`` (and ``roughness``) write what they
found as scenario tables, so the measured population, the fitted coefficient laws
or the measured surface can be simulated without retyping a number:

* :func:`particles_snippet` -- a ``[particles]`` table from a size fit, a
  :class:`~microimpact.population.distributions.SizeDistribution` or a
  :class:`~microimpact.population.sizes_report.SizesReport` (its recommendation);
* :func:`coefficients_snippet` -- a ``[coefficients]`` table from
  :class:`~microimpact.physics.coefficients.ImpactCoefficients` (e.g. the result of
  :func:`~microimpact.physics.fitting.fit_coefficient_laws`);
* :func:`surface_snippet` -- a ``[[surfaces]]`` block of kind ``"angles"`` reading a
  roughness-angle file (e.g. the ``angles.txt`` of ``microimpact roughness``).

Each function is pure and returns text. Floats are written with ``repr`` (the
shortest text that reads back to the same float), so a snippet parsed by
:func:`microimpact.scenario.file.scenario_from_dict` gives back exactly the values it
was written from.
"""

from __future__ import annotations

import math
import numbers
import os
import re
from collections.abc import Mapping, Sequence

import numpy as np

from ..units import m_to_um

__all__ = [
    "coefficients_snippet",
    "particles_snippet",
    "surface_snippet",
    "to_toml",
    "toml_key",
    "toml_value",
]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_string(text: str) -> str:
    out = []
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(key) -> str:
    """A TOML key: bare where it can be, else a quoted string."""
    key = str(key)
    return key if _BARE.match(key) else _toml_string(key)


def toml_value(value, *, allow_nan=False) -> str:
    """One TOML value: a string, boolean, number (``inf`` allowed, NaN only with
    `allow_nan`), array or inline table.

    Raises
    ------
    ValueError
        For NaN without `allow_nan` (TOML could hold it, but no scenario key
        accepts it).
    TypeError
        For any other type.
    """
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, os.PathLike):
        return _toml_string(os.fspath(value))
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if math.isnan(x):
            if allow_nan:
                return "nan"
            raise ValueError("NaN cannot be written to a scenario snippet.")
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v, allow_nan=allow_nan) for v in value) + "]"
    if isinstance(value, Mapping):
        items = (
            f"{toml_key(k)} = {toml_value(v, allow_nan=allow_nan)}"
            for k, v in value.items()
        )
        return "{ " + ", ".join(items) + " }"
    raise TypeError(f"cannot write a {type(value).__name__} as a TOML value.")


def to_toml(data: Mapping, *, header: Sequence[str] = ()) -> str:
    """Parsed TOML data as TOML text (``tomllib.loads`` gives `data` back).

    Top-level tables become ``[table]`` sections, arrays of tables ``[[array]]``
    sections; tables inside a section are written inline. `header` lines are
    written first as comments.
    """

    def line(k, v):
        return f"{toml_key(k)} = {toml_value(v, allow_nan=True)}"

    out = [f"# {h}" for h in header]
    for k, v in data.items():
        if not isinstance(v, Mapping) and not _table_array(v):
            out.append(line(k, v))
    for k, v in data.items():
        if isinstance(v, Mapping):
            out += ["", f"[{toml_key(k)}]"]
            out += [line(a, b) for a, b in v.items()]
        elif _table_array(v):
            for entry in v:
                out += ["", f"[[{toml_key(k)}]]"]
                out += [line(a, b) for a, b in entry.items()]
    return "\n".join(out) + "\n"


def _table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(e, Mapping) for e in v)


def _table(header: str, items: dict, comment: str | None) -> str:
    lines = [f"# {c}" for c in (comment or "").splitlines() if c.strip()]
    lines.append(header)
    lines += [f"{k} = {toml_value(v)}" for k, v in items.items() if v is not None]
    return "\n".join(lines) + "\n"


def _distribution_items(dist, *, file=None, column=None, unit=None) -> dict:

    p = dict(dist.params)
    limits = {"min_um": p.get("min_um"), "max_um": p.get("max_um")}
    kind = dist.kind
    if kind == "normal":
        return {
            "distribution": kind,
            "mean_um": p["mean_um"],
            "std_um": p["std_um"],
        } | limits
    if kind == "lognormal":
        return {
            "distribution": kind,
            "median_um": p["median_um"],
            "geometric_std": p["geometric_std"],
        } | limits
    if kind == "uniform":
        return {"distribution": kind, "min_um": p["min_um"], "max_um": p["max_um"]}
    if kind == "monodisperse":
        return {"distribution": kind, "diameter_um": p["diameter_um"]}
    if kind == "empirical":
        if file is not None:
            items = {"distribution": kind, "file": file, "column": column, "unit": unit}
        else:
            items = {
                "distribution": kind,
                "diameters_um": [float(v) for v in m_to_um(dist.atoms)],
            }
        return items | limits
    if kind == "histogram":
        return {"distribution": kind, "edges_um": p["edges_um"], "counts": p["counts"]}
    raise ValueError(
        f"a {kind!r} population has no [particles] table; allowed: normal, "
        "lognormal, uniform, monodisperse, empirical, histogram."
    )


def particles_snippet(
    fit_or_distribution, *, file=None, column=None, unit=None, comment=None
) -> str:
    """A ``[particles]`` table for a scenario file.

    Parameters
    ----------
    fit_or_distribution : FitResult, SizeDistribution or SizesReport
        A fit of :func:`~microimpact.population.distributions.fit_normal` /
        :func:`~microimpact.population.distributions.fit_lognormal`, a population,
        or a :class:`~microimpact.population.sizes_report.SizesReport` (its
        recommended population).
    file, column, unit : optional
        For an empirical population: refer to the measured file instead of
        listing every diameter (``file`` is written as given; a relative path
        resolves from the scenario's folder).
    comment : str, optional
        ``#`` lines written above the table.

    Returns
    -------
    str
        TOML text ending with a newline.
    """
    obj = fit_or_distribution
    if hasattr(obj, "recommended_distribution"):  # a SizesReport
        if comment is None:
            comment = obj.verdict
        obj = obj.recommended_distribution
    dist = getattr(obj, "distribution", obj)  # a FitResult holds its population
    if not (hasattr(dist, "kind") and hasattr(dist, "params")):
        raise TypeError(
            "`fit_or_distribution` must be a FitResult, a SizeDistribution or a "
            f"SizesReport; got {type(fit_or_distribution).__name__}."
        )
    items = _distribution_items(dist, file=file, column=column, unit=unit)
    return _table("[particles]", items, comment)


def coefficients_snippet(laws, *, comment=None) -> str:
    """A ``[coefficients]`` table for a scenario file.

    Parameters
    ----------
    laws : ImpactCoefficients
        E.g. from :func:`~microimpact.physics.fitting.fit_coefficient_laws`. Each law
        is written as the law table of its ``describe()``, which
        :func:`~microimpact.physics.coefficients.law_from_dict` reads back.
    comment : str, optional
        ``#`` lines written above the table.

    Raises
    ------
    ValueError
        If a law cannot be written as a scenario law table (a Python callable).
    """
    items, described = {}, laws.describe()
    for name in ("k1", "k2", "v_c"):
        spec = described[name]
        if spec.get("law") == "callable":
            raise ValueError(
                f"{name} is a Python function; a scenario file cannot hold it."
            )
        items[name] = spec
    items.update(p=laws.p, q=laws.q, friction=laws.friction)
    return _table("[coefficients]", items, comment)


def surface_snippet(angle_file, *, name="measured", comment=None) -> str:
    """A ``[[surfaces]]`` block of kind ``"angles"`` reading `angle_file` (one angle
    [deg] per line, as written by
    :func:`~microimpact.surface.roughness.write_angle_file`).

    The path is written as given; a relative path resolves from the folder of the
    scenario file it is pasted into.
    """
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"`name` must be a non-empty string; got {name!r}.")
    items = {"name": name, "kind": "angles", "file": os.fspath(angle_file)}
    return _table("[[surfaces]]", items, comment)
