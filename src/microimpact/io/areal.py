"""Readers for areal surface topography (height maps).

An areal scan is a grid of heights ``z[j, i]`` at ``x = i dx``, ``y = j dy``: rows are
``y`` and columns ``x``, as in ISO 25178-72 (``.x3p``). The readers return a
:class:`HeightMap` with SI units inside (metres). Missing points (not measured,
``NaN``) are kept as ``NaN``; :mod:`microimpact.surface.areal` levels the map and
works around them.

Supported inputs
----------------
* **Plain-text height maps**: one row of heights per line (``y`` grows down the
  file), separated by ``;``, tab, ``,`` or whitespace (sniffed from the first row, or
  ``delimiter=``). Missing points are written ``nan`` (or empty, ``na``, ``-``, ...).
  The grid spacing and units are given either in ``#`` header lines before the data
  (``key = value`` or ``key: value``)::

      # dx_um = 0.5
      # dy_um = 0.5
      # z_unit = nm
      12.1 13.0 nan 11.7
      ...

  or as arguments (`dx_um`, `dy_um`, `z_unit`). Header keys: ``dx`` and ``dy`` with
  a length unit in the key (``dx_um``, ``dx [nm]``) or in ``xy_unit``; ``z_unit``
  for the heights (default µm). A value given both in the header and as an argument
  must agree.
* **ISO 25178-72 ``.x3p``** surfaces through the optional package ``x3pio``
  (``pip install x3pio``, the ``x3p`` extra), imported only when such a file is read.
* **Other instrument formats** (``.sur``, ``.plu``, ``.datx``, ``.sdf``, ``.opd``,
  ``.di``, ``.ibw``, ...) through the optional package ``SurfaceTopography``
  (``pip install SurfaceTopography``), imported only when such a file is read.

Every problem in a file raises a one-line
:class:`~microimpact.errors.ProfileFormatError` naming the file, the line or field,
the value and what is allowed.

References
----------
.. [1] ISO 25178-72:2017, Geometrical product specifications (GPS) -- Surface
   texture: Areal -- Part 72: XML file format x3p.
.. [2] L. Pastewka et al., SurfaceTopography,
   https://github.com/ContactEngineering/SurfaceTopography.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.files import MISSING, check_delimiter, parse_number, read_lines, split_rows
from .._core.validation import as_float_array
from ..errors import ProfileFormatError
from ..units import length_factor
from .instruments import channel_unit, read_instrument
from .plausibility import check_map, plausible_spacing
from .profiles import header_unit, instrument_reader, open_x3p

__all__ = ["HeightMap", "read_height_map"]

#: Suffixes read as plain text.
TEXT_SUFFIXES = (".txt", ".csv", ".tsv", ".dat", ".asc")
FORMATS = ("text", "x3p", "surfacetopography")
_HEADER_LINE = re.compile(r"^#\s*(?P<key>[^=:]+?)\s*[=:]\s*(?P<value>.+?)\s*$")
_KEY_NAME = re.compile(r"^[A-Za-z]+")
_POSITIVE = "a finite number > 0"


def check_grid(z, dx, dy):
    """`z` as a float 2-d array and `dx`, `dy` as floats, or ``ValueError`` unless
    `z` is at least 2 x 2 with some finite heights (NaN marks a missing point) and
    the spacings are finite and > 0."""
    z = as_float_array(z, "z")
    if z.ndim != 2 or min(z.shape) < 2:
        raise ValueError(
            f"`z` must be a 2-d array of at least 2 x 2 heights; got shape {z.shape}."
        )
    if np.isinf(z).any():
        raise ValueError("`z` must not hold inf; mark a missing point with NaN.")
    if not np.isfinite(z).any():
        raise ValueError("`z` holds no finite height.")
    out = []
    for name, d in (("dx", dx), ("dy", dy)):
        d = float(d)
        if not (np.isfinite(d) and d > 0):
            raise ValueError(f"`{name}` must be {_POSITIVE}; got {d!r}.")
        out.append(d)
    return z, out[0], out[1]


@dataclass(frozen=True, eq=False)
class HeightMap:
    """An areal height map on a regular grid.

    Attributes
    ----------
    z : ndarray, shape (ny, nx)
        Heights [m]; row ``j`` is ``y = j dy``, column ``i`` is ``x = i dx``. NaN
        marks a missing (not measured) point.
    dx, dy : float
        Grid spacing along x and y [m].
    metadata : dict
        Provenance: ``source`` (file), ``format``, the units in the file, ...
    """

    z: np.ndarray
    dx: float
    dy: float
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        z, dx, dy = check_grid(np.array(self.z, dtype=float), self.dx, self.dy)
        z.setflags(write=False)
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "dy", dy)
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``."""
        return self.z.shape

    @property
    def nx(self) -> int:
        """Number of columns (points along x)."""
        return int(self.z.shape[1])

    @property
    def ny(self) -> int:
        """Number of rows (points along y)."""
        return int(self.z.shape[0])

    @property
    def x(self) -> np.ndarray:
        """Column positions ``i dx`` [m]."""
        return np.arange(self.nx) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Row positions ``j dy`` [m]."""
        return np.arange(self.ny) * self.dy

    @property
    def valid(self) -> np.ndarray:
        """True where a height was measured."""
        return np.isfinite(self.z)

    @property
    def valid_fraction(self) -> float:
        """Fraction of measured points."""
        return float(self.valid.mean())

    @property
    def source(self):
        """The file the map was read from, or ``None``."""
        return self.metadata.get("source")

    def with_heights(self, z, **metadata) -> HeightMap:
        """A copy with new heights `z` [m] (same grid) and updated metadata."""
        return HeightMap(z, self.dx, self.dy, {**self.metadata, **metadata})

    def __repr__(self) -> str:
        return (
            f"HeightMap(nx={self.nx}, ny={self.ny}, dx={self.dx:.4g} m, "
            f"dy={self.dy:.4g} m, valid={self.valid_fraction:.3g}, "
            f"source={self.source!r})"
        )


# --------------------------------------------------------------------------- text


def _unit(unit, *, path, field, line=None) -> float:
    try:
        return length_factor(unit)
    except ValueError as exc:
        raise ProfileFormatError(
            str(exc), source=path, field=field, line=line
        ) from None


def _header(lines, path) -> dict:
    """``{key: (value, unit or None, line)}`` from the ``# key = value`` lines before
    the first data line."""
    out = {}
    for lineno, raw in enumerate(lines, start=1):
        text = raw.strip()
        if not text:
            continue
        if not text.startswith("#"):
            break
        m = _HEADER_LINE.match(text)
        if not m:
            continue  # a free comment
        key = m.group("key").strip()
        value = m.group("value").split("#", 1)[0].strip()
        folded = key.lower()
        if folded in ("xy_unit", "z_unit"):
            name, unit = folded, None
        else:
            head = _KEY_NAME.match(key)
            name = head.group(0).lower() if head else folded
            if name not in ("dx", "dy"):
                continue  # other metadata (instrument, date, ...) is ignored
            unit, bad = header_unit(key)
            rest = key[len(name) :].strip(" _[]()/")
            if unit is None and (bad or rest):
                _unit(bad or rest, path=path, field=key, line=lineno)  # raises
        if name in out:
            raise ProfileFormatError(
                f"{name!r} is given twice (first on line {out[name][2]}); allowed: "
                "once",
                source=path,
                line=lineno,
                field=key,
            )
        out[name] = (value, unit, lineno)
    return out


def _spacing(name, header, arg, xy_unit, path) -> tuple[float, str, str]:
    """The spacing `name` ('dx' or 'dy') [m], where it came from and
    the unit it was given in. An argument overrides an implausible header value
    (a unit slip); otherwise the two must agree."""
    from_arg = None
    if arg is not None:
        v = float(arg)
        if not (np.isfinite(v) and v > 0):
            raise ProfileFormatError(
                f"bad value {arg!r}; allowed: {_POSITIVE} (µm)",
                source=path,
                field=f"{name}_um",
            )
        from_arg = v * 1e-6
    if name not in header:
        if from_arg is None:
            raise ProfileFormatError(
                f"no grid spacing {name!r}: give a '# {name}_um = ...' header line or "
                f"the argument `{name}_um`",
                source=path,
                field=name,
            )
        return from_arg, "argument", "um"
    value, unit, lineno = header[name]
    if unit is None:
        if xy_unit is None:
            raise ProfileFormatError(
                f"the header gives {name} = {value!r} without a unit; allowed: a unit "
                f"in the key ('{name}_um', '{name} [nm]') or an 'xy_unit' line",
                source=path,
                line=lineno,
                field=name,
            )
        unit = xy_unit
    v = parse_number(
        value,
        source=path,
        line=lineno,
        field=name,
        allowed=_POSITIVE,
        ok=lambda x: x > 0,
        error=ProfileFormatError,
    )
    v *= _unit(unit, path=path, field=name, line=lineno)
    if from_arg is not None and not plausible_spacing(v, 2):
        return from_arg, "argument (the header's value is implausible)", "um"
    if from_arg is not None and not np.isclose(v, from_arg, rtol=1e-9, atol=0.0):
        raise ProfileFormatError(
            f"the header gives {name} = {v * 1e6:.9g} µm but `{name}_um` is "
            f"{from_arg * 1e6:.9g}; allowed: the same value, or leave `{name}_um` out",
            source=path,
            line=lineno,
            field=f"{name}_um",
        )
    return v, "header", unit


def _row_values(cells, *, path, lineno) -> np.ndarray:
    """One row of heights; missing-value markers give NaN."""
    try:
        row = np.array(cells, dtype=float)
    except ValueError:
        row = np.empty(len(cells))
        for k, cell in enumerate(cells):
            if cell.strip().lower() in MISSING:
                row[k] = np.nan
            else:
                row[k] = parse_number(
                    cell,
                    source=path,
                    line=lineno,
                    field=f"column {k}",
                    allowed="a finite number, or nan for a missing point",
                    what="height",
                    error=ProfileFormatError,
                )
    if np.isinf(row).any():
        k = int(np.argmax(np.isinf(row)))
        raise ProfileFormatError(
            f"bad height {cells[k]!r}; allowed: a finite number, or nan for a "
            "missing point",
            source=path,
            line=lineno,
            field=f"column {k}",
        )
    return row


def _read_text(path, *, dx_um, dy_um, z_unit, delimiter) -> HeightMap:
    lines = read_lines(
        path,
        error=ProfileFormatError,
        hint=" (for .x3p files use the .x3p suffix)",
    )
    header = _header(lines, path)
    xy_unit = None
    if "xy_unit" in header:
        value, _, lineno = header["xy_unit"]
        _unit(value, path=path, field="xy_unit", line=lineno)
        xy_unit = value
    dx, dx_from, dx_unit = _spacing("dx", header, dx_um, xy_unit, path)
    if "dy" not in header and dy_um is None:
        dy, dy_from = dx, "dx"  # the docs: dy defaults to dx
    else:
        dy, dy_from, _ = _spacing("dy", header, dy_um, xy_unit, path)
    z_from = None
    unit = None
    if "z_unit" in header:
        value, _, lineno = header["z_unit"]
        _unit(value, path=path, field="z_unit", line=lineno)
        unit, z_from = value, "header"
        if z_unit is not None and length_factor(z_unit) != length_factor(value):
            raise ProfileFormatError(
                f"the header gives the height unit {value!r} but `z_unit` is "
                f"{z_unit!r}; allowed: the same unit, or leave `z_unit` out",
                source=path,
                line=lineno,
                field="z_unit",
            )
    elif z_unit is not None:
        _unit(z_unit, path=path, field="z_unit")
        unit, z_from = z_unit, "argument"
    rows, delim = split_rows(
        lines,
        source=path,
        delimiter=check_delimiter(delimiter),
        error=ProfileFormatError,
    )
    if not rows:
        raise ProfileFormatError("no data rows", source=path)
    width = len(rows[0][1])
    grid = []
    for lineno, cells in rows:
        if len(cells) != width:
            raise ProfileFormatError(
                f"row has {len(cells)} heights, the first row has {width}; allowed: "
                "the same number in every row (write nan for a missing point; the "
                "decimal separator must be '.')",
                source=path,
                line=lineno,
            )
        grid.append(_row_values(cells, path=path, lineno=lineno))
    z = np.vstack(grid)
    if z.shape[0] < 2 or z.shape[1] < 2:
        raise ProfileFormatError(
            f"the grid is {z.shape[0]} x {z.shape[1]}; allowed: at least 2 x 2 "
            "heights (for a line scan use read_profile)",
            source=path,
        )
    if not np.isfinite(z).any():
        raise ProfileFormatError("every height is missing (nan)", source=path)
    if unit is None:
        raise ProfileFormatError(
            "the file gives no height unit; give a '# z_unit = ...' header line or "
            "the argument `z_unit` (µm, nm, ...)",
            source=path,
            field="z_unit",
        )
    z = z * length_factor(unit)
    meta = {
        "source": path,
        "format": "text",
        "reader": "microimpact",
        "z_unit": unit,
        "z_unit_from": z_from,
        "xy_unit": xy_unit if xy_unit is not None else "um",
        # where the lateral unit came from, in the words docs/roughness.md uses:
        # an xy_unit line or a unit in the header's key ('dx_um', 'dx [nm]') is the
        # header's; a spacing given as `dx_um` is in µm by that argument's name
        "xy_unit_from": (
            "header" if xy_unit is not None or dx_from == "header" else "dx_um"
        ),
        "dx_from": dx_from,
        "dy_from": dy_from,
        "dx_unit": dx_unit,
        "delimiter": delim,
        "masked_fraction": float(np.mean(~np.isfinite(z))),
    }
    return HeightMap(z, dx, dy, meta)


# --------------------------------------------------------------------------- x3p


def _read_x3p(path) -> HeightMap:

    f = open_x3p(path)
    kind = type(f).__name__
    if kind != "Surface":
        raise ProfileFormatError(
            f"the file holds a {kind} (feature type {kind!r}); allowed: a Surface "
            "(SUR) for a height map; read a line scan with read_profiles (or "
            "`microimpact roughness`)",
            source=path,
            field="Record1/FeatureType",
        )
    layer = f.layers[0]
    try:
        dx, dy = layer.spacing
    except ValueError as exc:
        raise ProfileFormatError(
            f"{exc}; allowed: a surface on a regular grid (incremental x and y axes)",
            source=path,
            field="Record1/Axes",
        ) from None
    z = np.array(layer.z, dtype=float)
    if z.ndim != 2 or min(z.shape) < 2:
        raise ProfileFormatError(
            f"the surface is {z.shape}; allowed: at least 2 x 2 points",
            source=path,
            field="Record3",
        )
    if not np.isfinite(z).any():
        raise ProfileFormatError("every point is invalid", source=path, field="Record3")
    meta = {
        "source": path,
        "format": "x3p",
        "reader": "x3pio",
        "layers": len(f.layers),
        "z_unit": "m",
        "z_unit_from": "file",
        "xy_unit": "m",
        "xy_unit_from": "file",
        "dx_from": "file",
        "dy_from": "file",
        "masked_fraction": float(np.mean(~np.isfinite(z))),
    }
    return HeightMap(z, float(dx), float(dy), meta)


# ---------------------------------------------------------- SurfaceTopography


def _read_surfacetopography(path, *, dx_um=None, dy_um=None, z_unit=None, reader=None):
    data = read_instrument(
        path,
        want="map",
        z_unit=None if z_unit is None else (z_unit, "z_unit"),
        dx_um=dx_um,
        dy_um=dy_um,
        reader=reader,
    )
    return HeightMap(data.z, data.dx, data.dy, data.metadata)


# --------------------------------------------------------------------------- API


def read_height_map(
    path, *, dx_um=None, dy_um=None, z_unit=None, delimiter=None, format=None
) -> HeightMap:
    """Read an areal height map.

    Parameters
    ----------
    path : str or path-like
        A plain-text grid (``.txt``, ``.csv``, ``.tsv``, ``.dat``, ``.asc``), an
        ``.x3p`` file (needs ``x3pio``) or another instrument format read by
        SurfaceTopography (needs ``SurfaceTopography``).
    dx_um, dy_um : float, optional
        Grid spacing along x (columns) and y (rows) [µm], for text files whose header
        does not give it (if it does, the values must agree, unless the file's
        value is implausible: then the argument overrides it). `dy_um` defaults to
        the header's ``dy``, else to `dx_um`.
    z_unit : str, optional
        Unit of the heights in a text file: ``m``, ``mm``, ``um``/``µm``, ``nm``,
        ``A``/``Å``; default: the header's ``z_unit``, else µm.
    delimiter : str, optional
        Column delimiter of a text file; default: sniffed from the first row.
    format : {'text', 'x3p', 'surfacetopography'}, optional
        Default: from the suffix (``.x3p``, the text suffixes above, else
        SurfaceTopography).

    Returns
    -------
    HeightMap
        Heights [m] (NaN at missing points) and the spacings [m].

    Raises
    ------
    ProfileFormatError
        One line naming the file, the line or field, the value and what is allowed:
        a missing or contradictory grid spacing, an unknown unit, a non-numeric
        height, rows of different lengths, a grid smaller than 2 x 2, an optional
        package that is not installed, an exception inside a third-party reader,
        or a map that is not physically plausible
        (:mod:`microimpact.io.plausibility`: a spacing outside 0.1 nm to 1 mm, a
        field of 1 m or more, heights spanning over ten times the field), naming
        the likely unit slip and the override.
    """
    hm = _read_height_map(
        path,
        dx_um=dx_um,
        dy_um=dy_um,
        z_unit=z_unit,
        delimiter=delimiter,
        format=format,
    )
    meta = hm.metadata
    check_map(
        hm.z,
        hm.dx,
        hm.dy,
        source=hm.source,
        xy_unit=meta.get("dx_unit", meta.get("xy_unit")),
        z_unit=meta.get("z_unit"),
    )
    return hm


def _read_height_map(path, *, dx_um, dy_um, z_unit, delimiter, format) -> HeightMap:
    path = os.fspath(path)
    if format is None:
        suffix = Path(path).suffix.lower()
        if suffix == ".x3p":
            format = "x3p"
        elif suffix in TEXT_SUFFIXES or suffix == "":
            format = "text"
        else:
            format = "surfacetopography"
    elif format not in FORMATS:
        allowed = ", ".join(repr(f) for f in FORMATS)
        raise ValueError(f"`format` must be one of {allowed}; got {format!r}.")
    if format == "text":
        check_delimiter(delimiter)
    elif format == "x3p":
        for name, value in (
            ("dx_um", dx_um),
            ("dy_um", dy_um),
            ("z_unit", z_unit),
            ("delimiter", delimiter),
        ):
            if value is not None:
                raise ProfileFormatError(
                    f"`{name}` applies to plain-text height maps only; an x3p "
                    f"file carries its own grid and units: leave `{name}` out",
                    source=path,
                    field=name,
                )
        return _read_x3p(path)
    else:
        if delimiter is not None:
            raise ProfileFormatError(
                "`delimiter` applies to plain-text height maps only; leave it out",
                source=path,
                field="delimiter",
            )
        return _read_surfacetopography(path, dx_um=dx_um, dy_um=dy_um, z_unit=z_unit)
    try:
        return _read_text(
            path, dx_um=dx_um, dy_um=dy_um, z_unit=z_unit, delimiter=delimiter
        )
    except ProfileFormatError as ours:
        # not our plain text: an export SurfaceTopography knows (Gwyddion ASCII
        # with its '# Width: ...' header, ...)? Its units are honoured; a plain
        # grid we cannot read keeps our message (it names the line and the cell)
        if delimiter is not None:
            raise
        reader = instrument_reader(path)
        if reader is None:
            raise ours from None
        own = channel_unit(reader, path) is not None or "UTF-8" in ours.message
        given = any(v is not None for v in (dx_um, dy_um, z_unit))
        if not (own or given):
            raise ours from None
        try:
            return _read_surfacetopography(
                path, dx_um=dx_um, dy_um=dy_um, z_unit=z_unit, reader=reader
            )
        except ProfileFormatError:
            if own:
                raise
            raise ours from None
