"""docs/presets.md holds no number the code does not give (issue 29).

Its generated blocks (``checks``, ``mechanism``, ``areal``, ``tradeoff``) are
written again here with docs/figures/paper_statements.py's own functions and must
be the same text; its prose numbers are recomputed from the presets, the data
files and closed forms. The ``statements`` block (the full robustness study) is
compared in tests/analysis/test_robustness.py (slow).
"""

from __future__ import annotations

import importlib.util
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from microimpact.engine.montecarlo import run
from microimpact.scenario import PRESET_DIR, load_preset

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "presets.md"


def _script():
    spec = importlib.util.spec_from_file_location(
        "_paper_statements", ROOT / "docs" / "figures" / "paper_statements.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _block(name):
    text = DOC.read_text(encoding="utf-8")
    m = re.search(rf"<!-- {name}:begin -->\n(.*?)\n<!-- {name}:end -->", text, re.S)
    assert m, name
    return m.group(1)


@pytest.fixture(scope="module")
def script():
    return _script()


def test_checks_block_is_the_code(script):
    assert script.checks_section(script.run_presets()) == _block("checks")


def test_mechanism_and_tradeoff_blocks_are_the_code(script):
    assert script.mechanism_section() == _block("mechanism")
    assert script.tradeoff_section() == _block("tradeoff")


@pytest.mark.slow
def test_areal_block_is_the_code(script):
    assert script.areal_section() == _block("areal")


def _sample(name):
    return pd.read_csv(PRESET_DIR / name, comment="#")["diameter_um"].to_numpy(float)


@pytest.mark.parametrize(
    ("file", "text"),
    [
        (
            "sst125_diameters.csv",
            "median {:.1f} µm, mean {:.1f} µm, std {:.1f} µm, {:.1f}-{:.1f} µm",
        ),
        (
            "sst76_diameters.csv",
            "median {:.1f} µm, mean {:.1f} µm, std {:.1f} µm, {:.1f}-{:.1f} µm",
        ),
    ],
)
def test_sample_statistics_in_prose(file, text):
    d = _sample(file)
    want = text.format(np.median(d), d.mean(), d.std(ddof=1), d.min(), d.max())
    assert want in DOC.read_text(encoding="utf-8")


def test_closed_form_numbers_in_prose():
    doc = DOC.read_text(encoding="utf-8")
    # the Gaussian's mass below d = 0, cut by the truncation
    cut = stats.norm.cdf(0.0, 52.8, 15.3)
    assert f"it cuts {cut / 1e-4:.1f} × 10⁻⁴ of the Gaussian" in doc
    assert f"v_c(30 µm) = {0.20 * (30 / 52.8) ** -1.58:.2f} m/s" in doc
    assert f"R = {4.0 / (4.0 + 1.0):.2f} at 1 m/s" in doc
    b = math.log(0.13 / 0.20) / math.log(69.4 / 52.8)
    assert f"ln(0.13/0.20)/ln(69.4/52.8) = {b:.2f}" in doc
    assert f"180°/√12 = {180 / math.sqrt(12):.0f}°" in doc


def test_areal_prose_is_the_preset():
    """The areal surface's rms and the profile angle std it was matched to."""
    doc = DOC.read_text(encoding="utf-8")
    toml = (PRESET_DIR / "sst76-formica-areal.toml").read_text(encoding="utf-8")
    rms = re.search(r"rms_um = ([0-9.]+)", toml).group(1)
    assert f"`rms_um = {rms}`" in doc
    sc = load_preset("sst76-formica-areal")
    q = np.linspace(0.0005, 0.9995, 4000)
    std = math.degrees(float(np.std(sc.surfaces[0].angles.ppf(q))))
    assert f"angles', {std:.2f}°" in doc


def test_capture_speed_spread_over_seeds():
    """The 20-seed spread of the capture speeds quoted above the checks."""
    doc = DOC.read_text(encoding="utf-8")
    for name, label in (
        ("sst65-silicon-normal", "SST65"),
        ("sst125-silicon-normal", "SST125"),
    ):
        v = [
            float(
                run(load_preset(name).with_options(seed=s))
                .capture_speed()["speed_m_s"]
                .iloc[0]
            )
            for s in range(1, 21)
        ]
        want = f"{label} mean {np.mean(v):.4f} m/s, std {np.std(v, ddof=1):.4f}"
        assert want in doc, want
