"""The inputs of a calibration, shared by least squares
(:mod:`~microimpact.analysis.calibration`) and the Bayesian method
(:mod:`~microimpact.analysis.bayes`): parameter keys with their bounds, and the
experiment table."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from ..errors import InputError
from ..io.experiments import read_experiments
from ..scenario.parameters import check_parameter_key
from .compare import _experiments_iv

__all__ = ["default_bounds", "parse_parameter"]


# ---------------------------------------------------------------------- inputs
def parse_parameter(text: str):
    """``KEY`` or ``KEY=LOW:HIGH`` (either limit may be empty: its default) ->
    ``(key, (low, high) or None)``; None for an empty limit.

    >>> parse_parameter("surfaces.formica.std_deg=2:20")
    ('surfaces.formica.std_deg', (2.0, 20.0))
    """
    text = str(text).strip()
    if "=" not in text:
        if not text:
            raise InputError(
                "empty parameter; give KEY or KEY=LOW:HIGH", field="--parameter"
            )
        return text, None
    key, _, rng = text.partition("=")
    key = key.strip()
    lo, sep, hi = rng.partition(":")
    if not key or not sep:
        raise InputError(
            f"{text!r}: give KEY or KEY=LOW:HIGH (e.g. surfaces.rough.std_deg=2:20)",
            field="--parameter",
        )

    def num(s, which):
        s = s.strip()
        if not s:
            return None
        try:
            v = float(s)
        except ValueError:
            raise InputError(
                f"{text!r}: the {which} bound {s!r} is not a number",
                field="--parameter",
            ) from None
        if math.isnan(v):
            raise InputError(f"{text!r}: the {which} bound is NaN", field="--parameter")
        return v

    return key, (num(lo, "lower"), num(hi, "upper"))


def default_bounds(key: str, value: float) -> tuple[float, float]:
    """The bounds of a parameter without ``=LOW:HIGH``: physically valid ranges.

    * roughness angles: ``*std_deg`` in [0, 45] deg (a spread of 45 deg is already
      a surface of cliffs), ``*mean_deg`` in [-45, 45] deg;
    * ``speed_spread`` (a relative spread) in [0, 0.5];
    * any other number keeps its sign within a decade either side of its file
      value: ``[v/10, 10 v]`` for ``v > 0`` (lengths, diameters, speeds, the
      coefficients' prefactors, friction), ``[10 v, v/10]`` for ``v < 0`` (the
      exponents ``b`` of the power laws);
    * a zero value has no natural scale: give the bounds.
    """
    last = key.rsplit(".", 1)[-1]
    if last.endswith("std_deg"):
        return 0.0, 45.0
    if last.endswith("mean_deg"):
        return -45.0, 45.0
    if last == "speed_spread":
        return 0.0, 0.5
    if value > 0:
        return value / 10.0, value * 10.0
    if value < 0:
        return value * 10.0, value / 10.0
    raise InputError(
        "its file value is 0, so there is no default range; give one as "
        f"--parameter {key}=LOW:HIGH",
        field=key,
    )


def _check_key(data, key, source):
    return check_parameter_key(data, key, source=source)


def _parameters(smodel, parameters, bounds):
    """``(keys, x0, B)``: the parameters' keys, file values and bounds (each bound
    checked to be a value the scenario accepts, with its one-line error)."""
    source = smodel.source
    if isinstance(parameters, str):
        parameters = [parameters]
    given = dict(bounds or {})
    if isinstance(parameters, Mapping):
        for k, b in parameters.items():
            if b is not None:
                given.setdefault(k, b)
    keys = list(parameters)
    if not keys:
        raise InputError("give at least one parameter", field="--parameter")
    dup = {k for k in keys if keys.count(k) > 1}
    if dup:
        raise InputError(f"given twice: {sorted(dup)}", field="--parameter")
    unknown = set(given) - set(keys)
    if unknown:
        raise InputError(
            f"bounds for keys that are not parameters: {sorted(unknown)}",
            field="bounds",
        )
    x0 = np.array([_check_key(smodel.data, k, source) for k in keys])
    B = np.empty((len(keys), 2))
    for j, key in enumerate(keys):
        b = given.get(key)
        lo = hi = None
        if b is not None:
            try:
                lo, hi = b
            except (TypeError, ValueError):
                raise InputError(
                    f"bounds must be (low, high); got {b!r}", field=key
                ) from None
        if lo is None or hi is None:
            dlo, dhi = default_bounds(key, x0[j])
            lo = dlo if lo is None else lo
            hi = dhi if hi is None else hi
        lo, hi = float(lo), float(hi)
        if not lo < hi:
            raise InputError(
                f"empty range {lo:g}:{hi:g}; the lower bound must be below the upper",
                field=key,
            )
        B[j] = lo, hi
        for v in (lo, hi):  # the scenario must accept its bounds (one-line error)
            if math.isfinite(v):
                try:
                    smodel.scenario({key: v})
                except InputError as exc:
                    raise InputError(
                        f"the bound {v:g} is not allowed: {exc.message}"
                        + (
                            ""
                            if b is not None
                            else f"; give --parameter {key}=LOW:HIGH"
                        ),
                        source=source,
                        field=key,
                    ) from None
    return keys, x0, B


def _read_experiments(experiments):
    """``(table, file name or None)`` of the experiments."""
    if isinstance(experiments, str | os.PathLike):
        exp_source = str(experiments)
        experiments = read_experiments(experiments)
    else:
        exp_source = None
    try:
        return _experiments_iv(experiments), exp_source
    except (TypeError, ValueError) as exc:
        raise InputError(str(exc), source=exp_source) from None
