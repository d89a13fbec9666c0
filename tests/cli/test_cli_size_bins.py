"""``microimpact sizes`` and ``run`` on binned size exports (issue 22), end to
end."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from microimpact.cli import main

DATA = Path(__file__).parents[1] / "data" / "size_exports"
APS = DATA / "aps3321_issue22.txt"


def test_sizes_on_the_aps_export_of_the_issue_prints_its_median(capsys):
    assert main(["sizes", str(APS), "--density-kg-m3", "1500"]) == 0
    out = capsys.readouterr().out
    assert "32 bins" in out and "values dN/dlogDp" in out
    assert "count median 3.49 um, GSD 1.689" in out
    assert "aerodynamic (density 1500 kg/m3" in out
    assert "recommended: lognormal" in out


def test_sizes_json_of_a_binned_export(capsys):
    assert main(["sizes", str(APS), "--json", "--density-kg-m3", "1000"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["schema"] == "microimpact.sizes.binned/1"
    ln = out["lognormal"]["params"]
    assert abs(ln["median_um"] - 3.49) < 0.2 and abs(ln["geometric_std"] - 1.69) < 0.1
    assert out["lognormal"]["chi2"] is None and out["counted"] is False
    a = out["aerosol"]
    # unit density: the aerodynamic diameters are the diameters themselves
    assert a["aerodynamic_count_median_um"] == pytest.approx(a["count_median_um"])
    assert a["mass_median_hatch_choate_um"] == pytest.approx(
        ln["median_um"] * np.exp(3 * np.log(ln["geometric_std"]) ** 2)
    )


def test_sizes_out_writes_json_snippet_and_figure(tmp_path):
    out = tmp_path / "o"
    assert main(["sizes", str(DATA / "opcn2_total_counts.csv"), "--out", str(out)]) == 0
    report = json.loads((out / "sizes.json").read_text())
    assert report["counted"] and report["n_bins"] == 16 and report["total"] == 34047
    assert report["recommended"] == "histogram"  # the chi-squared test rejects both
    assert 'distribution = "histogram"' in (out / "particles.toml").read_text()
    assert list(out.glob("size_distribution.*"))


def test_sizes_asks_for_the_value_column_in_cli_syntax(tmp_path, capsys):
    f = tmp_path / "two.csv"
    f.write_text("Dp (um),dN/dlogDp,dM/dlogDp\n1,5,5\n2,6,6\n4,2,2\n")
    assert main(["sizes", str(f)]) == 2
    err = capsys.readouterr().err
    assert "two.csv" in err and "'dN/dlogDp'" in err and "'dM/dlogDp'" in err
    assert "--column dN/dlogDp" in err and "column=" not in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert main(["sizes", str(f), "--column", "dM/dlogDp"]) == 0
    out = capsys.readouterr().out
    assert "values dM/dlogDp" in out and "converted to number per bin" in out


def test_sizes_asks_for_the_aim_sample(capsys):
    path = DATA / "aim_smps_column_pysmps.txt"
    assert main(["sizes", str(path)]) == 2
    assert "--sample 1" in capsys.readouterr().err
    assert main(["sizes", str(path), "--sample", "13"]) == 0
    assert "sample 13 of 15" in capsys.readouterr().out


def test_density_with_raw_diameters_is_refused(tmp_path, capsys):
    f = tmp_path / "d.csv"
    f.write_text("diameter_um\n" + "".join(f"{v}\n" for v in range(20, 80)))
    assert main(["sizes", str(f), "--density-kg-m3", "1000"]) == 2
    assert "needs size bins" in capsys.readouterr().err


SCENARIO = """\
name = "binned"
seed = 3
samples = 400

[particles]
distribution = "histogram"
file = "{file}"

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {{ law = "power", a_m_s = 0.2, b = -1.5, d_ref_um = 3.5 }}
friction = 0.15

[[surfaces]]
name = "smooth"
kind = "smooth"

[sweep]
speed_m_s = [0.5]
angle_deg = [90]
"""


def test_run_a_scenario_whose_particles_are_a_binned_export(tmp_path):
    sc = tmp_path / "binned.toml"
    sc.write_text(SCENARIO.format(file=APS.as_posix()))
    out = tmp_path / "out"
    assert main(["run", str(sc), "--out", str(out), "--quiet", "--no-figures"]) == 0
    assert (out / "summary.csv").stat().st_size > 0


def test_scenario_asks_for_the_aim_sample_in_toml_syntax(tmp_path, capsys):
    sc = tmp_path / "aim.toml"
    aim = (DATA / "aim_smps_column_pysmps.txt").as_posix()
    sc.write_text(SCENARIO.format(file=aim))
    assert main(["run", str(sc), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "particles.file" in err and "sample = 1" in err and "--sample" not in err


def test_sizes_of_a_grimm_wide_export_with_edges_um(tmp_path, capsys):
    path = tmp_path / "grimm.csv"
    path.write_text(
        "timestamp,0.3,0.4,0.5,0.65,0.8,1.0,1.6,2.0\n"
        "2026-01-01T10:00:00Z,120,80,60,30,15,8,3,1\n"
    )
    args = ["sizes", str(path), "--unit", "um", "--values", "count", "--sample", "1"]
    assert main(args) == 2
    assert "--edges-um" in capsys.readouterr().err
    edges = "0.3,0.4,0.5,0.65,0.8,1.0,1.6,2.0,3.0"
    assert main([*args, "--edges-um", edges]) == 0
    assert "8 bins, 0.3 to 3 um" in capsys.readouterr().out
