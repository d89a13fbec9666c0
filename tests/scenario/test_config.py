"""Tests of microimpact.scenario.file: TOML scenario files -> Scenario.

Every documented error has one ``pytest.raises(ScenarioError, match=...)`` and the
corpus ``tests/data/bad_scenarios/*.toml`` (first line ``# expect: <key path>``)
checks that each broken file gives one one-line message naming that key path.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import ScenarioError
from microimpact.scenario.file import (
    PRESET_DIR,
    PRESETS,
    list_presets,
    outputs_from_dict,
    outputs_from_toml,
)
from microimpact.scenario.outputs import Outputs
from microimpact.scenario.scenario import (
    Scenario,
    load_preset,
    scenario_from_dict,
    scenario_from_toml,
)
from microimpact.units import deg_to_rad, um_to_m

BAD_DIR = Path(__file__).parents[1] / "data" / "bad_scenarios"
BAD_FILES = sorted(BAD_DIR.glob("*.toml"))

MINIMAL = """
[particles]
distribution = "normal"
mean_um = 50.0
std_um = 10.0

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2

[sweep]
speed_m_s = [0.5, 1.0]
"""


def write(tmp_path, text, name="scenario.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def minimal(**overrides):
    """The MINIMAL scenario as a dict with some tables replaced."""
    data = {
        "particles": {"distribution": "normal", "mean_um": 50.0, "std_um": 10.0},
        "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
        "sweep": {"speed_m_s": [0.5, 1.0]},
    }
    data.update(overrides)
    return data


# --------------------------------------------------------------------- parsing
def test_minimal_file_and_defaults(tmp_path):
    sc = scenario_from_toml(write(tmp_path, MINIMAL))
    assert isinstance(sc, Scenario)
    assert sc.name == "scenario"  # the file stem
    assert sc.source == str(tmp_path / "scenario.toml")
    assert sc.samples == 4000
    assert sc.seed is None
    assert sc.sampling == "mc"
    assert sc.shadowing == "reject"
    assert sc.precision is None
    assert sc.particle_roughness is None
    assert sc.speed_spread == 0.0
    assert sc.qmc_replicates == 8
    assert_allclose(sc.confidence, 0.95, rtol=0)
    assert_allclose(sc.reference_angle_deg, 85.0, rtol=0)
    assert sc.capture_quantiles == (0.5,)
    assert_allclose(sc.speeds_m_s, [0.5, 1.0], rtol=0)
    assert_allclose(sc.angles_deg, [90.0], rtol=0)
    assert [s.name for s in sc.surfaces] == ["smooth"]
    assert sc.surfaces[0].smooth
    # output settings are not physics: they are the Study's (default Outputs)
    assert not hasattr(sc, "experiments") and not hasattr(sc, "config")
    assert outputs_from_dict(minimal()) == Outputs()
    # coefficients: numbers are constant laws [m/s]; paper's p = q = 1 by default
    k1, k2, v_c = sc.coefficients.evaluate(np.array([um_to_m(30.0), um_to_m(70.0)]))
    assert_allclose(k1, 4.0, rtol=1e-15)
    assert_allclose(k2, 0.05, rtol=1e-15)
    assert_allclose(v_c, 0.2, rtol=1e-15)
    assert sc.coefficients.p == 1.0 and sc.coefficients.q == 1.0
    assert math.isinf(sc.coefficients.friction)
    # the normal distribution is N(50 um, 10 um) truncated to d > 0
    from scipy import stats

    q = np.array([0.1, 0.5, 0.9])
    oracle = stats.truncnorm(-5.0, np.inf, loc=50, scale=10).ppf(q)
    assert_allclose(sc.particles.ppf(q), um_to_m(oracle), rtol=1e-9)


def test_every_top_level_key(tmp_path):
    text = """
name = "full"
description = "every key"
seed = 7
samples = 1234
shadowing = "weighted"
sampling = "mc"
qmc_replicates = 4
confidence = 0.9
reference_angle_deg = 80
capture_quantiles = [0.1, 0.5, 0.9]

[precision]
statistic = "e_mean"
half_width = 0.02
max_samples = 50000
min_samples = 500
""" + MINIMAL.replace(
        "speed_m_s = [0.5, 1.0]",
        "speed_m_s = [0.5, 1.0]\nangle_deg = [30, 80]\nspeed_spread = 0.1",
    )
    sc = scenario_from_toml(write(tmp_path, text))
    assert (sc.name, sc.description, sc.seed, sc.samples) == (
        "full",
        "every key",
        7,
        1234,
    )
    assert (sc.shadowing, sc.sampling, sc.qmc_replicates) == ("weighted", "mc", 4)
    assert_allclose([sc.confidence, sc.reference_angle_deg], [0.9, 80.0], rtol=0)
    assert sc.capture_quantiles == (0.1, 0.5, 0.9)
    p = sc.precision
    assert (p.statistic, p.max_samples, p.min_samples) == ("e_mean", 50000, 500)
    assert_allclose(p.half_width, 0.02, rtol=0)
    assert_allclose(sc.angles_deg, [30.0, 80.0], rtol=0)
    assert_allclose(sc.speed_spread, 0.1, rtol=0)


def test_reference_angle_can_be_disabled():
    sc = scenario_from_dict(minimal(reference_angle_deg=False))
    assert sc.reference_angle_deg is None


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        (0.7, [0.7]),
        ({"start": 0.1, "stop": 0.5, "num": 5}, [0.1, 0.2, 0.3, 0.4, 0.5]),
        ({"start": 0.1, "stop": 0.3, "step": 0.1}, [0.1, 0.2, 0.3]),  # stop included
        ({"start": 0.1, "stop": 0.35, "step": 0.1}, [0.1, 0.2, 0.3]),
        ({"start": 0.2, "stop": 0.2, "num": 1}, [0.2]),
        (
            [{"start": 0.05, "stop": 0.07, "step": 0.01}, 0.5, 1.0],
            [0.05, 0.06, 0.07, 0.5, 1.0],
        ),
    ],
)
def test_sweep_ranges(spec, expected):
    sc = scenario_from_dict(minimal(sweep={"speed_m_s": spec}))
    assert_allclose(sc.speeds_m_s, expected, rtol=1e-12)
    assert len(sc.speeds_m_s) == len(expected)


def test_angle_range_from_10_to_90():
    sc = scenario_from_dict(
        minimal(
            sweep={"speed_m_s": 1.0, "angle_deg": {"start": 10, "stop": 90, "step": 5}}
        )
    )
    assert_allclose(sc.angles_deg, np.arange(10, 91, 5), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("table", "ppf_oracle"),
    [
        (
            {"distribution": "lognormal", "median_um": 40.0, "geometric_std": 1.5},
            lambda q: (
                __import__("scipy.stats").stats.lognorm(np.log(1.5), scale=40).ppf(q)
            ),
        ),
        (
            {"distribution": "uniform", "min_um": 10.0, "max_um": 30.0},
            lambda q: 10 + 20 * q,
        ),
        (
            {"distribution": "monodisperse", "diameter_um": 42.0},
            lambda q: np.full_like(q, 42.0),
        ),
        (
            {"distribution": "histogram", "edges_um": [10, 20, 30], "counts": [1, 3]},
            lambda q: np.where(q < 0.25, 10 + 40 * q, 20 + (q - 0.25) / 0.75 * 10),
        ),
    ],
)
def test_particle_distributions(table, ppf_oracle):
    sc = scenario_from_dict(minimal(particles=table))
    q = np.array([0.1, 0.3, 0.5, 0.8])
    assert_allclose(sc.particles.ppf(q), um_to_m(ppf_oracle(q)), rtol=1e-9)


def test_empirical_inline_and_file_with_unit(tmp_path):
    inline = scenario_from_dict(
        minimal(
            particles={"distribution": "empirical", "diameters_um": [30.0, 10.0, 20.0]}
        )
    )
    assert_allclose(inline.particles.atoms, um_to_m([10.0, 20.0, 30.0]), rtol=1e-15)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "d.csv").write_text("id,d_mm\n1,0.010\n2,0.030\n3,0.020\n")
    text = MINIMAL.replace(
        'distribution = "normal"\nmean_um = 50.0\nstd_um = 10.0',
        'distribution = "empirical"\nfile = "data/d.csv"\ncolumn = "d_mm"\nunit = "mm"',
    )
    sc = scenario_from_toml(write(tmp_path, text))
    assert_allclose(sc.particles.atoms, um_to_m([10.0, 20.0, 30.0]), rtol=1e-12)


def test_relative_paths_resolve_from_the_scenario_folder(tmp_path, monkeypatch):
    sub = tmp_path / "study"
    sub.mkdir()
    (sub / "angles.csv").write_text("# angles\n-10\n0\n10\n20\n")
    (sub / "exp.csv").write_text("angle_deg,e\n10,0.5\n")
    text = (
        MINIMAL
        + """
[[surfaces]]
name = "measured"
kind = "angles"
file = "angles.csv"

[outputs]
figures = ["png", "pdf"]
experiments = "exp.csv"
"""
    )
    path = write(sub, text)
    monkeypatch.chdir(tmp_path)  # the working directory must not matter
    sc = scenario_from_toml(Path("study") / "scenario.toml")
    atoms = sc.surfaces[0].angles.table().values
    assert_allclose(np.unique(atoms), deg_to_rad([-10.0, 0.0, 10.0, 20.0]), rtol=1e-9)
    outputs = outputs_from_toml(Path("study") / "scenario.toml")
    assert outputs.experiments == (path.resolve().parent / "exp.csv",)
    assert outputs.figures == ("png", "pdf")


def test_base_dir_for_dicts(tmp_path):
    (tmp_path / "a.csv").write_text("5\n-5\n")
    data = minimal(surface={"kind": "angles", "file": "a.csv"})
    sc = scenario_from_dict(data, base_dir=tmp_path)
    assert sc.surfaces[0].name == "angles"  # a single [surface] is named by its kind
    assert_allclose(
        np.unique(sc.surfaces[0].angles.table().values),
        deg_to_rad([-5.0, 5.0]),
        rtol=1e-12,
    )


def test_surface_kinds():
    data = minimal(
        surfaces=[
            {"name": "flat", "kind": "smooth"},
            {"name": "gauss", "kind": "normal", "std_deg": 10.0, "mean_deg": 2.0},
            {"name": "inline", "kind": "angles", "angles_deg": [-3.0, 3.0]},
            {
                "name": "laplace",
                "kind": "scipy",
                "distribution": "laplace",
                "loc_deg": 0.0,
                "scale_deg": 4.0,
            },
            {
                "name": "synthetic",
                "kind": "synthetic",
                "profile": "gaussian",
                "n_points": 4000,
                "dx_um": 1.0,
                "rms_height_um": 2.0,
                "correlation_length_um": 40.0,
                "seed": 3,
                "contact_length_um": 10.0,
            },
        ],
        particle_roughness={"kind": "normal", "std_deg": 3.0},
    )
    sc = scenario_from_dict(data)
    names = [s.name for s in sc.surfaces]
    assert names == ["flat", "gauss", "inline", "laplace", "synthetic"]
    assert sc.surfaces[0].angles is None
    assert_allclose(sc.surfaces[1].angles.mean(), deg_to_rad(2.0), rtol=1e-6)
    assert_allclose(sc.surfaces[1].angles.std(), deg_to_rad(10.0), rtol=1e-6)
    # Laplace: std = sqrt(2) * scale
    assert_allclose(
        sc.surfaces[3].angles.std(), deg_to_rad(4.0 * np.sqrt(2)), rtol=1e-4
    )
    # Gaussian profile: RMS slope sqrt(2) sigma / ell = 0.0707 -> angles of a few deg
    s = np.rad2deg(sc.surfaces[4].angles.std())
    assert 1.0 < s < 8.0
    assert_allclose(sc.particle_roughness.std(), deg_to_rad(3.0), rtol=1e-6)


def test_smooth_particle_roughness_is_none():
    sc = scenario_from_dict(minimal(particle_roughness={"kind": "smooth"}))
    assert sc.particle_roughness is None


def test_profile_surface_from_file(tmp_path):
    x = np.arange(0, 400.0, 0.5)
    z = 0.25 * x  # a ramp of slope 0.25: every slope angle is atan(0.25)
    np.savetxt(
        tmp_path / "p.csv",
        np.column_stack([x, z]),
        delimiter=",",
        header="x_um,z_um",
        comments="",
    )
    data = minimal(
        surface={
            "kind": "profile",
            "file": "p.csv",
            "contact_length_um": 20.0,
            "detrend": "none",
        }
    )
    sc = scenario_from_dict(data, base_dir=tmp_path)
    atoms = sc.surfaces[0].angles.table().values
    assert_allclose(atoms, np.arctan(0.25), rtol=1e-9)


def test_coefficient_laws_set_and_friction():
    sc = scenario_from_dict(
        minimal(
            coefficients={
                "k1": {"law": "power", "a_m_s": 2.0, "b": -0.5, "d_ref_um": 50.0},
                "k2": {"law": "constant", "value_m_s": 0.05},
                "v_c": 0.2,
                "p": 2.0,
                "q": 0.5,
                "friction": "inf",
            }
        )
    )
    k1, _, _ = sc.coefficients.evaluate(np.array([um_to_m(200.0)]))
    assert_allclose(k1, 2.0 * 4.0**-0.5, rtol=1e-12)
    assert (sc.coefficients.p, sc.coefficients.q) == (2.0, 0.5)
    assert math.isinf(sc.coefficients.friction)
    over = scenario_from_dict(
        minimal(
            coefficients={
                "set": "li2000_sst_silicon_illustrative",
                "friction": 0.3,
                "k1": 7.0,
            }
        )
    )
    assert_allclose(over.coefficients.friction, 0.3, rtol=0)
    k1, _, v_c = over.coefficients.evaluate(np.array([um_to_m(52.8)]))
    assert_allclose(k1, 7.0, rtol=0)
    assert_allclose(v_c, 0.20, rtol=1e-12)  # the set's v_c(52.8 um)


# --------------------------------------------------------------------- errors
def check(data_or_path, match, *, base_dir=None):
    with pytest.raises(ScenarioError, match=match) as info:
        if isinstance(data_or_path, Path):
            scenario_from_toml(data_or_path)
        else:
            scenario_from_dict(data_or_path, source="s.toml", base_dir=base_dir)
    assert "\n" not in str(info.value)
    return info.value


def test_error_unknown_key_did_you_mean():
    err = check(
        {**minimal(), "sead": 1},
        r"^s\.toml: sead: unknown key 'sead' "
        r"\(did you mean 'seed'\?\)",
    )
    assert err.field == "sead" and err.source == "s.toml"


def test_error_unknown_nested_key():
    check(
        minimal(particles={"distribution": "normal", "mean_um": 5, "stdev_um": 1}),
        r"particles\.stdev_um: unknown key 'stdev_um' \(did you mean 'std_um'\?\)",
    )


def test_error_missing_required_key():
    check(
        minimal(particles={"distribution": "normal", "mean_um": 5}),
        r"particles\.std_um: missing required key",
    )


def test_error_missing_table():
    data = minimal()
    del data["coefficients"]
    check(data, r"coefficients: missing required table")


def test_error_wrong_type():
    check(minimal(samples="many"), r"samples: must be an integer >= 1; got 'many'")
    check(
        minimal(particles={"distribution": "normal", "mean_um": "5", "std_um": 1}),
        r"particles\.mean_um: must be a number; got a string '5'",
    )
    check(minimal(samples=True), r"samples: must be an integer >= 1; got True")


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_error_negative_nan_inf(bad):
    check(
        minimal(particles={"distribution": "normal", "mean_um": 50, "std_um": bad}),
        r"particles\.std_um: must be",
    )


def test_error_empty_sweep():
    check(minimal(sweep={"speed_m_s": []}), r"sweep\.speed_m_s: must not be empty")


@pytest.mark.parametrize("angle", [0.0, -5.0, 90.5])
def test_error_angle_outside_0_90(angle):
    check(
        minimal(sweep={"speed_m_s": 1.0, "angle_deg": [45.0, angle]}),
        r"sweep\.angle_deg: .* must be in \(0, 90\] deg .*\(the 2nd of 2 values\)",
    )


def test_error_negative_speed_names_its_position_not_a_value():
    # found by a user: "got -2 (value 0)" read as if the value were 0
    err = check(minimal(sweep={"speed_m_s": [1.0, 3.0, -2.0]}), r"sweep\.speed_m_s: ")
    assert "got -2 (the 3rd of 3 values)" in str(err)
    assert "(value" not in str(err)


def test_error_directory_given_as_a_file(tmp_path):
    # found by a user: a folder given as a data file was "file not found"
    (tmp_path / "data").mkdir()
    err = check(
        minimal(particles={"distribution": "empirical", "file": "data"}),
        r"particles\.file: 'data' is a directory, not a file \(resolved to .*data\)",
        base_dir=tmp_path,
    )
    assert "not found" not in str(err)


def test_error_missing_file():
    check(
        minimal(particles={"distribution": "empirical", "file": "nope.csv"}),
        r"particles\.file: file not found: 'nope\.csv' \(resolved to .*nope\.csv\)",
    )


def test_error_bad_data_file_names_both_files(tmp_path):
    (tmp_path / "d.csv").write_text("diameter_um\n10\n-3\n")
    err = check(
        minimal(particles={"distribution": "empirical", "file": "d.csv"}),
        r"^s\.toml: particles\.file: .*d\.csv:3: ",
        base_dir=tmp_path,
    )
    assert "-3" in str(err)


def test_error_toml_syntax_with_line_and_column(tmp_path):
    path = write(tmp_path, MINIMAL.replace("std_um = 10.0", "std_um = = 10.0"))
    line = MINIMAL.splitlines().index("std_um = 10.0") + 1
    check(path, rf"scenario\.toml:{line}: TOML syntax error: .*\(column \d+\)")


def test_error_file_not_found(tmp_path):
    check(tmp_path / "missing.toml", r"missing\.toml: scenario file not found")


def test_error_not_utf8(tmp_path):
    path = tmp_path / "latin.toml"
    path.write_bytes(b'name = "caf\xe9"\n')
    check(path, r"latin\.toml: not UTF-8 text")


def test_error_factory_message_is_wrapped():
    err = check(
        minimal(particles={"distribution": "uniform", "min_um": 50, "max_um": 10}),
        r"^s\.toml: particles\.max_um: `max_um` must be > `min_um`",
    )
    assert err.field == "particles.max_um"


def test_error_law_parameter():
    check(
        minimal(
            coefficients={"k1": 4.0, "k2": 0.05, "v_c": {"law": "power", "a_m_s": 0.2}}
        ),
        r"coefficients\.v_c\.b: missing required key 'b'",
    )


def test_error_unknown_coefficient_set():
    check(
        minimal(coefficients={"set": "li2000"}),
        r"coefficients\.set: unknown coefficient set 'li2000'",
    )


def test_error_friction():
    check(
        minimal(coefficients={"k1": 4, "k2": 0.05, "v_c": 0.2, "friction": "lots"}),
        r"coefficients\.friction: must be a number >= 0 or 'inf'; got 'lots'",
    )


def test_error_surface_kind_and_duplicates():
    check(
        minimal(surfaces=[{"name": "a", "kind": "rough"}]),
        r"surfaces\[0\]\.kind: must be one of 'smooth', .*got 'rough'",
    )
    check(
        minimal(
            surfaces=[{"name": "a", "kind": "smooth"}, {"name": "a", "kind": "smooth"}]
        ),
        r"surfaces\[1\]\.name: duplicate surface name 'a'",
    )
    check(minimal(surfaces=[]), r"surfaces: must be a non-empty array of tables")


def test_error_range_tables():
    check(
        minimal(sweep={"speed_m_s": {"start": 0.1, "stop": 1.0}}),
        r"sweep\.speed_m_s\.num: give exactly one of 'num' or 'step'",
    )
    check(
        minimal(sweep={"speed_m_s": {"start": 0.1, "stop": 1.0, "step": -0.1}}),
        r"sweep\.speed_m_s\.step: must be > 0",
    )
    check(
        minimal(sweep={"speed_m_s": {"start": 0.1, "stop": 1e9, "step": 1e-6}}),
        r"sweep\.speed_m_s\.step: gives \d+ values, more than 100000",
    )


def test_error_precision_and_options():
    check(minimal(precision={"half_width": 0}), r"precision\.half_width: must be > 0")
    check(
        minimal(precision={"min_samples": 10, "max_samples": 5}),
        r"precision\.min_samples: must be <= max_samples",
    )
    check(minimal(sampling="sobol"), r"sampling: must be one of 'mc', 'qmc'")
    check(minimal(qmc_replicates=1), r"qmc_replicates: must be an integer >= 2")
    check(minimal(confidence=1.0), r"confidence: must be in \(0, 1\)")
    check(minimal(capture_quantiles=0), r"capture_quantiles: must be in \(0, 1\)")


def test_error_outputs():
    check(
        minimal(outputs={"figures": ["gif"]}),
        r"outputs\.figures\[0\]: must be one of 'png'.*got 'gif'",
    )
    check(
        minimal(outputs={"experiments": 3}),
        r"outputs\.experiments: must be a CSV file name or an array of them",
    )
    check(
        minimal(outputs={"report": "yes"}),
        r"outputs\.report: must be true or false; got 'yes'",
    )


def test_outputs_report_key():
    assert outputs_from_dict(minimal(outputs={"report": False})).report is False


def test_error_top_level_not_a_table():
    with pytest.raises(ScenarioError, match="must be a table"):
        scenario_from_dict(["not", "a", "table"])


@pytest.mark.parametrize("path", BAD_FILES, ids=[p.stem for p in BAD_FILES])
def test_bad_scenario_corpus(path):
    first = path.read_text(encoding="utf-8").splitlines()[0]
    m = re.fullmatch(r"# expect: (\S+)", first)
    assert m, f"{path.name}: first line must be '# expect: <key path>'"
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(path))
    assert m.group(1) in msg


def test_corpus_is_large():
    assert len(BAD_FILES) >= 40


# --------------------------------------------------------------------- presets
def test_list_presets_and_files():
    assert list_presets() == sorted(PRESETS)
    assert set(PRESETS) == {
        "sst65-silicon-normal",
        "sst125-silicon-normal",
        "sst76-formica-oblique",
        "lycopodium-formica-oblique",
        "sst76-formica-areal",
    }
    for name, file in PRESETS.items():
        assert (PRESET_DIR / file).is_file()
        assert load_preset(name).name == name
        assert Scenario.from_preset(name).name == name


def test_load_preset_unknown_name():
    with pytest.raises(
        ValueError,
        match=r"`name` must be one of .*did you mean "
        r"'sst65-silicon-normal'",
    ):
        load_preset("sst65-silicon")


def test_examples_are_relative_symlinks_to_the_presets():
    examples = Path(__file__).resolve().parents[2] / "examples"
    for file in PRESETS.values():
        link = examples / file
        assert link.is_symlink()
        target = os.readlink(link)
        assert target == f"../src/microimpact/scenario/presets/{file}"
        assert link.resolve() == (PRESET_DIR / file).resolve()
        a, b = scenario_from_toml(link), scenario_from_toml(PRESET_DIR / file)
        assert_allclose(a.particles.table().values, b.particles.table().values, rtol=0)


# --------------------------------------------------------------------- review fixes
def test_precision_checks_itself():
    from microimpact.scenario.scenario import Precision

    for bad in (True, False):
        with pytest.raises(ScenarioError, match=r"precision\.half_width: must be a"):
            Precision(half_width=bad)
    with pytest.raises(ScenarioError) as info:
        Precision(min_samples=10, max_samples=5)
    assert info.value.field == "precision.min_samples"
    assert "must be <= max_samples (5); got 10" in str(info.value)
    with pytest.raises(ScenarioError, match=r"got 1000 \(the default\)"):
        Precision(max_samples=500)
    assert Precision(max_samples=500, min_samples=500).max_samples == 500


def test_precision_min_above_max_in_a_file():
    err = check(
        minimal(precision={"max_samples": 500}),
        r"^s\.toml: precision\.min_samples: must be <= max_samples \(500\); "
        r"got 1000 \(the default\)$",
    )
    assert err.source == "s.toml"


def test_figure_formats_are_those_save_figure_writes():
    from microimpact._core.formats import FIGURE_FORMATS
    from microimpact.plotting.results import FIGURE_FORMATS as PLOTTED

    assert FIGURE_FORMATS == PLOTTED == ("png", "pdf", "svg")
    data = minimal(outputs={"figures": list(FIGURE_FORMATS)})
    scenario_from_dict(data)  # the [outputs] table is validated with the file
    assert outputs_from_dict(data).figures == ("png", "pdf", "svg")
    for fmt in ("eps", "ps", "jpg", "tif"):
        check(
            minimal(outputs={"figures": ["png", fmt]}),
            rf"outputs\.figures\[1\]: must be one of 'png', 'pdf', 'svg'; got '{fmt}'",
        )


def test_normal_surface_mean_angle_range():
    for bad in (90, -90, 95, -120.5):
        check(
            minimal(
                surfaces=[
                    {"name": "g", "kind": "normal", "std_deg": 5, "mean_deg": bad}
                ]
            ),
            rf"surfaces\[0\]\.mean_deg: must be in \(-90, 90\); got {bad}$",
        )


def test_column_keys_must_be_a_name_or_an_index(tmp_path):
    (tmp_path / "d.csv").write_text("d_um\n10\n20\n30\n")
    (tmp_path / "p.csv").write_text("x_um,z_um\n0,0\n1,1\n2,0\n")
    particles = {"distribution": "empirical", "file": "d.csv", "column": True}
    check(
        minimal(particles=particles),
        r"particles\.column: must be a column name or a 0-based index; got True",
        base_dir=tmp_path,
    )
    surface = {
        "kind": "profile",
        "file": "p.csv",
        "contact_length_um": 1.0,
        "z_column": 1.5,
    }
    check(
        minimal(surface=surface),
        r"surface\.z_column: must be a column name or a 0-based index; got 1\.5",
        base_dir=tmp_path,
    )


@pytest.mark.parametrize("distribution", ["empirical", "histogram"])
@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("unit", "parsec", r"particles\.unit: .*'parsec'"),
        ("column", 1.5, r"particles\.column: must be a column name or a 0-based"),
    ],
)
def test_a_particles_files_keys_are_checked(tmp_path, distribution, key, value, match):
    """The file, column and unit keys of both file-reading populations (one
    shared check)."""
    (tmp_path / "d.csv").write_text("d_um\n10\n20\n30\n")
    particles = {"distribution": distribution, "file": "d.csv", key: value}
    check(minimal(particles=particles), match, base_dir=tmp_path)


def test_missing_kind_names_the_choices():
    check(
        minimal(particles={"mean_um": 50.0}),
        r"particles\.distribution: missing required key \(one of: normal, ",
    )
    check(
        minimal(surfaces=[{"name": "a"}]),
        r"surfaces\[0\]\.kind: missing required key \(one of: smooth, ",
    )


def test_input_errors_are_one_line():
    from microimpact.errors import DataFormatError, InputError

    err = InputError("bad\n  value;\tallowed:\n 1", source="f.csv", field="x", line=3)
    assert str(err) == "f.csv:3: x: bad value; allowed: 1"
    assert "\n" not in str(DataFormatError("a\nb", source="f\nname.csv"))


@pytest.mark.parametrize("delimiter", [";;", '"', "#"])
def test_error_areal_delimiter_names_the_key_and_value(tmp_path, delimiter):
    (tmp_path / "map.txt").write_text("# dx_um = 1\n# dy_um = 1\n1 2\n3 4\n")
    surface = {
        "name": "a",
        "kind": "areal",
        "file": "map.txt",
        "contact_diameter_um": 1.0,
        "delimiter": delimiter,
    }
    err = check(
        minimal(surfaces=[surface]),
        r"^s\.toml: surfaces\[0\]\.delimiter: `delimiter` must be one character",
        base_dir=tmp_path,
    )
    assert repr(delimiter) in str(err)


@pytest.mark.parametrize(("counts", "got"), [([5], 1), ([1, 2, 3], 3)])
def test_histogram_counts_of_the_wrong_length_are_worded_for_a_toml_user(counts, got):
    table = {"distribution": "histogram", "edges_um": [1, 2, 3], "counts": counts}
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(minimal(particles=table))
    msg = str(info.value)
    assert (
        "particles.counts: needs 2 values (one per bin between the 3 edges of "
        f"edges_um); got {got}"
    ) in msg
    assert "len(" not in msg and "`" not in msg
