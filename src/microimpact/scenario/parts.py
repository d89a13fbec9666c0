"""The parts of a scenario below the :class:`~microimpact.scenario.scenario.Scenario`
itself: named surfaces, the precision target, the allowed options and the scalar
validators that every scenario table shares (one message format: the field, the bad
value and what is allowed)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._core.validation import (
    as_field_error,
    check_choice,
    check_int,
    check_scalar,
    implausible_speed,
)
from ..errors import ScenarioError

__all__ = [
    "PRECISION_STATISTICS",
    "SAMPLING_OPTIONS",
    "SHADOWING_OPTIONS",
    "Precision",
    "SurfaceVariant",
]

#: How a facet shadowed from the incoming particle is treated (``docs/engine.md``).
SHADOWING_OPTIONS = ("reject", "weighted", "none")
#: Monte Carlo or scrambled-Sobol' quasi-Monte Carlo sampling.
SAMPLING_OPTIONS = ("mc", "qmc")
#: Statistics a ``[precision]`` target may name.
PRECISION_STATISTICS = ("capture_fraction", "e_mean", "e_rebound_mean", "mu_mean")


@dataclass(frozen=True)
class SurfaceVariant:
    """A named surface: a roughness-angle distribution, or None for molecularly
    smooth (phi = 0 exactly)."""

    name: str
    angles: Any = None

    @property
    def smooth(self) -> bool:
        """Molecularly smooth, by structure: no angle distribution, or one whose
        only value is exactly 0 (never by name)."""
        if self.angles is None:
            return True
        flag = getattr(self.angles, "is_smooth", None)
        if flag is not None:
            return bool(flag)
        try:
            return tuple(self.angles.support()) == (0.0, 0.0)
        except (AttributeError, TypeError, ValueError):
            return False

    def describe(self) -> dict:
        if self.angles is None:
            return {"name": self.name, "kind": "smooth"}
        d = dict(self.angles.describe())
        d["name"] = self.name
        return d


@dataclass(frozen=True)
class Precision:
    """Automatic sample size: stop a sweep point once the confidence-interval
    half-width of `statistic` is at most `half_width` (or `max_samples` is reached).
    """

    statistic: str = "capture_fraction"
    half_width: float = 0.01
    max_samples: int = 10_000_000
    min_samples: int = 1000

    def __post_init__(self):
        if self.statistic not in PRECISION_STATISTICS:
            raise ScenarioError(
                f"must be one of {', '.join(PRECISION_STATISTICS)}; "
                f"got {self.statistic!r}",
                field="precision.statistic",
            )
        hw = self.half_width
        if isinstance(hw, bool) or not (isinstance(hw, int | float) and hw > 0):
            raise ScenarioError(
                f"must be a number > 0; got {hw!r}", field="precision.half_width"
            )
        for name in ("max_samples", "min_samples"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ScenarioError(
                    f"must be an integer >= 1; got {v!r}", field=f"precision.{name}"
                )
        if self.min_samples > self.max_samples:
            default = Precision.__dataclass_fields__["min_samples"].default
            raise ScenarioError(
                f"must be <= max_samples ({self.max_samples}); got {self.min_samples}"
                + (" (the default)" if self.min_samples == default else ""),
                field="precision.min_samples",
            )


def _positive_tuple(values, name, *, lo=0.0, hi=math.inf, hi_inclusive=False):
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        raise ScenarioError(f"must be numbers; got {values!r}", field=name) from None
    if arr.ndim != 1 or arr.size == 0:
        raise ScenarioError(f"must be a non-empty list; got {values!r}", field=name)
    for v in arr:
        ok = np.isfinite(v) and v > lo and (v <= hi if hi_inclusive else v < hi)
        if not ok:
            rng = f"({lo}, {hi}{']' if hi_inclusive else ')'}"
            raise ScenarioError(f"value {float(v):g} is outside {rng}", field=name)
    return tuple(float(v) for v in arr)


def _plausible_speeds(values, name):
    """ScenarioError naming `name` for the first speed [m/s] of `values` that is no
    plausible impact speed (a probable unit mistake; `implausible_speed`)."""
    for v in values:
        why = implausible_speed(float(v))
        if why is not None:
            raise ScenarioError(why, field=name)


def _choice(value, field, options):
    with as_field_error(field, ScenarioError):
        return check_choice(value, field, options)


def _integer(value, field, low):
    with as_field_error(field, ScenarioError):
        return check_int(value, field, minimum=low)


def _number(value, field, *, low, high, open_=False, open_low=False):
    """A real number in [low, high] ((low, high) if `open_`, (low, high] if
    `open_low`), else ScenarioError naming `field`."""
    try:
        x = check_scalar(value, field)
    except (TypeError, ValueError):
        raise ScenarioError(f"must be a number; got {value!r}", field=field) from None
    lo_ok = x > low if (open_ or open_low) else x >= low
    hi_ok = x < high if open_ else x <= high
    if not (lo_ok and hi_ok):
        left = "(" if (open_ or open_low) else "["
        right = ")" if open_ else "]"
        raise ScenarioError(
            f"must be in {left}{low:g}, {high:g}{right}; got {value!r}", field=field
        )
    return x
