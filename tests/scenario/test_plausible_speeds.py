"""Impact speeds outside physical ranges are refused as probable unit mistakes
(issue 22, item 2): a sweep, a wall law's speed nodes and a reduced axis' r v_c(d)."""

from __future__ import annotations

import math

import pytest
from engine_helpers import scenario
from hypothesis import given, settings
from hypothesis import strategies as st

from microimpact._core.validation import PLAUSIBLE_SPEED_M_S
from microimpact.cli import main
from microimpact.errors import ScenarioError
from microimpact.population.distributions import PLAUSIBLE_DIAMETER_UM
from microimpact.scenario.wall_law import WallLawSpec
from microimpact.wall_law import build_wall_law

LO, HI = PLAUSIBLE_SPEED_M_S


@settings(max_examples=60, deadline=None)
@given(v=st.floats(LO, HI))
def test_every_plausible_speed_is_a_sweep_speed(v):
    assert scenario(speeds_m_s=(v,)).speeds_m_s == (v,)


@settings(max_examples=60, deadline=None)
@given(
    v=st.one_of(st.floats(HI * (1 + 1e-12), 1e300), st.floats(1e-300, LO * (1 - 1e-12)))
)
def test_every_implausible_speed_is_refused_naming_the_field(v):
    with pytest.raises(ScenarioError) as err:
        scenario(speeds_m_s=(0.5, v))
    assert err.value.field == "sweep.speed_m_s"
    assert f"{v:g} m/s" in str(err.value) and "allowed: 1e-06 to 10000 m/s" in str(
        err.value
    )


def test_a_speed_in_mm_per_s_is_named_as_such():
    with pytest.raises(
        ScenarioError, match=r"was it given in mm/s\? 20000 mm/s is 20 m/s"
    ):
        scenario(speeds_m_s=(2e4,))
    with pytest.raises(ScenarioError, match=r"below 1 um/s.*km/s"):
        scenario(speeds_m_s=(1e-7,))


TOML = """
[particles]
distribution = "normal"
mean_um = 40
std_um = 5

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {{ law = "power", a_m_s = {a}, b = -1.58, d_ref_um = 52.8 }}

[[surfaces]]
name = "smooth"
kind = "smooth"

[sweep]
speed_m_s = {speeds}
angle_deg = [90]
"""


def test_the_cli_refuses_a_sweep_in_mm_per_s_before_any_work(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(TOML.format(a=0.2, speeds="[500, 20000]"))
    assert main(["run", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "s.toml: sweep.speed_m_s: 20000 m/s is above 10 km/s" in err
    assert "Traceback" not in err
    assert not (tmp_path / "out" / "summary.csv").exists()


def test_wall_law_speed_nodes_are_checked():
    with pytest.raises(ScenarioError) as err:
        WallLawSpec(diameters_um=(10,), speeds_m_s=(1.0, 1e6), angles_deg=(45,))
    assert err.value.field == "wall_law.speed_m_s" and "mm/s" in str(err.value)
    with pytest.raises(ScenarioError) as err:
        WallLawSpec(
            diameters_um=(10,),
            speeds_m_s=None,
            speed_axis="reduced",
            reduced_speeds=(1.0, 1e300),
            angles_deg=(45,),
        )
    assert err.value.field == "wall_law.reduced_speed"
    assert "outside (0.001, 1000.0]" in str(err.value)


def test_a_reduced_node_at_an_implausible_speed_is_refused_before_any_work(
    tmp_path, monkeypatch
):
    """r = 900 on v_c = 277 m/s (10 um) is 2.5e5 m/s: refused, naming the node."""
    from microimpact.wall_law import build

    monkeypatch.setattr(build, "_node_rows", lambda *a: pytest.fail("simulated"))
    f = tmp_path / "w.toml"
    f.write_text(TOML.format(a=20.0, speeds="[1]"))
    from microimpact.scenario.scenario import read_scenario

    sc = read_scenario(f).scenario
    spec = WallLawSpec(
        diameters_um=(10, 20),
        speeds_m_s=None,
        speed_axis="reduced",
        reduced_speeds=(1.0, 900.0),
        angles_deg=(45,),
        samples=100,
    )
    with pytest.raises(ScenarioError) as err:
        build_wall_law(sc, spec)
    msg = str(err.value)
    assert err.value.field == "wall_law.reduced_speed"
    assert "r = 900 at diameter 10 um" in msg and "mm/s" not in msg
    v = 900 * 20.0 * (10 / 52.8) ** -1.58
    assert f"{v:g} m/s" in msg and math.isfinite(v)


DLO, DHI = PLAUSIBLE_DIAMETER_UM


@settings(max_examples=40, deadline=None)
@given(
    d=st.one_of(
        st.floats(1e-300, DLO * (1 - 1e-12)), st.floats(DHI * (1 + 1e-12), 1e300)
    )
)
def test_an_implausible_wall_law_diameter_is_refused_naming_the_field(d):
    # found by a user: diameter_um = [5e-6] (metres typed as um) in [wall_law]
    # passed the scenario and ended in an internal error (exit 1) in the build
    with pytest.raises(ScenarioError) as err:
        WallLawSpec(diameters_um=(10.0, d), speeds_m_s=(1.0,), angles_deg=(45,))
    assert err.value.field == "wall_law.diameter_um"
    assert f"{d:g}" in str(err.value) and "0.01 to 10000 um" in str(err.value)


@settings(max_examples=20, deadline=None)
@given(d=st.floats(DLO, DHI))
def test_every_plausible_wall_law_diameter_is_a_node(d):
    spec = WallLawSpec(diameters_um=(d,), speeds_m_s=(1.0,), angles_deg=(45,))
    assert spec.diameters_um == (d,)


def test_the_cli_refuses_wall_law_diameters_in_metres(tmp_path, capsys):
    f = tmp_path / "w.toml"
    text = TOML.format(a=0.2, speeds="[1]")
    f.write_text(text + "[wall_law]\ndiameter_um = [5e-6, 10e-6]\n")
    assert main(["wall-law", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "w.toml" in err and "wall_law.diameter_um" in err
    assert "was it given in metres? 5e-06 m is 5 um" in err
    assert not (tmp_path / "out" / "wall_law.nc").exists()
