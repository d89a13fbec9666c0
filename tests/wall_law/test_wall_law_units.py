"""Samplers refuse queries that look like a wrong unit (issue 33, item 5).

OpenFOAM and Fluent hold a diameter in metres: 3e-6 passed where µm belong is a
3 pm particle, which the samplers used to clamp silently to the table's smallest
node. Every sampler now refuses a diameter below 0.01 µm, and a speed above
1 km/s beyond the table's fastest node (mm/s given as m/s), as the scenario files
do: Python with a ValueError naming the value and the likely slip, C with
``SWL_E_UNIT``, the Fluent wrapper by aborting the particle and saying why once.
The OpenFOAM model stops with a FatalError carrying ``swl_strerror``'s message
(its source is checked here; its real-solver tests need OpenFOAM).
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
from test_wall_law_c import (
    C_DIR,
    CC,
    ROOT,
    SPEEDS,
    compile_shared,
    fluent_udf,
    synthetic_dataset,
)

from microimpact.wall_law import WallLaw
from microimpact.wall_law.export_c import write_binary

E_ARG, E_UNIT = -1, -10
U = [0.5, 0.5, 0.5, 0.99, 0.5]


@pytest.fixture(scope="module")
def dataset():
    return synthetic_dataset()


@pytest.mark.parametrize(
    ("d", "v", "match"),
    [
        (3e-6, 1.0, "metres"),  # 3 um given in metres
        (0.0099, 1.0, "below 0.01 um"),
        (5.0, 1500.0, "mm/s"),  # above 1 km/s and the table's 30 m/s
    ],
)
def test_python_sampler_refuses_a_wrong_unit(dataset, d, v, match):
    law = WallLaw(dataset)
    with pytest.raises(ValueError, match=match) as err:
        law.sample(d, v, 45.0, rng=1)
    assert "\n" not in str(err.value) and "np." not in str(err.value)


def test_the_messages_give_the_value_in_the_likely_unit(dataset):
    law = WallLaw(dataset)
    with pytest.raises(ValueError, match=r"3e-06 m is 3 um"):
        law.sample(3e-6, 1.0, 45.0, rng=1)
    with pytest.raises(ValueError, match=r"1500 mm/s is 1\.5 m/s"):
        law.sample(5.0, 1500.0, 45.0, rng=1)


def test_the_speed_limits_themselves_are_taken(dataset):
    """1 km/s exactly is a speed; and a table whose fastest node is 1.5 km/s
    takes 1.5 km/s exactly."""
    assert WallLaw(dataset).sample(5.0, 1000.0, 45.0, rng=1).valid.all()
    fast = dataset.assign_coords(speed_m_s=SPEEDS * 50.0)  # top node 1500 m/s
    assert WallLaw(fast).sample(5.0, 1500.0, 45.0, rng=1).valid.all()


def test_python_sampler_takes_what_is_plausible(dataset):
    law = WallLaw(dataset)
    s = law.sample([0.01, 5.0, 5.0], [1.0, 999.0, 1.0], 45.0, rng=1)
    assert s.valid.all() and s.clamped[1]  # 999 m/s: clamped, not refused


def test_a_table_built_fast_takes_fast_queries(dataset):
    """Cold spray: a table whose fastest node is 1.5 km/s takes 1.2 km/s."""
    fast = dataset.assign_coords(speed_m_s=SPEEDS * 50.0)  # 25 .. 1500 m/s
    s = WallLaw(fast).sample(5.0, 1200.0, 45.0, rng=1)
    assert s.valid.all()


@pytest.fixture(scope="module")
def swl(tmp_path_factory):
    from test_wall_law_c import TRAPS, Swl

    if CC is None:
        pytest.skip("no C compiler")
    return Swl(
        compile_shared([C_DIR / "swl.c", TRAPS], tmp_path_factory.mktemp("u") / "l.so")
    )


def test_c_sampler_refuses_a_wrong_unit(swl, dataset, tmp_path):
    rc, law = swl.load(write_binary(dataset, tmp_path / "t.swl"))
    assert rc == 0
    try:
        for d, v, want in (
            (3e-6, 1.0, E_UNIT),
            (0.0099, 1.0, E_UNIT),
            (0.01, 1.0, 0),  # the limit itself is a diameter
            (5.0, 1500.0, E_UNIT),
            (5.0, 999.0, 0),
            (float("nan"), 1.0, E_ARG),
        ):
            status, _, vel = swl.sample(law, 0, d, v, 45.0, U)
            assert (status if status < 0 else 0) == want, (d, v, status)
            if status < 0:
                assert np.isnan(vel).all()
        message = swl.lib.swl_strerror(E_UNIT).decode()
        assert "0.01 um" in message and "1 km/s" in message and "unit" in message
        # through swl_rebound_velocity too: a diameter in metres
        status, _, _ = swl.rebound(law, 0, 3e-6, [1.0, 0.0, -1.0], [0, 0, 1.0], U)
        assert status == E_UNIT
    finally:
        swl.lib.swl_free(law)


def test_fluent_wrapper_aborts_a_wrong_unit_and_says_so_once(
    swl, dataset, tmp_path, monkeypatch
):
    if CC is None:
        pytest.skip("no C compiler")
    table = write_binary(dataset, tmp_path / "t.swl")
    udf = fluent_udf(tmp_path, table, monkeypatch)
    d3 = ctypes.c_double * 3
    path_active, path_abort = 1, 3

    def hit(diam_m):
        return udf.hit(
            d3(1.0, 0.0, -1.0),
            d3(0, 0, -1.0),
            diam_m,
            (ctypes.c_double * 5)(*U),
            d3(),
            d3(),
        )

    assert hit(5e-6) == path_active  # 5 um: a rebound
    assert hit(3e-12) == path_abort  # 3e-12 m = 3e-6 um: a diameter in um as m
    said = udf.message().decode()
    assert "0.01 um" in said and "3e-06 um" in said and "said once" in said
    udf.Message(b"-")  # the mock's last message, reset
    assert hit(3e-12) == path_abort
    assert udf.message() == b"-"  # not said again


def test_openfoam_model_stops_on_any_sampler_error_with_its_message():
    """The model's FatalError quotes swl_strerror(rc) for every negative code
    (SWL_E_UNIT included) and converts the parcel's diameter from m to um."""
    src = (
        ROOT / "src/microimpact/wall_law/openfoam_model/StochasticWallLaw.C"
    ).read_text()
    assert "const double diameterUm = p.d()*1e6;" in src
    fatal = src[
        src.index('FatalErrorInFunction\n            << "stochasticWallLaw on patch') :
    ]
    assert "swl_strerror(rc)" in fatal[:400] and "diameterUm" in fatal[:400]
