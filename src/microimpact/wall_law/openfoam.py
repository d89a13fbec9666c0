"""OpenFOAM dictionaries of a wall law: ``openfoam/`` in the wall law's folder.

Two kinds of file:

* **The no-compile fallback**, for OpenFOAM's own ``localInteraction`` patch
  interaction model: each surface's *mean* normal restitution ``e`` and OpenFOAM's
  ``mu`` at one condition (diameter, speed, angle) of the table. This keeps no
  scatter and no capture: OpenFOAM's interaction types are ``none``, ``rebound``,
  ``stick`` and ``escape`` only (v1912 and the Foundation's releases alike), with
  no per-patch sticking probability, so the capture probability is written as a
  comment.

  OpenFOAM's ``mu`` is **not** a Coulomb friction coefficient nor microimpact's
  impulse ratio: it is one minus the tangential restitution. OpenCFD's v1912 (the
  Debian package ``openfoam`` 1912.200626), ``src/lagrangian/intermediate/
  submodels/Kinematic/PatchInteractionModel/LocalInteraction/LocalInteraction.C``,
  ``LocalInteraction<CloudType>::correct``, case ``itRebound``::

      scalar Un = U & nw;
      vector Ut = U - Un*nw;

      if (Un > 0)
      {
          U -= (1.0 + patchData_[patchi].e())*Un*nw;
      }

      U -= patchData_[patchi].mu()*Ut;

  (``nw`` the patch's outward normal, ``U`` relative to the patch velocity), so the
  normal velocity becomes ``-e Un`` and the tangential one ``(1 - mu) Ut`` (lines
  297-305 of that file at OpenCFD's commit "REL: Updated bashrc|cshrc version to
  v1912", 2019-12-19). The same lines are in ``StandardWallInteraction.C`` there
  and in the OpenFOAM Foundation's OpenFOAM-dev.
  ``patchInteractionData.C`` reads ``e`` (default 1) and ``mu`` (default 0) per patch,
  and ``PatchInteractionModel::wordToInteractionType`` knows ``none``, ``rebound``,
  ``stick`` and ``escape``. Hence ``e = mean e_n`` and ``mu = 1 - mean e_t``.

* **The stochastic model**: the C++ patch interaction model ``stochasticWallLaw``
  (shipped in ``openfoam_model/``, written to ``openfoam/stochasticWallLaw/`` with
  ``build.sh`` and a demo case), which samples the C table (``c/wall_law.swl``,
  through ``c/swl.h``'s ``swl_rebound_velocity``) at every wall strike, and its
  coefficients ``stochasticWallLawCoeffs``, whose table path is the case's
  ``$FOAM_CASE/constant/wall_law.swl``. The keys are described in the file itself
  and in docs/wall-law.md. Its exporter (:func:`write_stochastic_model`,
  :func:`write_demo_case`) lives in :mod:`.openfoam_stochastic` and is imported
  from here as before.

The condition of the fallback: on each axis the node nearest the middle of the
axis' range, measured in the axis' interpolation variable (log d, log v, angle in
degrees), the lower one on a tie; or, where a value is given, the node nearest
that value in the same variable (a value outside the axis' range is an error).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

# the stochastic model and the writing it shares (openfoam_stochastic.py); its
# constants are imported from here too, as before the split (hence the noqa)
from .openfoam_stochastic import (
    _FOAMFILE,
    BUILD_SCRIPT,  # noqa: F401
    C_TABLE,  # noqa: F401
    CASE_TABLE,  # noqa: F401
    DEMO_CASE,  # noqa: F401
    DEMO_FAMILIES,  # noqa: F401
    MODEL_DIR,  # noqa: F401
    MODEL_FILES,  # noqa: F401
    MODEL_SOURCES,  # noqa: F401
    STOCHASTIC_FILE,
    _comment_block,
    _demo_family_iv,
    _patch_names,
    _provenance,
    _write_text,
    write_demo_case,
    write_stochastic_model,
)

__all__ = [
    "LOCAL_INTERACTION_FILE",
    "LOCAL_PATCHES_FILE",
    "STOCHASTIC_FILE",
    "OpenFOAMFallbackWarning",
    "fallback_condition",
    "openfoam_coefficients",
    "write_demo_case",
    "write_openfoam",
    "write_stochastic_model",
]

#: The fallback: a complete ``localInteractionCoeffs`` entry.
LOCAL_INTERACTION_FILE = "localInteractionCoeffs"
#: The same patch entries alone, to ``#include`` inside the user's ``patches ( )``.
LOCAL_PATCHES_FILE = "localInteractionPatches"
#: The axes of the condition and whether the node distance is taken in log.
_AXES = (("diameter_um", True), ("speed_m_s", True), ("angle_deg", False))


def _pick_node(coord, value, name: str, log: bool) -> int:
    """Index of the node of `coord` chosen for `value` (None: the middle)."""
    x = np.asarray(coord, dtype=float)
    f = np.log if log else (lambda a: a)
    if value is None:
        target = 0.5 * (f(x[0]) + f(x[-1]))
    else:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"`{name}` must be a number; got {value!r}") from None
        lo, hi = x[0], x[-1]
        tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
        if not (math.isfinite(v) and lo - tol <= v <= hi + tol):
            raise ValueError(
                f"`{name}` = {v:g} is outside the table's range "
                f"[{lo:g}, {hi:g}]; choose a value within it"
            )
        target = f(max(v, x[0])) if log else v
    dist = np.abs(f(x) - target)
    return int(np.flatnonzero(dist <= dist.min() * (1 + 1e-12) + 1e-300)[0])


def fallback_condition(dataset, *, diameter_um=None, speed_m_s=None, angle_deg=None):
    """The node of the fallback dictionary: ``{axis: (index, value)}``.

    On each axis, the node nearest `value` (or, where it is None, nearest the
    middle of the axis' range) in the axis' interpolation variable: log d, log v,
    and the angle in degrees; the lower node on a tie. The default angle is the
    middle of the oblique nodes (below 90 deg), where the table has any. Raises
    ``ValueError`` naming the argument if a value lies outside the axis' range.
    On a reduced speed axis (``speed_m_s`` of shape (diameters, ratios), the
    speeds r v_c(d)) the speed node is chosen among the chosen diameter's.
    """
    given = {"diameter_um": diameter_um, "speed_m_s": speed_m_s, "angle_deg": angle_deg}
    out = {}
    for axis, log in _AXES:
        coord = np.asarray(dataset[axis], dtype=float)  # a Dataset or a dict of axes
        if coord.ndim == 2:  # reduced speed axis: the chosen diameter's speeds
            coord = coord[out["diameter_um"][0]]
        if axis == "angle_deg" and given[axis] is None and np.any(coord < 90.0):
            # the default is an oblique node: e_t is undefined at normal incidence
            oblique = coord[coord < 90.0]
            i = _pick_node(oblique, None, axis, log)
            out[axis] = (i, float(oblique[i]))
            continue
        try:
            i = _pick_node(coord, given[axis], axis, log)
        except ValueError as err:
            if np.asarray(dataset[axis]).ndim == 2:
                d = out["diameter_um"][1]
                raise ValueError(
                    f"{err} (a reduced speed axis: the speeds r v_c(d) of the "
                    f"{d:g} um diameter node)"
                ) from None
            raise
        out[axis] = (i, float(coord[i]))
    return out


def _value(ds, name, s, node):
    if name not in ds:
        return math.nan
    i, j, k = node
    speed = "reduced_speed" if "reduced_speed" in ds.dims else "speed_m_s"
    a = ds[name].sel(surface=s).isel({"diameter_um": i, speed: j, "angle_deg": k})
    return float(a.values)


class OpenFOAMFallbackWarning(UserWarning):
    """The no-compile fallback applies something other than the node's mean
    rebound: a whole patch sticks, or the table's mean rebound replaces a node that
    captures everything (the CLI prints it as a one-line warning)."""


def _table_mean(ds, s) -> tuple[float, float, int, int]:
    """``(mean e_n, mean e_t, rebounds, nodes)`` over every rebound of surface
    `s` in the table: each node's means weighted by its rebounds (e_t over the
    oblique nodes only, where it is defined)."""
    node = ds.sel(surface=s)
    n = np.asarray(node["n_rebounds"].values, dtype=float)
    e_n = np.asarray(node["e_n_mean"].values, dtype=float)
    e_t = np.asarray(node["e_t_mean"].values, dtype=float)
    oblique = np.asarray(node["angle_deg"].values, dtype=float) < 90.0
    ok = (n > 0) & np.isfinite(e_n)
    ok_t = ok & np.isfinite(e_t) & np.broadcast_to(oblique, n.shape)
    if not ok.any():
        return math.nan, math.nan, 0, 0
    mean_n = float(np.sum(n[ok] * e_n[ok]) / np.sum(n[ok]))
    mean_t = (
        float(np.sum(n[ok_t] * e_t[ok_t]) / np.sum(n[ok_t])) if ok_t.any() else math.nan
    )
    return mean_n, mean_t, int(np.sum(n[ok])), int(np.count_nonzero(ok))


def openfoam_coefficients(law, *, diameter_um=None, speed_m_s=None, angle_deg=None):
    """The fallback's numbers: the condition and, per surface, a dict with ``type``
    (``"rebound"`` or ``"stick"``), ``e`` (mean e_n), ``mu`` (OpenFOAM's: 1 - mean
    e_t), ``applied`` (what the entry applies: ``"node"``, ``"table mean"`` or
    ``"stick"``), ``note`` (why, where it is not the node's mean rebound, else
    ``""``) and the node's statistics.

    A surface that captures every impact at the node is never made to stick
    silently: where the condition was not given on every axis, its entry is the
    mean rebound over the whole table (each node weighted by its rebounds); where
    the user gave the condition, or the table has no rebound of that surface at
    all, it is ``stick``; either way `note` says so.

    Raises ``ValueError`` naming the argument for a value outside the table, at
    normal incidence (e_t is undefined there) and for a surface with no impact at
    the node (every draw shadowed).
    """
    ds = law.dataset
    cond = fallback_condition(
        ds, diameter_um=diameter_um, speed_m_s=speed_m_s, angle_deg=angle_deg
    )
    node = tuple(cond[a][0] for a, _ in _AXES)
    surfaces = [str(s) for s in np.asarray(ds["surface"].values).tolist()]
    out = {}
    for s, label in zip(ds["surface"].values.tolist(), surfaces, strict=True):
        stats = {
            name: _value(ds, name, s, node)
            for name in (
                "capture_probability",
                "capture_ci_low",
                "capture_ci_high",
                "reimpact_probability",
                "e_n_mean",
                "e_n_std",
                "e_t_mean",
                "e_t_std",
                "mu_mean",
                "mu_std",
                "n_impacts",
                "n_rebounds",
            )
        }
        p = stats["capture_probability"]
        where = (
            f"at diameter_um={cond['diameter_um'][1]:g}, "
            f"speed_m_s={cond['speed_m_s'][1]:g}, angle_deg={cond['angle_deg'][1]:g}"
        )
        if not math.isfinite(p):
            raise ValueError(
                f"surface {label!r} has no impact {where} (every draw shadowed); "
                "choose another `angle_deg`"
            )
        applied, note = "node", ""
        if p >= 1.0 or not math.isfinite(stats["e_n_mean"]):
            mean_n, mean_t, rebounds, nodes = _table_mean(ds, s)
            given = None not in (diameter_um, speed_m_s, angle_deg)
            if given or not (math.isfinite(mean_n) and math.isfinite(mean_t)):
                kind, e, mu, applied = "stick", math.nan, math.nan, "stick"
                why = (
                    f"captures every impact {where}, the condition given"
                    if given
                    else "has no rebound anywhere in the table"
                )
                note = (
                    f"surface {label!r} {why}: its OpenFOAM patch is written "
                    "'type stick', so every parcel that strikes it sticks"
                )
            else:
                kind, e, mu, applied = "rebound", mean_n, 1.0 - mean_t, "table mean"
                note = (
                    f"surface {label!r} captures every impact {where}; OpenFOAM's "
                    "localInteraction cannot apply a capture probability, so instead "
                    "of making the whole patch stick its entry is the mean rebound "
                    f"over the table's {rebounds} rebounds at {nodes} nodes (e "
                    f"{mean_n:.4g}, mu {1.0 - mean_t:.4g}), applied to every "
                    "parcel; give the condition (--diameter-um, --speed-m-s, "
                    "--angle-deg) or use the stochastic model"
                )
        else:
            if cond["angle_deg"][1] >= 90.0 or not math.isfinite(stats["e_t_mean"]):
                raise ValueError(
                    f"`angle_deg` = {cond['angle_deg'][1]:g}: the tangential "
                    "restitution is undefined at normal incidence; choose an "
                    "oblique angle"
                )
            kind = "rebound"
            e = stats["e_n_mean"]
            mu = 1.0 - stats["e_t_mean"]
        out[label] = {
            "type": kind,
            "e": e,
            "mu": mu,
            "applied": applied,
            "note": note,
            **stats,
        }
    return {axis: v for axis, (_, v) in cond.items()}, out


def _fmt(x: float) -> str:
    return "nan" if not math.isfinite(x) else f"{x:.10g}"


def _header(ds, cond, coeffs, requested) -> list[str]:
    lines = [
        *_provenance(ds),
        "condition (the table's node; "
        + ", ".join(
            f"{a} {'given ' + format(float(r), 'g') if r is not None else 'middle'}"
            for a, r in requested.items()
        )
        + "):",
        f"    diameter {cond['diameter_um']:g} um, speed {cond['speed_m_s']:g} m/s, "
        f"angle {cond['angle_deg']:g} deg from the wall plane",
        "per surface, at that node (means and standard deviations over rebounds):",
    ]
    for s, c in coeffs.items():
        lines.append(
            f"  {s}: e_n {_fmt(c['e_n_mean'])} +- {_fmt(c['e_n_std'])}, "
            f"e_t {_fmt(c['e_t_mean'])} +- {_fmt(c['e_t_std'])}, "
            f"capture probability {_fmt(c['capture_probability'])} "
            f"(CI {_fmt(c['capture_ci_low'])} .. {_fmt(c['capture_ci_high'])}), "
            f"re-impacts {_fmt(c['reimpact_probability'])} of rebounds"
        )
    return lines


_CONVENTION = [
    "OpenFOAM's rebound (localInteraction, standardWallInteraction):",
    "  U_n' = -e U_n and U_t' = (1 - mu) U_t, so e = mean e_n and",
    "  mu = 1 - mean e_t: OpenFOAM's mu is NOT a friction coefficient.",
    "OpenFOAM has no per-patch sticking probability (types none, rebound, stick,",
    "escape): the capture probability above is NOT applied by this dictionary;",
    "what each patch entry applies is said above it.",
]


def _patch_entries(coeffs, names, indent) -> str:
    pad = " " * indent
    out = []
    for s, c in coeffs.items():
        p = _fmt(c["capture_probability"])
        said = {
            "node": [
                f"surface {s!r}: applied: the mean rebound at the node (e, mu) to "
                "every parcel;",
                f"its capture probability {p} there is NOT applied.",
            ],
            "table mean": [
                f"surface {s!r}: captures every impact at the node (probability {p});",
                "applied: the mean rebound over the whole table (e, mu) to every "
                "parcel;",
                "the capture is NOT applied (no sticking probability in OpenFOAM).",
            ],
            "stick": [
                f"surface {s!r}: applied: type stick, EVERY parcel that strikes it "
                "sticks",
                f"(capture probability {p} at the node).",
            ],
        }[c.get("applied", "node")]
        out.extend(f"{pad}// {line}\n" for line in said)
        if c["type"] == "stick":
            out.append(f"{pad}{names[s]}\n{pad}{{\n{pad}    type    stick;\n{pad}}}\n")
        else:
            out.append(
                f"{pad}{names[s]}\n{pad}{{\n{pad}    type    rebound;\n"
                f"{pad}    e       {_fmt(c['e'])};\n"
                f"{pad}    mu      {_fmt(c['mu'])};\n{pad}}}\n"
            )
    return "".join(out)


def write_openfoam(
    law,
    out_dir,
    *,
    diameter_um=None,
    speed_m_s=None,
    angle_deg=None,
    patches: Mapping[str, str] | None = None,
    demo_family: str = "kinematic",
) -> list[Path]:
    """Write ``out_dir/openfoam/``: OpenFOAM dictionaries of the wall law `law`.

    Files:

    * ``localInteractionCoeffs``: a ``localInteractionCoeffs { patches ( ... ); }``
      entry with each surface's mean ``e`` and OpenFOAM's ``mu`` (= 1 - mean e_t)
      at one condition, for OpenFOAM's ``localInteraction`` model;
    * ``localInteractionPatches``: the same patch entries alone, to ``#include``
      inside a ``patches ( ... )`` list that also names the mesh's other patches;
    * the stochastic model (:func:`write_stochastic_model`):
      ``stochasticWallLawCoeffs`` (its coefficients), ``stochasticWallLaw/`` (the
      C++ patch interaction model, which samples the table at every wall strike),
      ``build.sh`` and ``demoCase/``.

    Parameters
    ----------
    law : WallLaw
        Anything with the wall law's Dataset as ``.dataset``.
    out_dir : path
        The wall law's folder (the stochastic dictionary points at its
        ``c/wall_law.swl``).
    diameter_um, speed_m_s, angle_deg : float, optional
        The condition of the fallback's means: on each axis the node nearest the
        value in (log d, log v, angle); default the node nearest the middle of the
        axis' range. A value outside the axis' range raises ``ValueError``.
    patches : mapping, optional
        Surface name -> mesh patch name (or OpenFOAM regular expression, written in
        double quotes, e.g. ``"(top|bottom)Wall"``). Default: the surface name,
        with characters other than ``A-Z a-z 0-9 _ . : + -`` replaced by ``_``.
    demo_family : {"kinematic", "mppic", "reacting"}, optional
        The solver family of ``demoCase/`` (:func:`write_demo_case`):
        ``icoUncoupledKinematicParcelFoam``, ``MPPICFoam`` or
        ``reactingParcelFoam``. Default ``"kinematic"``.

    Returns
    -------
    list of Path
        The files written.
    """
    _demo_family_iv(demo_family)
    ds = law.dataset
    requested = {
        "diameter_um": diameter_um,
        "speed_m_s": speed_m_s,
        "angle_deg": angle_deg,
    }
    cond, coeffs = openfoam_coefficients(
        law, diameter_um=diameter_um, speed_m_s=speed_m_s, angle_deg=angle_deg
    )
    for c in coeffs.values():
        if c["note"]:  # said on the terminal: never a silent all-stick wall
            warnings.warn(
                f"OpenFOAM fallback: {c['note']}", OpenFOAMFallbackWarning, stacklevel=2
            )
    names = _patch_names(list(coeffs), patches)
    header = _header(ds, cond, coeffs, requested)
    folder = Path(out_dir) / "openfoam"
    written = []

    usage = [
        "Use: in constant/<cloud>Properties, subModels { patchInteractionModel",
        'localInteraction; #include "<this file>" }. localInteraction needs every',
        "non-coupled, non-empty patch of the mesh in 'patches': add the others",
        "(inlets, outlets) here, or #include localInteractionPatches inside your own",
        "list instead. Patch names are the surface names unless mapped at export.",
    ]
    text = (
        _FOAMFILE.format(obj=LOCAL_INTERACTION_FILE)
        + _comment_block([*header, "", *_CONVENTION, "", *usage])
        + "\nlocalInteractionCoeffs\n{\n    patches\n    (\n"
        + _patch_entries(coeffs, names, 8)
        + "    );\n}\n"
    )
    written.append(_write_text(folder / LOCAL_INTERACTION_FILE, text))

    usage = [
        "A fragment, not a dictionary: the patch entries alone, to include in the",
        "'patches' list of localInteractionCoeffs next to the mesh's other patches:",
        "    patches",
        "    (",
        '        #include "<path>/openfoam/localInteractionPatches"',
        "        outlet { type escape; }",
        "    );",
    ]
    text = (
        _comment_block([*header, "", *_CONVENTION, "", *usage])
        + "\n"
        + _patch_entries(coeffs, names, 0)
    )
    written.append(_write_text(folder / LOCAL_PATCHES_FILE, text))

    written.extend(
        write_stochastic_model(law, out_dir, patches=patches, demo_family=demo_family)
    )
    return written
