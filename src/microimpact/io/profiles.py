"""Readers for surface-profile (profilometer) data.

A profile is a line scan: positions ``x`` along the scan and heights ``z``. The readers
return :class:`Profile` (one scan) or :class:`ProfileSet` (several scans kept apart,
as the paper's ten 4 mm scans of 8,000 points each [1]_), with SI units inside.

Supported inputs
----------------
* Delimited text (CSV, TSV, semicolon or whitespace separated; the delimiter is
  sniffed from the first row unless given; cells may be quoted; the decimal separator
  is ``.``). Lines starting with ``#`` are comments and a trailing ``# ...`` on a data
  line is ignored. An optional header row names the columns (matched
  case-insensitively). Either a position and a height column, or heights alone with a
  sampling interval ``dx_um``. An optional scan column (``scan`` or ``scan_id`` in the
  header, or ``scan_column=``) splits one file into several scans.
* ISO 25178-72 / ISO 5436-2 ``.x3p`` files through the optional package ``x3pio``
  (``pip install x3pio``), imported only when such a file is read.

Every problem in a file raises a one-line
:class:`~microimpact.errors.ProfileFormatError` that names the file, the line (or
field) and the problem.

References
----------
.. [1] X. Li, P. F. Dunn and R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.files import (
    MISSING,
    SNIFF,
    check_delimiter,
    looks_like_header,
    parse_number,
    read_lines,
    resolve_column,
    split_rows,
)
from .._core.validation import as_float_array
from ..errors import ProfileFormatError
from ..units import LENGTH_UNITS, length_factor
from .instruments import channel_unit, open_instrument, read_instrument
from .plausibility import check_scan

__all__ = ["Profile", "ProfileSet", "read_profile", "read_profiles"]

#: Relative tolerance on the intervals of a uniformly spaced scan.
UNIFORM_RTOL = 1e-3
#: Suffixes read as plain text by our reader first (then by SurfaceTopography).
TEXT_SUFFIXES = (".txt", ".csv", ".tsv", ".dat", ".asc", "")
_SCAN_NAMES = ("scan", "scan_id", "scanid", "scan_no", "scan_number")
_DECIMAL = "; the decimal separator must be '.'"


def check_xz(x, z):
    """`x`, `z` as float arrays, or ``ValueError`` unless they are 1-d arrays of the
    same length (>= 2) with `x` finite and strictly increasing and `z` finite or NaN
    (a missing point, masked as a height map masks it), at least 2 measured."""
    x = as_float_array(x, "x")
    z = as_float_array(z, "z")
    if x.ndim != 1 or z.ndim != 1 or x.shape != z.shape:
        raise ValueError(
            "`x` and `z` must be 1-d arrays of the same length; got shapes "
            f"{x.shape} and {z.shape}."
        )
    if x.size < 2:
        raise ValueError(f"a profile needs at least 2 points; got {x.size}.")
    if not np.isfinite(x).all() or np.isinf(z).any():
        raise ValueError(
            "`x` must be finite and `z` finite or NaN (a missing point); got inf or "
            "NaN positions."
        )
    if np.count_nonzero(np.isfinite(z)) < 2:
        raise ValueError("a profile needs at least 2 measured (non-NaN) heights.")
    if not np.all(np.diff(x) > 0):
        raise ValueError("`x` must be strictly increasing.")
    return x, z


@dataclass(frozen=True, eq=False)
class Profile:
    """One profilometer scan.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Positions along the scan [m], strictly increasing (not necessarily
        uniformly spaced: :attr:`is_uniform`).
    z : ndarray, shape (n,)
        Heights [m]; NaN marks a missing (not measured) point, left out of every
        fit, mean and slope (:attr:`valid`, :attr:`masked_fraction`).
    metadata : dict
        Provenance: ``source`` (file), ``scan`` (scan id), ``x_unit`` and ``z_unit``
        (units in the file) and where they came from, ``format``, ... The number of
        points and the median sampling interval [m] are the properties
        :attr:`n_points` and :attr:`dx`.
    """

    x: np.ndarray
    z: np.ndarray
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        x, z = check_xz(np.array(self.x, dtype=float), np.array(self.z, dtype=float))
        x.setflags(write=False)
        z.setflags(write=False)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def n_points(self) -> int:
        """Number of points."""
        return int(self.x.size)

    @property
    def dx(self) -> float:
        """Median sampling interval [m]."""
        return float(np.median(np.diff(self.x)))

    @property
    def is_uniform(self) -> bool:
        """True if every interval is within 0.1 % of the median :attr:`dx`."""
        d = np.diff(self.x)
        return bool(np.max(np.abs(d - self.dx)) <= UNIFORM_RTOL * self.dx)

    @property
    def valid(self) -> np.ndarray:
        """True where a height was measured."""
        return np.isfinite(self.z)

    @property
    def masked_fraction(self) -> float:
        """Fraction of missing (NaN) heights."""
        return float(1.0 - self.valid.mean())

    @property
    def length(self) -> float:
        """Scan length ``n * dx`` [m] (each point stands for one interval)."""
        return float(self.x[-1] - self.x[0] + self.dx)

    @property
    def scan(self):
        """The scan id (from the metadata), or ``None``."""
        return self.metadata.get("scan")

    @property
    def source(self):
        """The file the scan was read from, or ``None``."""
        return self.metadata.get("source")

    def __repr__(self) -> str:
        return (
            f"Profile(n_points={self.n_points}, dx={self.dx:.4g} m, "
            f"length={self.length:.4g} m, scan={self.scan!r}, source={self.source!r})"
        )


@dataclass(frozen=True, eq=False)
class ProfileSet:
    """Several scans of one surface, kept apart.

    Conditioning (detrending, filtering) and segmenting are done scan by scan, so a
    segment never straddles two scans; statistics combine all scans.

    Attributes
    ----------
    profiles : tuple of Profile
        The scans, in file order.
    metadata : dict
        Provenance of the set (empty unless given); the files, the number of scans
        and of points are :attr:`sources`, ``len(set)`` and :attr:`n_points`.
    """

    profiles: tuple
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        profiles = tuple(self.profiles)
        if not profiles:
            raise ValueError("a ProfileSet needs at least one profile.")
        for p in profiles:
            if not isinstance(p, Profile):
                raise TypeError(f"`profiles` must hold Profile objects; got {p!r}.")
        object.__setattr__(self, "profiles", profiles)
        object.__setattr__(self, "metadata", dict(self.metadata))

    def __len__(self) -> int:
        return len(self.profiles)

    def __iter__(self) -> Iterator[Profile]:
        return iter(self.profiles)

    def __getitem__(self, i) -> Profile:
        return self.profiles[i]

    @property
    def n_points(self) -> int:
        """Total number of points over all scans."""
        return sum(p.n_points for p in self.profiles)

    @property
    def sources(self) -> list:
        """The files the scans were read from, each once, in order."""
        return sources_of(self.profiles)

    def __repr__(self) -> str:
        return f"ProfileSet(n_scans={len(self)}, n_points={self.n_points})"


def sources_of(profiles) -> list:
    """The distinct non-``None`` sources of `profiles`, in order."""
    out = []
    for p in profiles:
        if p.source is not None and p.source not in out:
            out.append(p.source)
    return out


def as_profiles(profile_or_set) -> tuple[Profile, ...]:
    """The scans of a :class:`Profile`, :class:`ProfileSet` or sequence of profiles."""
    if isinstance(profile_or_set, Profile):
        return (profile_or_set,)
    if isinstance(profile_or_set, ProfileSet):
        return profile_or_set.profiles
    if isinstance(profile_or_set, (list, tuple)) and all(
        isinstance(p, Profile) for p in profile_or_set
    ):
        if not profile_or_set:
            raise ValueError("`profile_or_set` is an empty sequence.")
        return tuple(profile_or_set)
    raise TypeError(
        "`profile_or_set` must be a Profile, a ProfileSet or a list of Profile; "
        f"got {type(profile_or_set).__name__}."
    )


# --------------------------------------------------------------------------- units


def _unit_factor(unit, name: str, path) -> float:
    try:
        return length_factor(unit)
    except ValueError as exc:
        raise ProfileFormatError(str(exc), source=path, field=name) from None


#: ``height [nm]``, ``x (mm)``, ``z / um``: a unit in brackets or after a slash.
_BRACKETED = re.compile(
    r"^(?P<name>.*?)\s*(?:\[(?P<b>[^\]]*)\]|\((?P<p>[^)]*)\)|/\s*(?P<s>\S+))$"
)
#: ``x_um``, ``z_nm``, ``height_µm``, ``z A``: a unit after the last ``_`` or space.
_SUFFIXED = re.compile(r"^(?P<name>.+?)[_\s]+(?P<u>[^_\s]+)$")
#: Case-folded spellings accepted in headers (``Z_NM``); ``A`` (ångström) only as is.
_FOLDED_UNITS = {k.lower(): k for k in LENGTH_UNITS if k != "A"}


def _known_unit(text: str) -> str | None:
    text = text.strip()
    if text in LENGTH_UNITS:
        return text
    return _FOLDED_UNITS.get(text.lower())


def header_unit(cell: str) -> tuple[str | None, str | None]:
    """The length unit a header cell names, and the text of a unit it names but
    which is not a known length unit.

    ``"z_nm"``, ``"height [nm]"``, ``"x (mm)"``, ``"z / um"``, ``"z_A"`` and
    ``"height_µm"`` name a unit of :data:`~microimpact.units.LENGTH_UNITS` (matched
    as written, else case-insensitively except ``A``): ``(unit, None)``. A suffix
    that is not a length unit (``x_pos``, ``speed_m_s``) is part of the name:
    ``(None, None)``. A bracketed unit that is not a length unit (``z [au]``):
    ``(None, "au")``.
    """
    cell = cell.strip()
    m = _BRACKETED.match(cell)
    if m and m.group("name"):
        text = next(
            g for g in (m.group("b"), m.group("p"), m.group("s")) if g is not None
        )
        unit = _known_unit(text)
        return (unit, None) if unit else (None, text.strip())
    m = _SUFFIXED.match(cell)
    if m:
        return _known_unit(m.group("u")), None
    return None, None


class _ArgumentError(ProfileFormatError):
    """A problem with the units of our plain text (never handed on to another
    reader)."""


def _same_unit(a: str, b: str) -> bool:
    return length_factor(a) == length_factor(b)


def _column_unit(path, names, idx, axis, explicit):
    """``(unit, where it came from)`` of the x or z column `idx`.

    The header's unit is honoured; an explicit unit (`explicit`: ``(value, argument
    name)`` or ``None``, already checked by :func:`_unit_factor`) must agree with it,
    else ProfileFormatError naming the file, the column and both units. Without
    either: ``(None, None)`` (the caller refuses the file: units are never
    guessed).
    """
    from_header = bad = None
    if names is not None and idx is not None:
        from_header, bad = header_unit(names[idx])
    label = None if idx is None or names is None else _label(names, idx)
    if explicit is not None:
        value, arg = explicit
        if from_header is not None and not _same_unit(from_header, value):
            raise _ArgumentError(
                f"the header of {label} gives the unit {from_header!r} but "
                f"`{arg}` is {value!r}; allowed: the same unit, or leave `{arg}` out "
                "to use the header's",
                source=path,
                field=arg,
            )
        return value, "argument"
    if bad is not None:
        try:
            length_factor(bad)  # its message lists the allowed units
        except ValueError as exc:
            raise _ArgumentError(
                f"{exc}, or give the {axis} unit explicitly (`{axis}_unit`) instead "
                "of the header's",
                source=path,
                field=names[idx],
            ) from None
    if from_header is not None:
        return from_header, "header"
    return None, None


# --------------------------------------------------------------------------- text


def _read_rows(path, delimiter):
    """Header ``(lineno, cells)`` or None, rows [(lineno, cells)], comment lines."""
    lines = read_lines(
        path,
        error=ProfileFormatError,
        hint=" (for .x3p files use the .x3p suffix)",
    )
    comments = [
        t.lstrip("#").strip() for t in (raw.strip() for raw in lines) if t[:1] == "#"
    ]
    rows, _ = split_rows(
        lines,
        source=path,
        delimiter=SNIFF if delimiter is None else delimiter,
        error=ProfileFormatError,
        trailing_comments=True,
    )
    header = None
    if rows and looks_like_header(rows[0][1]):
        header, rows = rows[0], rows[1:]
    if not rows:
        raise ProfileFormatError("no data rows", source=path)
    return header, rows, comments


def _parse_text(path, *, x_column, z_column, scan_column, dx_um, delimiter, explicit):
    """Parse a delimited text file into [(scan_id, x_raw|None, z_raw, linenos)]."""
    header, rows, comments = _read_rows(path, delimiter)
    first_line, first = rows[0]
    ncols = len(first)
    names = header[1] if header is not None else None
    if names is not None and len(names) != ncols:
        raise ProfileFormatError(
            f"header has {len(names)} columns but the first data row has {ncols}"
            + (_DECIMAL if ncols > len(names) else ""),
            source=path,
            line=first_line,
        )

    def resolve(col, name):
        return resolve_column(
            col,
            names,
            ncols,
            name=name,
            source=path,
            line=None if header is None else header[0],
            error=ProfileFormatError,
        )

    if scan_column is None:
        folded = [h.lower() for h in names or []]
        scan_idx = next((folded.index(n) for n in _SCAN_NAMES if n in folded), None)
    else:
        scan_idx = resolve(scan_column, "scan_column")
    x_idx = resolve(x_column, "x_column")
    z_idx = resolve(z_column, "z_column")
    given = [
        (n, i)
        for n, i in (
            (
                "`scan_column`" if scan_column is not None else "the scan-id column",
                scan_idx,
            ),
            ("`x_column`", x_idx),
            ("`z_column`", z_idx),
        )
        if i is not None
    ]
    for k, (a, i) in enumerate(given):
        for b, j in given[k + 1 :]:
            if i == j:
                raise ProfileFormatError(
                    f"{a} and {b} are the same column ({_label(names, i)}); "
                    "allowed: different columns",
                    source=path,
                    field=b.strip("`"),
                )
    free = [i for i in range(ncols) if i not in (scan_idx, x_idx, z_idx)]
    if dx_um is not None:
        if x_idx is not None:
            raise ProfileFormatError(
                "give either `x_column` or `dx_um`, not both", source=path
            )
        if z_idx is None:
            if len(free) != 1:
                raise ProfileFormatError(
                    f"{len(free)} candidate height columns; say which with `z_column`",
                    source=path,
                    line=first_line,
                )
            z_idx = free[0]
    else:
        if x_idx is None:
            if not free:
                raise ProfileFormatError(
                    "no position column: give `x_column`, or `dx_um` for heights alone",
                    source=path,
                    line=first_line,
                )
            x_idx = free.pop(0)
        if z_idx is None:
            if not free:
                raise ProfileFormatError(
                    "only one numeric column: heights alone need the sampling "
                    "interval `dx_um`",
                    source=path,
                    line=first_line,
                )
            z_idx = free.pop(0)

    x_unit, x_from = (
        ("um", "dx_um")
        if dx_um is not None
        else _column_unit(path, names, x_idx, "x", explicit[0])
    )
    z_unit, z_from = _column_unit(path, names, z_idx, "z", explicit[1])
    units = (x_unit, z_unit)
    wanted = [
        (
            i,
            None if i is None else _label(names, i),
            f"a finite {what} in {unit}{extra}",
            missing_ok,
        )
        for i, what, unit, extra, missing_ok in (
            (x_idx, "position", units[0], " (every point needs a position)", False),
            (
                z_idx,
                "height",
                units[1],
                ", or nan / an empty cell for a missing point",
                True,
            ),
        )
    ]
    scans: dict = {}
    for lineno, cells in rows:
        if len(cells) != ncols:
            raise ProfileFormatError(
                f"expected {ncols} columns, found {len(cells)}"
                + (_DECIMAL if len(cells) > ncols else ""),
                source=path,
                line=lineno,
            )
        vals = [
            None
            if i is None
            else math.nan
            if missing_ok and cells[i].strip().lower() in MISSING
            else parse_number(
                cells[i],
                source=path,
                line=lineno,
                field=label,
                allowed=allowed,
                error=ProfileFormatError,
            )
            for i, label, allowed, missing_ok in wanted
        ]
        sid = cells[scan_idx] if scan_idx is not None else None
        if sid is not None and sid == "":
            raise ProfileFormatError(
                "missing scan id; allowed: a non-empty scan id",
                source=path,
                line=lineno,
                field=_label(names, scan_idx),
            )
        entry = scans.setdefault(sid, ([], [], []))
        entry[0].append(vals[0])
        entry[1].append(vals[1])
        entry[2].append(lineno)

    def name_of(i):
        return None if i is None else (names[i] if names is not None else i)

    cols = {
        "x_column": name_of(x_idx),
        "z_column": name_of(z_idx),
        "scan_column": name_of(scan_idx),
        "x_unit": x_unit,
        "x_unit_from": x_from,
        "z_unit": z_unit,
        "z_unit_from": z_from,
    }
    return scans, cols, comments


def _label(names, i) -> str:
    """How a column is named in messages: ``column 'z'`` or ``column 1``."""
    return f"column {names[i]!r}" if names is not None else f"column {i}"


def _check_monotonic(x, linenos, path, scan):
    d = np.diff(x)
    if np.all(d > 0):
        return x, slice(None)
    if np.all(d < 0):
        return x, slice(None, None, -1)
    sign = 1.0 if d[0] > 0 else -1.0
    k = int(np.argmax(~(sign * d > 0)))
    where = "" if scan is None else f" (scan {scan!r})"
    raise ProfileFormatError(
        f"positions are not strictly monotonic{where}: x = {float(x[k + 1])!r} "
        f"follows {float(x[k])!r}",
        source=path,
        line=linenos[k + 1] if linenos is not None else None,
    )


def _build_profiles(path, scans, *, xf, zf, dx, meta):
    out = []
    for sid, (xs, zs, linenos) in scans.items():
        z = np.asarray(zs, dtype=float) * zf
        if dx is not None:
            x = np.arange(z.size, dtype=float) * dx
        else:
            xr = np.asarray(xs, dtype=float)
            xr, order = _check_monotonic(xr, linenos, path, sid)
            x = xr[order] * xf
            z = z[order]
        measured = int(np.count_nonzero(np.isfinite(z)))
        if measured < 2:
            which = "the profile" if sid is None else f"scan {sid!r}"
            raise ProfileFormatError(
                f"{which} has {measured} measured point(s) of {z.size}; at "
                "least 2 are needed",
                source=path,
                line=linenos[0],
            )
        out.append(Profile(x, z, {**meta, **_spacing_meta(x, z), "scan": sid}))
    return out


def _spacing_meta(x, z) -> dict:
    """``spacing`` ('uniform' or 'non-uniform') and ``masked_fraction`` of a scan."""
    d = np.diff(x)
    med = float(np.median(d))
    uniform = bool(np.max(np.abs(d - med)) <= UNIFORM_RTOL * med)
    return {
        "spacing": "uniform" if uniform else "non-uniform",
        "masked_fraction": float(np.mean(~np.isfinite(z))),
    }


def open_x3p(path):
    """The x3pio object of an ``.x3p`` file; a missing package, a missing or an
    unreadable file is a :class:`ProfileFormatError` naming the file."""
    try:
        # deferred: optional extra [x3p]
        import x3pio
    except ImportError:
        raise ProfileFormatError(
            "reading .x3p files needs the optional package x3pio: "
            "`pip install x3pio` (or `pip install microimpact[x3p]`)",
            source=path,
        ) from None
    try:
        f = x3pio.read(path)
    except FileNotFoundError:
        raise ProfileFormatError("file not found", source=path) from None
    except (x3pio.X3pError, OSError, ValueError) as exc:
        msg = " ".join(str(exc).split())
        raise ProfileFormatError(
            f"not a readable x3p file: {msg}", source=path
        ) from None
    except Exception as exc:  # inside the third-party reader: never a traceback
        msg = " ".join(str(exc).split())[:200]
        raise ProfileFormatError(
            f"the x3pio reader failed on this x3p file ({type(exc).__name__}: "
            f"{msg}); microimpact cannot read it",
            source=path,
            field="format",
        ) from None
    return f


def _x3p_line_of_points(f, path):
    """Positions along the line and heights of a point cloud whose points lie on a
    straight line in the x-y plane; ProfileFormatError otherwise."""
    layer = f.layers[0]
    pts = np.asarray(layer.points(), dtype=float).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if pts.shape[0] < 2:
        raise ProfileFormatError(
            "the point cloud has fewer than 2 points", source=path, field="Record3"
        )
    xy = pts[:, :2] - pts[:, :2].mean(axis=0)
    _, sv, vt = np.linalg.svd(xy, full_matrices=False)
    if sv[0] == 0 or sv[-1] > 1e-6 * sv[0]:
        width = float(2 * sv[-1] / np.sqrt(pts.shape[0])) * 1e6 if sv[0] else 0.0
        raise ProfileFormatError(
            "the point cloud is not a line scan: its points spread across the x-y "
            f"plane (RMS width {width:.3g} µm across the main direction); allowed: "
            "points along one line (a profile), or a surface on a regular grid; "
            "resample the cloud onto a grid (e.g. with Gwyddion or Open3D) and "
            "export it as an x3p surface",
            source=path,
            field="Record3",
        )
    direction = vt[0] if vt[0][np.argmax(np.abs(vt[0]))] > 0 else -vt[0]
    s = xy @ direction
    order = np.argsort(s, kind="stable")
    s, z = s[order] - s[order][0], pts[order, 2]
    if np.any(np.diff(s) <= 0):
        raise ProfileFormatError(
            "the point cloud holds two points at the same place along its line",
            source=path,
            field="Record3",
        )
    return s, z


def _read_x3p(path, *, meta):
    f = open_x3p(path)
    kind = type(f).__name__
    base = dict(meta, x_unit="m", z_unit="m", x_unit_from="file", z_unit_from="file")
    base.update(format="x3p", reader="x3pio", feature_type=kind)
    if kind == "PointCloud":
        x, z = _x3p_line_of_points(f, path)
        return [Profile(x, z, {**base, **_spacing_meta(x, z), "scan": None})]
    layer = f.layers[0]
    z = np.asarray(layer.z, dtype=float)
    if layer.x is not None:
        x = np.asarray(layer.x, dtype=float)
    else:
        x = np.asarray(layer.x_values, dtype=float)
    if z.ndim == 1:
        zs = [z]
        xs = [x.ravel()]
    else:
        zs = list(z)
        xs = list(x) if x.ndim == 2 else [x] * len(zs)
    out = []
    for row, (xr, zr) in enumerate(zip(xs, zs, strict=True)):
        if np.count_nonzero(np.isfinite(zr)) < 2:
            if len(zs) > 1:
                continue  # a row without 2 measured points holds no slope
            raise ProfileFormatError(
                "fewer than 2 valid points", source=path, field="Record3"
            )
        keep = np.isfinite(xr)  # an absolute axis has no position where invalid
        xr, zr = xr[keep], zr[keep]
        xr, order = _check_monotonic(np.asarray(xr, dtype=float), None, path, row)
        zr = zr[order]
        m = dict(base, scan=row if len(zs) > 1 else None)
        m.update(_spacing_meta(xr[order], zr))
        out.append(Profile(xr[order], zr, m))
    if not out:
        raise ProfileFormatError(
            "no row has 2 valid points", source=path, field="Record3"
        )
    return out


def _read_any(path, **kw):
    """The profiles of `path` (see :func:`read_profiles`), each checked for
    physical plausibility (:mod:`microimpact.io.plausibility`)."""
    profiles = _read_unchecked(path, **kw)
    for p in profiles:
        m = p.metadata
        check_scan(
            p.x,
            p.z,
            source=m.get("source"),
            x_unit=m.get("x_unit"),
            z_unit=m.get("z_unit"),
            scan=m.get("scan") if len(profiles) > 1 else None,
        )
    return profiles


def _read_unchecked(
    path,
    *,
    x_column,
    z_column,
    scan_column,
    unit,
    x_unit,
    z_unit,
    dx_um,
    delimiter,
):
    path = os.fspath(path)
    meta = {"source": path}
    explicit = [
        (u, name) if u is not None else ((unit, "unit") if unit is not None else None)
        for u, name in ((x_unit, "x_unit"), (z_unit, "z_unit"))
    ]
    for e in explicit:
        if e is not None:
            _unit_factor(*e, path)
    check_delimiter(delimiter)
    dx = None
    if dx_um is not None:
        try:
            dx_f = float(dx_um)
        except (TypeError, ValueError):
            dx_f = float("nan")
        if not (math.isfinite(dx_f) and dx_f > 0):
            raise ProfileFormatError(
                f"bad value {dx_um!r}; allowed: a number > 0 (µm)",
                source=path,
                field="dx_um",
            )
        dx = dx_f * 1e-6  # [µm] -> [m]
    suffix = Path(path).suffix.lower()
    if suffix == ".x3p":
        for name, value in (("unit", unit), ("x_unit", x_unit), ("z_unit", z_unit)):
            if value is not None and length_factor(value) != 1.0:
                raise ProfileFormatError(
                    f"an x3p file stores metres but `{name}` is {value!r}; allowed: "
                    f"leave `{name}` out",
                    source=path,
                    field=name,
                )
        if dx_um is not None:
            raise ProfileFormatError(
                "an x3p file stores its own spacing; leave `dx_um` out",
                source=path,
                field="dx_um",
            )
        return _read_x3p(path, meta=meta)
    if suffix not in TEXT_SUFFIXES:
        return _instrument_profiles(path, explicit, dx_um, None)
    try:
        scans, cols, comments = _parse_text(
            path,
            x_column=x_column,
            z_column=z_column,
            scan_column=scan_column,
            dx_um=dx_um,
            delimiter=delimiter,
            explicit=explicit,
        )
    except ProfileFormatError as ours:
        # not our plain text: an instrument export (Dektak CSV, Gwyddion, ...)?
        if isinstance(ours, _ArgumentError) or any(
            v is not None for v in (x_column, z_column, scan_column, delimiter)
        ):
            raise
        # a plain table that we cannot read keeps our message (it names the line
        # and the cell), unless SurfaceTopography knows the format's unit, the
        # file is not UTF-8 text (an instrument's own encoding), or the units are
        # given and SurfaceTopography reads the file
        reader = instrument_reader(path)
        if reader is None:
            raise ours from None
        own = channel_unit(reader, path) is not None or "UTF-8" in ours.message
        given = any(e is not None for e in explicit) or dx_um is not None
        if not (own or given):
            raise ours from None
        try:
            return _instrument_profiles(path, explicit, dx_um, reader)
        except ProfileFormatError:
            if own:
                raise
            raise ours from None
    meta.update(format="text", reader="microimpact", comments=comments, **cols)
    if cols["x_unit"] is None or cols["z_unit"] is None:
        # an export whose header (in comments) gives the unit: SurfaceTopography
        reader = instrument_reader(path)
        if reader is not None and channel_unit(reader, path) is not None:
            return _instrument_profiles(path, explicit, dx_um, reader)
        # structural problems (order, too few points) first, then the unit
        _build_profiles(path, scans, xf=1.0, zf=1.0, dx=dx, meta=meta)
        axes = [a for a, k in (("x", "x_unit"), ("z", "z_unit")) if cols[k] is None]
        raise ProfileFormatError(
            f"the file gives no length unit for {' and '.join(axes)}; give `unit` "
            "(both columns)"
            + (" or `x_unit`" if "x" in axes else "")
            + (" and `z_unit`" if axes == ["x", "z"] else "")
            + (" or `z_unit`" if axes == ["z"] else "")
            + (
                ", or name it in the header (e.g. x_um, z_nm)"
                if cols.get("x_column") is not None or cols.get("z_column") is not None
                else ""
            ),
            source=path,
            field="unit",
        )
    xf = length_factor(cols["x_unit"])
    zf = length_factor(cols["z_unit"])
    return _build_profiles(path, scans, xf=xf, zf=zf, dx=dx, meta=meta)


def _profiles_of(scans) -> list[Profile]:
    """Profiles of the scans read by SurfaceTopography, with their spacing and
    masked share."""
    return [Profile(x, z, {**meta, **_spacing_meta(x, z)}) for x, z, meta in scans]


def instrument_reader(path):
    """SurfaceTopography's reader of `path`, or ``None`` if none recognises it (or
    SurfaceTopography is not installed)."""
    try:
        return open_instrument(os.fspath(path))
    except ProfileFormatError:
        return None


def read_profile(
    path,
    *,
    x_column=None,
    z_column=None,
    unit=None,
    x_unit=None,
    z_unit=None,
    dx_um=None,
    delimiter=None,
) -> Profile:
    """Read one profilometer scan.

    Parameters
    ----------
    path : str or path-like
        A delimited text file, or an ``.x3p`` file (needs ``x3pio``).
    x_column, z_column : int or str, optional
        Position and height columns, as 0-based numbers or header names. By default
        the first two columns (other than a scan column) are x and z; with `dx_um`
        the only column is z.
    unit : str, optional
        Length unit of both columns: ``'m'``, ``'mm'``, ``'um'`` (``'µm'``),
        ``'nm'``, ``'A'`` (``'Å'``).
    x_unit, z_unit : str, optional
        Override `unit` for one column (e.g. ``x_unit='um', z_unit='A'``).
    dx_um : float, optional
        Sampling interval [µm] for a file of heights alone.
    delimiter : str, optional
        Column separator, one character (``""``: whitespace); sniffed from the first
        data row when ``None`` (``;``, else tab, else ``,``, else whitespace; quoted
        text ignored), as by every reader of the package. Cells may be quoted
        (``"1,5"`` is one cell).

    Returns
    -------
    Profile
        ``x`` and ``z`` in metres; metadata with the source, the scan id, the
        columns, and the units: ``x_unit``, ``z_unit`` and where each came from,
        ``x_unit_from`` / ``z_unit_from`` (``"header"``, ``"argument"``,
        ``"default"`` or, for x, ``"dx_um"``). ``n_points`` and ``dx`` [m] are
        properties.

    Raises
    ------
    ProfileFormatError
        One line naming the file, the line and the problem: non-numeric cells,
        missing values, positions that are not strictly monotonic, an unknown unit,
        a header unit that contradicts an explicit one, or a file holding several
        scans (use :func:`read_profiles`).

    Notes
    -----
    **Units.** A header cell may name its unit: ``x_um``, ``z_nm``,
    ``height [nm]``, ``x (mm)``, ``z / um``, ``z_A``, ``height_µm``
    (:func:`header_unit`). That unit is used. An explicit `unit`, `x_unit` or
    `z_unit` must agree with it (``ProfileFormatError`` naming the file, the column
    and both units otherwise: the reader never guesses between them). With neither
    a header unit nor an explicit one, the unit is µm (``*_unit_from`` is then
    ``"default"``).
    """
    profiles = _read_any(
        path,
        x_column=x_column,
        z_column=z_column,
        scan_column=None,
        unit=unit,
        x_unit=x_unit,
        z_unit=z_unit,
        dx_um=dx_um,
        delimiter=delimiter,
    )
    if len(profiles) > 1:
        raise ProfileFormatError(
            f"the file holds {len(profiles)} scans; read it with read_profiles()",
            source=os.fspath(path),
        )
    return profiles[0]


def _instrument_profiles(path, explicit, dx_um, reader=None):
    """The profiles of an instrument file, read by SurfaceTopography (its
    `reader`, if already opened) with the units given (`explicit`: x and z
    units, or None) and `dx_um`."""
    return _profiles_of(
        read_instrument(
            path,
            want="profiles",
            x_unit=explicit[0],
            z_unit=explicit[1],
            dx_um=dx_um,
            reader=reader,
        )
    )


def read_profiles(
    paths,
    *,
    x_column=None,
    z_column=None,
    scan_column=None,
    unit=None,
    x_unit=None,
    z_unit=None,
    dx_um=None,
    delimiter=None,
) -> ProfileSet:
    """Read several scans into a :class:`ProfileSet`.

    Each file is one scan, or several if it has a scan-id column (``scan`` or
    ``scan_id`` in the header, or `scan_column`); an ``.x3p`` surface gives one scan
    per row. The scans stay separate so conditioning and segmenting never straddle
    two scans; :func:`~microimpact.surface.roughness.characterise` pools their
    statistics, as the paper combined 10 scans x 8,000 points [1]_.

    Parameters
    ----------
    paths : str, path-like or iterable of them
        One or more files.
    scan_column : int or str, optional
        Column holding the scan id. Rows with the same id form one scan, in file
        order.
    x_column, z_column, unit, x_unit, z_unit, dx_um, delimiter
        As for :func:`read_profile`.

    Returns
    -------
    ProfileSet
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    elif not isinstance(paths, Iterable):
        raise TypeError(f"`paths` must be a path or a list of paths; got {paths!r}.")
    profiles = []
    for path in paths:
        profiles.extend(
            _read_any(
                path,
                x_column=x_column,
                z_column=z_column,
                scan_column=scan_column,
                unit=unit,
                x_unit=x_unit,
                z_unit=z_unit,
                dx_um=dx_um,
                delimiter=delimiter,
            )
        )
    if not profiles:
        raise ValueError("`paths` is empty: no profile files given.")
    return ProfileSet(tuple(profiles))
