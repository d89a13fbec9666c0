"""Write docs/api.md: every public name, grouped by folder, one line each.

Run ``python docs/make_api.py`` after changing a subpackage's ``__all__``;
``tests/test_docs_api.py`` checks that the page lists exactly those names.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path

import microimpact

ROOT = Path(__file__).resolve().parents[1]
SRC = Path(microimpact.__file__).resolve().parent
#: The folders in the order of the page (the reader's order: scenario first).
PACKAGES = (
    "scenario",
    "physics",
    "population",
    "surface",
    "io",
    "engine",
    "wall_law",
    "analysis",
    "pipeline",
    "plotting",
)
MAX = 160


def _summary(text: str) -> str:
    line = " ".join(text.strip().split("\n\n")[0].split())
    if len(line) > MAX:
        line = line[:MAX].rsplit(" ", 1)[0] + " …"
    return line


def _constant_doc(name: str) -> str:
    """The ``#:`` comment above the constant's definition in the package."""
    for path in sorted(SRC.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").split("\n")
        for i, line in enumerate(lines):
            if re.match(rf"^{re.escape(name)}\b[^=]*=", line):
                doc, j = [], i - 1
                while j >= 0 and lines[j].startswith("#:"):
                    doc.insert(0, lines[j][2:].strip())
                    j -= 1
                if doc:
                    return _summary(" ".join(doc))
    return ""


def describe(obj, name: str) -> str:
    if callable(obj) or inspect.isclass(obj):
        return _summary(inspect.getdoc(obj) or "")
    return "constant: " + _constant_doc(name)


def page() -> str:
    top = set(microimpact.__all__)
    out = [
        "# API",
        "",
        "Every public name, grouped by folder, one line each: each folder's",
        "`__all__` (written by `python docs/make_api.py`; `tests/test_docs_api.py`",
        "checks that this page lists exactly those names). The names marked **top**",
        "are also importable from the top level (`import microimpact as mi;",
        "mi.run(...)`), as the README and the other pages use them; everything",
        "else is imported from its folder, e.g.",
        "`from microimpact.engine import Checkpoint`.",
        "",
    ]
    for pkg in PACKAGES:
        mod = importlib.import_module(f"microimpact.{pkg}")
        out += [f"## `microimpact.{pkg}`", "", _summary(mod.__doc__ or ""), ""]
        for name in mod.__all__:
            mark = " **top**" if name in top else ""
            out.append(f"- `{name}`{mark}: {describe(getattr(mod, name), name)}")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    target = ROOT / "docs" / "api.md"
    target.write_text(page(), encoding="utf-8")
    print(f"wrote {target}", file=sys.stderr)
