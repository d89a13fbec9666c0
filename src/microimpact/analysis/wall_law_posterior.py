"""The wall law of a posterior: the table averaged over posterior draws
(``microimpact wall-law --posterior posterior.nc --draws K``; docs/calibration.md).

Each of `K` draws of the calibrated parameters (spread evenly over the posterior
sample of ``posterior.nc``, written by ``calibrate --method bayes``) gives a scenario,
and :func:`~microimpact.wall_law.build_wall_law` tabulates it at the same nodes with
the same seed (common random numbers: the draws differ by their parameters, not by
their Monte Carlo noise). The mixture table pools them:

* the counts (``n_*``) are summed, so ``capture_probability`` (``n_captured /
  n_impacts``) is the average of the draws' capture probabilities when every draw
  makes the same impacts per node (the Wilson limits are those of the pooled counts,
  the Monte Carlo interval of the mixture, not the parameters' spread);
* ``*_mean`` and ``*_std`` are the mixture's, each draw weighted by its rebounds;
* ``*_quantile`` is the average of the draws' quantiles at each level (the
  "Vincentized" mixture, close to the mixture's quantiles when the draws' rebound
  distributions differ mostly in location);
* the reservoir holds sample ``i`` of draw ``i mod K`` (each draw's reservoir is a
  random sample, so this is a random sample of the mixture), as many as the fewest
  any draw holds;
* ``capture_probability_draw_std`` and ``<name>_mean_draw_std``: the standard
  deviation over the draws, the parameters' uncertainty at each node;
* ``stay_probability`` (where the scenario has ``[resuspension]``): the
  probability that a particle the mixture captures stays, each draw's weighted
  by its captures at the node (the draws' average where none captured).

The C sampler, the Fluent UDF and the OpenFOAM model read the table as any other
(the added variables are ignored by them).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..engine.statistics import wilson_interval
from ..errors import InputError
from ..scenario.resuspension import resuspension_from_dict
from ..wall_law import WallLaw, build_wall_law
from .bayes import split_calibration_table
from .model import ScenarioModel

__all__ = ["posterior_draws", "posterior_wall_law"]


def posterior_draws(posterior, draws: int) -> dict:
    """`draws` parameter vectors spread evenly over the posterior sample of
    `posterior` (a ``posterior.nc`` path or an ArviZ InferenceData):
    ``{key: array (draws,)}``."""
    # deferred: ArviZ loads only where a posterior is read (import time)
    import arviz as az

    if isinstance(draws, bool) or not isinstance(draws, int) or draws < 1:
        raise InputError(f"must be an integer >= 1; got {draws}", field="--draws")
    if isinstance(posterior, str) or hasattr(posterior, "__fspath__"):
        try:
            idata = az.from_netcdf(posterior)
        except (OSError, ValueError) as exc:
            raise InputError(
                f"not a posterior file written by calibrate --method bayes ({exc})",
                source=posterior,
            ) from None
    else:
        idata = posterior
    if "posterior" not in idata.groups():
        raise InputError("has no posterior group", source=str(posterior))
    post = idata.posterior
    flat = {k: np.asarray(post[k].values, float).ravel() for k in post.data_vars}
    n = len(next(iter(flat.values())))
    if draws > n:
        raise InputError(
            f"{draws} draws asked of a posterior sample of {n}", field="--draws"
        )
    idx = np.round(np.linspace(0, n - 1, draws)).astype(int)
    return {k: v[idx] for k, v in flat.items()}


def _mixture(laws):
    """The pooled Dataset of the draws' wall-law Datasets (module docstring)."""
    dss = [w.dataset for w in laws]
    k = len(dss)
    out = dss[0].copy(deep=True)
    for name in out.data_vars:
        if name.startswith("n_"):
            out[name] = sum(d[name] for d in dss)
    n = out["n_impacts"].values
    cap = out["n_captured"].values
    with np.errstate(invalid="ignore", divide="ignore"):
        out["capture_probability"].values = np.where(
            n > 0, cap / np.maximum(n, 1), np.nan
        )
        reb = out["n_rebounds"].values
        out["reimpact_probability"].values = np.where(
            reb > 0, out["n_reimpacts"].values / np.maximum(reb, 1), np.nan
        )
    low, high = wilson_interval(cap, n, float(out.attrs.get("confidence", 0.95)))
    out["capture_ci_low"].values = np.where(n > 0, low, np.nan)
    out["capture_ci_high"].values = np.where(n > 0, high, np.nan)
    if "stay_probability" in out:
        # P(stays | captured) of the mixture: each draw's weighted by its captures
        q = np.stack([d["stay_probability"].values for d in dss])
        c = np.stack([d["n_captured"].values for d in dss]).astype(float)
        total = c.sum(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            mixed = (c * q).sum(axis=0) / total
        out["stay_probability"].values = np.where(total > 0, mixed, q.mean(axis=0))
    p = np.stack([d["capture_probability"].values for d in dss])
    spread = out["capture_probability"].copy(data=np.std(p, axis=0))
    spread.attrs.update(
        units="1",
        long_name="standard deviation over the posterior draws of the capture "
        "probability",
    )
    out["capture_probability_draw_std"] = spread
    w = np.stack([d["n_rebounds"].values for d in dss]).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = w / w.sum(axis=0)
    for name in list(out.data_vars):
        if name.endswith("_mean") and name[:-5] + "_std" in out:
            base = name[:-5]
            m = np.stack([d[name].values for d in dss])
            s = np.stack([d[base + "_std"].values for d in dss])
            wm = np.nan_to_num(w)
            mix = np.sum(wm * np.nan_to_num(m), axis=0)
            var = np.sum(wm * np.nan_to_num(s**2 + m**2), axis=0) - mix**2
            empty = out["n_rebounds"].values == 0
            out[name].values = np.where(empty, np.nan, mix)
            out[base + "_std"].values = np.where(
                empty, np.nan, np.sqrt(np.maximum(var, 0))
            )
            sd = out[name].copy(data=np.nanstd(m, axis=0))
            sd.attrs.update(
                units=out[name].attrs.get("units", "1"),
                long_name=f"standard deviation over the posterior draws of {name}",
            )
            out[name + "_draw_std"] = sd
        elif name.endswith("_quantile"):
            q = np.stack([d[name].values for d in dss])
            out[name].values = np.nanmean(q, axis=0) if k > 1 else q[0]
    counts = np.stack([d["reservoir_count"].values for d in dss])
    keep = counts.min(axis=0)
    # a node where some draw has no rebound at all (it captured everything there)
    # takes its rebounds from the draw with the most, so that a node the mixture
    # does not capture with certainty always holds rebounds (the table's rule)
    most = counts.max(axis=0)
    alone = (keep == 0) & (most > 0)
    best = counts.argmax(axis=0)
    out["reservoir_count"].values = np.where(alone, most, keep).astype(
        out["reservoir_count"].dtype
    )
    for name in out.data_vars:
        if name.startswith("reservoir_") and name != "reservoir_count":
            arr = np.stack([d[name].values for d in dss])  # (K, ..., sample)
            size = arr.shape[-1]
            pick = np.arange(size) % k
            mixed = np.take_along_axis(
                np.moveaxis(arr, 0, -1),
                pick.reshape((1,) * (arr.ndim - 2) + (size, 1)),
                axis=-1,
            )[..., 0]
            one = np.take_along_axis(arr, best[None, ..., None], axis=0)[0]
            out[name].values = np.where(alone[..., None], one, mixed)
    return out


def posterior_wall_law(
    scenario,
    posterior,
    *,
    draws: int = 20,
    spec=None,
    seed=None,
    workers: int = 1,
    executor=None,
    progress=None,
) -> WallLaw:
    """The wall law of `scenario` averaged over `draws` posterior draws of the
    parameters in `posterior` (module docstring).

    Parameters
    ----------
    scenario : path, preset name or dict
        The scenario the posterior was calibrated on, with its ``[wall_law]``
        table (or give `spec`).
    posterior : path or InferenceData
        ``posterior.nc`` of ``calibrate --method bayes``; its posterior variables
        are the parameters' dotted keys.
    draws : int
        Posterior draws to tabulate (one table build each).
    spec, seed, workers, executor, progress :
        As for :func:`~microimpact.wall_law.build_wall_law` (the same `seed` for
        every draw; default the scenario's).

    Returns
    -------
    WallLaw
        With the added variables ``capture_probability_draw_std`` and
        ``<name>_mean_draw_std``, and the attributes ``posterior_draws`` and
        ``posterior_parameters``.
    """
    values = posterior_draws(posterior, draws)
    scenario, _, source, base_dir = split_calibration_table(scenario)
    model = ScenarioModel(scenario, list(values), source=source, base_dir=base_dir)
    spec = model.file.wall_law if spec is None else spec
    if seed is None:
        seed = model.base.seed if model.base.seed is not None else 0
    laws = []
    for i in range(draws):
        sc = model.scenario({k: float(v[i]) for k, v in values.items()})
        # the file's [resuspension] at this draw (its surface energy may come
        # from the draw's capture law)
        res = resuspension_from_dict(
            model.file.data,
            source=model.source,
            base_dir=model.base_dir,
            capture_law=sc.coefficients.v_c,
        )
        laws.append(
            build_wall_law(
                sc,
                spec,
                seed=seed,
                workers=workers,
                executor=executor,
                progress=progress,
                resuspension=False if res is None else res,
            )
        )
    with warnings.catch_warnings():  # a node with no rebound in a draw: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        ds = _mixture(laws)
    ds.attrs["posterior_draws"] = int(draws)
    ds.attrs["posterior_parameters"] = ", ".join(values)
    return WallLaw(ds)
