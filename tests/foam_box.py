"""OpenFOAM cases and the model's library for the real-solver wall-law tests.

* :func:`box_case`: a 0.1 m box of 4 x 4 x 4 cells whose floor (y = 0) is the
  wall struck, a ballistic kinematic cloud in a still, laminar fluid (no drag,
  no gravity); each test adds its own parcels and cloud properties with the
  `put` this returns.
* :data:`SOLVERS`, :func:`solver_case`, :func:`cloud_properties`: the same box
  for every Lagrangian solver of Debian's OpenFOAM 1912 (the fluid each needs,
  at rest; ballistic parcels without heat or mass transfer).
* :func:`film_region`: a water film on the floor.
* :func:`build_library`: ``libstochasticWallLaw.so`` built once per machine and
  source by the exported ``build.sh`` (a cache keyed by a hash of the sources).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

HEAD = "FoamFile {{ version 2.0; format ascii; class {cls}; object {obj}; }}\n"

#: The box's faces: the floor and the five others.
FACES = {
    "floor": "(0 1 5 4)",
    "outer": "(3 7 6 2) (0 4 7 3) (2 6 5 1) (0 3 2 1) (4 5 6 7)",
}


def box_case(
    case: Path,
    *,
    boundary: dict,
    solver: str,
    dt: float,
    steps: int,
    control_extra: str = "",
):
    """Write the box's mesh, controls, schemes and fields into `case`.

    `boundary` maps patch name -> (type, faces); `steps` time steps of `dt` are
    run and the last written; `control_extra` is appended to controlDict (e.g.
    a ``libs (...)`` line). Returns ``put(rel, cls, body)``, which writes one more
    dictionary with its FoamFile header."""
    for sub in ("0", "constant", "system"):
        (case / sub).mkdir(parents=True, exist_ok=True)

    def put(rel, cls, body):
        (case / rel).parent.mkdir(parents=True, exist_ok=True)
        (case / rel).write_text(HEAD.format(cls=cls, obj=Path(rel).name) + body)

    blocks = "\n".join(
        f"    {name} {{ type {kind}; faces ( {faces} ); }}"
        for name, (kind, faces) in boundary.items()
    )
    put(
        "system/blockMeshDict",
        "dictionary",
        "convertToMeters 1;\nvertices ( (0 0 0) (0.1 0 0) (0.1 0.1 0) (0 0.1 0) "
        "(0 0 0.1) (0.1 0 0.1) (0.1 0.1 0.1) (0 0.1 0.1) );\n"
        "blocks ( hex (0 1 2 3 4 5 6 7) (4 4 4) simpleGrading (1 1 1) );\n"
        f"boundary\n(\n{blocks}\n);\n",
    )
    put(
        "system/controlDict",
        "dictionary",
        f"application {solver};\nstartFrom startTime; startTime 0; stopAt endTime;\n"
        f"endTime {steps * dt!r}; deltaT {dt!r};\nwriteControl timeStep; "
        f"writeInterval {steps}; purgeWrite 0; writeFormat ascii; writePrecision 17;\n"
        "writeCompression off; timeFormat general; timePrecision 12;\n"
        "runTimeModifiable no;\n" + control_extra,
    )
    put(
        "system/fvSchemes",
        "dictionary",
        "ddtSchemes { default none; } gradSchemes { default none; }\n"
        "divSchemes { default none; } laplacianSchemes { default none; }\n"
        "interpolationSchemes { default linear; }\n",
    )
    put("system/fvSolution", "dictionary", "solvers { }\n")
    bcs = " ".join(f"{name} {{ type zeroGradient; }}" for name in boundary)
    put(
        "0/U",
        "volVectorField",
        "dimensions [0 1 -1 0 0 0 0];\ninternalField uniform (0 0 0);\n"
        f"boundaryField {{ {bcs} }}\n",
    )
    put(
        "constant/g",
        "uniformDimensionedVectorField",
        "dimensions [0 1 -2 0 0 0 0];\nvalue (0 0 0);\n",
    )
    put(
        "constant/transportProperties",
        "dictionary",
        "rhoInf 1.2; transportModel Newtonian; nu 1e-05;\n",
    )
    put("constant/turbulenceProperties", "dictionary", "simulationType laminar;\n")
    return put


def foam_env(libdir=None):
    """The environment OpenFOAM's binaries run in, with `libdir` on
    LD_LIBRARY_PATH."""
    env = dict(os.environ)
    if "FOAM_ETC" not in env:  # Debian's binaries find their etc/ through this
        for etc in ("/usr/share/openfoam/etc", "/usr/lib/openfoam/openfoam1912/etc"):
            if Path(etc, "controlDict").is_file():
                env["FOAM_ETC"] = etc
                env.setdefault("WM_PROJECT_DIR", str(Path(etc).parent))
                break
    if libdir is not None:
        env["LD_LIBRARY_PATH"] = os.pathsep.join(
            p for p in (str(libdir), env.get("LD_LIBRARY_PATH", "")) if p
        )
    # Open MPI refuses root without these (CI runs as root in a container)
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    env.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    return env


# --- every Lagrangian solver of Debian's OpenFOAM 1912 ----------------------------

#: solver -> (family, cloud names, cloud type the model is registered for). The
#: cloud types were read from the solvers' own symbols (nm -DC): coalCloud is
#: basicReactingMultiphaseCloud's C++ type; coalChemistryFoam's limestone cloud
#: is a basicThermoCloud.
SOLVERS = {
    "icoUncoupledKinematicParcelFoam": (
        "kinematic",
        ("kinematicCloud",),
        "basicKinematicCollidingCloud",
    ),
    "icoUncoupledKinematicParcelDyMFoam": (
        "kinematic",
        ("kinematicCloud",),
        "basicKinematicCollidingCloud",
    ),
    "uncoupledKinematicParcelFoam": (
        "kinematicRho",
        ("kinematicCloud",),
        "basicKinematicCloud",
    ),
    "uncoupledKinematicParcelDyMFoam": (
        "kinematicRho",
        ("kinematicCloud",),
        "basicKinematicCloud",
    ),
    "DPMFoam": ("dpm", ("kinematicCloud",), "basicKinematicCollidingCloud"),
    "DPMDyMFoam": ("dpm", ("kinematicCloud",), "basicKinematicCollidingCloud"),
    "MPPICFoam": ("mppic", ("kinematicCloud",), "basicKinematicMPPICCloud"),
    "MPPICDyMFoam": ("mppic", ("kinematicCloud",), "basicKinematicMPPICCloud"),
    "MPPICInterFoam": ("mppicInter", ("kinematicCloud",), "basicKinematicMPPICCloud"),
    "reactingParcelFoam": (
        "reacting",
        ("reactingCloud1",),
        "basicReactingMultiphaseCloud",
    ),
    "simpleReactingParcelFoam": (
        "reacting",
        ("reactingCloud1",),
        "basicReactingMultiphaseCloud",
    ),
    "reactingHeterogenousParcelFoam": (
        "heterogeneous",
        ("reactingCloud1",),
        "basicHeterogeneousReactingCloud",
    ),
    "coalChemistryFoam": (
        "coal",
        ("coalCloud1", "limestoneCloud1"),
        "coalCloud, basicThermoCloud",
    ),
    "simpleCoalParcelFoam": (
        "coal",
        ("reactingCloud1",),
        "coalCloud",
    ),
    "sprayFoam": ("spray", ("sprayCloud",), "basicSprayCloud"),
    "sprayDyMFoam": ("spray", ("sprayCloud",), "basicSprayCloud"),
    "simpleSprayFoam": ("spray", ("sprayCloud1",), "basicSprayCloud"),
}


def _field(put, name, cls, dims, value, bc):
    """A field whose every patch has the boundary condition `bc` (a dictionary's
    inside, e.g. ``type zeroGradient;``)."""
    put(
        f"0/{name}",
        cls,
        f"dimensions {dims};\ninternalField uniform {value};\n"
        f'boundaryField {{ ".*" {{ {bc} }} }}\n',
    )


_SOLVERS_LIN = (
    '    "(U|k|epsilon|omega|h|e|Yi|T).*" { solver smoothSolver; '
    "smoother symGaussSeidel; tolerance 1e-8; relTol 0; }\n"
    '    "(p|p_rgh|rho|pcorr|alpha.*).*" { solver PCG; preconditioner DIC; '
    "tolerance 1e-8; relTol 0; }\n"
)
_PIMPLE = (
    "{ nOuterCorrectors 1; nCorrectors 1; nNonOrthogonalCorrectors 0;\n"
    "  momentumPredictor no; pRefCell 0; pRefValue 0; pRefPoint (0.05 0.05 0.05);\n"
    "  pRefValue 0; nAlphaCorr 1; nAlphaSubCycles 1; cAlpha 1; MULESCorr no;\n"
    "  nAlphaSubCycles 1; residualControl { } }\n"
)


def _kinematic_fluid(put, family):
    """The fluid of the kinematic, DPM and MPPIC families: still, laminar."""
    if family == "kinematic":
        return  # box_case's U, transportProperties and laminar turbulence
    if family == "kinematicRho":  # a compressible carrier: one gas, at rest
        _field(
            put, "T", "volScalarField", "[0 0 0 1 0 0 0]", "300", "type zeroGradient;"
        )
        _field(
            put,
            "p",
            "volScalarField",
            "[1 -1 -2 0 0 0 0]",
            "100000",
            "type zeroGradient;",
        )
        put(
            "constant/thermophysicalProperties",
            "dictionary",
            "thermoType\n{\n    type hePsiThermo; mixture pureMixture;\n"
            "    transport const; thermo hConst; energy sensibleEnthalpy;\n"
            "    equationOfState perfectGas; specie specie;\n}\n"
            "mixture { specie { molWeight 28.96; }\n"
            "    thermodynamics { Cp 1004.5; Hf 0; }\n"
            "    transport { mu 1.8e-05; Pr 0.7; } }\n",
        )
        return
    if family in ("dpm", "mppic"):
        _field(
            put,
            "U.air",
            "volVectorField",
            "[0 1 -1 0 0 0 0]",
            "(0 0 0)",
            "type zeroGradient;",
        )
        _field(
            put, "p", "volScalarField", "[0 2 -2 0 0 0 0]", "0", "type zeroGradient;"
        )
        put(
            "constant/transportProperties",
            "dictionary",
            "continuousPhase air;\nrho.air 1.2;\ntransportModel Newtonian;\n"
            "nu 1e-05;\n",
        )
        put(
            "constant/turbulenceProperties.air",
            "dictionary",
            "simulationType laminar;\n",
        )
        div = (
            "div(alphaPhi.air,U.air) Gauss upwind;\n"
            "div(((alpha.air*nuEff.air)*dev2(T(grad(U.air))))) Gauss linear;\n"
        )
    else:  # MPPICInterFoam: water below, air above, at rest
        _field(
            put,
            "U",
            "volVectorField",
            "[0 1 -1 0 0 0 0]",
            "(0 0 0)",
            "type zeroGradient;",
        )
        _field(
            put,
            "p_rgh",
            "volScalarField",
            "[1 -1 -2 0 0 0 0]",
            "0",
            "type zeroGradient;",
        )
        _field(
            put,
            "alpha.water",
            "volScalarField",
            "[0 0 0 0 0 0 0]",
            "0",
            "type zeroGradient;",
        )
        put(
            "constant/transportProperties",
            "dictionary",
            "phases (water air);\n"
            "water { transportModel Newtonian; nu 1e-06; rho 1000; }\n"
            "air { transportModel Newtonian; nu 1.48e-05; rho 1; }\nsigma 0.07;\n",
        )
        div = (
            "div(rhoPhi,U) Gauss upwind;\ndiv(phi,alpha) Gauss upwind;\n"
            "div(phirb,alpha) Gauss linear;\n"
            "div(((alphac*rhoc)*nuEff)*dev2(T(grad(U)))) Gauss linear;\n"
            "div((((alphac*rhoc)*nuEff)*dev2(T(grad(U))))) Gauss linear;\n"
            "div(phi,k) Gauss upwind; div(phi,epsilon) Gauss upwind;\n"
            "div(alphacRhoPhic,U) Gauss upwind;\n"
            "div(((alphac*rhoc)*nuEff)) Gauss linear;\n"
        )
    put(
        "system/fvSchemes",
        "dictionary",
        "ddtSchemes { default Euler; }\ngradSchemes { default Gauss linear; }\n"
        f"divSchemes {{ default Gauss linear;\n{div}}}\n"
        "laplacianSchemes { default Gauss linear corrected; }\n"
        "interpolationSchemes { default linear; }\n"
        "snGradSchemes { default corrected; }\n",
    )
    alpha = (
        '    "alpha.water.*" { nAlphaCorr 1; nAlphaSubCycles 1; cAlpha 1;\n'
        "        MULESCorr no; nLimiterIter 3; solver smoothSolver;\n"
        "        smoother symGaussSeidel; tolerance 1e-8; relTol 0; }\n"
    )
    put(
        "system/fvSolution",
        "dictionary",
        f"solvers\n{{\n{_SOLVERS_LIN}{alpha}}}\nPIMPLE {_PIMPLE}\n"
        'relaxationFactors { equations { ".*" 1; } }\n',
    )


def _reacting_fluid(put, family, solver):
    """The gas of the thermo families (reacting, heterogeneous, coal, spray):
    air at rest, one inert specie with constant properties, no chemistry, no
    combustion, no radiation, laminar; H2O the parcels' liquid."""
    steady = solver.startswith("simple")
    psi = solver in ("sprayFoam", "sprayDyMFoam", "coalChemistryFoam")
    thermo = "hePsiThermo" if psi else "heRhoThermo"
    liquids = "" if family == "heterogeneous" else "H2O;"  # pure solid parcels
    _field(
        put,
        "U",
        "volVectorField",
        "[0 1 -1 0 0 0 0]",
        "(0 0 0)",
        "type fixedValue; value uniform (0 0 0);",
    )
    _field(put, "T", "volScalarField", "[0 0 0 1 0 0 0]", "300", "type zeroGradient;")
    p_bc = (
        "type zeroGradient;"
        if psi or steady
        else "type calculated; value uniform 100000;"
    )
    _field(put, "p", "volScalarField", "[1 -1 -2 0 0 0 0]", "100000", p_bc)
    _field(
        put,
        "p_rgh",
        "volScalarField",
        "[1 -1 -2 0 0 0 0]",
        "100000",
        "type fixedFluxPressure; value uniform 100000;",
    )
    for y, value in (("air", 1), ("H2O", 0), ("Ydefault", 0)):
        _field(put, y, "volScalarField", "[0 0 0 0 0 0 0]", value, "type zeroGradient;")
    _field(put, "G", "volScalarField", "[1 0 -3 0 0 0 0]", "0", "type zeroGradient;")
    put(
        "constant/thermophysicalProperties",
        "dictionary",
        f"thermoType\n{{\n    type {thermo}; mixture reactingMixture;\n"
        "    transport const; thermo hConst; energy sensibleEnthalpy;\n"
        "    equationOfState perfectGas; specie specie;\n}\n"
        "chemistryReader foamChemistryReader;\n"
        'foamChemistryFile "<constant>/reactions";\n'
        'foamChemistryThermoFile "<constant>/thermo.air";\n'
        f"inertSpecie air;\nliquids {{ {liquids} }}\nsolids {{ C; }}\n",
    )
    put("constant/reactions", "dictionary", "species ( air H2O );\nreactions { }\n")
    put(
        "constant/thermo.air",
        "dictionary",
        "air { specie { molWeight 28.96; } thermodynamics { Cp 1004.5; Hf 0; }\n"
        "      transport { mu 1.8e-05; Pr 0.7; } }\n"
        "H2O { specie { molWeight 18.0153; } thermodynamics { Cp 1900; "
        "Hf -1.3423e7; }\n      transport { mu 1e-05; Pr 1; } }\n",
    )
    put(
        "constant/chemistryProperties",
        "dictionary",
        "chemistryType { solver none; method standard; }\nchemistry off;\n"
        "initialChemicalTimeStep 1e-07;\n",
    )
    put("constant/combustionProperties", "dictionary", "combustionModel none;\n")
    put(
        "constant/radiationProperties",
        "dictionary",
        "radiation off;\nradiationModel none;\n",
    )
    put("constant/surfaceFilmProperties", "dictionary", "surfaceFilmModel none;\n")
    div = (
        "div(phi,U) Gauss upwind; div(phi,K) Gauss upwind; div(phi,h) Gauss upwind;\n"
        "div(phi,Yi_h) Gauss upwind; div(phid,p) Gauss upwind;\n"
        "div(phi,k) Gauss upwind; div(phi,epsilon) Gauss upwind;\n"
        "div(((rho*nuEff)*dev2(T(grad(U))))) Gauss linear;\n"
    )
    ddt = "steadyState" if steady else "Euler"
    put(
        "system/fvSchemes",
        "dictionary",
        f"ddtSchemes {{ default {ddt}; }}\ngradSchemes {{ default Gauss linear; }}\n"
        f"divSchemes {{ default Gauss linear;\n{div}}}\n"
        "laplacianSchemes { default Gauss linear corrected; }\n"
        "interpolationSchemes { default linear; }\n"
        "snGradSchemes { default corrected; }\n",
    )
    put(
        "system/fvSolution",
        "dictionary",
        f"solvers\n{{\n{_SOLVERS_LIN}}}\nPIMPLE {_PIMPLE}\nSIMPLE {_PIMPLE}\n"
        'relaxationFactors { equations { ".*" 0.7; } fields { ".*" 0.3; } }\n',
    )


#: Interpolation of the carrier's fields per family.
_INTERPOLATION = {
    "kinematic": "rho cell; U cellPoint; mu cell;",
    "kinematicRho": "rho cell; U cellPoint; thermo:mu cell;",
    "dpm": "rho.air cell; U.air cellPoint; mu.air cell; alpha.air cell;",
    "mppic": "rho.air cell; U.air cellPoint; mu.air cell; alpha.air cell;",
    "mppicInter": "rho cell; U cellPoint; mu cell; alpha.water cell;",
    "thermo": "rho cell; U cellPoint; thermo:mu cell; T cell; Cp cell; "
    "kappa cell; p cell; G cell;",
}


def cloud_properties(family, cloud, *, injection, patch_model):
    """The body of constant/<cloud>Properties for `family`: ballistic parcels (no
    forces, no dispersion; no heat or mass transfer, no breakup), the given
    `injection` models' body and the patch interaction model text `patch_model`
    (e.g. ``patchInteractionModel stochasticWallLaw; #include "..."``)."""
    thermo = family in ("reacting", "heterogeneous", "coal", "spray")
    interp = _INTERPOLATION["thermo" if thermo else family]
    const = "rho0 2500; youngsModulus 1e8; poissonsRatio 0.35; alphaMax 0.9;"
    sub = "heatTransferModel none; surfaceFilmModel none; radiation off;\n"
    sub += "stochasticCollisionModel none; collisionModel none;\n"
    if family in ("mppic", "mppicInter"):
        sub += "packingModel none; dampingModel none; isotropyModel none;\n"
    if thermo:
        const += " T0 300; Cp0 4100; constantVolume false; epsilon0 1; f0 0.5;"
        const += " TDevol 400; LDevol 0; hRetentionCoeff 1; Pr 0.7;"
        const += " deltaWallCoeff 1; TMin 200; TMax 5000;"
    if thermo and cloud != "limestoneCloud1":
        sub += "phaseChangeModel none; devolatilisationModel none;\n"
        sub += "surfaceReactionModel none; atomizationModel none;\n"
        sub += "breakupModel none; heterogeneousReactingModel none;\n"
        if family == "heterogeneous":  # pure solid particles only
            sub += (
                "compositionModel singleMixtureFraction;\n"
                "singleMixtureFractionCoeffs { phases ( gas { } liquid { }"
                " solid { C 1; } ); YGasTot0 0; YLiquidTot0 0; YSolidTot0 1; }\n"
            )
        elif family in ("reacting", "coal"):
            sub += (
                "compositionModel singleMixtureFraction;\n"
                "singleMixtureFractionCoeffs { phases ( gas { } liquid { H2O 1; }"
                " solid { } ); YGasTot0 0; YLiquidTot0 1; YSolidTot0 0; }\n"
            )
        else:
            sub += (
                "compositionModel singlePhaseMixture;\n"
                "singlePhaseMixtureCoeffs { phases ( liquid { H2O 1; } ); }\n"
            )
    schemes = "U Euler; T analytical;" if thermo else "U Euler;"
    return (
        "solution\n{\n    active true; coupled false; transient yes;\n"
        "    cellValueSourceCorrection off; maxCo 0.3; averagingMethod basic;\n"
        "    calcFrequency 1; maxTrackTime 1; resetSourcesOnStartup false;\n"
        f"    interpolationSchemes {{ {interp} }}\n"
        f"    integrationSchemes {{ {schemes} }}\n"
        "    sourceTerms { schemes { } resetOnStartup false; }\n}\n"
        f"constantProperties {{ {const} }}\n"
        "subModels\n{\n    particleForces { }\n"
        f"    injectionModels\n    {{\n{injection}    }}\n"
        "    dispersionModel none;\n"
        f"    {patch_model}\n"
        f"{sub}}}\ncloudFunctions {{ }}\n"
    )


def solver_case(case: Path, solver: str, *, dt: float, steps: int, control_extra=""):
    """The box of :func:`box_case` with what `solver` needs (its fluid at rest,
    its schemes and solution controls); patches ``formica`` (the floor, a wall)
    and ``outer``. Returns ``put`` and the solver's family; the caller writes the
    clouds' properties with :func:`cloud_properties`."""
    family = SOLVERS[solver][0]
    boundary = {"formica": ("wall", FACES["floor"]), "outer": ("patch", FACES["outer"])}
    put = box_case(
        case,
        boundary=boundary,
        solver=solver,
        dt=dt,
        steps=steps,
        control_extra="adjustTimeStep no; maxCo 1; maxAlphaCo 1; maxDeltaT 1;\n"
        + control_extra,
    )
    if "DyM" in solver:
        put("constant/dynamicMeshDict", "dictionary", "dynamicFvMesh staticFvMesh;\n")
    if family in ("kinematic", "kinematicRho", "dpm", "mppic", "mppicInter"):
        _kinematic_fluid(put, family)
    else:
        _reacting_fluid(put, family, solver)
    return put, family


# --- one build of the model per machine and source --------------------------------


def library_cache() -> Path:
    """Where built models are kept between test sessions:
    $MICROIMPACT_TEST_CACHE, else ${XDG_CACHE_HOME:-~/.cache}/microimpact/test-libs."""
    given = os.environ.get("MICROIMPACT_TEST_CACHE")
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "microimpact" / "test-libs"


def model_key(openfoam_dir: Path, solver: str) -> str:
    """A hash of what the library is built from: every file of the exported
    ``openfoam/stochasticWallLaw/`` and ``build.sh``, and the installed OpenFOAM
    (its solver's and libraries' path, size and time), so that a change to any
    source, or another OpenFOAM, builds anew."""
    h = hashlib.sha256()
    model = openfoam_dir / "stochasticWallLaw"
    for path in sorted([*model.rglob("*"), openfoam_dir / "build.sh"]):
        if path.is_file():
            h.update(path.relative_to(openfoam_dir).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
    exe = shutil.which(solver)
    if exe is not None:
        for f in (Path(exe).resolve(), *Path("/usr/lib").glob("libOpenFOAM.so*")):
            st = f.stat()
            h.update(f"{f}:{st.st_size}:{st.st_mtime_ns}\0".encode())
    return h.hexdigest()[:20]


def build_library(openfoam_dir: Path, solver: str, *, timeout=1800):
    """``libstochasticWallLaw.so`` built by ``openfoam_dir/build.sh``, once per
    :func:`model_key`: the first caller builds into the cache (others wait on a
    lock, e.g. pytest-xdist's workers), later ones reuse it. Returns ``(returncode,
    libdir, log)``; the log is the build's stdout and stderr (the cached build's
    where reused). A failed build is not cached. $MICROIMPACT_TEST_LIBRARY, a
    folder holding a library built by other means (a hand-mutated model for
    mutation testing), replaces the build."""
    given = os.environ.get("MICROIMPACT_TEST_LIBRARY")
    if given:  # a library built elsewhere, e.g. a hand-mutated model
        return 0, Path(given), f"build.sh: MICROIMPACT_TEST_LIBRARY={given}\n"
    cache = library_cache()
    cache.mkdir(parents=True, exist_ok=True)
    key = model_key(openfoam_dir, solver)
    libdir = cache / key
    with open(cache / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if (libdir / "libstochasticWallLaw.so").is_file():
            return 0, libdir, (libdir / "build.log").read_text()
        tmp = Path(tempfile.mkdtemp(prefix=f"{key}.", dir=cache))
        proc = subprocess.run(
            ["bash", str(openfoam_dir / "build.sh"), str(tmp)],
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        log = proc.stdout + proc.stderr
        if proc.returncode != 0:
            shutil.rmtree(tmp, ignore_errors=True)
            return proc.returncode, None, log
        (tmp / "build.log").write_text(log)
        tmp.rename(libdir)
        return 0, libdir, log


def build_error(log: str) -> str:
    """The last error line of a build.sh log (its reason to stop)."""
    errors = [line for line in log.splitlines() if "build.sh: error" in line]
    return errors[-1] if errors else (log.strip().splitlines() or [""])[-1]


# --- a surface film on the floor ------------------------------------------------------

#: The applications that make the film region: a face zone of the floor, extruded
#: into the region wallFilmRegion (the floor becomes the mapped wall patch
#: FILM_PATCH of the fluid's mesh).
FILM_APPS = (["topoSet"], ["extrudeToRegionMesh", "-overwrite"])
FILM_PATCH = "region0_to_wallFilmRegion_wallFilmFaces"


def film_region(put, floor="formica"):
    """The dictionaries and fields of a thermoSingleLayer film of water on the
    patch `floor`, after reactingParcelFoam/splashPanel of OpenFOAM v1912's
    tutorials; run :data:`FILM_APPS` after blockMesh."""
    put(
        "system/topoSetDict",
        "dictionary",
        "actions (\n { name filmFaces; type faceSet; action new; source patchToFace;"
        f" patch {floor}; }}\n {{ name wallFilmFaces; type faceZoneSet; action new;"
        " source setToFaceZone; faceSet filmFaces; } );\n",
    )
    put(
        "system/extrudeToRegionMeshDict",
        "dictionary",
        "region wallFilmRegion;\nfaceZones (wallFilmFaces);\noneD false;\n"
        "sampleMode nearestPatchFace;\nextrudeModel linearNormal;\nnLayers 1;\n"
        "expansionRatio 1;\nadaptMesh yes;\nlinearNormalCoeffs { thickness 0.001; }\n",
    )
    put(
        "constant/surfaceFilmProperties",
        "dictionary",
        "surfaceFilmModel thermoSingleLayer;\nregion wallFilmRegion;\nactive true;\n"
        "thermoSingleLayerCoeffs\n{\n"
        "    filmThermoModel liquid; liquidCoeffs { useReferenceValues no; "
        "liquid H2O; }\n    filmViscosityModel liquid;\n"
        "    deltaWet 2e-4; hydrophilic no; turbulence laminar;\n"
        "    laminarCoeffs { Cf 0.005; }\n    forces ( ); injectionModels ( );\n"
        "    phaseChangeModel none; radiationModel none;\n"
        "    upperSurfaceModels { heatTransferModel constant; "
        "constantCoeffs { c0 1e-8; } }\n"
        "    lowerSurfaceModels { heatTransferModel constant; "
        "constantCoeffs { c0 1e-8; } }\n}\n",
    )
    for name, cls, dims, value in (
        ("Tf", "volScalarField", "[0 0 0 1 0 0 0]", "300"),
        ("Uf", "volVectorField", "[0 1 -1 0 0 0 0]", "(0 0 0)"),
        ("deltaf", "volScalarField", "[0 1 0 0 0 0 0]", "0"),
    ):
        _field(put, f"wallFilmRegion/{name}", cls, dims, value, "type zeroGradient;")
    put(
        "system/wallFilmRegion/fvSchemes",
        "dictionary",
        "ddtSchemes { default Euler; }\ndivSchemes { default Gauss upwind; }\n"
        "gradSchemes { default Gauss linear; }\n"
        "laplacianSchemes { default Gauss linear uncorrected; }\n"
        "snGradSchemes { default uncorrected; }\n"
        "interpolationSchemes { default linear; }\n",
    )
    put(
        "system/wallFilmRegion/fvSolution",
        "dictionary",
        'solvers { ".*" { solver PBiCGStab; preconditioner DILU; tolerance 1e-10;'
        " relTol 0; } }\nPISO { momentumPredictor yes; nCorr 1; nNonOrthCorr 0; }\n"
        'relaxationFactors { fields { ".*" 1; } equations { ".*" 1; } }\n',
    )
