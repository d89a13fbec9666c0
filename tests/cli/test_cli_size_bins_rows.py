"""``microimpact sizes`` on wide exports (TSI AIM row exports, OPC logs) with
``--sample``, ``--edges-um`` and ``--sampled-volume-cm3``, and the ``[particles]``
histogram keys for them, end to end (issue 22, round two)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from microimpact.cli import main
from microimpact.errors import ScenarioError
from microimpact.scenario.scenario import scenario_from_dict

DATA = Path(__file__).parents[1] / "data" / "size_exports"
ROW = DATA / "aim_smps_row_pysmps.txt"
OPCN2 = DATA / "opcn2_pysmps.csv"
OPCN3 = DATA / "modulair_pm_opcn3_pysmps.csv"
OPCN2_EDGES = "0.38,0.54,0.78,1.05,1.34,1.59,2.07,3,4,5,6.5,8,10,12,14,16,17.5"
#: py-smps's OPC-N3 (and MODULAIR-PM) bin boundaries [um]
OPCN3_EDGES = [0.35, 0.46, 0.66, 1.0, 1.3, 1.7, 2.3, 3.0, 4.0, 5.2, 6.5, 8.0, 10.0,
               12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 28.0, 31.0, 34.0, 37.0,
               40.0]  # fmt: skip


def test_sizes_on_an_aim_row_export_asks_for_the_sample(capsys):
    assert main(["sizes", str(ROW)]) == 2
    err = capsys.readouterr().err
    assert "holds 6 samples" in err and "--sample 1 " in err and "--sample sum" in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_sampled_volume_gives_the_chi2_test_and_standard_errors(capsys):
    assert main(["sizes", str(ROW), "--sample", "2", "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert plain["counted"] is False and plain["lognormal"]["chi2"] is None
    argv = ["sizes", str(ROW), "--sample", "2", "--sampled-volume-cm3", "0.5"]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["counted"] is True and out["values"] == "dN/dlogDp"
    assert out["total"] == pytest.approx(0.5 * plain["total"])
    chi2 = out["lognormal"]["chi2"]
    assert chi2 is not None and chi2["dof"] >= 1
    se = out["lognormal"]["stderr"]["median_um"]
    assert se is not None and math.isfinite(se) and se > 0
    # the fit itself does not depend on the scale of the bins
    assert out["lognormal"]["params"]["median_um"] == pytest.approx(
        plain["lognormal"]["params"]["median_um"], rel=1e-5
    )
    assert any("sampled volume 0.5 cm^3" in n for n in out["notes"])
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert " particles" in text and "no chi2 test" not in text


def test_opcn2_log_with_edges_and_a_sample_range(capsys):
    argv = ["sizes", str(OPCN2), "--values", "count", "--edges-um", OPCN2_EDGES]
    assert main([*argv, "--sample", "sum", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["total"] == 34047 and out["counted"] and out["n_bins"] == 16
    assert main([*argv, "--sample", "sum 1..10", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["total"] < 34047


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--edges-um", "0.38,x"], "not a list of numbers"),
        (["--edges-um", "0.38,0.54", "--sample", "1"], "do not bound the 16 bin"),
        (["--sampled-volume-cm3", "0"], "must be a finite number > 0"),
        (["--sampled-volume-cm3", "5", "--sample", "1"], "counted particles already"),
        (["--sample", "5..2"], "runs backwards"),
    ],
)
def test_bad_wide_options_exit_2_without_traceback(capsys, extra, words):
    argv = ["sizes", str(OPCN2), "--values", "count"]
    if "--edges-um" not in extra:
        argv += ["--edges-um", OPCN2_EDGES]
    assert main([*argv, *extra]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


# -- the [particles] histogram keys ---------------------------------------------------
def _scenario(particles):
    return {
        "particles": {"distribution": "histogram", **particles},
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [0.5]},
    }


def test_scenario_reads_a_wide_opc_log_with_edges_and_samples():
    sc = scenario_from_dict(
        _scenario(
            {
                "file": str(OPCN3),
                "values": "dN",
                "edges_um": OPCN3_EDGES,
                "sample": "1..30",
            }
        )
    )
    d_um = sc.particles.ppf(np.array([0.001, 0.5, 0.999])) * 1e6
    assert OPCN3_EDGES[0] <= d_um[0] < d_um[1] < d_um[2] <= OPCN3_EDGES[-1]


@pytest.mark.parametrize(
    ("particles", "words"),
    [
        ({"edges_um": [1, 2, 3], "counts": [1, 2], "unit": "nm"}, "in micrometres"),
        ({"file": str(OPCN3), "values": "dN", "sample": 1}, "edges_um = [0.35"),
        ({"file": str(OPCN3), "values": "dN", "sample": True}, '"sum A..B"'),
        (
            {"file": str(OPCN3), "edges_um": OPCN3_EDGES, "counts": [1]},
            "only allowed with inline 'edges_um'",
        ),
    ],
)
def test_scenario_histogram_key_mistakes(particles, words):
    with pytest.raises(ScenarioError) as exc:
        scenario_from_dict(_scenario(particles))
    assert words in str(exc.value) and "particles." in str(exc.value)
