"""Priors of a Bayesian calibration (:mod:`~microimpact.analysis.bayes`): scipy frozen
distributions named in a ``[calibration]`` table or built from ``KEY=LOW:HIGH``
bounds (uniform).

A prior is given per dotted parameter key as a table::

    [calibration.priors."surfaces.rough.std_deg"]
    distribution = "truncnormal"   # uniform | normal | lognormal | truncnormal
    mean = 12.0
    std = 3.0
    low = 0.0
    high = 45.0

with the fields of each distribution:

* ``uniform``: ``low``, ``high``;
* ``normal``: ``mean``, ``std``;
* ``lognormal``: ``median``, ``sigma`` (the standard deviation of the logarithm;
  scipy ``lognorm(s=sigma, scale=median)``);
* ``truncnormal``: ``mean``, ``std``, ``low``, ``high`` (scipy ``truncnorm`` with
  ``a = (low - mean)/std``, ``b = (high - mean)/std``).

Values in the parameter's own unit (the key's suffix: ``_deg``, ``_um``, ``_m_s``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from scipy import stats

from ..errors import InputError

__all__ = ["PRIOR_FIELDS", "Prior", "make_prior"]

#: Distribution name -> its fields, in order.
PRIOR_FIELDS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "lognormal": ("median", "sigma"),
    "truncnormal": ("mean", "std", "low", "high"),
}


@dataclass(frozen=True)
class Prior:
    """A parameter's prior: its distribution's name, fields and scipy frozen
    distribution."""

    key: str
    distribution: str
    fields: tuple  #: ((name, value), ...) in the order of :data:`PRIOR_FIELDS`
    dist: object  #: scipy frozen distribution

    def logpdf(self, x: float) -> float:
        return float(self.dist.logpdf(x))

    def describe(self) -> str:
        inner = ", ".join(f"{k} = {v:g}" for k, v in self.fields)
        return f"{self.distribution}({inner})"

    def to_dict(self) -> dict:
        return {"distribution": self.distribution, **dict(self.fields)}


def make_prior(key: str, spec: Mapping, *, source=None) -> Prior:
    """The :class:`Prior` of `key` from its table `spec` (``distribution`` and the
    fields of :data:`PRIOR_FIELDS`), each field checked (one-line errors naming the
    key and the field)."""
    where = f"calibration.priors.{key}"
    if not isinstance(spec, Mapping):
        raise InputError(
            "must be a table with `distribution` and its fields",
            source=source,
            field=where,
        )
    name = spec.get("distribution")
    if name not in PRIOR_FIELDS:
        raise InputError(
            f"`distribution` is {name!r}; allowed: {', '.join(PRIOR_FIELDS)}",
            source=source,
            field=where,
        )
    need = PRIOR_FIELDS[name]
    extra = sorted(set(spec) - set(need) - {"distribution"})
    if extra:
        raise InputError(
            f"unknown field(s) {', '.join(extra)} for a {name} prior; "
            f"allowed: {', '.join(need)}",
            source=source,
            field=where,
        )
    values = {}
    for f in need:
        if f not in spec:
            raise InputError(
                f"a {name} prior needs `{f}` (fields: {', '.join(need)})",
                source=source,
                field=where,
            )
        v = spec[f]
        if (
            isinstance(v, bool)
            or not isinstance(v, int | float)
            or not math.isfinite(v)
        ):
            raise InputError(
                f"`{f}` must be a finite number; got {v!r}", source=source, field=where
            )
        values[f] = float(v)
    for f in ("std", "sigma", "median"):
        if f in values and values[f] <= 0:
            raise InputError(
                f"`{f}` must be > 0; got {values[f]:g}", source=source, field=where
            )
    if "low" in values and not values["low"] < values["high"]:
        raise InputError(
            f"`low` ({values['low']:g}) must be below `high` ({values['high']:g})",
            source=source,
            field=where,
        )
    if name == "uniform":
        dist = stats.uniform(values["low"], values["high"] - values["low"])
    elif name == "normal":
        dist = stats.norm(values["mean"], values["std"])
    elif name == "lognormal":
        dist = stats.lognorm(values["sigma"], scale=values["median"])
    else:
        m, s = values["mean"], values["std"]
        dist = stats.truncnorm(
            (values["low"] - m) / s, (values["high"] - m) / s, loc=m, scale=s
        )
    return Prior(key, name, tuple((f, values[f]) for f in need), dist)


def uniform_prior(key: str, low: float, high: float) -> Prior:
    """The uniform prior of ``KEY=LOW:HIGH`` bounds."""
    return make_prior(key, {"distribution": "uniform", "low": low, "high": high})
