"""Honest geometry of profiles (issue 21): a contact length below the sampling
interval is refused, missing points are masked as maps mask them, the roughness
verb takes --detrend and --cutoff-um, and every hint works when followed."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import microimpact as mi
from microimpact.cli import main
from microimpact.errors import ProfileFormatError, ScenarioError
from microimpact.io.profiles import Profile, read_profile
from microimpact.surface.roughness import (
    characterise,
    gaussian_filter_profile,
    profile_angles,
    profile_parameters,
    surface_angles,
)


def _scan(path, n=4000, dx_um=0.5, holes=()):
    """A sine scan (x_um, z_nm) with empty height cells at `holes`."""
    x = np.arange(n) * dx_um
    z = 200 * np.sin(2 * np.pi * x / 60.0)
    rows = [
        f"{xi:g},{'' if i in holes else f'{zi:.6f}'}"
        for i, (xi, zi) in enumerate(zip(x, z, strict=True))
    ]
    path.write_text("x_um,z_nm\n" + "\n".join(rows) + "\n")
    return path


def test_contact_length_below_the_spacing_is_refused_naming_both_numbers():
    x = np.arange(200) * 0.5
    with pytest.raises(ProfileFormatError) as info:
        profile_angles(x, np.sin(x), contact_length_um=0.4)
    msg = str(info.value)
    assert "0.4 µm" in msg and "0.5 µm" in msg and "at least 0.5 µm" in msg
    # the hint, followed: a contact length of one interval averages one point
    # per segment, and two intervals average two
    assert profile_angles(x, np.sin(x), contact_length_um=0.5).size == 199
    assert profile_angles(x, np.sin(x), contact_length_um=1.0).size == 99


def test_metres_typed_as_micrometres_on_the_cli_is_a_clear_exit_2(tmp_path, capsys):
    scan = _scan(tmp_path / "scan.csv")
    args = ["roughness", str(scan), "--out", str(tmp_path / "o")]
    code = main([*args, "--contact-length-um", "20e-6"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "2e-05 µm" in err and "0.5 µm" in err and "internal error" not in err
    # followed: the contact length in µm
    assert main(["roughness", str(scan), "--out", str(tmp_path / "o")]) == 0


def test_metres_typed_as_micrometres_in_a_scenario_names_the_key(tmp_path):
    _scan(tmp_path / "scan.csv")
    (tmp_path / "s.toml").write_text(
        """name = "m"
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
[[surfaces]]
name = "measured"
kind = "profile"
file = "scan.csv"
contact_length_um = 20e-6
[sweep]
speed_m_s = [1.0]
angle_deg = [45]
"""
    )
    with pytest.raises(ScenarioError) as info:
        mi.Scenario.from_toml(tmp_path / "s.toml")
    msg = str(info.value)
    assert "contact_length_um" in msg and "2e-05 µm" in msg and "0.5 µm" in msg
    assert "angles_deg" not in msg and "\n" not in msg


def test_missing_heights_are_masked_and_reported(tmp_path, capsys):
    holes = set(range(1000, 1040)) | {5, 17, 3999}
    scan = _scan(tmp_path / "holes.csv", holes=holes)
    p = read_profile(scan)
    assert p.masked_fraction == pytest.approx(len(holes) / 4000)
    full = read_profile(_scan(tmp_path / "full.csv"))
    # Rq over the measured points only (independently: numpy on the raw cells)
    raw = np.genfromtxt(scan, delimiter=",", skip_header=1)[:, 1] * 1e-9
    measured = raw[np.isfinite(raw)]
    par = profile_parameters(p, detrend="mean")
    assert par.Rq == pytest.approx(measured.std(), rel=1e-9)
    assert par.Rq == pytest.approx(200e-9 / np.sqrt(2), rel=5e-3)
    # a segment (40 points) with less than half measured is left out: the 40-point
    # hole removes segment 25 and its two slopes; the other segments keep their
    # angles (their means are over the measured points)
    a_full = surface_angles(full, contact_length=20e-6, detrend=None)
    a_holes = surface_angles(p, contact_length=20e-6, detrend=None)
    assert a_holes.size == a_full.size - 2
    assert_allclose(a_holes[:24], a_full[:24], atol=2e-4)
    assert_allclose(a_holes[24:-1], a_full[26:-1], atol=1e-12)
    assert_allclose(a_holes[-1], a_full[-1], atol=1e-4)  # its last point is missing
    ch = characterise(p, contact_length=20e-6)
    assert ch.masked_fraction == pytest.approx(len(holes) / 4000)
    assert main(["roughness", str(scan), "--out", str(tmp_path / "o")]) == 0
    out = json.loads((tmp_path / "o" / "roughness.json").read_text())
    assert out["data"]["masked_fraction"] == pytest.approx(len(holes) / 4000)
    share = f"{100 * len(holes) / 4000:.3g} % of the heights missing"
    assert share in capsys.readouterr().out


def test_a_masked_text_scan_and_a_masked_x3p_scan_give_the_same_numbers(tmp_path):
    x3pio = pytest.importorskip("x3pio")
    z = np.sin(np.arange(400) * 0.05) * 1e-6
    z[100:110] = np.nan
    z[0] = np.nan
    f = x3pio.Profile.from_array(z, x_scale=0.5e-6)
    f.save(tmp_path / "p.x3p")
    rows = [
        f"{i * 0.5:g},{'' if np.isnan(v) else f'{v * 1e6:.12f}'}"
        for i, v in enumerate(z)
    ]
    (tmp_path / "p.csv").write_text("x_um,z_um\n" + "\n".join(rows) + "\n")
    a, b = read_profile(tmp_path / "p.x3p"), read_profile(tmp_path / "p.csv")
    assert a.masked_fraction == b.masked_fraction == pytest.approx(11 / 400)
    pa, pb = profile_parameters(a), profile_parameters(b)
    assert pa.Rq == pytest.approx(pb.Rq, rel=1e-9)
    assert pa.Rdq == pytest.approx(pb.Rdq, rel=1e-9)


def test_an_x3p_surface_with_invalid_points_reads_as_masked_profiles(tmp_path):
    x3pio = pytest.importorskip("x3pio")
    z = np.random.default_rng(2).normal(0, 1e-6, (8, 300))
    z[3, 0] = np.nan  # the issue: refused with "missing value at index 0 of row 0"
    z[5, 40:60] = np.nan
    x3pio.Surface.from_array(z, x_scale=1e-6, y_scale=2e-6).save(tmp_path / "s.x3p")
    ps = mi.read_profiles(tmp_path / "s.x3p")
    assert len(ps) == 8
    assert ps[3].masked_fraction == pytest.approx(1 / 300)
    assert ps[5].masked_fraction == pytest.approx(20 / 300)
    hm = mi.read_height_map(tmp_path / "s.x3p")
    assert hm.metadata["masked_fraction"] == pytest.approx(21 / 2400)


def test_point_clouds_read_where_they_are_a_line_and_refused_otherwise(tmp_path):
    x3pio = pytest.importorskip("x3pio")
    t = np.linspace(0, 1e-3, 500)
    line = np.column_stack([t * 0.6, t * 0.8, 1e-6 * np.sin(t * 2e4)])
    x3pio.PointCloud.from_points(line).save(tmp_path / "line.x3p")
    p = read_profile(tmp_path / "line.x3p")  # along the line, from its start
    assert_allclose(p.x[-1], 1e-3, rtol=1e-9)
    assert_allclose(p.z, line[:, 2], atol=1e-18)
    cloud = np.random.default_rng(1).uniform(0, 1e-4, (300, 3))
    x3pio.PointCloud.from_points(cloud).save(tmp_path / "cloud.x3p")
    with pytest.raises(ProfileFormatError, match="not a line scan") as info:
        read_profile(tmp_path / "cloud.x3p")
    assert "\n" not in str(info.value)
    assert "allowed: points along one line (a profile), or a surface on a " in str(
        info.value
    )
    with pytest.raises(ProfileFormatError, match="read a line scan with read_profiles"):
        mi.read_height_map(tmp_path / "line.x3p")


def test_roughness_cli_detrend_and_cutoff_are_the_librarys(tmp_path):
    scan = _scan(tmp_path / "scan.csv")
    p = read_profile(scan)
    for extra, kw in (
        (["--detrend", "none"], {"detrend": None}),
        (
            ["--detrend", "mean", "--cutoff-um", "250"],
            {"detrend": "mean", "cutoff": 250e-6},
        ),
    ):
        out = tmp_path / "_".join(extra)
        assert main(["roughness", str(scan), "--out", str(out), *extra]) == 0
        data = json.loads((out / "roughness.json").read_text())
        ch = characterise(p, contact_length=20e-6, **kw)
        assert data["angles"]["std_deg"] == pytest.approx(np.degrees(ch.std_angle))
        assert data["profile"]["Rq_um"] == pytest.approx(ch.profile.Rq * 1e6)
        assert data["conditioning"]["detrend"] == kw["detrend"]


def test_the_gaussian_filter_refuses_a_non_uniform_scan_and_the_hint_works(tmp_path):
    x = np.cumsum(np.random.default_rng(3).uniform(0.2, 0.8, 2000)) * 1e-6
    p = Profile(x, np.sin(x / 20e-6) * 1e-7, {"source": "irregular.csv"})
    with pytest.raises(ProfileFormatError, match="leave `cutoff_um` out") as info:
        characterise(p, contact_length=20e-6, cutoff=250e-6)
    assert "irregular.csv" in str(info.value)
    assert characterise(p, contact_length=20e-6).n_segments > 0  # followed
    with pytest.raises(ValueError, match="uniformly spaced"):
        gaussian_filter_profile(x, p.z, cutoff=250e-6)


def test_header_dx_alone_sets_dy(tmp_path):
    f = tmp_path / "map.txt"
    f.write_text("# dx_um = 0.5\n# z_unit = nm\n1 2 3\n4 5 6\n")
    hm = mi.read_height_map(f)
    assert hm.dy == hm.dx == pytest.approx(0.5e-6)
    assert hm.metadata["dy_from"] == "dx"


def test_an_areal_contact_below_the_pixel_in_a_scenario_names_both_numbers(tmp_path):
    rows = np.random.default_rng(5).normal(0, 1, (20, 20))
    text = "# dx_um = 200\n# z_unit = um\n" + "\n".join(
        " ".join(f"{v:.4f}" for v in r) for r in rows
    )
    (tmp_path / "map.txt").write_text(text + "\n")
    scenario = """name = "a"
[particles]
distribution = "monodisperse"
diameter_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.4
[[surfaces]]
name = "map"
kind = "areal"
file = "map.txt"
contact_length_um = CONTACT
[sweep]
speed_m_s = [1.0]
angle_deg = [45]
"""
    path = tmp_path / "s.toml"
    path.write_text(scenario.replace("CONTACT", "20"))
    with pytest.raises(ScenarioError) as info:
        mi.Scenario.from_toml(path)
    msg = str(info.value)
    assert "20 µm" in msg and "200 µm" in msg and "at least 200 µm" in msg
    assert "contact_diameter_um" not in msg and "\n" not in msg
    path.write_text(scenario.replace("CONTACT", "400"))  # the hint, followed
    assert mi.Scenario.from_toml(path).surfaces[0].angles is not None
