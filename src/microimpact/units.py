"""Unit conversions used at the package's interfaces.

Everything inside microimpact is SI with angles in radians. Micrometres and degrees
appear only at the interfaces (scenario files, readers, CLI, plots, reports), in names
that carry the unit (``diameter_um``, ``angle_deg``), and are converted once with these
helpers, never with a bare ``* 1e-6``.
"""

from __future__ import annotations

import numpy as np

#: Metres per unit for the length units accepted at the interfaces.
LENGTH_UNITS: dict[str, float] = {
    "m": 1.0,
    "mm": 1e-3,
    "um": 1e-6,
    "µm": 1e-6,
    "μm": 1e-6,
    "micron": 1e-6,
    "nm": 1e-9,
    "A": 1e-10,
    "Å": 1e-10,
    "angstrom": 1e-10,
}


def um_to_m(x):
    """Micrometres to metres."""
    return np.multiply(x, 1e-6)


def m_to_um(x):
    """Metres to micrometres."""
    return np.multiply(x, 1e6)


def deg_to_rad(x):
    """Degrees to radians."""
    return np.deg2rad(x)


def rad_to_deg(x):
    """Radians to degrees."""
    return np.rad2deg(x)


#: The spellings shown in the unknown-unit message (the Greek mu "μm" is accepted as
#: well as the micro sign "µm", but not shown: the two look the same).
_UNIT_SPELLINGS = (
    ("m",),
    ("mm",),
    ("um", "µm", "micron"),
    ("nm",),
    ("A", "Å", "angstrom"),
)


def length_factor(unit: str) -> float:
    """Metres per `unit` (one of :data:`LENGTH_UNITS`).

    Raises
    ------
    ValueError
        If `unit` is not a known length unit; the message lists the allowed ones.
        The file readers re-raise it as an :class:`~microimpact.errors.InputError`
        naming the file.
    """
    try:
        return LENGTH_UNITS[unit]
    except (KeyError, TypeError):
        allowed = ", ".join(
            repr(first) + (f" (or {', '.join(map(repr, rest))})" if rest else "")
            for first, *rest in _UNIT_SPELLINGS
        )
        raise ValueError(f"unknown length unit {unit!r}; allowed: {allowed}") from None
