"""CLI tests of the input verbs: roughness (units, scan column), sizes and fit
(standard JSON, TOML snippets, identifiability)."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact import scenario_from_dict
from microimpact.cli import main

TAIL = '[particles]\ndistribution = "monodisperse"\ndiameter_um = 50\n'
SWEEP = "[sweep]\nspeed_m_s = [0.5]\n"


def _sine_nm(path, *, scans=1, amp_nm=800.0):
    x = np.arange(2000) * 0.5
    z = amp_nm * np.sin(2 * np.pi * x / 100.0)  # 10 whole periods per scan
    if scans == 1:
        rows = "x_um,z_nm\n" + "".join(
            f"{a},{b:.6f}\n" for a, b in zip(x, z, strict=True)
        )
    else:
        rows = "scan,x_um,z_nm\n" + "".join(
            f"{s},{a},{b:.6f}\n"
            for s in range(scans)
            for a, b in zip(x, z, strict=True)
        )
    path.write_text(rows)
    return path


def test_roughness_honours_nm_in_the_header(tmp_path, capsys):
    prof = _sine_nm(tmp_path / "nm.csv")
    assert main(["roughness", str(prof), "--out", str(tmp_path / "o")]) == 0
    out = json.loads((tmp_path / "o" / "roughness.json").read_text())
    assert_allclose(
        out["profile"]["Ra_um"], 2 * 0.8 / np.pi, rtol=1e-2
    )  # 0.51, not 509
    assert out["units"]["z_unit"] == "nm" and out["units"]["z_unit_from"] == "header"
    snippet = (tmp_path / "o" / "surface.toml").read_text()
    assert 'kind = "angles"' in snippet and 'file = "angles.txt"' in snippet


def test_roughness_conflicting_unit_is_a_one_line_user_error(tmp_path, capsys):
    prof = _sine_nm(tmp_path / "nm.csv")
    code = main(["roughness", str(prof), "--z-unit", "um", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "nm.csv" in err and "'z_nm'" in err and "'nm'" in err and "'um'" in err


def test_roughness_accepts_a_file_with_a_scan_column(tmp_path):
    prof = _sine_nm(tmp_path / "scans.csv", scans=3)
    assert main(["roughness", str(prof), "--out", str(tmp_path / "o")]) == 0
    out = json.loads((tmp_path / "o" / "roughness.json").read_text())
    assert out["n_scans"] == 3


def test_sizes_writes_standard_json_and_a_particles_snippet(tmp_path, capsys):
    d = np.random.default_rng(7).lognormal(np.log(50), 0.45, 400)
    data = tmp_path / "d.csv"
    data.write_text("diameter_um\n" + "".join(f"{v:.4f}\n" for v in d))
    assert main(["sizes", str(data), "--out", str(tmp_path / "o")]) == 0
    printed = capsys.readouterr().out
    assert "log-normal fits better than the normal" in printed
    text = (tmp_path / "o" / "sizes.json").read_text()
    out = json.loads(text)
    assert out["better_fit"] == "lognormal" and "NaN" not in text
    snippet = (tmp_path / "o" / "particles.toml").read_text()
    assert snippet == out["particles_toml"]
    sc = scenario_from_dict(
        tomllib.loads(
            snippet + "[coefficients]\nk1 = 4\nk2 = 0.05\nv_c = 0.2\n" + SWEEP
        )
    )
    assert sc.particles.kind == "lognormal"


def test_fit_at_one_speed_is_refused_with_exit_2(tmp_path, capsys):
    data = tmp_path / "one.csv"
    data.write_text(
        "diameter_um,v_n_m_s,e\n"
        + "".join(f"50,1.0,{0.5 + 0.01 * i}\n" for i in range(10))
    )
    assert main(["fit", str(data)]) == 2
    err = capsys.readouterr().err
    assert "one.csv" in err and "1 distinct speed" in err and err.count("\n") == 1


def test_fit_with_too_few_impacts_per_diameter_names_the_need(tmp_path, capsys):
    # found by a user: three impacts per diameter ended in "`table` has no rows
    # ... `min_points`", names of the library the command line does not have
    data = tmp_path / "few.csv"
    data.write_text(
        "diameter_um,v_n_m_s,e\n"
        + "".join(f"{d},{v},0.5\n" for d in (50, 60) for v in (0.5, 1, 2))
    )
    assert main(["fit", str(data)]) == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert "few.csv" in last and "`table`" not in last and "min_points" not in last
    assert "at least 5 impacts" in last and "50 um: 3, 60 um: 3" in last


@pytest.fixture
def impacts(tmp_path):
    rng = np.random.default_rng(8)
    lines = []
    for d in (30, 40, 50, 65, 80):
        r = d / 50
        k1, k2, v_c = 4 * r**-0.5, 0.05 / r, 0.2 * r**-1.5
        for v in np.linspace(1.3 * v_c, 3.0, 30):
            e = k1 / (k1 + v) * (1 - k2 / (k2 + v - v_c)) + rng.normal(0, 0.01)
            lines.append(f"{d},{float(v)!r},{float(e)!r}\n")
    path = tmp_path / "impacts.csv"
    path.write_text("diameter_um,v_n_m_s,e\n" + "".join(lines))
    return path


def test_fit_writes_standard_json_and_a_coefficients_snippet(tmp_path, impacts):
    assert main(["fit", str(impacts), "--out", str(tmp_path / "o")]) == 0
    text = (tmp_path / "o" / "coefficient_laws.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    out = json.loads(text)
    assert out["schema"] == "microimpact.coefficient_laws/1"
    snippet = (tmp_path / "o" / "coefficients.toml").read_text()
    sc = scenario_from_dict(tomllib.loads(TAIL + snippet + SWEEP))
    law = out["coefficients"]["v_c"]["law"]
    assert_allclose(
        sc.coefficients.v_c(law["d_ref_um"] * 1e-6), law["a_m_s"], rtol=1e-12
    )
