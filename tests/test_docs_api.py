"""The curated API: docs/api.md lists exactly the folders' ``__all__``, every
top-level name still imports, and no public name lives only in a private module."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import pytest

import microimpact

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import make_api  # noqa: E402


def _sections():
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    out, current = {}, None
    for line in text.splitlines():
        m = re.match(r"^## `microimpact\.(\w+)`", line)
        if m:
            current = out.setdefault(m.group(1), [])
        m = re.match(r"^- `([A-Za-z_][A-Za-z0-9_]*)`", line)
        if m and current is not None:
            current.append(m.group(1))
    return out


def test_api_page_lists_exactly_each_folders_all():
    sections = _sections()
    assert set(sections) == set(make_api.PACKAGES)
    for pkg in make_api.PACKAGES:
        mod = importlib.import_module(f"microimpact.{pkg}")
        assert sections[pkg] == list(mod.__all__), pkg


def test_api_page_is_the_generated_one():
    assert (ROOT / "docs" / "api.md").read_text(encoding="utf-8") == make_api.page()


@pytest.mark.parametrize("name", microimpact.__all__)
def test_every_top_level_name_imports(name):
    assert getattr(microimpact, name) is not None


def test_no_public_name_only_in_a_private_module():
    """Each top-level name is also in the ``__all__`` of a public folder."""
    public = set()
    for pkg in make_api.PACKAGES:
        public |= set(importlib.import_module(f"microimpact.{pkg}").__all__)
    errors = {
        "InputError",
        "ScenarioError",
        "ScenarioErrors",
        "ProfileFormatError",
        "DataFormatError",
    }
    missing = set(microimpact.__all__) - public - errors - {"ConvergenceWarning"}
    assert missing == {"__version__"}
    private = [
        (n, m) for n, m in microimpact._EXPORTS.items() if m.split(".")[0] == "_core"
    ]
    assert not private


def test_each_folder_all_names_exist():
    for pkg in make_api.PACKAGES:
        mod = importlib.import_module(f"microimpact.{pkg}")
        assert len(set(mod.__all__)) == len(mod.__all__)
        for name in mod.__all__:
            assert hasattr(mod, name), (pkg, name)
