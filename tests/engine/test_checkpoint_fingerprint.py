"""Every field of a plan that determines a run's result changes the checkpoint's
fingerprint on its own (issue 34, item 3).

A fingerprint that ignored one field (say ``friction``) would resume a run from
the checkpoint of another friction and mix two models' impacts without a word.
Each field of :class:`~microimpact.engine.plan.Plan` is replaced, one at a time,
by the value another plan holds or by a nearby value, and the fingerprint must
change; a field left out must be listed below with the reason it cannot change
the result.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import microimpact as mi
from microimpact.engine.checkpoint import FINGERPRINT_PARTS, plan_fingerprint
from microimpact.engine.plan import Plan, build_plan

#: Plan fields outside the fingerprint, and why they cannot change the result.
NOT_FINGERPRINTED = {
    # the compiled and the NumPy kernel compute the same bits
    # (tests/engine/test_kernel_compiled.py)
    "kernel",
    # a cache of tables derived from the other fields
    "_cache",
    # the points as arrays, derived from `points`
    "_columns",
}


def _scenario(**kw):
    base = {
        "name": "fingerprint",
        "particles": mi.lognormal_diameters(10.0, 1.5),
        "coefficients": mi.ImpactCoefficients(
            k1=4.0,
            k2=mi.PowerLaw(a=0.05, b=-1.5, d_ref=10e-6),
            v_c=mi.PowerLaw(a=0.5, b=-1.0, d_ref=10e-6),
            friction=0.2,
        ),
        "surfaces": (mi.SurfaceVariant("rough", mi.normal_angles(8.0)),),
        "speeds_m_s": (1.0, 3.0),
        "angles_deg": (45.0, 90.0),
        "speed_spread": 0.1,
        "seed": 11,
        "samples": 100,
    }
    return mi.Scenario(**{**base, **kw})


@pytest.fixture(scope="module")
def plans():
    a = build_plan(_scenario(), kernel="numpy")
    b = build_plan(
        _scenario(
            particles=mi.lognormal_diameters(12.0, 1.6),
            surfaces=(mi.SurfaceVariant("rougher", mi.normal_angles(12.0)),),
            speeds_m_s=(1.0, 2.0),
            speed_spread=0.2,
        ),
        kernel="numpy",
    )
    return a, b


def _other(name, a: Plan, b: Plan):
    """A value of field `name` other than plan `a`'s."""
    nearby = {
        "entropy": a.entropy + 1,
        "p": a.p * 1.01,
        "q": a.q * 1.01,
        "friction": a.friction + 0.01,
        "shadowing": "none" if a.shadowing != "none" else "reject",
        "sampling": "qmc" if a.sampling != "qmc" else "mc",
        "replicates": a.replicates + 1,
        "block_size": a.block_size * 2,
    }
    return nearby[name] if name in nearby else getattr(b, name)


def test_every_plan_field_changes_the_fingerprint_on_its_own(plans):
    a, b = plans
    targets = (100,)
    base = plan_fingerprint(a, targets)
    names = [f.name for f in dataclasses.fields(Plan)]
    checked = []
    for name in names:
        if name in NOT_FINGERPRINTED:
            continue
        value = _other(name, a, b)
        assert repr(value) != repr(getattr(a, name)) or name in (
            "diameters",
            "speeds",
            "surfaces",
        ), name  # the replacement is really another value
        changed = plan_fingerprint(dataclasses.replace(a, **{name: value}), targets)
        assert changed != base, f"the fingerprint ignores Plan.{name}"
        checked.append(name)
    assert set(checked) | NOT_FINGERPRINTED == set(names)
    assert "friction" in checked


def test_the_samplers_differ_where_they_are_swapped(plans):
    # the swapped samplers are really other tables (else the test above is void)
    a, b = plans
    assert not np.array_equal(a.diameter, b.diameter)
    assert not np.array_equal(a.speed_factor, b.speed_factor)
    assert not np.array_equal(a.surface_atoms[0], b.surface_atoms[0])


@pytest.mark.parametrize(
    ("change", "part"),
    [
        ({"seed": 12}, "seed"),
        ({"samples": 101}, "samples"),
        ({"angles_deg": (45.0, 89.0)}, "scenario"),
        ({"shadowing": "none"}, "scenario"),
    ],
)
def test_scenario_changes_reach_their_part(change, part):
    """Through the scenario: each change reaches the part it is reported by."""
    a = _scenario()
    b = _scenario(**change)
    fa = plan_fingerprint(build_plan(a, kernel="numpy"), (a.samples,))
    fb = plan_fingerprint(build_plan(b, kernel="numpy"), (b.samples,))
    assert {p for p in FINGERPRINT_PARTS if fa[p] != fb[p]} == {part}


def test_friction_through_the_scenario():
    """The issue's mutant: a run must not resume from another friction's
    checkpoint."""
    a = _scenario()
    coefficients = dataclasses.replace(a.coefficients, friction=0.3)
    b = _scenario(coefficients=coefficients)
    fa = plan_fingerprint(build_plan(a, kernel="numpy"), (100,))
    fb = plan_fingerprint(build_plan(b, kernel="numpy"), (100,))
    assert fa["scenario"] != fb["scenario"] and fa["seed"] == fb["seed"]


def test_a_plan_without_optional_tables_has_the_same_fingerprint_in_any_process():
    """A smooth surface and no speed spread leave tables out (None): they must
    hash as a fixed marker, not as the bytes of an object array (an address that
    differs from process to process, so a run could never resume)."""
    import subprocess
    import sys

    code = (
        "import microimpact as mi\n"
        "from microimpact.engine.plan import build_plan\n"
        "from microimpact.engine.checkpoint import plan_fingerprint\n"
        "s = mi.Scenario(name='f', particles=mi.lognormal_diameters(10.0, 1.5),\n"
        "    coefficients=mi.ImpactCoefficients(k1=4.0, k2=0.05, v_c=0.5),\n"
        "    surfaces=(mi.SurfaceVariant('smooth'),), seed=1, samples=10)\n"
        "print(plan_fingerprint(build_plan(s, kernel='numpy'), (10,))['scenario'])\n"
    )
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.strip()
        for _ in range(2)
    ]
    plan = build_plan(
        mi.Scenario(
            name="f",
            particles=mi.lognormal_diameters(10.0, 1.5),
            coefficients=mi.ImpactCoefficients(k1=4.0, k2=0.05, v_c=0.5),
            surfaces=(mi.SurfaceVariant("smooth"),),
            seed=1,
            samples=10,
        ),
        kernel="numpy",
    )
    assert plan.speeds is None and plan.surface_atoms == (None,)
    assert runs[0] == runs[1] == plan_fingerprint(plan, (10,))["scenario"]


def test_the_pair_drawing_algorithm_is_in_the_fingerprint(monkeypatch):
    """An areal surface's pairs are drawn by ArealSampler.ALGORITHM: a checkpoint
    written by another algorithm (other pairs from the same seed) is not
    resumed."""
    from microimpact.engine.plan import ArealSampler
    from microimpact.surface.areal_angles import gaussian_areal_angles

    areal = gaussian_areal_angles(
        nx=32,
        ny=32,
        dx_um=1.0,
        rms_um=1.0,
        corr_x_um=6.0,
        contact_diameter_um=3.0,
        seed=4,
        azimuth_deg=None,
    )
    plan = build_plan(
        _scenario(surfaces=(mi.SurfaceVariant("areal", areal),)), kernel="numpy"
    )
    assert plan.pair_algorithm(0)
    before = plan_fingerprint(plan, (100,))
    monkeypatch.setattr(ArealSampler, "ALGORITHM", "another algorithm")
    assert plan_fingerprint(plan, (100,))["scenario"] != before["scenario"]
