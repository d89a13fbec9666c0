"""What the node spacing costs at the capture edge (issue 33, item 5).

``microimpact wall-law`` prints, for the user's own table, the largest change of
capture probability between neighbouring nodes on each axis: where capture is
monotone between two nodes (in speed it is), the true value and the sampler's
interpolated one both lie between the nodes' values, so that change bounds the
sampler's capture error in the cell. Checked on a table with a known step, and on
a real build against a direct engine run at the middle of the worst speed cell
(an independent oracle: the engine at that exact speed).
"""

from __future__ import annotations

import math

import numpy as np
from test_wall_law import ROUGH, SPEC, _scenario
from test_wall_law import _toml as scenario_toml
from test_wall_law_c import synthetic_dataset

import microimpact as mi
from microimpact.cli import main
from microimpact.wall_law import build_wall_law
from microimpact.wall_law.accuracy import capture_steps


def test_the_largest_step_is_found_on_each_axis():
    ds = synthetic_dataset()
    p = np.full(ds["capture_probability"].shape, 0.5)
    p[0, 0, :, 0] = [1.0, 0.95, 0.2, 0.0]  # polished, 1 um, 15 deg: 0.5 .. 30 m/s
    ds["capture_probability"].values[...] = p
    d, v, a = capture_steps(ds)
    assert (v.axis, v.between, v.step) == ("speed_m_s", (2.0, 8.0), 0.75)
    assert v.at == {"surface": "polished", "diameter_um": 1.0, "angle_deg": 15.0}
    assert d.axis == "diameter_um" and d.step == 0.5
    assert a.axis == "angle_deg" and a.step == 0.5
    assert v.describe() == (
        "0.75 across speed 2-8 m/s (surface 'polished', diameter_um 1, angle_deg 15)"
    )


def test_an_axis_of_one_node_has_no_cell():
    ds = synthetic_dataset().isel(angle_deg=[1])
    assert math.isnan(capture_steps(ds)[2].step)


def test_the_bound_holds_against_a_direct_run_mid_cell():
    law = build_wall_law(_scenario(ROUGH), SPEC)
    _, v, _ = capture_steps(law)
    lo, hi = v.between
    mid = math.sqrt(lo * hi)  # the middle of the cell in log speed
    d, a = v.at["diameter_um"], v.at["angle_deg"]
    p_lo, p_hi = (
        float(
            law.dataset.capture_probability.sel(
                surface=v.at["surface"], diameter_um=d, speed_m_s=s, angle_deg=a
            )
        )
        for s in (lo, hi)
    )
    sampler = 0.5 * (p_lo + p_hi)  # the sampler's capture at t = 1/2
    direct = _scenario(ROUGH, seed=999, samples=8000).with_options(
        particles=mi.monodisperse(d), speeds_m_s=(mid,), angles_deg=(a,)
    )
    out = mi.sample_point(direct, 0, 8000)
    n = int(np.count_nonzero(~out["shadowed"]))
    p = float(np.count_nonzero(out["captured"] & ~out["shadowed"])) / n
    se = math.sqrt(0.25 / n) + math.sqrt(0.25 / 2000)  # direct run and nodes
    assert abs(p - sampler) <= v.step + 4 * se
    assert v.step > 0.1  # the capture edge lies inside the speed range


def test_the_cli_prints_it(tmp_path, capsys):
    path = scenario_toml(
        tmp_path,
        "[wall_law]\ndiameter_um = [10]\nspeed_m_s = [0.1, 0.2, 20]\n"
        "angle_deg = [30, 60, 90]\nreservoir = 8\nsamples = 200",
    )
    out = tmp_path / "out"
    assert (
        main(["wall-law", str(path), "--out", str(out), "--no-c", "--no-openfoam"]) == 0
    )
    said = capsys.readouterr().out
    line = next(x for x in said.splitlines() if x.startswith("capture between nodes"))
    assert "across speed 0.2-20 m/s (surface 'rough'" in line
    assert "Accuracy between nodes" in line
