"""Standard JSON for every JSON output (RFC 8259: no NaN, no Infinity).

:func:`dumps` writes NaN and infinities as ``null``, NumPy scalars and arrays as
numbers and lists, tuples as lists, paths as strings, and dataclasses and mappings as
objects. It never writes a Python ``repr``: an object it cannot represent raises
``TypeError`` naming its type, so a new output field cannot slip through as text.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping

import numpy as np

__all__ = ["dumps", "plain", "restore_nonfinite"]


#: How :func:`dumps` writes a non-finite float when asked to keep it.
NONFINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


def _nonfinite_text(x: float) -> str:
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def plain(obj, *, keep_nonfinite: bool = False):
    """`obj` as plain JSON-able Python data.

    Non-finite floats become None, or with `keep_nonfinite` the strings ``"inf"``,
    ``"-inf"``, ``"nan"`` (standard JSON that :func:`restore_nonfinite` reads back).
    """
    kw = {"keep_nonfinite": keep_nonfinite}
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        x = float(obj)
        if math.isfinite(x):
            return x
        return _nonfinite_text(x) if keep_nonfinite else None
    if isinstance(obj, np.ndarray):
        return [plain(v, **kw) for v in obj.tolist()]
    if isinstance(obj, Mapping):
        return {str(k): plain(v, **kw) for k, v in obj.items()}
    if isinstance(obj, list | tuple | set | frozenset):
        return [plain(v, **kw) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {
            f.name: plain(getattr(obj, f.name), **kw) for f in dataclasses.fields(obj)
        }
    raise TypeError(f"cannot write a {type(obj).__name__} as JSON.")


def dumps(obj, *, indent=None, keep_nonfinite: bool = False) -> str:
    """Standard JSON text of `obj` (see the module notes and :func:`plain`)."""
    return json.dumps(
        plain(obj, keep_nonfinite=keep_nonfinite), indent=indent, allow_nan=False
    )


def restore_nonfinite(obj):
    """Undo ``keep_nonfinite``: the values ``"inf"``, ``"-inf"`` and ``"nan"`` (not
    keys) become floats again, recursively."""
    if isinstance(obj, str):
        return NONFINITE.get(obj, obj)
    if isinstance(obj, list):
        return [restore_nonfinite(v) for v in obj]
    if isinstance(obj, dict):
        return {k: restore_nonfinite(v) for k, v in obj.items()}
    return obj
