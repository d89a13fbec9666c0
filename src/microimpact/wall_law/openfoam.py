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
  and in docs/wall-law.md.

The condition of the fallback: on each axis the node nearest the middle of the
axis' range, measured in the axis' interpolation variable (log d, log v, angle in
degrees), the lower one on a tie; or, where a value is given, the node nearest
that value in the same variable (a value outside the axis' range is an error).
"""

from __future__ import annotations

import hashlib
import math
import re
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write
from .._core.validation import did_you_mean
from .export_c import C_SOURCES

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
#: The stochastic model's coefficients (the model: ``stochasticWallLaw/``).
STOCHASTIC_FILE = "stochasticWallLawCoeffs"
#: The binary table of the C sampler, relative to the wall law's folder.
C_TABLE = ("c", "wall_law.swl")
#: Where the stochastic model's dictionary looks for the table: in the case, so
#: that no path of the machine that built the law is written.
CASE_TABLE = "$FOAM_CASE/constant/wall_law.swl"
#: The model's C++ sources and build script shipped with the package.
MODEL_SOURCES = Path(__file__).with_name("openfoam_model")
#: The model's folder in ``openfoam/`` and its files (from :data:`MODEL_SOURCES`).
MODEL_DIR = "stochasticWallLaw"
MODEL_FILES = (
    "StochasticWallLaw.H",
    "StochasticWallLaw.C",
    "swlPatchEntry.H",
    # one registration per cloud type of OpenFOAM v1912's solvers (Make/files)
    "makeStochasticWallLawKinematicCloud.C",
    "makeStochasticWallLawKinematicCollidingCloud.C",
    "makeStochasticWallLawKinematicMPPICCloud.C",
    "makeStochasticWallLawThermoCloud.C",
    "makeStochasticWallLawReactingCloud.C",
    "makeStochasticWallLawReactingMultiphaseCloud.C",
    "makeStochasticWallLawHeterogeneousReactingCloud.C",
    "makeStochasticWallLawSprayCloud.C",
    "Make/files",
    "Make/options",
)
#: The build script, written to ``openfoam/build.sh``.
BUILD_SCRIPT = "build.sh"

#: Characters of a patch name written as a plain OpenFOAM word; any other name is
#: written in double quotes, which OpenFOAM reads as a regular expression.
_WORD = re.compile(r"[A-Za-z0-9_.:+-]+")
_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.:+-]*")
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


def _patch_names(surfaces, patches) -> dict:
    """Surface -> the OpenFOAM keyword written for it (plain word or "regex")."""
    names = {}
    if patches is None:
        patches = {}
    elif not isinstance(patches, Mapping):
        raise TypeError(
            "`patches` must map surface names to mesh patch names; "
            f"got {type(patches).__name__}"
        )
    for key in patches:
        if key not in surfaces:
            raise ValueError(
                f"`patches` names surface {key!r}, which the table does not have"
                f"{did_you_mean(key, surfaces)}; surfaces: "
                + ", ".join(repr(s) for s in surfaces)
            )
    for s in surfaces:
        if s in patches:
            p = patches[s]
            if not isinstance(p, str) or not p.strip():
                raise ValueError(
                    f"`patches[{s!r}]` must be a non-empty patch name; got {p!r}"
                )
            if '"' in p or "\\" in p or any(ord(c) < 32 for c in p):
                raise ValueError(
                    f"`patches[{s!r}]` = {p!r}: a patch name or regular expression "
                    "without quotes, backslashes or control characters"
                )
            names[s] = p if _PLAIN.fullmatch(p) else f'"{p}"'
        else:
            word = "".join(c if _WORD.fullmatch(c) else "_" for c in s) or "_"
            if not _PLAIN.fullmatch(word):
                word = "_" + word
            names[s] = word
    seen: dict = {}
    for s, w in names.items():
        if w in seen:
            raise ValueError(
                f"surfaces {seen[w]!r} and {s!r} would both be written as patch "
                f"{w}; give `patches` to name their mesh patches"
            )
        seen[w] = s
    return names


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


def _provenance(ds) -> list[str]:
    """The first lines of every file's header: versions, scenario, seed."""
    attrs = ds.attrs
    scenario = str(attrs.get("scenario", "") or "")
    digest = hashlib.sha256(scenario.encode()).hexdigest()[:16] if scenario else "-"
    title = str(attrs.get("title", "microimpact wall law"))
    return [
        f"Generated by microimpact {__version__} (table built by microimpact "
        f"{attrs.get('microimpact_version', '?')}); do not edit, regenerate.",
        f"{title}",
        f"scenario: sha256 {digest} of the scenario text held in wall_law.nc",
        f"seed: {attrs.get('seed', '?')}; samples per node: "
        f"{attrs.get('samples_per_node', '?')}; shadowing: "
        f"{attrs.get('shadowing', '?')}",
    ]


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


def _comment_block(lines) -> str:
    return "".join(f"// {line}".rstrip() + "\n" for line in lines)


_FOAMFILE = (
    "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n"
    "    class       dictionary;\n    object      {obj};\n}}\n\n"
)

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


def _write_text(path: Path, text: str) -> Path:
    def write(tmp):
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    return atomic_write(path, write)


def write_openfoam(
    law,
    out_dir,
    *,
    diameter_um=None,
    speed_m_s=None,
    angle_deg=None,
    patches: Mapping[str, str] | None = None,
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

    Returns
    -------
    list of Path
        The files written.
    """
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

    written.extend(write_stochastic_model(law, out_dir, patches=patches))
    return written


def write_stochastic_model(law, out_dir, *, patches=None) -> list[Path]:
    """Write the stochastic model into ``out_dir/openfoam/``: its coefficients
    (``stochasticWallLawCoeffs``), the C++ sources of the patch interaction model
    ``stochasticWallLaw`` with the C sampler (``stochasticWallLaw/``, for
    ``wmake libso``) and ``build.sh`` (``bash build.sh LIBDIR`` builds
    ``LIBDIR/libstochasticWallLaw.so``). Needs no condition: every node is used.
    `patches` maps surfaces to mesh patch names as in :func:`write_openfoam`.
    Returns the paths written."""
    ds = law.dataset
    surfaces = [str(s) for s in np.asarray(ds["surface"].values).tolist()]
    names = _patch_names(surfaces, patches)
    folder = Path(out_dir) / "openfoam"
    written = [
        _write_text(
            folder / STOCHASTIC_FILE,
            _stochastic_text(surfaces, names, _provenance(ds), _resuspension(ds)),
        )
    ]
    model = folder / MODEL_DIR
    sources = [(MODEL_SOURCES / f, model / f) for f in MODEL_FILES]
    sources += [(C_SOURCES / f, model / f) for f in ("swl.h", "swl.c")]
    for src, dst in sources:
        data = src.read_bytes()
        written.append(atomic_write(dst, lambda tmp, b=data: Path(tmp).write_bytes(b)))
    script = (MODEL_SOURCES / BUILD_SCRIPT).read_bytes()
    path = atomic_write(
        folder / BUILD_SCRIPT, lambda tmp: Path(tmp).write_bytes(script)
    )
    path.chmod(path.stat().st_mode | 0o111)  # executable, as `bash build.sh` needs not
    written.append(path)
    written.extend(write_demo_case(law, folder / DEMO_CASE))
    return written


_STOCHASTIC_KEYS = [
    "Coefficients of the patch interaction model stochasticWallLaw, written",
    "next to this file (stochasticWallLaw/, built by build.sh LIBDIR into",
    "LIBDIR/libstochasticWallLaw.so), which samples the wall law at every wall",
    "strike through c/swl.h (swl_rebound_velocity). In system/controlDict:",
    '  libs ("libstochasticWallLaw.so");',
    "and in constant/<cloud>Properties, subModels:",
    "  patchInteractionModel stochasticWallLaw;",
    '  #include "<this file>"',
    "Keys:",
    "  table         the binary table c/wall_law.swl: copy it to the case's",
    "                constant/wall_law.swl (the model expands $FOAM_CASE and",
    "                other environment variables in the path).",
    '  patches       a list of  <mesh patch name or "regex"> { ... }  entries',
    "                that, as in localInteraction, names every non-coupled,",
    "                non-empty patch of the mesh (first match wins). An entry is",
    "                either a wall-law patch:",
    "    surface     the table's surface name (swl_surface_index);",
    "    captured    what a captured parcel does: stick (kept, inactive, U = 0)",
    "                or escape (removed); default stick;",
    "                or one of localInteraction's own entries, e.g.",
    "                outlet { type escape; }  or  { type rebound; e 1; mu 0; }.",
    "  maxReimpacts  a rebound with U_z < 0 (SWL_FLAG_REIMPACT) strikes the same",
    "                wall again with the rebound velocity, at most this many times;",
    "                after that the parcel is captured. Default 10.",
    "  warnClamped   report parcels whose diameter, speed or angle lay outside the",
    "                table (they use its end nodes, SWL_FLAG_CLAMPED). Default yes.",
    "  strictClamp   yes: a query outside the table stops the run with a fatal",
    "                error naming the parcel and the patch. Default no.",
    "  resuspension  yes: a captured parcel that the table flags resuspended",
    "                (SWL_FLAG_RESUSPENDED, from its stay_probability) is removed",
    "                (counted as escape; the summary says how many). Needs a",
    "                table with stay_probability (else a fatal error); written",
    "                yes where the table has it. Default no.",
    "Per strike the model takes, relative to the patch velocity Up: d = the",
    "parcel's diameter * 1e6 [um], v_in = U - Up, normal = -nw (OpenFOAM's patch",
    "normal points out of the fluid; the table's z points into it), five",
    "uniform numbers from the cloud's rndGen, and sets U = Up + v_out, or applies",
    "'captured' on SWL_CAPTURED. SWL_NO_DATA (no impact tabulated at the node) is",
    "a fatal error naming the patch.",
]


def _steps(values, unit) -> str:
    return ", ".join(f"{float(v):g}" for v in np.atleast_1d(values)) + f" {unit}"


def _resuspension(ds) -> tuple[str, list[str]]:
    """The ``resuspension`` switch for `ds` (``yes`` where it carries
    ``stay_probability``) and the comment said above it."""
    if "stay_probability" not in ds:
        return "no", [
            "resuspension no: the table has no stay_probability (built without a",
            "[resuspension] table), so every captured parcel stays captured.",
        ]
    attrs = ds["stay_probability"].attrs
    if "friction_velocity_m_s" in attrs and "exposure_s" in attrs:
        flow = (
            f"friction velocity {_steps(attrs['friction_velocity_m_s'], 'm/s')} "
            f"for {_steps(attrs['exposure_s'], 's')}"
        )
    else:
        flow = "friction velocity and exposure (see wall_law.nc)"
    return "yes", [
        "resuspension yes: the table carries stay_probability; a captured parcel",
        "that the table says does not stay is removed (as escape) at its capture,",
        "as if the whole exposure had passed. It assumes quasi-steady flow at the",
        f"table's {flow} (steps in order),",
        "independent particles (a monolayer) and the table's adhesion, not the",
        "time your run has left. Set no to keep every capture.",
    ]


def _stochastic_text(surfaces, names, header, resuspension) -> str:
    """The ``stochasticWallLawCoeffs`` dictionary; `resuspension` is
    :func:`_resuspension`'s ``(switch, comment)``."""
    table = CASE_TABLE
    switch, said = resuspension
    entries = []
    for index, s in enumerate(surfaces):
        entries.append(
            f"        {names[s]}\n        {{\n"
            f"            surface     {_quote(s)};  // index {index} in the table\n"
            "            captured    stick;\n        }\n"
        )
    return (
        _FOAMFILE.format(obj=STOCHASTIC_FILE)
        + _comment_block([*header, "", *_STOCHASTIC_KEYS])
        + f"\nstochasticWallLawCoeffs\n{{\n    table           {_quote(table)};\n"
        + "    patches\n    (\n"
        + "".join(entries)
        + "        // the mesh's other patches, e.g. outlet { type escape; }\n"
        + "    );\n"
        + "    maxReimpacts    10;\n"
        + "    warnClamped     yes;\n"
        + "    strictClamp     no;\n"
        + "".join(f"    // {line}\n" for line in said)
        + f"    resuspension    {switch};\n}}\n"
    )


def _quote(text: str) -> str:
    """An OpenFOAM string: double quotes, with ``\\`` and ``"`` escaped."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


#: The demonstration case written by :func:`write_stochastic_model`.
DEMO_CASE = "demoCase"

_DEMO_HEAD = (
    "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n"
    "    class       {cls};\n    object      {obj};\n}}\n"
    "// microimpact: demonstration case of the stochasticWallLaw model\n\n"
)


def _demo_condition(ds) -> dict:
    """The node of the first surface whose capture probability is nearest 0.5,
    among the oblique angles (below 90 deg) where the table has any; the first
    such node in (d, v, angle) order on a tie."""
    p = np.asarray(ds["capture_probability"].isel(surface=0).values, dtype=float)
    angles = np.asarray(ds["angle_deg"].values, dtype=float)
    dist = np.abs(p - 0.5)
    dist[~np.isfinite(dist)] = np.inf
    if np.any(angles < 90.0):
        dist[..., angles >= 90.0] = np.inf
    i, j, k = np.unravel_index(int(np.argmin(dist)), dist.shape)
    speeds = np.asarray(ds["speed_m_s"].values, dtype=float)
    return {
        "diameter_um": float(ds["diameter_um"].values[i]),
        # on a reduced speed axis the speeds are (diameter, ratio): r v_c(d)
        "speed_m_s": float(speeds[i, j] if speeds.ndim == 2 else speeds[j]),
        "angle_deg": float(angles[k]),
    }


def write_demo_case(law, case_dir, *, parcels: int = 1000) -> list[Path]:
    """Write a small OpenFOAM case that runs the stochastic model: a 0.1 m box
    (4 x 4 x 4 cells) whose floor (y = 0) is the wall patch of the table's first
    surface and whose other faces (patch ``outer``) let parcels escape. `parcels`
    parcels start 1 cm above the floor (lower at angles below about 11 deg, so that
    they strike it within the box) and strike it once, at the diameter, speed
    and angle of the node of that surface whose capture probability is nearest
    0.5 (oblique angles only); no drag, no gravity, under
    ``icoUncoupledKinematicParcelFoam``; the run ends 4 steps after the strike.

    The case holds ``constant/stochasticWallLawCoeffs`` (the exported
    coefficients with ``outer { type escape; }`` added) but **not** the table:
    copy ``c/wall_law.swl`` to ``constant/wall_law.swl`` (docs/wall-law.md).
    Returns the paths written."""
    ds = law.dataset
    surfaces = [str(s) for s in np.asarray(ds["surface"].values).tolist()]
    names = _patch_names(surfaces, None)
    wall = names[surfaces[0]]
    cond = _demo_condition(ds)
    theta = math.radians(cond["angle_deg"])
    speed = cond["speed_m_s"]
    u_n, u_t = speed * math.sin(theta), speed * math.cos(theta)
    # the parcels strike the floor inside the box: below ~11 deg they start lower
    # than 1 cm, so that they travel at most 5 cm along it before the strike
    h = min(0.01, 0.05 * math.tan(theta))
    travel = h * u_t / u_n
    dt = h / u_n / 9.5  # every parcel strikes in step 10
    steps = 14
    case = Path(case_dir)
    files: dict[str, tuple[str, str]] = {}
    files["system/blockMeshDict"] = (
        "dictionary",
        "scale 1;\n\nvertices\n(\n    (0 0 0) (0.1 0 0) (0.1 0.1 0) "
        "(0 0.1 0)\n    (0 0 0.1) (0.1 0 0.1) (0.1 0.1 0.1) (0 0.1 0.1)\n);\n\n"
        "blocks ( hex (0 1 2 3 4 5 6 7) (4 4 4) simpleGrading (1 1 1) );\n\n"
        "boundary\n(\n"
        f"    {wall} {{ type wall; faces ( (0 1 5 4) ); }}\n"
        "    outer\n    {\n        type patch;\n        faces ( (3 7 6 2) (0 4 7 3) "
        "(2 6 5 1) (0 3 2 1) (4 5 6 7) );\n    }\n);\n",
    )
    files["system/controlDict"] = (
        "dictionary",
        "application     icoUncoupledKinematicParcelFoam;\n"
        "startFrom       startTime;\nstartTime       0;\nstopAt          endTime;\n"
        f"endTime         {steps * dt!r};\ndeltaT          {dt!r};\n"
        f"writeControl    timeStep;\nwriteInterval   {steps};\npurgeWrite      0;\n"
        "writeFormat     ascii;\nwritePrecision  12;\nwriteCompression off;\n"
        "timeFormat      general;\ntimePrecision   12;\nrunTimeModifiable no;\n\n"
        "// the model, built by ../build.sh LIBDIR: LIBDIR on LD_LIBRARY_PATH, or\n"
        "// the library copied into $FOAM_USER_LIBBIN\n"
        'libs ("libstochasticWallLaw.so");\n',
    )
    files["system/fvSchemes"] = (
        "dictionary",
        "ddtSchemes { default none; }\ngradSchemes { default none; }\n"
        "divSchemes { default none; }\nlaplacianSchemes { default none; }\n"
        "interpolationSchemes { default linear; }\n",
    )
    files["system/fvSolution"] = ("dictionary", "solvers { }\n")
    files["system/decomposeParDict"] = (
        "dictionary",
        "numberOfSubdomains 2;\nmethod          simple;\n"
        "coeffs { n (1 1 2); delta 0.001; }\n",
    )
    files["0/U"] = (
        "volVectorField",
        "dimensions      [0 1 -1 0 0 0 0];\ninternalField   uniform (0 0 0);\n"
        f"boundaryField\n{{\n    {wall} {{ type zeroGradient; }}\n"
        "    outer { type zeroGradient; }\n}\n",
    )
    files["constant/g"] = (
        "uniformDimensionedVectorField",
        "dimensions      [0 1 -2 0 0 0 0];\nvalue           (0 0 0);\n",
    )
    files["constant/transportProperties"] = (
        "dictionary",
        "rhoInf          1.2;\ntransportModel  Newtonian;\nnu              1e-05;\n",
    )
    files["constant/turbulenceProperties"] = (
        "dictionary",
        "simulationType  laminar;\n",
    )
    side = max(1, math.ceil(math.sqrt(parcels)))
    xs = np.linspace(0.005, min(0.08, 0.095 - travel), side)
    zs = np.linspace(0.005, 0.095, side)
    pts = [(float(x), h, float(z)) for z in zs for x in xs][:parcels]
    files["constant/kinematicCloudPositions"] = (
        "vectorField",
        f"{len(pts)}\n(\n"
        + "".join(f"({x:.6g} {y:.6g} {z:.6g})\n" for x, y, z in pts)
        + ")\n",
    )
    d_m = cond["diameter_um"] * 1e-6
    files["constant/kinematicCloudProperties"] = (
        "dictionary",
        "solution\n{\n    active          true;\n    coupled         false;\n"
        "    transient       yes;\n    cellValueSourceCorrection off;\n"
        "    maxCo           0.3;\n"
        "    interpolationSchemes { rho cell; U cellPoint; mu cell; }\n"
        "    integrationSchemes { U Euler; }\n    sourceTerms { schemes { } }\n}\n\n"
        "constantProperties\n{\n    rho0            2500;\n"
        "    youngsModulus   1e8;\n    poissonsRatio   0.35;\n}\n\n"
        "subModels\n{\n    particleForces { }    // no drag, no gravity\n\n"
        "    injectionModels\n    {\n        model1\n        {\n"
        "            type            manualInjection;\n"
        "            massTotal       0;\n            parcelBasisType fixed;\n"
        "            nParticle       1;\n            SOI             0;\n"
        '            positionsFile   "kinematicCloudPositions";\n'
        f"            U0              ({u_t:.12g} {-u_n:.12g} 0);  "
        f"// {speed:g} m/s at {cond['angle_deg']:g} deg\n"
        "            sizeDistribution\n            {\n"
        "                type fixedValue;\n"
        f"                fixedValueDistribution {{ value {d_m:.12g}; }}  "
        f"// {cond['diameter_um']:g} um\n            }}\n        }}\n    }}\n\n"
        "    dispersionModel none;\n"
        "    patchInteractionModel stochasticWallLaw;\n"
        f'    #include "{STOCHASTIC_FILE}"\n\n'
        "    heatTransferModel none;\n    surfaceFilmModel none;\n"
        "    stochasticCollisionModel none;\n    collisionModel none;\n"
        "    radiation off;\n}\n\ncloudFunctions { }\n",
    )
    coeffs = _stochastic_text(
        surfaces, names, _provenance(ds), _resuspension(ds)
    ).replace(
        "        // the mesh's other patches, e.g. outlet { type escape; }\n",
        "        outer { type escape; }\n",
    )
    written = []
    for rel, (cls, body) in files.items():
        text = _DEMO_HEAD.format(cls=cls, obj=Path(rel).name) + body
        written.append(_write_text(case / rel, text))
    written.append(_write_text(case / "constant" / STOCHASTIC_FILE, coeffs))
    return written
