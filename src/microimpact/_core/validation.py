"""Private input validation shared by the public entry points.

Messages backtick the parameter, show the bad value and say what is allowed.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import numbers

import numpy as np


def as_float_array(x, name: str) -> np.ndarray:
    """`x` as a float64 ndarray, or ``TypeError`` naming `name`."""
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be numeric (array_like); got {x!r}.") from None


def check_nonnegative(x, name: str, *, allow_inf: bool = True) -> np.ndarray:
    """Raise ``ValueError`` if any element of `x` is negative or NaN."""
    a = as_float_array(x, name)
    bad = np.isnan(a) | (a < 0)
    if not allow_inf:
        bad |= np.isinf(a)
    if np.any(bad):
        v = a[bad].flat[0].item() if a.ndim else a.item()  # no np.float64(...)
        allowed = "a number >= 0" + ("" if allow_inf else " (finite)")
        raise ValueError(f"`{name}` must be {allowed}; got {v!r}.")
    return a


def check_positive(x, name: str, *, allow_inf: bool = False) -> np.ndarray:
    """Raise ``ValueError`` unless every element of `x` is > 0 (and finite)."""
    a = as_float_array(x, name)
    bad = np.isnan(a) | (a <= 0)
    if not allow_inf:
        bad |= np.isinf(a)
    if np.any(bad):
        v = a[bad].flat[0].item() if a.ndim else a.item()  # no np.float64(...)
        raise ValueError(f"`{name}` must be a number > 0; got {v!r}.")
    return a


def check_int(x, name: str, *, minimum: int = 1) -> int:
    """Return `x` as int, or raise ``ValueError`` unless it is an integer >= minimum."""
    if isinstance(x, bool) or not isinstance(x, numbers.Integral) or x < minimum:
        raise ValueError(f"`{name}` must be an integer >= {minimum}; got {x!r}.")
    return int(x)


def did_you_mean(word, choices) -> str:
    """``" (did you mean 'x'?)"`` for the closest of `choices` to `word`, or ``""``.

    Words are compared as text, but the suggestion is the choice itself: a choice
    ``None`` is suggested as ``None``, not as the string ``'None'``.
    """
    by_text = {str(c): c for c in choices}
    close = difflib.get_close_matches(str(word), list(by_text), n=1)
    return f" (did you mean {by_text[close[0]]!r}?)" if close else ""


def check_choice(x, name: str, choices) -> str:
    """Raise ``ValueError`` unless `x` is one of `choices` (with a "did you mean")."""
    if x not in choices:
        allowed = ", ".join(repr(c) for c in choices)
        raise ValueError(
            f"`{name}` must be one of {allowed}; got {x!r}{did_you_mean(x, choices)}."
        )
    return x


def field_message(exc) -> str:
    """The message of a ``check_*`` error without its leading backticked name and
    final period: ``"must be an integer >= 1; got 0"``, for an error that names
    the field another way (a scenario file's key path, a CLI flag)."""
    text = str(exc)
    if text.startswith("`") and "` " in text:
        text = text.split("` ", 1)[1]
    return text[:-1] if text.endswith(".") else text


@contextlib.contextmanager
def as_field_error(field: str, error, **kwargs):
    """Turn the ``ValueError``/``TypeError`` of a ``check_*`` call into
    ``error(message, field=field, **kwargs)``: the same words, the field named the
    caller's way (one validation family for arguments, scenario objects and
    files)."""
    try:
        yield
    except (TypeError, ValueError) as exc:
        raise error(field_message(exc), field=field, **kwargs) from None


def check_scalar(
    x, name: str, *, minimum=None, strict: bool = False, allow_inf: bool = False
) -> float:
    """Return the real scalar `x` as a float, or raise naming `name`.

    The scalar validator of the distribution factories and the coefficient-law
    builders, the laws and the scenario (the one scalar validator). A Python or NumPy
    real number, or a 0-d numeric array, is accepted. ``TypeError`` for a string
    (numeric strings included), a bool, any other non-number, or an array or
    sequence (naming its shape); ``ValueError`` for NaN, for inf unless
    `allow_inf`, and below `minimum` (or at it if `strict`).
    """
    if isinstance(x, np.ndarray) and x.ndim == 0 and x.dtype.kind in "iuf":
        x = x.item()
    if isinstance(x, bool | np.bool_) or not isinstance(x, numbers.Real):
        if isinstance(x, list | tuple | np.ndarray):
            shape = x.shape if isinstance(x, np.ndarray) else (len(x),)
            raise TypeError(
                f"`{name}` must be a scalar (a real number); got an array of shape "
                f"{shape}."
            )
        raise TypeError(f"`{name}` must be numeric (a real number); got {x!r}.")
    shown = int(x) if isinstance(x, numbers.Integral) else float(x)
    v = float(x)
    ok = not math.isnan(v) and (allow_inf or not math.isinf(v))
    if ok and minimum is not None:
        ok = v > minimum if strict else v >= minimum
    if not ok:
        bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
        finite = "" if allow_inf else " (finite)"
        raise ValueError(f"`{name}` must be a number{bound}{finite}; got {shown!r}.")
    return v


def check_subset(values, name: str, choices) -> tuple:
    """`values` (one value or a sequence) as a non-empty tuple of `choices`, or
    ``ValueError`` naming `name`, the bad value and the allowed set."""
    if isinstance(values, str):
        values = (values,)
    try:
        values = tuple(values)
    except TypeError:
        values = (values,)
    bad = [v for v in values if v not in choices]
    if bad or not values:
        raise ValueError(
            f"`{name}` must be a non-empty subset of {tuple(choices)}; got {values!r}."
        )
    return values


#: Plausible impact speeds [m/s]: 1 µm/s to 10 km/s. The paper's impacts are
#: 0.1-10 m/s and cold spray reaches ~1 km/s; above 10 km/s (hypervelocity) the
#: impact model does not apply, and such a number is usually mm/s or µm/s typed as
#: m/s. Below 1 µm/s nothing impacts (diffusion, not impaction, moves the particle).
PLAUSIBLE_SPEED_M_S = (1e-6, 1e4)


def implausible_speed(v_m_s: float, *, unit_hint: bool = True) -> str | None:
    """Why `v_m_s` [m/s] is not a plausible impact speed (with the likely unit
    mistake when `unit_hint`, and the allowed range), or None if it is one."""
    lo, hi = PLAUSIBLE_SPEED_M_S
    if lo <= v_m_s <= hi:
        return None
    if v_m_s > hi:
        why = (
            f"{v_m_s:g} m/s is above 10 km/s, a hypervelocity impact that the model "
            "(paper Eqs. 1-9) does not describe"
        )
        guess = f"was it given in mm/s? {v_m_s:g} mm/s is {v_m_s * 1e-3:g} m/s"
    else:
        why = f"{v_m_s:g} m/s is below 1 um/s, not an impact speed"
        guess = f"was it given in km/s? {v_m_s:g} km/s is {v_m_s * 1e3:g} m/s"
    if unit_hint:
        why = f"{why}; {guess}"
    return f"{why}; speeds are in m/s here (allowed: {lo:g} to {hi:g} m/s)"
