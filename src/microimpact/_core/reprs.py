"""Readable representations: plain numbers (no ``np.float64(...)``), short arrays
written out, long ones summarised, and small HTML tables for notebooks."""

from __future__ import annotations

import dataclasses
import html

import numpy as np

__all__ = ["dataclass_repr", "html_table", "value_text"]


def value_text(value) -> str:
    """`value` as short text: NumPy scalars as Python numbers (floats to 6
    significant digits), arrays of up to 6 values written out, longer ones as
    their shape."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return value_text(value.item())
        if value.size <= 6:
            return "[" + ", ".join(value_text(v) for v in value.ravel()) + "]"
        return f"array(shape={value.shape}, dtype={value.dtype})"
    if isinstance(value, float):
        return f"{value:.6g}"
    return repr(value)


def dataclass_repr(obj) -> str:
    """``Name(field=value, ...)`` of a dataclass, with :func:`value_text` values;
    fields that are None are left out."""
    parts = [
        f"{f.name}={value_text(getattr(obj, f.name))}"
        for f in dataclasses.fields(obj)
        if f.repr and getattr(obj, f.name) is not None
    ]
    return f"{type(obj).__name__}({', '.join(parts)})"


def html_table(title: str, rows) -> str:
    """A two-column HTML table (``rows``: (label, text) pairs) under a title."""
    body = "".join(
        f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
        f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>"
        for k, v in rows
    )
    return f"<div><strong>{html.escape(title)}</strong><table>{body}</table></div>"
