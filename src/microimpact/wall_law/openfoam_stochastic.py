"""The stochastic OpenFOAM model of a wall law, as written to ``openfoam/``.

The C++ patch interaction model ``stochasticWallLaw`` (shipped in
``openfoam_model/``, written to ``openfoam/stochasticWallLaw/`` with ``build.sh``
and a demo case), which samples the C table (``c/wall_law.swl``, through
``c/swl.h``'s ``swl_rebound_velocity``) at every wall strike, and its
coefficients ``stochasticWallLawCoeffs``, whose table path is the case's
``$FOAM_CASE/constant/wall_law.swl``. The keys are described in the file itself
and in docs/wall-law.md.

Also the FoamFile writing that :mod:`.openfoam` (the ``localInteraction``
fallback and :func:`~.openfoam.write_openfoam`, which writes both) shares with
it: patch names, provenance headers, atomic text files. Import the public names
from :mod:`microimpact.wall_law.openfoam` or :mod:`microimpact.wall_law`.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import __version__
from .._core.files import atomic_write
from .._core.validation import did_you_mean
from .export_c import C_SOURCES

__all__ = [
    "BUILD_SCRIPT",
    "CASE_TABLE",
    "C_TABLE",
    "DEMO_CASE",
    "DEMO_FAMILIES",
    "MODEL_DIR",
    "MODEL_FILES",
    "MODEL_SOURCES",
    "STOCHASTIC_FILE",
    "write_demo_case",
    "write_stochastic_model",
]


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


def _comment_block(lines) -> str:
    return "".join(f"// {line}".rstrip() + "\n" for line in lines)


_FOAMFILE = (
    "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n"
    "    class       dictionary;\n    object      {obj};\n}}\n\n"
)


def _write_text(path: Path, text: str) -> Path:
    def write(tmp):
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    return atomic_write(path, write)


def write_stochastic_model(
    law, out_dir, *, patches=None, demo_family: str = "kinematic"
) -> list[Path]:
    """Write the stochastic model into ``out_dir/openfoam/``: its coefficients
    (``stochasticWallLawCoeffs``), the C++ sources of the patch interaction model
    ``stochasticWallLaw`` with the C sampler (``stochasticWallLaw/``, for
    ``wmake libso``), ``build.sh`` (``bash build.sh LIBDIR`` builds
    ``LIBDIR/libstochasticWallLaw.so``) and the demo case ``demoCase/`` of the
    solver family `demo_family` (:func:`write_demo_case`). Needs no condition:
    every node is used. `patches` maps surfaces to mesh patch names as in
    :func:`write_openfoam`. Returns the paths written."""
    _demo_family_iv(demo_family)
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
    written.extend(write_demo_case(law, folder / DEMO_CASE, family=demo_family))
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
#: The demo case's families: ``family -> (solver, cloud)``.
DEMO_FAMILIES = {
    "kinematic": ("icoUncoupledKinematicParcelFoam", "kinematicCloud"),
    "mppic": ("MPPICFoam", "kinematicCloud"),
    "reacting": ("reactingParcelFoam", "reactingCloud1"),
}

_DEMO_HEAD = (
    "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n"
    "    class       {cls};\n    object      {obj};\n}}\n"
    "// microimpact: demonstration case of the stochasticWallLaw model\n\n"
)


def _demo_family_iv(family, name="demo_family") -> None:
    if family not in DEMO_FAMILIES:
        raise ValueError(
            f"`{name}` must be one of {', '.join(map(repr, DEMO_FAMILIES))}; "
            f"got {family!r}"
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


def write_demo_case(
    law, case_dir, *, parcels: int = 1000, family: str = "kinematic"
) -> list[Path]:
    """Write a small OpenFOAM case that runs the stochastic model: a 0.1 m box
    (4 x 4 x 4 cells) whose floor (y = 0) is the wall patch of the table's first
    surface and whose other faces (patch ``outer``) let parcels escape. `parcels`
    parcels start 1 cm above the floor (lower at angles below about 11 deg, so that
    they strike it within the box) and strike it once, at the diameter, speed
    and angle of the node of that surface whose capture probability is nearest
    0.5 (oblique angles only); no drag, no gravity, in a fluid at rest; the run
    ends 4 steps after the strike.

    `family` picks the solver (:data:`DEMO_FAMILIES`): ``"kinematic"``
    (``icoUncoupledKinematicParcelFoam``, cloud ``kinematicCloud``),
    ``"mppic"`` (``MPPICFoam``, ``kinematicCloud``, air as the continuous
    phase ``air``) or ``"reacting"`` (``reactingParcelFoam``,
    ``reactingCloud1``: water droplets in air, no heat or mass transfer, no
    chemistry).

    The case holds ``constant/stochasticWallLawCoeffs`` (the exported
    coefficients with ``outer { type escape; }`` added) but **not** the table:
    copy ``c/wall_law.swl`` to ``constant/wall_law.swl`` (docs/wall-law.md).
    Returns the paths written. Raises ``ValueError`` for another `family`."""
    _demo_family_iv(family, "family")
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
    if family != "kinematic":
        _family_files(files, family, injection=(u_t, u_n, d_m))
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


# ----------------------------------------------------- the MPPIC and reacting demos
# After tests/foam_box.py, whose cases run every Lagrangian solver of Debian's
# OpenFOAM 1912: the carrier at rest, laminar; ballistic parcels (no forces, no
# heat or mass transfer, no breakup).


def _uniform(cls, dims, value, bc) -> tuple[str, str]:
    """A field of value `value` whose every patch has the condition `bc`."""
    return (
        cls,
        f"dimensions      {dims};\ninternalField   uniform {value};\n"
        f'boundaryField\n{{\n    ".*" {{ {bc} }}\n}}\n',
    )


_SCALAR, _VECTOR = "volScalarField", "volVectorField"
_VELOCITY, _PRESSURE = "[0 1 -1 0 0 0 0]", "[1 -1 -2 0 0 0 0]"
_ZERO_GRADIENT = "type zeroGradient;"
_LINEAR_SOLVERS = (
    'solvers\n{\n    "(U|h|e|Yi|T).*" { solver smoothSolver; smoother '
    "symGaussSeidel;\n        tolerance 1e-8; relTol 0; }\n"
    '    "(p|p_rgh|rho|pcorr|alpha).*" { solver PCG; preconditioner DIC;\n'
    "        tolerance 1e-8; relTol 0; }\n}\n"
    "PIMPLE\n{\n    nOuterCorrectors 1; nCorrectors 1; nNonOrthogonalCorrectors 0;\n"
    "    momentumPredictor no; pRefCell 0; pRefValue 0;\n}\n"
    'relaxationFactors { equations { ".*" 1; } }\n'
)


def _fv_schemes(div: str) -> tuple[str, str]:
    return (
        "dictionary",
        "ddtSchemes { default Euler; }\ngradSchemes { default Gauss linear; }\n"
        f"divSchemes\n{{\n    default Gauss linear;\n{div}}}\n"
        "laplacianSchemes { default Gauss linear corrected; }\n"
        "interpolationSchemes { default linear; }\n"
        "snGradSchemes { default corrected; }\n",
    )


def _mppic_fluid(files) -> None:
    """MPPICFoam's continuous phase ``air`` at rest."""
    del files["0/U"], files["constant/turbulenceProperties"]
    files["0/U.air"] = _uniform(_VECTOR, _VELOCITY, "(0 0 0)", _ZERO_GRADIENT)
    files["0/p"] = _uniform(_SCALAR, "[0 2 -2 0 0 0 0]", "0", _ZERO_GRADIENT)
    files["constant/transportProperties"] = (
        "dictionary",
        "continuousPhase air;\nrho.air         1.2;\ntransportModel  Newtonian;\n"
        "nu              1e-05;\n",
    )
    files["constant/turbulenceProperties.air"] = (
        "dictionary",
        "simulationType  laminar;\n",
    )
    files["system/fvSchemes"] = _fv_schemes(
        "    div(alphaPhi.air,U.air) Gauss upwind;\n"
        "    div(((alpha.air*nuEff.air)*dev2(T(grad(U.air))))) Gauss linear;\n"
    )
    files["system/fvSolution"] = ("dictionary", _LINEAR_SOLVERS)


def _reacting_fluid(files) -> None:
    """reactingParcelFoam's gas: air at rest, one inert specie with constant
    properties (and H2O, the droplets' liquid), no chemistry, no combustion."""
    del files["0/U"], files["constant/transportProperties"]
    files["0/U"] = _uniform(
        _VECTOR, _VELOCITY, "(0 0 0)", "type fixedValue; value uniform (0 0 0);"
    )
    files["0/T"] = _uniform(_SCALAR, "[0 0 0 1 0 0 0]", "300", _ZERO_GRADIENT)
    files["0/p"] = _uniform(
        _SCALAR, _PRESSURE, "100000", "type calculated; value uniform 100000;"
    )
    files["0/p_rgh"] = _uniform(
        _SCALAR,
        _PRESSURE,
        "100000",
        "type fixedFluxPressure; value uniform 100000;",
    )
    for specie, value in (("air", 1), ("H2O", 0), ("Ydefault", 0)):
        files[f"0/{specie}"] = _uniform(
            _SCALAR, "[0 0 0 0 0 0 0]", value, _ZERO_GRADIENT
        )
    files["constant/thermophysicalProperties"] = (
        "dictionary",
        "thermoType\n{\n    type heRhoThermo; mixture reactingMixture;\n"
        "    transport const; thermo hConst; energy sensibleEnthalpy;\n"
        "    equationOfState perfectGas; specie specie;\n}\n"
        "chemistryReader foamChemistryReader;\n"
        'foamChemistryFile "<constant>/reactions";\n'
        'foamChemistryThermoFile "<constant>/thermo.air";\n'
        "inertSpecie air;\nliquids { H2O; }\nsolids { }\n",
    )
    files["constant/reactions"] = (
        "dictionary",
        "species ( air H2O );\nreactions { }\n",
    )
    files["constant/thermo.air"] = (
        "dictionary",
        "air { specie { molWeight 28.96; } thermodynamics { Cp 1004.5; Hf 0; }\n"
        "      transport { mu 1.8e-05; Pr 0.7; } }\n"
        "H2O { specie { molWeight 18.0153; }\n"
        "      thermodynamics { Cp 1900; Hf -1.3423e7; }\n"
        "      transport { mu 1e-05; Pr 1; } }\n",
    )
    files["constant/chemistryProperties"] = (
        "dictionary",
        "chemistryType { solver none; method standard; }\nchemistry off;\n"
        "initialChemicalTimeStep 1e-07;\n",
    )
    files["constant/combustionProperties"] = (
        "dictionary",
        "combustionModel none;\n",
    )
    files["constant/radiationProperties"] = (
        "dictionary",
        "radiation off;\nradiationModel none;\n",
    )
    files["constant/surfaceFilmProperties"] = (
        "dictionary",
        "surfaceFilmModel none;\n",
    )
    files["system/fvSchemes"] = _fv_schemes(
        "    div(phi,U) Gauss upwind; div(phi,K) Gauss upwind;\n"
        "    div(phi,h) Gauss upwind; div(phi,Yi_h) Gauss upwind;\n"
        "    div(((rho*nuEff)*dev2(T(grad(U))))) Gauss linear;\n"
    )
    files["system/fvSolution"] = ("dictionary", _LINEAR_SOLVERS)


def _family_files(files, family, *, injection) -> None:
    """Turn the kinematic demo's `files` into `family`'s (:data:`DEMO_FAMILIES`):
    its solver, its carrier at rest and its cloud's properties."""
    solver, cloud = DEMO_FAMILIES[family]
    cls, control = files["system/controlDict"]
    control = control.replace(
        "application     icoUncoupledKinematicParcelFoam;\n",
        f"application     {solver};\n",
    ).replace(
        "runTimeModifiable no;\n",
        "runTimeModifiable no;\nadjustTimeStep  no;\nmaxCo           1;\n"
        "maxDeltaT       1;\n",
    )
    files["system/controlDict"] = (cls, control)
    (_mppic_fluid if family == "mppic" else _reacting_fluid)(files)
    files[f"constant/{cloud}Positions"] = files.pop("constant/kinematicCloudPositions")
    del files["constant/kinematicCloudProperties"]
    u_t, u_n, d_m = injection
    if family == "mppic":
        interpolation = "rho.air cell; U.air cellPoint; mu.air cell; alpha.air cell;"
        integration = "U Euler;"
        constant = "alphaMax        0.9;\n"
        models = "    packingModel none; dampingModel none; isotropyModel none;\n"
    else:
        interpolation = (
            "rho cell; U cellPoint; thermo:mu cell; T cell; Cp cell;\n"
            "        kappa cell; p cell; G cell;"
        )
        integration = "U Euler; T analytical;"
        constant = (
            "T0              300;\n    Cp0             4100;\n"
            "    constantVolume  false;\n    TDevol 400; LDevol 0; hRetentionCoeff 1;\n"
            "    epsilon0 1; f0 0.5; Pr 0.7; TMin 200; TMax 5000;\n"
        )
        models = (
            "    phaseChangeModel none; devolatilisationModel none;\n"
            "    surfaceReactionModel none;\n"
            "    compositionModel singleMixtureFraction;\n"
            "    singleMixtureFractionCoeffs\n    {\n"
            "        phases ( gas { } liquid { H2O 1; } solid { } );\n"
            "        YGasTot0 0; YLiquidTot0 1; YSolidTot0 0;\n    }\n"
        )
    files[f"constant/{cloud}Properties"] = (
        "dictionary",
        "solution\n{\n    active          true;\n    coupled         false;\n"
        "    transient       yes;\n    cellValueSourceCorrection off;\n"
        "    maxCo           0.3;\n    averagingMethod basic;\n"
        "    calcFrequency   1;\n    maxTrackTime    1;\n"
        "    resetSourcesOnStartup false;\n"
        f"    interpolationSchemes {{ {interpolation} }}\n"
        f"    integrationSchemes {{ {integration} }}\n"
        "    sourceTerms { schemes { } resetOnStartup false; }\n}\n\n"
        "constantProperties\n{\n    rho0            2500;\n"
        "    youngsModulus   1e8;\n    poissonsRatio   0.35;\n"
        f"    {constant}}}\n\n"
        "subModels\n{\n    particleForces { }    // no drag, no gravity\n\n"
        "    injectionModels\n    {\n        model1\n        {\n"
        "            type            manualInjection;\n"
        "            massTotal       1e-9;\n            parcelBasisType fixed;\n"
        "            nParticle       1;\n            SOI             0;\n"
        "            massFlowRate    constant 1e-9;\n            duration        1;\n"
        f'            positionsFile   "{cloud}Positions";\n'
        f"            U0              ({u_t:.12g} {-u_n:.12g} 0);\n"
        "            sizeDistribution\n            {\n"
        "                type fixedValue;\n"
        f"                fixedValueDistribution {{ value {d_m:.12g}; }}\n"
        "            }\n        }\n    }\n\n"
        "    dispersionModel none;\n"
        "    patchInteractionModel stochasticWallLaw;\n"
        f'    #include "{STOCHASTIC_FILE}"\n\n'
        "    heatTransferModel none;\n    surfaceFilmModel none;\n"
        "    stochasticCollisionModel none;\n    collisionModel none;\n"
        f"    radiation off;\n{models}}}\n\ncloudFunctions {{ }}\n",
    )
