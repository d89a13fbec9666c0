"""The docs run (issue 33, item 4): every code block and every import line of
README.md and docs/*.md, so a renamed path can never again leave the docs stale.

What "runs" means for each kind of block:

* ``python``: executed, the blocks of one page in order in one namespace, in a
  temporary folder that holds the files the pages name (a small scenario with a
  ``[wall_law]`` table as ``study.toml``, a finished run in ``out/``, a profile,
  measured diameters, experiments; :func:`_workspace`);
* every ``import``/``from ... import`` line of any block: executed alone;
* every dotted name of the package anywhere on a page (prose, comments,
  blocks): imported or looked up;
* ``toml``: parsed (``tomllib``); a complete scenario is also validated;
* ``sh``/``bash``/``console``: every ``microimpact ...`` command is parsed by the
  real argument parser (verb and flags exist, values have the right type), without
  running it; a ``python FILE`` names a file that exists;
* blocks without a language or ``text``: output, file trees: not code.

A block that cannot run in the suite (a long run, an external program, an
instrument's file) carries the marker ``<!-- snippet: skip (reason) -->`` on the
line before its fence; keep them rare. Pages others were editing when this test
was written have their skips listed in :data:`SKIPS` until the marker is added.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import re
import shlex
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^( *)```(\w*)[^\n]*\n(.*?)^\1```", re.S | re.M)
MARKER = re.compile(r"<!--\s*snippet:\s*skip\b\s*(.*?)\s*-->")
#: (page, first line of the block) -> why it is skipped, for pages this test may
#: not edit yet (each to become a marker on the page).
SKIPS: dict[tuple[str, str], str] = {}


@dataclass(frozen=True)
class Block:
    page: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str
    skip: str | None

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def _blocks(page: Path) -> list[Block]:
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        indent, lang, body = m.group(1), m.group(2).lower(), m.group(3)
        lines = [
            ln[len(indent) :] if ln.startswith(indent) else ln
            for ln in body.splitlines()
        ]
        line = text[: m.start()].count("\n") + 1
        before = text[: m.start()].rstrip().splitlines()[-1:] or [""]
        marker = MARKER.search(before[0])
        skip = marker.group(1) or "marked" if marker else None
        code = "\n".join(lines) + "\n"
        first = code.strip().splitlines()[0] if code.strip() else ""
        skip = skip or SKIPS.get((str(page.relative_to(ROOT)), first))
        out.append(Block(page, line, lang, code, skip))
    return out


BLOCKS = [b for page in PAGES for b in _blocks(page)]
PYTHON = [b for b in BLOCKS if b.lang in ("python", "py")]
SHELL = [b for b in BLOCKS if b.lang in ("sh", "bash", "console", "shell")]
TOML = [b for b in BLOCKS if b.lang == "toml"]


# ------------------------------------------------------------------ imports
def _import_lines():
    out = []
    for b in BLOCKS:
        for k, line in enumerate(b.code.splitlines()):
            s = line.strip()
            if re.match(r"(import|from)\s+[\w.]+", s) and "microimpact" in s:
                out.append(pytest.param(s, id=f"{b.id}+{k + 1}"))
    return out


@pytest.mark.parametrize("line", _import_lines())
def test_every_import_line_imports(line):
    exec(compile(line.split("#")[0], "<docs>", "exec"), {})


def _dotted_names():
    found = {}
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        # not a schema name (microimpact.sizes/1) nor a file (.microimpact-...)
        pattern = r"(?<![\w./-])microimpact(?:\.[A-Za-z_]\w*)++(?![\w/])"
        for m in re.finditer(pattern, text):
            name = m.group(0)
            line = text[: m.start()].count("\n") + 1
            found.setdefault(name, f"{page.relative_to(ROOT)}:{line}")
    return [pytest.param(name, id=f"{where}:{name}") for name, where in found.items()]


def _resolve(name: str):
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(name)


@pytest.mark.parametrize("name", _dotted_names())
def test_every_dotted_name_resolves(name):
    _resolve(name)


# ------------------------------------------------------------------ toml
@pytest.mark.parametrize("block", TOML, ids=[b.id for b in TOML])
def test_toml_blocks_parse(block, workspace):
    try:
        data = tomllib.loads(block.code)
    except tomllib.TOMLDecodeError as err:
        if "overwrite" not in str(err):
            raise
        # a list of alternatives for one key: each line is a table of its own
        for line in block.code.splitlines():
            tomllib.loads(line)
        return
    if {"particles", "coefficients"} <= set(data):  # a complete scenario
        from microimpact.scenario.scenario import scenario_from_dict

        scenario_from_dict(data, base_dir=workspace[0])


# ------------------------------------------------------------------ shell
def _commands(block: Block):
    text = re.sub(r"\\\n\s*", " ", block.code)
    for line in text.splitlines():
        s = line.strip()
        if block.lang == "console":
            if not s.startswith("$ "):
                continue
            s = s[2:]
        s = s.split(" #")[0].strip()
        if s:
            yield s


@pytest.mark.parametrize("block", SHELL, ids=[b.id for b in SHELL])
def test_shell_commands_parse(block):
    from microimpact.cli import build_parser

    for command in _commands(block):
        words = shlex.split(command)
        if words[0] == "microimpact":
            err = io.StringIO()
            with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as exit_:
                build_parser().parse_args([*words[1:], "--help"])
            assert exit_.value.code == 0, (command, err.getvalue())
            # --help stops at the verb: parse the real arguments too
            with contextlib.redirect_stderr(err):
                try:
                    build_parser().parse_args(words[1:])
                except SystemExit as exc:
                    pytest.fail(f"{command}: {err.getvalue().strip()} ({exc.code})")
        elif words[0].endswith("python") and len(words) > 1:
            assert (ROOT / words[1]).exists(), command


# ------------------------------------------------------------------ python
STUDY = """
name = "docs"
seed = 1
samples = 400
[particles]
distribution = "lognormal"
median_um = 10
geometric_std = 1.3
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
friction = 0.2
[[surfaces]]
name = "formica"
kind = "normal"
std_deg = 10.0
[sweep]
speed_m_s = [0.5, 1.0, 2.0]
angle_deg = [30, 60, 90]
[wall_law]
diameter_um = [5, 20]
speed_m_s = [0.5, 2.0]
angle_deg = [30, 90]
reservoir = 16
samples = 200
"""


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A folder with the files the pages name, and the names their blocks use
    without defining them."""
    import numpy as np

    import microimpact as mi

    tmp = tmp_path_factory.mktemp("docs")
    for name in ("study.toml", "my-study.toml", "my.toml"):
        (tmp / name).write_text(STUDY)
    rng = np.random.default_rng(0)
    (tmp / "sst65_pdpa.csv").write_text(
        "diameter_um\n" + "".join(f"{x:.3f}\n" for x in rng.normal(65, 8, 300))
    )
    (tmp / "scan.csv").write_text(
        "x_um,z_nm\n"
        + "".join(f"{i * 0.5},{(i * 37) % 101 - 50}\n" for i in range(800))
    )
    measured = (
        "surface,speed_m_s,angle_deg,statistic,mean,ci_low,ci_high\n"
        "formica,1.0,60,e,0.5,0.45,0.55\n"
    )
    (tmp / "measured.csv").write_text(measured)
    (tmp / "data").mkdir()
    (tmp / "data" / "measured.csv").write_text(measured.replace("formica", "rough"))
    impacts = ["diameter_um,v_n_m_s,e"]  # normal impacts of the model (Eqs. 1-9)
    for d in (20.0, 50.0, 80.0):
        for v in np.geomspace(0.8, 5.0, 8):
            scale = (d / 50.0) ** -1.5
            r = mi.apparent_rebound(
                v, 90.0, 0.0, k1=4.0, k2=0.05 * scale, v_c=0.2 * scale, friction=0.15
            )
            impacts.append(f"{d},{v:.5f},{float(r.e_m):.6f}")
    (tmp / "impacts.csv").write_text("\n".join(impacts) + "\n")
    result = mi.run(mi.Scenario.from_toml(tmp / "study.toml"), progress=False)
    mi.Study.from_result(result, outputs=mi.Outputs(figures=())).write(tmp / "out")
    names = {
        "microimpact": mi,
        "sys": __import__("sys"),
        "result": result,
        "scenario": result.scenario,
        "out": tmp / "out",
        "d": np.full(4, 10.0),
        "v": np.full(4, 1.0),
        "theta": np.full(4, 60.0),
    }
    return tmp, names


def _pages_with_python():
    pages = {}
    for b in PYTHON:
        pages.setdefault(b.page, []).append(b)
    return [
        pytest.param(blocks, id=str(page.relative_to(ROOT)))
        for page, blocks in pages.items()
    ]


@pytest.mark.parametrize("blocks", _pages_with_python())
def test_python_blocks_run(blocks, workspace, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tmp, names = workspace
    monkeypatch.chdir(tmp)
    namespace = {"__name__": "__docs__", **names}
    ran = 0
    for b in blocks:
        if b.skip:
            continue
        try:
            exec(compile(b.code, b.id, "exec"), namespace)
        except Exception as exc:  # name the block, its page and line
            pytest.fail(f"{b.id}: {type(exc).__name__}: {exc}")
        ran += 1
    plt.close("all")
    if not ran:
        pytest.skip("every block of the page is marked skip")


def test_skips_are_rare():
    skipped = [b.id for b in BLOCKS if b.skip and b.lang not in ("", "text")]
    assert len(skipped) <= max(3, len(PYTHON + SHELL + TOML) // 5), skipped
