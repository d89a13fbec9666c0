"""Scenario files: the ``[sensitivity]`` table (see ``docs/sensitivity.md``).

::

    [sensitivity]
    base_size = 1024                # base size n of the Sobol' design (a power of 2)
    statistics = ["capture_fraction", "e_rebound_mean", "mu_mean"]   # optional
    resamples = 999                 # bootstrap resamples (optional)
    [sensitivity.parameters]
    "particles.median_um" = { low = 8, high = 12 }                # uniform
    "surfaces.formica.std_deg" = { distribution = "normal", mean = 10, std = 2 }
    [sensitivity.parameters."coefficients.v_c.a_m_s"]            # or a sub-table
    distribution = "lognormal"
    median = 0.5
    geometric_std = 1.2

Part of the scenario configuration, split out to keep modules small. Every problem
is one :class:`~microimpact.errors.ScenarioError` naming the key path, as for the
rest of the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ._file_base import _Ctx, _join, _show
from .parameters import check_parameter_key

__all__ = [
    "DEFAULT_BASE_SIZE",
    "DEFAULT_RESAMPLES",
    "DEFAULT_STATISTICS",
    "DISTRIBUTIONS",
    "SENSITIVITY_KEYS",
    "STATISTICS",
    "SensitivitySettings",
    "parameter_distribution",
    "sensitivity_from_dict",
]

#: Keys of the ``[sensitivity]`` table.
SENSITIVITY_KEYS = ("base_size", "statistics", "resamples", "parameters")
#: Base size of the design when ``base_size`` is not given.
DEFAULT_BASE_SIZE = 1024
#: Bootstrap resamples of the confidence intervals.
DEFAULT_RESAMPLES = 999
#: The statistics of the issue: analysed when ``statistics`` is not given.
DEFAULT_STATISTICS = ("capture_fraction", "e_rebound_mean", "mu_mean")
#: Statistics that may be analysed: columns of ``SimulationResult.summary`` (one
#: value per sweep point), and ``capture_speed_m_s`` (the speed of 50 % capture
#: per surface and angle, ``SimulationResult.capture_speed(0.5)``).
STATISTICS = (
    "capture_fraction",
    "e_mean",
    "e_rebound_mean",
    "mu_mean",
    "e_std",
    "e_rebound_std",
    "mu_std",
    "e_p05",
    "e_p50",
    "e_p95",
    "mu_p05",
    "mu_p50",
    "mu_p95",
    "reimpact_fraction",
    "rolling_fraction",
    "shadowed_fraction",
    "capture_speed_m_s",
)
#: distribution -> (required keys, optional keys) of a parameter's table.
DISTRIBUTIONS = {
    "uniform": ({"low", "high"}, set()),
    "normal": ({"mean", "std"}, {"low", "high"}),
    "lognormal": ({"median", "geometric_std"}, set()),
    "triangular": ({"low", "mode", "high"}, set()),
}


@dataclass(frozen=True)
class SensitivitySettings:
    """The ``[sensitivity]`` table of a scenario file.

    Attributes
    ----------
    base_size : int
        Base size n of the Sobol' design (a power of 2); the model is run
        ``n * (d + 2)`` times for d parameters.
    parameters : dict
        Dotted key -> frozen ``scipy.stats`` distribution of that input.
    statistics : tuple of str
        The statistics analysed.
    resamples : int
        Bootstrap resamples of the confidence intervals.
    """

    base_size: int = DEFAULT_BASE_SIZE
    parameters: dict = field(default_factory=dict)
    statistics: tuple = DEFAULT_STATISTICS
    resamples: int = DEFAULT_RESAMPLES


def _number(ctx, t, where, key, **kw):
    return ctx.number(t[key], _join(where, key), **kw)


def parameter_distribution(spec, where="parameter", *, source=None):
    """A frozen ``scipy.stats`` distribution from a parameter's table.

    ``{low, high}`` (or ``distribution = "uniform"``): uniform on [low, high];
    ``{distribution = "normal", mean, std}`` with optional ``low``/``high``
    truncation; ``{distribution = "lognormal", median, geometric_std}`` (ln x
    normal, as the particle sizes); ``{distribution = "triangular", low, mode,
    high}``. An object with a ``ppf`` method (a frozen distribution) is returned
    as it is.
    """
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy import stats

    if not isinstance(spec, dict) and hasattr(spec, "ppf"):
        return spec
    ctx = _Ctx(source, None)
    t = ctx.table(spec, where)
    kind = t.get("distribution", "uniform")
    kind = ctx.choice(kind, _join(where, "distribution"), tuple(DISTRIBUTIONS))
    required, optional = DISTRIBUTIONS[kind]
    ctx.keys(t, where, {"distribution"} | required | optional, required)
    if kind == "uniform":
        low, high = _number(ctx, t, where, "low"), _number(ctx, t, where, "high")
        if not high > low:
            raise ctx.error(
                _join(where, "high"), f"must be > low ({low:g}); got {_show(t['high'])}"
            )
        return stats.uniform(loc=low, scale=high - low)
    if kind == "normal":
        mean = _number(ctx, t, where, "mean")
        std = _number(ctx, t, where, "std", low=0, strict=True)
        low = _number(ctx, t, where, "low") if "low" in t else -math.inf
        high = _number(ctx, t, where, "high") if "high" in t else math.inf
        if not high > low:
            raise ctx.error(
                _join(where, "high"), f"must be > low ({low:g}); got {_show(t['high'])}"
            )
        if math.isinf(low) and math.isinf(high):
            return stats.norm(loc=mean, scale=std)
        return stats.truncnorm((low - mean) / std, (high - mean) / std, mean, std)
    if kind == "lognormal":
        median = _number(ctx, t, where, "median", low=0, strict=True)
        gsd = _number(ctx, t, where, "geometric_std", low=1, strict=True)
        return stats.lognorm(s=math.log(gsd), scale=median)
    # triangular
    low, mode, high = (_number(ctx, t, where, k) for k in ("low", "mode", "high"))
    if not low <= mode <= high or not high > low:
        raise ctx.error(
            _join(where, "mode"),
            f"needs low <= mode <= high and low < high; got {low:g}, {mode:g}, "
            f"{high:g}",
        )
    return stats.triang((mode - low) / (high - low), loc=low, scale=high - low)


def _key_path(key) -> str:
    """``sensitivity.parameters."a.b"``: a dotted parameter key inside the table
    path, quoted as in TOML."""
    return f'sensitivity.parameters."{key}"'


def sensitivity_from_dict(data: dict, *, source=None) -> SensitivitySettings | None:
    """The ``[sensitivity]`` table of parsed scenario `data`, or None if absent.

    Each parameter key is checked against the rest of `data` (it must name a
    number of the scenario) and its table turned into a frozen distribution.
    """
    if "sensitivity" not in data:
        return None
    ctx = _Ctx(source, None)
    t = ctx.table(data["sensitivity"], "sensitivity")
    if "samples" in t:
        raise ctx.error(
            "sensitivity.samples",
            "renamed: the Sobol' design's base size is `base_size` (`samples` means "
            "impacts per sweep point everywhere, as in the scenario's own `samples`)",
        )
    ctx.keys(t, "sensitivity", SENSITIVITY_KEYS, ("parameters",))
    kw = {}
    if "base_size" in t:
        n = ctx.integer(t["base_size"], "sensitivity.base_size", low=2)
        if n & (n - 1):
            raise ctx.error(
                "sensitivity.base_size",
                f"must be a power of 2 (the balance of Sobol' points); got {n} "
                f"(e.g. {1 << (n.bit_length() - 1)} or {1 << n.bit_length()})",
            )
        kw["base_size"] = n
    if "resamples" in t:
        kw["resamples"] = ctx.integer(t["resamples"], "sensitivity.resamples", low=10)
    if "statistics" in t:
        stat = t["statistics"]
        stat = [stat] if isinstance(stat, str) else stat
        if not isinstance(stat, list) or not stat:
            raise ctx.error(
                "sensitivity.statistics", "must be a non-empty array of statistics"
            )
        kw["statistics"] = tuple(
            dict.fromkeys(
                ctx.choice(s, f"sensitivity.statistics[{i}]", STATISTICS)
                for i, s in enumerate(stat)
            )
        )
    params = ctx.table(t["parameters"], "sensitivity.parameters")
    if not params:
        raise ctx.error("sensitivity.parameters", "must name at least one parameter")
    scenario = {k: v for k, v in data.items() if k != "sensitivity"}
    dists = {}
    for key, spec in params.items():
        where = _key_path(key)
        check_parameter_key(scenario, key, source=source, where=where)
        dists[key] = parameter_distribution(spec, where, source=source)
    kw["parameters"] = dists
    return SensitivitySettings(**kw)
