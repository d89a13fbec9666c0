"""The OpenFOAM case both real-solver wall-law test files run: a 0.1 m box of
4 x 4 x 4 cells whose floor (y = 0) is the wall struck, a ballistic kinematic cloud
in a still, laminar fluid (no drag, no gravity). Each test adds its own parcels
and cloud properties with the `put` this returns."""

from __future__ import annotations

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
