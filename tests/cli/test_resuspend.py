"""``microimpact resuspend`` and ``microimpact.resuspend``: files, CF, the captured
chain, the Monte Carlo estimate against the quadrature, and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import netCDF4
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import microimpact as mi
from microimpact.cli import main
from microimpact.physics import resuspension as rnr
from microimpact.pipeline.resuspension import resuspension_section_html

AIR = {"density_kg_m3": 1.2, "kinematic_viscosity_m2_s": 1.5e-5}
FLUID = "fluid = { density_kg_m3 = 1.2, kinematic_viscosity_m2_s = 1.5e-5 }"

PARTICLES_ONLY = f"""name = "dust"
seed = 11
[particles]
distribution = "lognormal"
median_um = 8
geometric_std = 1.4
[resuspension]
source = "particles"
friction_velocity_m_s = [0.3, 0.8, 2.0]
exposure_s = [1.0, 2.0, 1.0]
surface_energy_j_m2 = 0.56
{FLUID}
diameter_classes = 5
monte_carlo_samples = 20000
"""

IMPACT = """seed = 5
samples = 400
[particles]
distribution = "normal"
mean_um = 12
std_um = 2
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {law = "power", a_m_s = 0.5, b = -1.5, d_ref_um = 12}
friction = 0.2
[[surfaces]]
name = "flat"
kind = "smooth"
[sweep]
speed_m_s = [0.2, 0.4, 0.6, 50.0]
angle_deg = [90]
"""

CAPTURED = (
    IMPACT
    + """[resuspension]
source = "captured"
friction_velocity_m_s = [0.5, 1.5]
exposure_s = 1.0
surface_energy_j_m2 = 0.56
fluid = { name = "air", temperature_k = 293.15, pressure_pa = 101325 }
diameter_classes = 4
"""
)


def _run(tmp_path, text, name="s.toml", extra=()):
    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    return main(["resuspend", str(path), "--out", str(out), *extra]), out


def test_particles_only_scenario_writes_the_files(tmp_path):
    rc, out = _run(tmp_path, PARTICLES_ONLY)
    assert rc == 0
    assert {"resuspension.csv", "resuspension.nc", "resuspension.png"} <= {
        p.name for p in out.iterdir()
    }
    table = pd.read_csv(out / "resuspension.csv")
    assert {"friction_velocity_m_s", "remaining_fraction"} <= set(table.columns)
    whole = table[table["diameter_um"].isna()]
    assert len(whole) == 3 and len(table) == 3 + 3 * 5
    # per class: the physics function at the class diameter, the same ramp
    per_class = table[table["diameter_um"].notna()]
    one = per_class[per_class["step"] == 0]
    d_m = one["diameter_um"].to_numpy() * 1e-6
    want = rnr.remaining_fraction_ramp(
        0.5 * d_m, [0.3, 0.8, 2.0], [1.0, 2.0, 1.0], 1.2, 1.5e-5, 0.56
    )[:, 0]
    assert_allclose(one["remaining_fraction"], want, rtol=1e-12)
    # the population is the mean over the equiprobable classes
    per = per_class.groupby("step")["remaining_fraction"]
    assert_allclose(whole["remaining_fraction"], per.mean().to_numpy(), rtol=1e-12)


def _cf_messages(path, tmp_path):
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    report_path = tmp_path / "cf.json"
    ComplianceChecker.run_checker(
        str(path), ["cf:1.10"], 0, "normal",
        output_filename=str(report_path), output_format="json",
    )  # fmt: skip
    report = json.loads(report_path.read_text())["cf:1.10"]
    return [
        f"{r['name']}: {m}"
        for level in ("high", "medium")
        for r in report[f"{level}_priorities"]
        for m in r["msgs"]
    ]


def test_captured_chain_end_to_end_and_cf(tmp_path):
    pytest.importorskip("compliance_checker")
    rc, out = _run(tmp_path, CAPTURED)
    assert rc == 0
    assert _cf_messages(out / "resuspension.nc", tmp_path) == []
    # the report: one page holding the resuspension section and its figure
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count('<section id="resuspension">') == 1
    assert "data:image/png;base64," in page and "Remaining fraction" in page
    with netCDF4.Dataset(out / "resuspension.nc") as ds:
        for v in ds.variables.values():
            assert "long_name" in v.ncattrs()
        capture = ds["capture_fraction"][:]  # (surface, speed, angle, class)
        weights = ds["deposited_probability"][:]
        remaining = ds["remaining_fraction"][:]
    # deposited weights: class probability times its capture probability
    c = np.asarray(capture[0, :, 0, :])
    with np.errstate(invalid="ignore"):
        assert_allclose(
            np.asarray(weights[0, :, 0, :])[:3], (c / c.sum(1, keepdims=True))[:3]
        )
    # at 50 m/s nothing is captured: no deposited population to resuspend
    assert np.all(np.isnan(np.asarray(remaining)[0, 3, 0]))
    assert np.all(np.isfinite(np.asarray(remaining)[0, :3, 0]))


def test_capture_independent_of_diameter_gives_the_particles_result(tmp_path):
    flat = CAPTURED.replace(
        'v_c = {law = "power", a_m_s = 0.5, b = -1.5, d_ref_um = 12}', "v_c = 0.6"
    ).replace("k2 = 0.05", "k2 = 0.0")
    path = tmp_path / "flat.toml"
    path.write_text(flat)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rnr.AdhesionRangeWarning)
        cap = mi.resuspend(path)
        spec = dict(
            source="particles", friction_velocity_m_s=[0.5, 1.5], exposure_s=1.0,
            surface_energy_j_m2=0.56, diameter_classes=4,
            fluid={"name": "air", "temperature_k": 293.15, "pressure_pa": 101325},
        )  # fmt: skip
        dep = mi.resuspend(path, spec)
    got = cap.dataset["remaining_fraction"].values[0, :3, 0]
    assert_allclose(got, np.broadcast_to(dep.dataset["remaining_fraction"], got.shape))


@pytest.mark.parametrize(
    ("ramp", "exposures"),
    [("[0.3, 0.8, 2.0]", "[1.0, 2.0, 1.0]"), ("[0.8, 0.8, 0.8]", "[1e3, 1.0, 1.0]")],
)
def test_monte_carlo_agrees_with_the_quadrature(tmp_path, ramp, exposures):
    path = tmp_path / "p.toml"
    text = PARTICLES_ONLY.replace("[0.3, 0.8, 2.0]", ramp)
    text = text.replace("diameter_classes = 5", "diameter_classes = 40")
    path.write_text(text.replace("[1.0, 2.0, 1.0]", exposures))
    ds = mi.resuspend(path).dataset
    quad = ds["remaining_fraction"].values
    mc, se = ds["remaining_fraction_mc"].values, ds["remaining_fraction_mc_se"].values
    assert np.all(se > 0)
    assert np.all(np.abs(mc - quad) < 4 * se), (mc - quad) / se
    # reproducible from the seed, and a new seed gives a new estimate
    again = mi.resuspend(path).dataset["remaining_fraction_mc"].values
    assert np.array_equal(mc, again)
    other = mi.resuspend(path, seed=12).dataset["remaining_fraction_mc"].values
    assert not np.array_equal(mc, other)


def test_engine_per_particle_capture_agrees_with_the_quadrature(tmp_path):
    """The engine's own impacts, the captured ones with their diameters and each
    its adhesion draw, against the quadrature over 40 diameter classes weighted by
    their capture (exact here: smooth wall, normal incidence)."""
    text = CAPTURED.replace("diameter_classes = 4", "diameter_classes = 40")
    path = tmp_path / "c.toml"
    path.write_text(text + "monte_carlo_samples = 20000\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rnr.AdhesionRangeWarning)
        ds = mi.resuspend(path).dataset
    quad = ds["remaining_fraction"].values[0, :3, 0]
    mc = ds["remaining_fraction_mc"].values[0, :3, 0]
    se = ds["remaining_fraction_mc_se"].values[0, :3, 0]
    assert np.all(np.isfinite(mc)) and np.all(se > 0)
    assert np.all(np.abs(mc - quad) < 4 * se), (mc - quad) / se
    # nothing captured at 50 m/s: no estimate
    assert np.all(np.isnan(ds["remaining_fraction_mc"].values[0, 3, 0]))


def test_report_section_is_one_html_section(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PARTICLES_ONLY.replace("monte_carlo_samples = 20000", ""))
    html = resuspension_section_html(mi.resuspend(path))
    assert html.startswith('<section id="resuspension">')
    assert html.endswith("</section>") and "data:image/png;base64," in html


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("[resuspension]", "[other]"), "unknown key 'other'"),
        (("[resuspension]", "[resuspension_]"), "did you mean 'resuspension'"),
        (('source = "particles"', 'source = "sticky"'), "resuspension.source"),
        (("[0.3, 0.8, 2.0]", "[0.3, -0.8]"), "friction_velocity_m_s[1]"),
        (("[1.0, 2.0, 1.0]", "[1.0, 2.0]"), "one per step (3); got 2"),
        (("density_kg_m3 = 1.2, ", ""), "resuspension.fluid.density_kg_m3"),
        (("surface_energy_j_m2 = 0.56", "surface_energy_j_m2 = 0"), "must be > 0"),
        (("diameter_classes = 5", 'adhesion = "biasi"'), "did you mean 'biasi2001'"),
        (("diameter_classes = 5", "adhesion = { median = 0.01 }"), "spread"),
        (("median_um = 8", "median_um = 90"), "resuspension.adhesion"),
        (("median_um = 8", "median_um = 30"), "resuspension.monte_carlo_samples"),
        (('source = "particles"', 'source = "captured"'), "coefficients"),
        (("friction_velocity_m_s", "velocity_m_s"), "did you mean"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, change, message):
    assert change[0] in PARTICLES_ONLY
    text = PARTICLES_ONLY.replace(*change)
    rc, _ = _run(tmp_path, text)
    lines = capsys.readouterr().err.strip().splitlines()
    errors = [line for line in lines if ": error: " in line]
    assert rc == 2, lines
    assert len(errors) == 1 and message in errors[0], lines
    err = errors[0]
    assert "s.toml" in err
    assert "np.float64" not in err and "None" not in err


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
    derandomize=True,
)
@given(
    diameter_um=st.floats(2.0, 19.0),
    steps=st.lists(
        st.tuples(st.floats(0.0, 5.0), st.floats(0.0, 20.0)), min_size=1, max_size=4
    ),
    gamma=st.floats(0.01, 2.0),
)
def test_properties_through_the_api(tmp_path, diameter_um, steps, gamma):
    u = [s[0] for s in steps]
    t = [s[1] for s in steps]
    text = f"""[particles]
distribution = "monodisperse"
diameter_um = {diameter_um!r}
[resuspension]
friction_velocity_m_s = {u!r}
exposure_s = {t!r}
surface_energy_j_m2 = {gamma!r}
{FLUID}
"""
    path = tmp_path / "h.toml"
    path.write_text(text)
    r = mi.resuspend(path).dataset["remaining_fraction"].values
    assert np.all((r >= 0) & (r <= 1))
    assert np.all(np.diff(r) <= 1e-9)  # each step acts on what the earlier left
    for k, (uk, tk) in enumerate(steps):  # a still or instant step removes nothing
        if (uk == 0 or tk == 0) and k > 0:
            assert_allclose(r[k], r[k - 1], atol=1e-9)


def test_subprocess_smoke(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PARTICLES_ONLY.replace("monte_carlo_samples = 20000", ""))
    done = subprocess.run(
        [sys.executable, "-m", "microimpact", "resuspend", str(path), "--out",
         str(tmp_path / "o")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "o" / "resuspension.csv").is_file()


def test_the_surface_energy_from_the_capture_law(tmp_path):
    # issue 32 leftover (a): without surface_energy_j_m2 the thornton_ning law's
    # work of adhesion w is gamma (the same pull-off force 1.5 pi w r); from two
    # materials' surface energies w = 2 sqrt(g1 g2): polystyrene on itself,
    # 40.7 mJ/m2 each (S. Wu 1982, physics/adhesion.py), so w = 2 x 0.0407
    from microimpact.errors import ScenarioError
    from microimpact.physics.coefficients import ThorntonNingLaw
    from microimpact.scenario.resuspension import resuspension_from_dict

    table = {"friction_velocity_m_s": 1.0, "exposure_s": 1.0, "fluid": AIR}
    polystyrene = {"law": "thornton_ning", "particle": "ps", "surface": "ps"}
    res = resuspension_from_dict(
        {"coefficients": {"v_c": polystyrene}, "resuspension": table}
    )
    assert_allclose(res.surface_energy_j_m2, 2 * 0.0407, rtol=1e-12)
    assert "thornton_ning" in res.surface_energy_source
    assert res.describe()["surface_energy_source"] == res.surface_energy_source
    given = {**polystyrene, "work_of_adhesion_J_m2": 0.4}  # the law's own w
    res = resuspension_from_dict(
        {"coefficients": {"v_c": given}, "resuspension": table}
    )
    assert res.surface_energy_j_m2 == 0.4
    law = ThorntonNingLaw(density=1050.0, contact_modulus=1e9, work_of_adhesion=0.3)
    res = resuspension_from_dict({"resuspension": table}, capture_law=law)
    assert res.surface_energy_j_m2 == 0.3  # a Scenario object's capture law
    res = resuspension_from_dict(
        {
            "coefficients": {"v_c": given},
            "resuspension": {**table, "surface_energy_j_m2": 0.56},
        }
    )
    assert (res.surface_energy_j_m2, res.surface_energy_source) == (0.56, "given")
    # without a thornton_ning law (or with w = 0) the key is required
    for v_c in (0.2, {**polystyrene, "work_of_adhesion_J_m2": 0.0}):
        with pytest.raises(
            ScenarioError, match=r"s\.toml: resuspension\.surface_energy_j_m2.*thornton"
        ):
            resuspension_from_dict(
                {"coefficients": {"v_c": v_c}, "resuspension": table}, source="s.toml"
            )
    # through the study: the quadrature with gamma = 2 x 0.0407
    text = PARTICLES_ONLY.replace("surface_energy_j_m2 = 0.56\n", "").replace(
        "monte_carlo_samples = 20000", ""
    )
    text += (
        "[coefficients]\nk1 = 4.0\nk2 = 0.05\n"
        'v_c = { law = "thornton_ning", particle = "ps", surface = "ps" }\n'
    )
    path = tmp_path / "ps.toml"
    path.write_text(text)
    result = mi.resuspend(path)
    assert_allclose(result.spec.surface_energy_j_m2, 2 * 0.0407, rtol=1e-12)
    d = result.dataset["diameter"].values[0]
    want = rnr.remaining_fraction_ramp(
        d / 2, [0.3, 0.8, 2.0], [1.0, 2.0, 1.0], 1.2, 1.5e-5, 2 * 0.0407,
        outside="ignore",
    )  # fmt: skip
    assert_allclose(
        result.dataset["remaining_fraction_class"].values[0], want, rtol=1e-9
    )
    assert (
        "thornton_ning"
        in json.loads(result.dataset.attrs["resuspension"])["surface_energy_source"]
    )
    # a Scenario object and the table as a dict: the Scenario's capture law
    scenario = mi.Scenario(
        name="ps",
        particles=mi.monodisperse(8.0),
        coefficients=mi.ImpactCoefficients(
            k1=4.0, k2=0.05, v_c=ThorntonNingLaw(1050.0, 3e9, 0.2), friction=0.2
        ),
    )
    result = mi.resuspend(scenario, {**table, "source": "particles"})
    assert result.spec.surface_energy_j_m2 == 0.2


def test_the_monte_carlo_names_the_range_its_particles_leave():
    # issue 32 leftover (b): per-particle draws with Biasi adhesion warn with the
    # share outside the fitted diameters and the range; inside it, silence
    from microimpact.analysis.resuspension import sample_remaining_fraction
    from microimpact.scenario.resuspension import ResuspensionSpec

    spec = ResuspensionSpec(
        friction_velocities_m_s=(1.0,),
        exposures_s=(1.0,),
        surface_energy_j_m2=0.56,
        density_kg_m3=1.2,
        kinematic_viscosity_m2_s=1.5e-5,
    )
    with pytest.warns(
        rnr.AdhesionRangeWarning,
        match=r"^1 of the 3 particles \(33\.3 %\).*0\.2 to 20 µm",
    ):
        sample_remaining_fraction(np.array([2e-6, 5e-6, 30e-6]), spec, rng=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rnr.AdhesionRangeWarning)
        sample_remaining_fraction(np.array([2e-6, 5e-6, 19e-6]), spec, rng=1)
