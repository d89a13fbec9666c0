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

__all__ = ["dumps", "plain"]


def plain(obj):
    """`obj` as plain JSON-able Python data (non-finite floats become None)."""
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.ndarray):
        return [plain(v) for v in obj.tolist()]
    if isinstance(obj, Mapping):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | set | frozenset):
        return [plain(v) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    raise TypeError(f"cannot write a {type(obj).__name__} as JSON.")


def dumps(obj, *, indent=None) -> str:
    """Standard JSON text of `obj` (see the module notes)."""
    return json.dumps(plain(obj), indent=indent, allow_nan=False)
