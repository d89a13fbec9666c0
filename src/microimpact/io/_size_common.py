"""Shared helpers of the size-export readers (:mod:`.size_bins`,
:mod:`._size_exports`, :mod:`._size_select`): how an option is spelled in each
syntax, the asking error, text decoding (UTF-8, else Windows-1252) and the bins
built from an export's values."""

from __future__ import annotations

import re

import numpy as np

from .._core.files import read_lines
from ..errors import DataFormatError
from ..population.binned import (
    BIN_VALUES,
    BinnedSizes,
    number_per_bin,
)
from .diameters import _number

_SYNTAX = ("python", "cli", "toml")
_HINT = "; expected delimited text"
_UNIT_SUFFIX = re.compile(r"[_\s/]+(um|µm|μm|nm|mm|cm|m)$", re.IGNORECASE)


def _option(name, value, syntax):
    """How the user passes option `name` = `value` in `syntax`."""
    if syntax == "cli":
        shown = value if re.fullmatch(r"[\w./-]+", str(value)) else f"'{value}'"
        return f"--{name.replace('_', '-')} {shown}"
    if syntax == "toml":
        raw = isinstance(value, int) or str(value).startswith("[")
        shown = value if raw else f'"{value}"'
        return f"{name} = {shown}"
    return f"{name}={value!r}"


def _key(name: str) -> str:
    """A header name folded for matching: no bracketed unit, no unit suffix, lower
    case, no spaces, underscores, dashes or dots."""
    s = re.sub(r"[\(\[\{].*?[\)\]\}]", "", name)
    s = _UNIT_SUFFIX.sub("", s.strip())
    return re.sub(r"[\s_\-.]", "", s.lower())


def _ask(path, what, choices, syntax, *, field):
    """The asking error: `what` is ambiguous; `choices` are (option, value, meaning)."""
    listing = "; ".join(
        f"{_option(opt, val, syntax)} ({meaning})" for opt, val, meaning in choices
    )
    return DataFormatError(f"{what}; choose one: {listing}", source=path, field=field)


def _values_choices():
    return [
        ("values", v, f"{w} per bin" if per == "bin" else f"{w} density over {per}")
        for v, (w, per) in BIN_VALUES.items()
        if v in ("count", "dN", "dN/dlogDp", "dN/dDp", "dM/dlogDp", "dV/dlogDp")
    ]


def _bin_value(cell, *, path, line, field, kind) -> float:
    """One bin's value (of `kind`, a key of ``BIN_VALUES``) in an export: a number
    >= 0; else DataFormatError naming the file, line, `field` and what is
    allowed."""
    return _number(
        cell,
        path=path,
        line=line,
        field=field,
        allowed=f"a value >= 0 ({kind})",
        minimum=0.0,
        strict=False,
    )


def _text_lines(path):
    """(lines, encoding): UTF-8, else Windows-1252 (as AIM writes ``cm³``)."""
    try:
        return read_lines(path, hint=_HINT), "utf-8"
    except DataFormatError as exc:
        if "not a UTF-8" not in str(exc):
            raise
    with open(path, encoding="cp1252", errors="replace") as fh:
        return fh.read().splitlines(), "cp1252"


def _bins(path, edges_um, values, kind, notes, diameter=None) -> BinnedSizes:
    if not np.sum(values) > 0:
        raise DataFormatError(
            "all values are zero; allowed: values >= 0 with a positive total",
            source=path,
            field="values",
        )
    number = number_per_bin(edges_um, values, kind)
    weighting = BIN_VALUES[kind][0]
    if weighting != "number":
        notes.append(
            f"{kind} converted to number per bin by dividing by d^3 of each bin's "
            "geometric midpoint (the d^3 moment)"
        )
    counted = kind == "count" and bool(np.all(values == np.round(values)))
    if kind == "count" and not counted:
        notes.append("the counts are not whole numbers: taken as relative frequencies")
    return BinnedSizes(
        edges_um=np.asarray(edges_um, float),
        number=number,
        values=kind,
        counted=counted,
        notes=tuple(notes),
        diameter=diameter,
    )
