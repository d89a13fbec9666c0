"""Physical plausibility of a height map or a line scan, checked before any number.

A reader can be wrong about a unit (a spacing field written in nm and read as mm),
and a user can type the wrong one. The heights' RMS can still look right while the
slopes are off by a factor of 10⁶. So every height map and every profile that
:func:`~microimpact.io.areal.read_height_map` or
:func:`~microimpact.io.profiles.read_profiles` returns has passed these checks:

* the lateral spacing lies within :data:`SPACING_RANGE` (0.1 nm to 1 mm per point:
  from an AFM's finest pixel to a coarse optical map);
* the field of view (the scan length, or the larger side of a map) is under
  :data:`MAX_FIELD` (1 m);
* the height range (peak to valley) is at most :data:`MAX_HEIGHT_TO_FIELD` (10)
  times the field: a surface that rises by more than ten times its own width is a
  unit slip, not a roughness.

An implausible one is refused with a one-line
:class:`~microimpact.errors.ProfileFormatError` that names the value, the unit it
was read in, the unit that would make it plausible ("312.5 read as mm: was it
nm?") and the override (``dx_um=...``, ``unit``, ``z_unit``). It is never passed
on.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ProfileFormatError
from ..units import LENGTH_UNITS

__all__ = [
    "MAX_FIELD",
    "MAX_HEIGHT_TO_FIELD",
    "SPACING_RANGE",
    "check_map",
    "check_scan",
    "plausible_spacing",
]

#: Plausible lateral spacing of a measured surface [m]: 0.1 nm to 1 mm per point.
SPACING_RANGE = (1e-10, 1e-3)
#: Largest plausible field of view (scan length or side of a map) [m].
MAX_FIELD = 1.0
#: Largest plausible ratio of the height range (peak to valley) to the field.
MAX_HEIGHT_TO_FIELD = 10.0
#: The units named as the likely slip, with how they are written in messages.
_UNITS = (("m", "m"), ("mm", "mm"), ("um", "µm"), ("nm", "nm"), ("A", "Å"))
_SHOW = {"um": "µm", "µm": "µm", "μm": "µm", "micron": "µm", "A": "Å", "Å": "Å"}


def _show_unit(unit) -> str:
    return _SHOW.get(unit, unit)


def _fmt(x: float) -> str:
    """`x` as the user would write it: 6 significant digits, thousands apart."""
    return f"{x:,.6g}"


def _length(x_m: float) -> str:
    """A length [m] in the unit that shows it best (nm, µm, mm or m)."""
    for factor, name in ((1.0, "m"), (1e-3, "mm"), (1e-6, "µm"), (1e-9, "nm")):
        if abs(x_m) >= factor:
            return f"{_fmt(x_m / factor)} {name}"
    return f"{_fmt(x_m / 1e-10)} Å"


def _likely_units(value_in_unit, unit, fits):
    """The units (message spelling) in which `value_in_unit` would pass `fits`
    (a predicate on metres), best first: the one giving a spacing nearest 1 µm."""
    read = LENGTH_UNITS.get(unit)
    out = []
    for key, shown in _UNITS:
        factor = LENGTH_UNITS[key]
        if read is not None and math.isclose(factor, read):
            continue
        if fits(value_in_unit * factor):
            out.append((abs(math.log10(value_in_unit * factor / 1e-6)), shown))
    return [shown for _, shown in sorted(out)]


def plausible_spacing(spacing, n) -> bool:
    """True if a spacing [m] of `n` points lies in :data:`SPACING_RANGE` and spans
    a field under :data:`MAX_FIELD`."""
    lo, hi = SPACING_RANGE
    return bool(lo <= spacing <= hi and spacing * max(n - 1, 1) < MAX_FIELD)


def _check_spacing(spacing, n, *, name, unit, source, override, scan):
    """Refuse an implausible spacing [m] of `n` points read in `unit`."""
    lo, hi = SPACING_RANGE
    field = spacing * max(n - 1, 1)
    if plausible_spacing(spacing, n):
        return
    where = "" if scan is None else f" (scan {scan})"
    if unit is not None and unit in LENGTH_UNITS:
        raw = spacing / LENGTH_UNITS[unit]
        read = f" ({_fmt(raw)} read as {_show_unit(unit)}"
        likely = _likely_units(raw, unit, lambda s: plausible_spacing(s, n))
        read += f": was it {likely[0]}?)" if likely else ")"
    else:
        read = ""
    what = (
        f"a field of view of {_length(field)}, over {_length(MAX_FIELD)}"
        if lo <= spacing <= hi
        else f"outside {_length(lo)} to {_length(hi)} per point"
    )
    raise ProfileFormatError(
        f"implausible lateral spacing {name} = {_length(spacing)}{read}{where}: "
        f"{what}; allowed: a spacing of {_length(lo)} to {_length(hi)} and a field "
        f"under {_length(MAX_FIELD)}; if the unit is wrong, give the spacing "
        f"with {override}",
        source=source,
        field=name,
    )


def _check_heights(z, field, *, unit, source, override, scan):
    """Refuse a height range [m] over ten times the `field` [m]."""
    finite = z[np.isfinite(z)]
    if finite.size == 0:
        return
    span = float(finite.max() - finite.min())
    if span <= MAX_HEIGHT_TO_FIELD * field:
        return
    where = "" if scan is None else f" (scan {scan})"
    read = ""
    if unit is not None and unit in LENGTH_UNITS:
        raw = span / LENGTH_UNITS[unit]
        likely = _likely_units(
            raw, unit, lambda s: s <= MAX_HEIGHT_TO_FIELD * field and s > 0
        )
        # the largest unit that fits: the smallest slip
        likely = sorted(likely, key=lambda u: -LENGTH_UNITS[u])
        read = f" ({_fmt(raw)} read as {_show_unit(unit)}"
        read += f": was it {likely[0]}?)" if likely else ")"
    raise ProfileFormatError(
        f"implausible heights: a range of {_length(span)}{read} over a field of "
        f"{_length(field)}{where}; allowed: a height range up to "
        f"{_fmt(MAX_HEIGHT_TO_FIELD)} times the field; if the file's height unit is "
        f"wrong, give it with {override}",
        source=source,
        field="z",
    )


def check_map(z, dx, dy, *, source=None, xy_unit=None, z_unit=None):
    """Refuse a height map ``z[y, x]`` [m] with spacings `dx`, `dy` [m] that is not
    physically plausible (see the module docstring).

    Parameters
    ----------
    z : array_like, shape (ny, nx)
        Heights [m]; NaN marks a missing point.
    dx, dy : float
        Spacings [m].
    source : str, optional
        The file, for the message.
    xy_unit, z_unit : str, optional
        The units the spacing and the heights were read in, to name the likely
        slip.

    Raises
    ------
    ProfileFormatError
        One line naming the file, the value, the unit it was read in, the likely
        slip and the override.
    """
    z = np.asarray(z, dtype=float)
    ny, nx = z.shape
    for name, d, n in (("dx", dx, nx), ("dy", dy, ny)):
        _check_spacing(
            float(d),
            n,
            name=name,
            unit=xy_unit,
            source=source,
            override=f"{name}_um=...",
            scan=None,
        )
    field = max(float(dx) * (nx - 1), float(dy) * (ny - 1))
    _check_heights(
        z, field, unit=z_unit, source=source, override="z_unit=...", scan=None
    )


def check_scan(x, z, *, source=None, x_unit=None, z_unit=None, scan=None):
    """Refuse a line scan (positions `x`, heights `z` [m]) that is not physically
    plausible: its median spacing, its length and its height range (see the module
    docstring). Arguments and errors as for :func:`check_map`."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    if x.size < 2:
        return
    spacing = float(np.median(np.diff(x)))
    _check_spacing(
        spacing,
        x.size,
        name="dx",
        unit=x_unit,
        source=source,
        override="x_unit=... (or unit=...) where the file names none, or dx_um=... "
        "for heights alone; a unit the file names is corrected in the file",
        scan=scan,
    )
    _check_heights(
        z,
        float(x[-1] - x[0]),
        unit=z_unit,
        source=source,
        override="z_unit=...",
        scan=scan,
    )
