"""Tests for microimpact._core.toml (the snippets): each snippet loads back through
the scenario parser and gives back what it was written from."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact import scenario_from_dict
from microimpact._core.toml import (
    coefficients_snippet,
    particles_snippet,
    surface_snippet,
    toml_value,
)
from microimpact.physics.coefficients import (
    ConstantLaw,
    ImpactCoefficients,
    PolynomialLaw,
    PowerLaw,
    TableLaw,
)
from microimpact.population import distributions as pd_

PARTICLES = '[particles]\ndistribution = "monodisperse"\ndiameter_um = 50\n'
COEFFICIENTS = "[coefficients]\nk1 = 4.0\nk2 = 0.05\nv_c = 0.2\n"
SWEEP = "[sweep]\nspeed_m_s = [0.5]\n"


def _load(text, tmp_path=None):
    data = tomllib.loads(text)
    return scenario_from_dict(data, base_dir=tmp_path)


@pytest.mark.parametrize(
    "dist",
    [
        pd_.normal_diameters(52.8, 15.3),
        pd_.normal_diameters(52.8, 15.3, min_um=5.0, max_um=120.0),
        pd_.lognormal_diameters(48.123456789, 1.4987654321),
        pd_.uniform_diameters(10.5, 20.25),
        pd_.monodisperse(33.3),
        pd_.empirical_diameters([12.5, 30.1, 30.1, 47.0]),
        pd_.histogram_diameters([10.0, 20.0, 35.0], [4.0, 9.0]),
    ],
    ids=lambda d: d.kind,
)
def test_particles_snippet_round_trips(dist):
    sc = _load(particles_snippet(dist) + COEFFICIENTS + SWEEP)
    back = sc.particles
    assert back.kind == dist.kind
    q = np.linspace(0.01, 0.99, 9)
    assert_allclose(back.ppf(q), dist.ppf(q), rtol=1e-12)


def test_particles_snippet_of_a_fit_and_of_an_empirical_file(tmp_path):
    d = np.random.default_rng(1).lognormal(np.log(50), 0.3, 200)
    fit = pd_.fit_lognormal(d)
    sc = _load(particles_snippet(fit) + COEFFICIENTS + SWEEP)
    assert sc.particles.params["median_um"] == fit.params["median_um"]
    assert sc.particles.params["geometric_std"] == fit.params["geometric_std"]
    f = tmp_path / "d.csv"
    f.write_text("n,size_nm\n" + "".join(f"{i},{v * 1000}\n" for i, v in enumerate(d)))
    text = particles_snippet(
        pd_.empirical_diameters(d), file="d.csv", column="size_nm", unit="nm"
    )
    sc = _load(text + COEFFICIENTS + SWEEP, tmp_path)
    assert_allclose(np.sort(sc.particles.atoms), np.sort(d) * 1e-6, rtol=1e-12)


@pytest.mark.parametrize(
    "laws",
    [
        ImpactCoefficients(
            PowerLaw(3.9941717019956213, -0.49461792599774773, 49.98398975e-6),
            PowerLaw(0.048, -0.91, 50e-6),
            PowerLaw(0.2031, -1.524, 50e-6),
            friction=math.inf,
        ),
        ImpactCoefficients(
            ConstantLaw(10.0),
            PolynomialLaw((0.05, -0.01, 0.001), 50e-6),
            TableLaw([20e-6, 50e-6, 80e-6], [0.5, 0.2, 0.1]),
            p=1.5,
            q=0.8,
            friction=0.15,
        ),
    ],
)
def test_coefficients_snippet_round_trips(laws):
    text = PARTICLES + coefficients_snippet(laws, comment="fitted\nby hand") + SWEEP
    assert text.count("# ") == 2
    back = _load(text).coefficients
    d = np.linspace(15e-6, 90e-6, 13)
    for name in ("k1", "k2", "v_c"):
        assert_allclose(getattr(back, name)(d), getattr(laws, name)(d), rtol=1e-11)
    assert (back.p, back.q, back.friction) == (laws.p, laws.q, laws.friction)


def test_coefficients_snippet_refuses_a_python_function():
    from microimpact.physics.coefficients import CallableLaw

    laws = ImpactCoefficients(CallableLaw(lambda d: d * 0 + 1.0), 0.05, 0.2)
    with pytest.raises(ValueError, match="k1 is a Python function"):
        coefficients_snippet(laws)


def test_surface_snippet_round_trips(tmp_path):
    from microimpact.surface.roughness import write_angle_file

    write_angle_file(tmp_path / "angles.txt", [-3.0, 0.0, 2.5, 7.0], n=None)
    text = PARTICLES + COEFFICIENTS + surface_snippet("angles.txt", name="formica")
    sc = _load(text + SWEEP, tmp_path)
    (surface,) = sc.surfaces
    assert surface.name == "formica"
    atoms = np.sort(np.unique(surface.angles.atoms))
    assert_allclose(np.rad2deg(atoms), [-3.0, 0.0, 2.5, 7.0], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (1e-06, "1e-06"),
        (math.inf, "inf"),
        (True, "true"),
        ('a "b"\\', '"a \\"b\\"\\\\"'),
        (
            {"law": "constant", "value_m_s": 2.0},
            '{ law = "constant", value_m_s = 2.0 }',
        ),
        (np.array([1.0, 2.5]), "[1.0, 2.5]"),
    ],
)
def test_toml_value(value, text):
    assert toml_value(value) == text
    assert tomllib.loads(f"x = {text}")["x"] == pytest.approx(
        value.tolist() if isinstance(value, np.ndarray) else value
    )


def test_toml_value_refuses_nan_and_objects():
    with pytest.raises(ValueError, match="NaN"):
        toml_value(float("nan"))
    with pytest.raises(TypeError, match="object"):
        toml_value(object())
