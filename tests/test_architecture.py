"""The layering of docs/architecture.md: no import cycles between modules, and the
physics, population, surface and config layers load no plotting."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "microimpact"


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


#: Lazy imports allowed to point back up the layers: the documented facades
#: ``Scenario.from_toml``/``from_preset`` and ``as_scenario`` (scenario -> config).
FACADES = {("microimpact.scenario.scenario", "microimpact.scenario.file")}


def _top_level_imports(path: Path, *, lazy=False) -> set[str]:
    """microimpact modules imported at module level (with `lazy`: anywhere)."""
    tree = ast.parse(path.read_text())
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(tree) if lazy else tree.body:
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("microimpact")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("microimpact"):
                continue
            out.add(mod)
            for a in node.names:  # "from . import x" may name a submodule
                if (SRC.parent / (mod.replace(".", "/") + f"/{a.name}.py")).exists():
                    out.add(f"{mod}.{a.name}")
    out.discard(name)
    return out


def _graph(lazy=False):
    graph = {}
    for path in SRC.rglob("*.py"):
        if "presets" in path.parts or "data" in path.parts:
            continue
        graph[_module_name(path)] = _top_level_imports(path, lazy=lazy)
    return graph


def _cycles(lazy):
    graph = _graph(lazy)
    # a package's __init__ importing its own submodules is not a cycle of layers;
    # nor is the package's lazy export table
    edges = {
        m: {
            d
            for d in deps
            if d in graph
            and not m.startswith(d + ".")
            and d != "microimpact"
            and (m, d) not in FACADES
        }
        for m, deps in graph.items()
    }
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(edges[m]):
            if state.get(d) == 1:
                cycles.append([*stack[stack.index(d) :], d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m)
    return cycles


def test_no_import_cycles_at_import_time():
    assert not _cycles(lazy=False)


def test_no_import_cycles_even_through_lazy_imports():
    """Lazy (function-level) imports do not make cycles either, but for the
    documented facades in FACADES."""
    assert not _cycles(lazy=True)


def test_core_layers_load_no_plotting():
    code = (
        "import sys, microimpact, microimpact.scenario.file, "
        "microimpact.physics.impact, "
        "microimpact.population.distributions, microimpact.surface.angles, "
        "microimpact.scenario.grid, microimpact.engine.montecarlo, "
        "microimpact.pipeline.study; "
        "microimpact.Scenario.from_preset('sst76-formica-oblique'); "
        "print(sorted({m.split('.')[0] for m in sys.modules} & "
        "{'matplotlib', 'xarray', 'pandas'}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert "matplotlib" not in out.stdout, out.stdout
