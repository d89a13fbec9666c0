"""Instrument files through SurfaceTopography: one way in for every format it reads.

`SurfaceTopography <https://github.com/ContactEngineering/SurfaceTopography>`_ [1]_
is the maintained reader of topography formats (Dektak CSV and OPDx, Mitutoyo
SurfTest ``.xlsx``, Digital Surf ``.sur`` as written by Taylor Hobson's software,
Gwyddion exports, ``.plu``, ``.datx``, ``.opd``, ``.di``, ``.ibw``, two-column text,
...). :func:`read_instrument` turns what it reads into a list of
:class:`~microimpact.io.profiles.Profile` (a line scan, or the rows of a map) or a
:class:`~microimpact.io.areal.HeightMap`, with the same spacing, units, heights and
missing-point mask as SurfaceTopography.

Units rule (the same for every format): the file's unit is honoured; an argument
that disagrees with it is an error naming both; a file without a unit is an error
naming the arguments that supply one, never a guess. Every unit is recorded in the
metadata with where it came from (``"file"`` or ``"argument"``).

References
----------
.. [1] L. Pastewka et al., SurfaceTopography,
   https://github.com/ContactEngineering/SurfaceTopography (MIT licence).
.. [2] F. Schell, surfalize, ``surfalize/file/nms.py``,
   https://github.com/fredericjs/surfalize: the NanoFocus ``.nms`` header read by a
   second, independent parser (spacing at byte 1376, in nm).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import ProfileFormatError
from ..units import LENGTH_UNITS, length_factor
from .plausibility import plausible_spacing

__all__ = [
    "InstrumentMap",
    "InstrumentScan",
    "read_instrument",
    "surfacetopography_unit_factor",
]


class InstrumentScan(NamedTuple):
    """One line scan: positions and heights [m] (NaN: missing) and its metadata;
    :mod:`microimpact.io.profiles` makes a ``Profile`` of it."""

    x: np.ndarray
    z: np.ndarray
    metadata: dict


class InstrumentMap(NamedTuple):
    """A height map ``z[y, x]`` [m] (NaN: missing), its spacings [m] and its
    metadata; :mod:`microimpact.io.areal` makes a ``HeightMap`` of it."""

    z: np.ndarray
    dx: float
    dy: float
    metadata: dict


_UNIFORM_RTOL = 1e-3
#: Formats without a magic number, chosen by the suffix: SurfaceTopography's
#: detection can take such a file for another format (a NanoFocus ``.nms`` for a
#: MATLAB file, whose reader then finds no channel).
_FORMAT_BY_SUFFIX = {".nms": "nms"}
#: Byte offset of the NanoFocus ``.nms`` spacing (two little-endian doubles, dx and
#: dy, in nm) [1]_ [2]_; SurfaceTopography 1.25 reads them as mm.
_NMS_SPACING_OFFSET = 1376


def surfacetopography_unit_factor(unit) -> float | None:
    """Metres per `unit` as SurfaceTopography names it (``'µm'``, ``'nm'``, ...), or
    ``None`` if it is not a length unit."""
    if unit in LENGTH_UNITS:
        return LENGTH_UNITS[unit]
    try:
        # deferred: SurfaceTopography takes 1-2 s to import; only for its files
        from SurfaceTopography.Support.UnitConversion import (
            get_unit_conversion_factor,
        )

        return float(get_unit_conversion_factor(unit, "m"))
    except Exception:  # not a length unit SurfaceTopography knows
        return None


def _same(a: float, b: float) -> bool:
    return bool(np.isclose(a, b, rtol=1e-6, atol=0.0))


def _short(exc) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def reader_name(reader) -> str:
    """How a SurfaceTopography reader is named in messages: ``SurfaceTopography's
    NanoFocus NMS reader (NMSReader)``."""
    name = getattr(reader, "_name", None) or type(reader).__name__
    return f"SurfaceTopography's {name} reader ({type(reader).__name__})"


def _format_of(reader) -> str:
    try:
        return str(reader.format())
    except Exception:  # a reader that cannot even name its format
        return type(reader).__name__


def _reader_failed(path, reader, exc) -> ProfileFormatError:
    """Our one-line error for an exception raised inside a third-party reader."""
    return ProfileFormatError(
        f"{reader_name(reader)} failed on this {_format_of(reader)} file "
        f"({type(exc).__name__}: {_short(exc)}); microimpact cannot read it: export "
        "the map as x3p, SDF or a plain-text grid (see docs/roughness.md)",
        source=path,
        field="format",
    )


def open_instrument(path):
    """SurfaceTopography's reader of `path`; ProfileFormatError naming the file if
    it is missing, no reader recognises it, or the reader finds no channel."""
    try:
        # deferred: SurfaceTopography takes 1-2 s to import; only for its files
        from SurfaceTopography import open_topography

        # deferred: as above
        from SurfaceTopography.Exceptions import CannotDetectFileFormat
    except ImportError:  # a core dependency: only a broken installation gets here
        raise ProfileFormatError(
            "reading instrument files needs the package SurfaceTopography, which is "
            "not installed: `pip install SurfaceTopography`",
            source=path,
        ) from None
    if not Path(path).exists():
        raise ProfileFormatError("file not found", source=path)
    if Path(path).is_dir():
        raise ProfileFormatError("it is a directory, not a file", source=path)
    fmt = _FORMAT_BY_SUFFIX.get(Path(path).suffix.lower())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = open_topography(path, format=fmt)
    except CannotDetectFileFormat:
        raise ProfileFormatError(
            "not a format that microimpact or SurfaceTopography reads (no reader "
            "recognises the file; see docs/roughness.md for the formats read)",
            source=path,
        ) from None
    except Exception as exc:  # SurfaceTopography raises many types for bad files
        what = f"{fmt} " if fmt else ""
        raise ProfileFormatError(
            f"SurfaceTopography cannot read the {what}file ({type(exc).__name__}: "
            f"{_short(exc)})",
            source=path,
            field="format",
        ) from None
    try:
        channels = list(reader.channels)
    except Exception as exc:  # the reader fails on its own metadata
        raise _reader_failed(path, reader, exc) from None
    if not channels:
        raise ProfileFormatError(
            f"{reader_name(reader)} finds no topography channel in this "
            f"{_format_of(reader)} file (a channel without length units, or a "
            "layout it does not know); allowed: a file with a height channel in "
            "a length unit; export the map as x3p, SDF or a plain-text grid with "
            "'# dx_um' and '# z_unit' lines",
            source=path,
            field="format",
        )
    return reader


def channel_unit(reader, path):
    """The unit of `reader`'s default channel (None: the file gives none); an
    exception inside the reader is our one-line error naming the reader."""
    try:
        return reader.default_channel.unit
    except Exception as exc:  # inside the third-party reader: never a traceback
        raise _reader_failed(path, reader, exc) from None


def _nms_spacing(path) -> tuple[float, float]:
    """dx, dy [m] of a NanoFocus ``.nms`` file, read from its header ourselves:
    two little-endian doubles at byte 1376, in nm [2]_ (SurfaceTopography 1.25
    reads them as mm, a pixel 10⁶ too large)."""
    with open(path, "rb") as f:
        f.seek(_NMS_SPACING_OFFSET)
        raw = f.read(16)
    if len(raw) != 16:
        raise ProfileFormatError(
            "the file ends inside its header (no grid spacing at byte "
            f"{_NMS_SPACING_OFFSET})",
            source=path,
            field="spacing",
        )
    dx_nm, dy_nm = np.frombuffer(raw, dtype="<f8")
    return float(dx_nm) * LENGTH_UNITS["nm"], float(dy_nm) * LENGTH_UNITS["nm"]


def read_instrument(
    path,
    *,
    want,
    x_unit=None,
    z_unit=None,
    dx_um=None,
    dy_um=None,
    reader=None,
):
    """Read `path` with SurfaceTopography.

    Parameters
    ----------
    path : str or path-like
    want : {'profiles', 'map'}
        ``'profiles'``: a list of :class:`InstrumentScan` (a line scan gives one, a
        map one per row); ``'map'``: an :class:`InstrumentMap` (a line scan is
        refused, naming ``read_profiles``).
    x_unit, z_unit : (str, argument name) or None
        Units given by the user, with the argument's name for messages.
    dx_um, dy_um : float, optional
        Spacings given by the user [µm].
    reader : optional
        An already opened SurfaceTopography reader.

    Raises
    ------
    ProfileFormatError
        One line naming the file: not readable, no unit and none given, an argument
        that disagrees with the file, a line scan asked for as a map, ...
    """
    path = os.fspath(path)
    if reader is None:
        reader = open_instrument(path)
    try:
        return _read_instrument(
            path,
            reader,
            want=want,
            x_unit=x_unit,
            z_unit=z_unit,
            dx_um=dx_um,
            dy_um=dy_um,
        )
    except ProfileFormatError:
        raise
    except Exception as exc:  # inside the third-party reader: never a traceback
        raise _reader_failed(path, reader, exc) from None


def _read_instrument(path, reader, *, want, x_unit, z_unit, dx_um, dy_um):
    channel = reader.default_channel
    fmt = f"SurfaceTopography:{reader.format()}"
    dim = int(channel.dim)
    file_unit = channel.unit
    file_factor = None
    if file_unit is not None:
        file_factor = surfacetopography_unit_factor(file_unit)
        if file_factor is None:
            raise ProfileFormatError(
                f"the file gives the unit {file_unit!r}, which is not a length unit; "
                "allowed: a height topography (m, mm, µm, nm, Å)",
                source=path,
                field="unit",
            )
    if want == "map" and dim == 1:
        raise ProfileFormatError(
            "the file holds a line scan; allowed: an areal topography (read a "
            "profile with read_profiles, or `microimpact roughness`)",
            source=path,
        )
    # ---- units: the file's, or the arguments', never both in disagreement
    units = {}
    for axis, given in (("x", x_unit), ("z", z_unit)):
        if given is not None:
            value, arg = given
            factor = LENGTH_UNITS.get(value)
            if factor is None:
                try:
                    length_factor(value)
                except ValueError as exc:
                    raise ProfileFormatError(str(exc), source=path, field=arg) from None
            if file_factor is not None and not _same(factor, file_factor):
                raise ProfileFormatError(
                    f"the file gives the unit {file_unit!r} but `{arg}` is {value!r}; "
                    f"allowed: the same unit, or leave `{arg}` out to use the file's",
                    source=path,
                    field=arg,
                )
            units[axis] = (value, factor, "argument" if file_factor is None else "file")
        elif file_factor is not None:
            units[axis] = (file_unit, file_factor, "file")
    spacing_args = {"dx": dx_um, "dy": dy_um}
    if want == "map" and dy_um is None and dx_um is not None:
        spacing_args["dy"] = dx_um
    has_sizes = channel.physical_sizes is not None
    uniform = bool(getattr(channel, "is_uniform", True))
    if file_factor is None:
        lateral = "x" in units or (dx_um is not None and uniform)
        if "z" not in units or not lateral:
            if want == "map":
                need = "`dx_um`, `dy_um` (default: dx_um) and `z_unit`"
            elif uniform:
                need = "`z_unit` and `dx_um` (or `unit` for both axes)"
            else:
                need = "`unit` (or `x_unit` and `z_unit`)"
            raise ProfileFormatError(
                f"the file gives no length unit; give {need}",
                source=path,
                field="unit",
            )
    if not has_sizes and dx_um is None:
        raise ProfileFormatError(
            "the file gives no lateral size; give the spacing `dx_um`"
            + (" (and `dy_um`)" if dim == 2 else ""),
            source=path,
            field="dx_um",
        )
    kw = {}
    if not has_sizes:
        # SurfaceTopography needs some size: one file unit per pixel; the spacing
        # itself is then taken from dx_um / dy_um below
        kw["physical_sizes"] = tuple(float(n) for n in channel.nb_grid_pts)
    if file_unit is None:
        kw["unit"] = "m"  # a placeholder: heights and positions are scaled below
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            topo = reader.topography(**kw)
    except Exception as exc:
        raise _reader_failed(path, reader, exc) from None
    zf = units["z"][1]
    heights = np.ma.filled(np.ma.asarray(topo.heights(), dtype=float), np.nan) * zf
    masked = float(np.mean(~np.isfinite(heights))) if heights.size else 0.0
    meta = {
        "source": path,
        "format": fmt,
        "reader": "SurfaceTopography",
        "channel": channel.name,
        "z_unit": units["z"][0],
        "z_unit_from": units["z"][2],
        "masked_fraction": masked,
    }
    # ---- lateral: from the file (in its unit or the given x unit) or dx_um / dy_um
    own = _nms_spacing(path) if reader.format() == "nms" else None
    if own is not None:
        meta["spacing_read_by"] = (
            "microimpact (the NanoFocus header's nm; SurfaceTopography reads it as mm)"
        )
    spacings = []
    for i, name in enumerate(("dx", "dy")[:dim]):
        arg = spacing_args[name]
        from_file = None
        if own is not None:
            from_file = own[i]
        elif has_sizes and (uniform or dim == 2):
            px = float(np.atleast_1d(topo.pixel_size)[i])
            if "x" in units:
                from_file = px * units["x"][1]
        n = int(np.atleast_1d(channel.nb_grid_pts)[i])
        if arg is not None:
            value = float(arg) * 1e-6
            if not (np.isfinite(value) and value > 0):
                raise ProfileFormatError(
                    f"bad value {arg!r}; allowed: a finite number > 0 (µm)",
                    source=path,
                    field=f"{name}_um",
                )
            if dim == 1 and not uniform:
                raise ProfileFormatError(
                    "the file stores the position of every point (a non-uniform scan); "
                    f"leave `{name}_um` out",
                    source=path,
                    field=f"{name}_um",
                )
            overrides = from_file is not None and not plausible_spacing(from_file, n)
            if overrides:
                # the file's spacing is implausible (a unit slip): the user's wins
                meta[f"{name}_file_um"] = from_file * 1e6
            elif from_file is not None and file_factor is not None:
                if not np.isclose(value, from_file, rtol=1e-6, atol=0.0):
                    raise ProfileFormatError(
                        f"the file gives {name} = {from_file * 1e6:.9g} µm but "
                        f"`{name}_um` is {arg!r}; allowed: the same value, or leave "
                        f"`{name}_um` out",
                        source=path,
                        field=f"{name}_um",
                    )
            spacings.append(value)
            meta[f"{name}_from"] = (
                "argument" if from_file is None or overrides else "file"
            )
        else:
            spacings.append(from_file)
            meta[f"{name}_from"] = "file"
    if "x" in units and (spacing_args["dx"] is None or file_factor is not None):
        meta["x_unit"], meta["x_unit_from"] = units["x"][0], units["x"][2]
    else:
        meta["x_unit"], meta["x_unit_from"] = "um", "dx_um"
    if dim == 2:
        z = heights.T  # SurfaceTopography indexes [x, y]; rows are y here
        if want == "map":
            meta["xy_unit"] = meta.pop("x_unit")
            meta["xy_unit_from"] = meta.pop("x_unit_from")
            return InstrumentMap(z, spacings[0], spacings[1], meta)
        x = np.arange(z.shape[1]) * spacings[0]
        out = []
        for row, zr in enumerate(z):
            if np.count_nonzero(np.isfinite(zr)) >= 2:
                out.append(InstrumentScan(x, zr, {**meta, "scan": row}))
        if not out:
            raise ProfileFormatError("no row has 2 measured points", source=path)
        return out
    if uniform:
        x = np.arange(heights.size) * spacings[0]
        meta["spacing"] = "uniform"
    else:
        x = np.asarray(topo.positions(), dtype=float) * units["x"][1]
        meta["spacing"] = "non-uniform"
    if not np.isfinite(x).all():
        raise ProfileFormatError(
            "a position is missing (NaN); allowed: a position for every point",
            source=path,
        )
    order = np.argsort(x, kind="stable")
    x, heights = x[order], heights[order]
    if np.any(np.diff(x) <= 0):
        k = int(np.argmax(np.diff(x) <= 0))
        raise ProfileFormatError(
            f"positions are not strictly monotonic: x = {x[k + 1]!r} m follows "
            f"{x[k]!r} m",
            source=path,
        )
    if np.count_nonzero(np.isfinite(heights)) < 2:
        raise ProfileFormatError(
            "fewer than 2 measured points; allowed: a scan of at least 2", source=path
        )
    return [InstrumentScan(x, heights, {**meta, "scan": None})]
