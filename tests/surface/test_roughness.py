"""Tests for microimpact.surface.roughness, .contact and plotting.roughness."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from microimpact.errors import DataFormatError, ProfileFormatError
from microimpact.io.profiles import Profile, ProfileSet
from microimpact.physics import adhesion
from microimpact.surface.contact import hertz_contact_diameter, hertz_max_compression
from microimpact.surface.roughness import (
    characterise,
    condition,
    detrend,
    gaussian_filter_profile,
    profile_angles,
    profile_parameters,
    read_angle_file,
    surface_angles,
    write_angle_file,
)
from microimpact.surface.synthetic import gaussian_profile

ALPHA = math.sqrt(math.log(2) / math.pi)  # ISO 16610-21


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


# ------------------------------------------------------------------ conditioning


def test_detrend_line_matches_polyfit(rng):
    x = np.linspace(0, 4e-3, 801)
    z = 3e-6 + 0.01 * x + 1e-6 * rng.standard_normal(x.size)
    r = detrend(x, z, method="line")
    c = np.polyfit(x, z, 1)  # independent least squares
    assert_allclose(r, z - np.polyval(c, x), rtol=0, atol=1e-15)
    assert_allclose(detrend(x, z, method="mean"), z - z.mean(), rtol=0, atol=1e-18)


def _fitted_amplitude(x, y, wavelength, sl):
    a = np.c_[np.sin(2 * np.pi * x / wavelength), np.cos(2 * np.pi * x / wavelength)]
    c = np.linalg.lstsq(a[sl], y[sl], rcond=None)[0]
    return float(np.hypot(*c))


@pytest.mark.parametrize("ratio", [1.0, 0.5, 2.0, 4.0])
def test_gaussian_filter_transmission(ratio):
    cutoff = 0.8e-3
    wavelength = ratio * cutoff
    x = np.arange(40000) * 0.5e-6
    z = np.sin(2 * np.pi * x / wavelength)
    rough = gaussian_filter_profile(x, z, cutoff=cutoff)
    sl = slice(8000, 32000)  # away from the ends
    mean_line = _fitted_amplitude(x, z - rough, wavelength, sl)
    expected = math.exp(-math.pi * (ALPHA * cutoff / wavelength) ** 2)
    assert_allclose(mean_line, expected, rtol=0, atol=2e-6)
    assert_allclose(
        _fitted_amplitude(x, rough, wavelength, sl), 1 - expected, atol=2e-6
    )
    if ratio == 1.0:  # ISO definition: 50 % transmission at the cutoff
        assert_allclose(mean_line, 0.5, atol=2e-6)


def test_gaussian_filter_validation():
    with pytest.raises(ValueError, match="uniformly spaced"):
        gaussian_filter_profile([0, 1, 3, 4.0], [0, 1, 0, 1.0], cutoff=1.0)
    with pytest.raises(ValueError, match="`cutoff` must be a number > 0"):
        gaussian_filter_profile([0, 1, 2.0], [0, 1, 0.0], cutoff=0)


# ------------------------------------------------------------------ angles


@pytest.mark.parametrize("slope", [0.3, -1.2, 0.0])
def test_ramp_gives_arctan_slope(slope):
    x_um = np.arange(8000) * 0.5
    phi = profile_angles(x_um, slope * x_um, contact_length_um=20.0)
    assert phi.size == 199  # 200 segments of 40 points
    assert_allclose(phi, math.degrees(math.atan(slope)), rtol=0, atol=1e-9)


def test_paper_method_matches_definition(rng):
    x_um = np.arange(4000) * 0.5
    z_um = 30 * rng.standard_normal(x_um.size) + 0.01 * x_um
    phi = profile_angles(x_um, z_um, contact_length_um=20.0, method="paper")
    # independent: polyfit mean line, reshape into 40-point segments
    resid = z_um - np.polyval(np.polyfit(x_um, z_um, 1), x_um)
    h = resid.reshape(-1, 40).mean(axis=1)
    assert_allclose(phi, np.degrees(np.arctan(h / 20.0)), rtol=1e-12, atol=1e-12)


def test_paper_method_angstrom_example():
    # the paper: phi = arctan(H_bar / 200,000) with H_bar in Å and L = 20 µm, so a
    # segment 200,000 Å = 20 µm above the mean line is at 45°. Segments at +20,
    # -20, -20, +20 µm have a flat least-squares mean line at zero.
    x_um = np.arange(160) * 0.5
    z_um = np.repeat([20.0, -20.0, -20.0, 20.0], 40)
    phi = profile_angles(x_um, z_um, contact_length_um=20.0, method="paper")
    assert_allclose(phi, [45.0, -45.0, -45.0, 45.0], rtol=1e-12)
    # the same heights in Å with an Å unit conversion give the same angles
    assert_allclose(np.tan(np.radians(phi)) * 200_000, z_um[::40] * 1e4, rtol=1e-12)


def test_slope_method_on_sinusoid_segment_means():
    # segment means of sin over L are known in closed form
    lam, amp, length = 200.0, 10.0, 20.0
    x_um = np.arange(40000) * 0.5
    z_um = amp * np.sin(2 * np.pi * x_um / lam)
    phi = profile_angles(x_um, z_um, contact_length_um=length)
    k = 2 * np.pi / lam
    dx = 0.5
    # discrete mean of 40 samples starting at x0 = 20 i: sum of a geometric series
    starts = np.arange(phi.size + 1) * length
    j = np.arange(40) * dx
    h = amp * np.sin(k * (starts[:, None] + j[None, :])).mean(axis=1)
    assert_allclose(phi, np.degrees(np.arctan(np.diff(h) / length)), atol=1e-9)


def test_surface_angles_never_straddle_scans():
    x = np.arange(400) * 0.5e-6
    a = Profile(x, 0.2 * x, {"scan": 0})
    b = Profile(x, -0.7 * x + 1.0, {"scan": 1})  # big jump between scans
    phi = surface_angles(ProfileSet([a, b]), contact_length=20e-6, detrend=None)
    assert phi.size == 2 * 9
    assert_allclose(phi[:9], math.atan(0.2), atol=1e-12)
    assert_allclose(phi[9:], math.atan(-0.7), atol=1e-12)
    # with detrending, each ramp is removed separately
    assert_allclose(surface_angles([a, b], contact_length=20e-6), 0.0, atol=1e-12)


def test_too_short_scan_names_file_and_scan():
    x = np.arange(30) * 0.5e-6  # 15 µm
    p = Profile(x, np.sin(x * 1e5), {"scan": "s3", "source": "f.csv"})
    with pytest.raises(ProfileFormatError, match="shorter than") as ei:
        surface_angles(p, contact_length=20e-6, method="paper")
    msg = str(ei.value)
    assert "f.csv" in msg and "'s3'" in msg and "\n" not in msg
    with pytest.raises(ProfileFormatError, match="2 contact length"):
        profile_angles(np.arange(60) * 0.5, np.zeros(60), contact_length_um=20.0)


def test_angle_argument_validation():
    x = np.arange(100) * 0.5
    with pytest.raises(ValueError, match="`method` must be one of"):
        profile_angles(x, x, contact_length_um=20.0, method="bogus")
    with pytest.raises(ValueError, match="`contact_length_um`"):
        profile_angles(x, x, contact_length_um=-1.0)
    with pytest.raises(ValueError, match="strictly increasing"):
        profile_angles(x[::-1], x, contact_length_um=20.0)


# ------------------------------------------------------------------ ISO 4287


def test_sinusoid_parameters():
    amp, lam = 2e-6, 50e-6
    x = np.arange(20000) * 0.25e-6  # 100 whole periods
    p = Profile(x, amp * np.sin(2 * np.pi * x / lam))
    par = profile_parameters(p, detrend="mean")
    # Ra: 2A/pi for the continuous sine; the mean of |sin| over N = 200 samples per
    # period is exactly (2/N) cot(pi/N), which differs from 2/pi by 8e-5
    n_per = 200
    assert_allclose(par.Ra, amp * 2 / n_per / np.tan(np.pi / n_per), rtol=1e-12)
    assert_allclose(par.Ra, 2 * amp / np.pi, rtol=1e-4)
    assert_allclose(par.Rq, amp / np.sqrt(2), rtol=1e-6)
    assert_allclose(par.Rsk, 0.0, atol=1e-6)
    assert_allclose(par.Rku, 1.5, rtol=1e-6)
    # the interval slopes of A sin(kx) sampled at dx are exactly
    # A (2/dx) sin(k dx/2) cos(k x_mid): RMS A (2/dx) sin(k dx/2)/sqrt(2) over
    # whole periods (19,999 intervals: one short of 100 periods, hence 1e-4)
    k = 2 * np.pi / lam
    dx = 0.25e-6
    interval = amp * (2 / dx) * np.sin(k * dx / 2)
    mids = x[:-1] + dx / 2
    assert_allclose(par.Rdq, np.sqrt(np.mean((interval * np.cos(k * mids)) ** 2)))
    assert_allclose(par.Rdq, interval / np.sqrt(2), rtol=1e-4)
    # the ISO seven-point slope exists at the interior points x[3:-3] only
    par7 = profile_parameters(p, detrend="mean", slope="iso7")
    exact = np.sqrt(np.mean((amp * k * np.cos(k * x[3:-3])) ** 2))
    assert_allclose(par7.Rdq, exact, rtol=1e-9)
    assert_allclose(par7.Rdq, amp * k / np.sqrt(2), rtol=1e-3)


def test_profile_parameters_pool_scans():
    x = np.arange(4000) * 0.25e-6
    a = Profile(x, 1e-6 * np.sin(2 * np.pi * x / 50e-6))
    b = Profile(x, 3e-6 * np.sin(2 * np.pi * x / 50e-6))
    par = profile_parameters([a, b], detrend="mean")
    # equal-length scans: pooled Rq = RMS of the per-scan Rq values
    assert_allclose(par.Rq, np.sqrt((0.5e-12 + 4.5e-12) / 2), rtol=1e-6)


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_cross_check_surface_topography(rng):
    st = pytest.importorskip("SurfaceTopography")
    p = gaussian_profile(
        2**14, 0.5e-6, rms_height=2e-6, correlation_length=20e-6, rng=rng
    )
    z = detrend(p.x, p.z)
    t = st.UniformLineScan(z, physical_sizes=p.n_points * p.dx, periodic=False)
    par = profile_parameters(p)
    assert_allclose(par.Rq, t.rms_height_from_profile(), rtol=1e-9)
    # both take the slope of each interval (two-point differences)
    assert_allclose(par.Rdq, t.rms_slope_from_profile(), rtol=1e-9)
    # the seven-point ISO formula agrees to O((dx/ell)^2)
    par7 = profile_parameters(p, slope="iso7")
    assert_allclose(par7.Rdq, t.rms_slope_from_profile(), rtol=2e-3)


# ------------------------------------------------------------------ characterise


def test_characterise(rng):
    profiles = [
        gaussian_profile(
            4000, 0.5e-6, rms_height=10e-6, correlation_length=60e-6, rng=rng
        )
        for _ in range(3)
    ]
    res = characterise(ProfileSet(profiles), contact_length=20e-6)
    phi = res.angles
    assert res.n_scans == 3
    assert res.n_segments == phi.size == 3 * 99
    assert_allclose(res.mean_angle, phi.sum() / phi.size, rtol=1e-12)
    assert_allclose(
        res.std_angle, np.sqrt(((phi - phi.mean()) ** 2).sum() / (phi.size - 1))
    )
    m2 = np.mean((phi - phi.mean()) ** 2)
    assert_allclose(res.skewness_angle, np.mean((phi - phi.mean()) ** 3) / m2**1.5)
    assert_allclose(res.kurtosis_angle, np.mean((phi - phi.mean()) ** 4) / m2**2)
    # Sturges' rule: ceil(log2 n) + 1 bins; a density integrates to 1
    assert res.pdf_density.size == math.ceil(math.log2(phi.size)) + 1
    assert_allclose((res.pdf_density * np.diff(res.pdf_edges)).sum(), 1.0, rtol=1e-12)
    assert_allclose(res.pdf_density_per_deg.sum() * np.diff(res.pdf_edges_deg)[0], 1.0)
    assert "method='slope'" in res.summary()
    assert res.conditioning == {"detrend": "line", "cutoff": None}


def test_condition_filter_removes_waviness():
    x = np.arange(16000) * 0.5e-6
    wavy = 50e-6 * np.sin(2 * np.pi * x / 4e-3)  # long waviness
    rough = 1e-6 * np.sin(2 * np.pi * x / 20e-6)
    cutoff = 0.25e-3
    (p,) = condition(Profile(x, wavy + rough), detrend=None, cutoff=cutoff)
    sl = slice(2000, 14000)
    # ISO transmission of the roughness profile: 1 - exp(-pi (alpha lc / lambda)^2)
    t_wavy = 1 - math.exp(-math.pi * (ALPHA * cutoff / 4e-3) ** 2)
    t_rough = 1 - math.exp(-math.pi * (ALPHA * cutoff / 20e-6) ** 2)
    assert_allclose(p.z[sl], t_rough * rough[sl] + t_wavy * wavy[sl], atol=1e-10)


# ------------------------------------------------------------------ Hertz


def test_hertz_contact_diameter_is_twice_the_adhesion_contact_radius():
    """The surface module re-uses physics.adhesion, whose Hertz formulas are checked
    against the equation of motion in test_adhesion.py; here only the wiring."""
    assert hertz_max_compression is adhesion.hertz_max_compression
    d = np.array([[30e-6], [70e-6], [0.0], [np.nan]])
    rho, e_star = np.array([7900.0, 2500.0, 1050.0]), 10e9
    v = np.array([1.3, 0.0, -2.0])
    out = hertz_contact_diameter(d, rho, e_star, v)
    assert out.shape == (4, 3)
    assert_array_equal(out, 2.0 * adhesion.hertz_contact_radius(d, rho, e_star, v))
    scalar = hertz_contact_diameter(70e-6, 7900.0, 10e9, 1.3)
    assert isinstance(scalar, np.float64)
    assert scalar == 2.0 * adhesion.hertz_contact_radius(70e-6, 7900.0, 10e9, 1.3)


def test_hertz_vectorised_and_edges():
    d = np.array([[30e-6], [70e-6]])
    v = np.array([0.5, 1.0, 2.0])
    out = hertz_contact_diameter(d, 7900.0, 10e9, v)
    assert out.shape == (2, 3)
    # 2a = 2 sqrt(r delta) with delta ∝ (d^3 v^2 / sqrt(d))^(2/5): 2a ∝ d v^(2/5)
    assert_allclose(out[1] / out[0], 70 / 30, rtol=1e-12)
    assert_allclose(out[:, 2] / out[:, 1], 2**0.4, rtol=1e-12)
    assert np.isnan(hertz_contact_diameter(0.0, 7900.0, 1e9, 1.0))
    assert hertz_contact_diameter(50e-6, 7900.0, 1e9, 0.0) == 0.0
    with pytest.raises(ValueError, match=r"`density` must be .*> 0"):
        hertz_contact_diameter(50e-6, -1.0, 1e9, 1.0)
    with pytest.raises(ValueError, match=r"`contact_modulus` must be .*> 0"):
        hertz_contact_diameter(50e-6, 1.0, 0.0, 1.0)


# ------------------------------------------------------------------ angle files


def test_angle_file_round_trip(tmp_path, rng):
    src = rng.uniform(-60, 60, 500)
    path = tmp_path / "angles.txt"
    out = write_angle_file(path, src, rng=7, metadata={"surface": "formica\nsynthetic"})
    assert out.size == 4000
    assert np.isin(out, src).all()  # drawn from the sample
    back = read_angle_file(path)
    assert_allclose(back, out, rtol=0, atol=5e-7)
    text = path.read_text()
    assert "# seed: 7" in text and "# surface: formica synthetic" in text
    assert "# units: degrees" in text
    assert [f for f in os.listdir(tmp_path) if f.startswith(".tmp")] == []
    given = write_angle_file(tmp_path / "all.txt", [1.0, -2.5], n=None)
    assert_allclose(read_angle_file(tmp_path / "all.txt"), given, atol=1e-9)


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        ("# h\n1.0\nabc\n", 3, "non-numeric angle 'abc'"),
        ("1.0\nnan\n", 2, "missing angle"),
        ("1.0\n90\n", 2, "out of range"),
        ("-95.5\n", 1, "out of range"),
        ("1.0 2.0\n", 1, "one angle per line"),
    ],
)
def test_bad_angle_files(tmp_path, text, line, match):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(DataFormatError, match=match) as ei:
        read_angle_file(p)
    msg = str(ei.value)
    assert f"{p}:{line}:" in msg and "\n" not in msg


def test_empty_angle_file(tmp_path):
    p = tmp_path / "e.txt"
    p.write_text("# nothing\n")
    with pytest.raises(DataFormatError, match="no angles"):
        read_angle_file(p)
    with pytest.raises(ValueError, match="within \\(-90, 90\\)"):
        write_angle_file(tmp_path / "x.txt", [10.0, 95.0])


# ------------------------------------------------------------------ plots


def test_plots(rng):
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    import matplotlib.pyplot as plt

    from microimpact.plotting.roughness import plot_angle_pdf, plot_profile

    p = gaussian_profile(
        2000, 0.5e-6, rms_height=5e-6, correlation_length=30e-6, rng=rng
    )
    ax = plot_profile(p)
    assert "[µm]" in ax.get_xlabel() and "[µm]" in ax.get_ylabel()
    assert_allclose(ax.lines[0].get_xdata()[-1], 1999 * 0.5, rtol=1e-12)
    res = characterise(p, contact_length=20e-6)
    ax2 = plot_angle_pdf(res)
    assert "[°]" in ax2.get_xlabel()
    _fig, ax3 = plt.subplots()
    assert plot_angle_pdf(res.angles_deg, ax=ax3) is ax3
    plt.close("all")


def test_roughness_json_is_standard_with_the_documented_keys():
    import json

    from microimpact.io.profiles import Profile
    from microimpact.surface.roughness import characterise

    x = np.arange(2000) * 0.5e-6
    z = 1e-6 * np.sin(2 * np.pi * x / 50e-6)  # 20 whole periods
    ch = characterise(Profile(x, z), contact_length=20e-6)
    units = {"x_unit": "um", "x_unit_from": "header"}
    out = json.loads(ch.to_json(units=units))
    assert out["schema"] == "microimpact.roughness/1" and out["units"] == units
    assert set(out["angles"]) == {
        "mean_deg", "std_deg", "skewness", "kurtosis", "min_deg", "max_deg",
        "pdf_edges_deg", "pdf_density_per_deg",
    }  # fmt: skip
    assert (
        len(out["angles"]["pdf_edges_deg"])
        == len(out["angles"]["pdf_density_per_deg"]) + 1
    )
    # Ra of a sine of amplitude 1 um over whole periods: 2/pi um
    np.testing.assert_allclose(out["profile"]["Ra_um"], 2 / np.pi, rtol=2e-3)
    # one angle only: skewness and kurtosis are NaN -> null, never NaN in the text
    short = characterise(Profile(x[:80], z[:80]), contact_length=20e-6)
    text = short.to_json()
    assert "NaN" not in text and json.loads(text)["angles"]["kurtosis"] is None


def test_a_contact_length_in_metres_is_named_as_such():
    """`contact_length_um = 20e-6` (metres typed as µm) is refused with the guess;
    a merely too short length gets no guess."""
    x = np.linspace(0.0, 2e-3, 2001)  # 1 µm sampling
    p = Profile(x=x, z=1e-7 * np.sin(x * 3e4))
    with pytest.raises(
        ProfileFormatError, match=r"was it given in metres\? 2e-05 m is 20 µm"
    ):
        surface_angles(p, contact_length=20e-6 * 1e-6)
    with pytest.raises(ProfileFormatError) as err:
        surface_angles(p, contact_length=0.5e-6)
    assert "metres" not in str(err.value)
