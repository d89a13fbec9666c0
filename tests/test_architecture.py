"""The layering of docs/architecture.md, checked from the code: every import
counted (those inside functions too), no import circle between files, nothing
imports a higher layer, imports at the top of the file except the deferrals that
say why, and the core layers load no plotting."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "microimpact"

#: The layers, lowest first: a module may import its own layer and those below.
LAYERS = (
    ("errors", "units", "_core"),
    ("physics",),
    ("population", "surface", "io"),
    ("scenario",),
    ("engine",),
    ("wall_law", "plotting"),
    ("analysis",),
    ("pipeline",),
    ("cli", "__main__"),
)
RANK = {name: rank for rank, names in enumerate(LAYERS) for name in names}

#: Third-party modules that may be imported inside a function (with a comment
#: saying why): heavy ones kept off the import of the core, and optional extras.
DEFERRABLE = {
    "matplotlib",
    "pandas",
    "xarray",
    "netCDF4",
    "scipy",
    "tqdm",
    "dask",
    "distributed",
    "x3pio",
    "SurfaceTopography",
    "statsmodels",
    "emcee",
    "arviz",
}


def _modules():
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC)
        if "presets" in rel.parts or "data" in rel.parts:
            continue  # scripts that regenerate shipped data
        yield path


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path):
    """``(node, absolute module names, inside a function)`` of every import."""
    tree = ast.parse(path.read_text())
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    inside = {
        id(n)
        for f in ast.walk(tree)
        if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
        for n in ast.walk(f)
    }
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            mods = {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            mods = {mod}
            for a in node.names:  # "from . import x" may name a submodule
                if (SRC.parent / (mod.replace(".", "/") + f"/{a.name}.py")).exists():
                    mods.add(f"{mod}.{a.name}")
        else:
            continue
        yield node, mods, id(node) in inside


def _graph():
    graph = {}
    for path in _modules():
        name = _module_name(path)
        deps = set()
        for _, mods, _lazy in _imports(path):
            deps |= {m for m in mods if m.startswith("microimpact")}
        deps.discard(name)
        graph[name] = deps
    return graph


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def test_no_import_circle_between_files():
    """Every import counted, inside functions too. A package's ``__init__``
    re-exporting its own modules is not a circle, nor is the top-level package's
    lazy table of public names (it imports nothing at import time)."""
    graph = _graph()
    edges = {
        m: {
            d
            for d in deps
            if d in graph and d != "microimpact" and not m.startswith(d + ".")
        }
        for m, deps in graph.items()
    }
    state, stack, circles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(edges[m]):
            if state.get(d) == 1:
                circles.append([*stack[stack.index(d) :], d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m)
    assert not circles


def test_nothing_imports_a_higher_layer():
    graph = _graph()
    assert set(RANK) >= {_layer(m) for m in graph if _layer(m) is not None}
    upward = sorted(
        (m, d)
        for m, deps in graph.items()
        for d in deps
        if _layer(m) is not None
        and _layer(d) is not None
        and d in graph
        and RANK[_layer(d)] > RANK[_layer(m)]
    )
    assert not upward


def test_imports_are_at_the_top_but_deferrals_that_say_why():
    """Inside a function only a heavy or optional third-party module may be
    imported, or (in ``cli/``, so that ``microimpact --help`` stays fast) the
    library a verb calls; each such import has a ``# deferred:`` comment on the
    line above or its own line."""
    bad = []
    for path in _modules():
        lines = path.read_text().split("\n")
        in_cli = path.relative_to(SRC).parts[0] == "cli"
        for node, mods, lazy in _imports(path):
            if not lazy:
                continue
            ours = any(m.startswith("microimpact") for m in mods)
            heavy = all(m.split(".")[0] in DEFERRABLE for m in mods)
            said = any(
                "deferred:" in lines[i]
                for i in range(max(0, node.lineno - 3), node.lineno)
            )
            if not ((heavy or (ours and in_cli)) and said):
                rel = path.relative_to(SRC.parent)
                bad.append(f"{rel}:{node.lineno}: {ast.unparse(node)}")
    assert not bad, "\n".join(bad)


def test_at_most_four_files_at_the_top():
    files = {p.name for p in SRC.glob("*.py")} - {"__init__.py", "__main__.py"}
    assert len(files) <= 4, sorted(files)


def test_core_layers_load_no_plotting():
    code = (
        "import sys, microimpact, microimpact.scenario, "
        "microimpact.physics.impact, "
        "microimpact.population.distributions, microimpact.surface.angles, "
        "microimpact.engine.montecarlo, microimpact.pipeline.study; "
        "microimpact.Scenario.from_preset('sst76-formica-oblique'); "
        "print(sorted({m.split('.')[0] for m in sys.modules} & "
        "{'matplotlib', 'xarray', 'pandas'}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert "matplotlib" not in out.stdout, out.stdout
