"""The compiled kernel (``_ckernel.c``), when the install built it: an install on a
machine without a C compiler has none and runs the NumPy kernel."""

try:
    from . import _ckernel as ckernel

    ERROR = None
except ImportError as exc:  # no C compiler at install time
    ckernel, ERROR = None, exc

__all__ = ["ERROR", "ckernel"]
