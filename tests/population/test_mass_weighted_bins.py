"""Mass- and volume-weighted size exports on linear and irregular bins, with
absolute known answers (issue 34, item 3).

A mass-weighted bin value becomes a number through the d³ moment at the bin's
geometric midpoint ``d_i = sqrt(b_i b_{i+1})`` (docs: population.binned):
``n_i = v_i w_i / (b_i b_{i+1})^{3/2}``, with the bin width w_i in the value's
variable (1, log10, ln or d). On log-spaced bins every bin's arithmetic centre is
the same multiple of its geometric one, so a reader that used the arithmetic
centre would give the right shape and pass every log-bin test; on linear and
irregular bins it does not. The expected numbers below were worked out by hand
from that definition (Python's ``math``, not microimpact), e.g. the first:
8 x log10(2) / 2^1.5 = 2.408240 / 2.828427 = 0.8514414.
"""

from __future__ import annotations

import numpy as np
import pytest

from microimpact.io.size_bins import read_size_bins
from microimpact.population.binned import number_per_bin

LINEAR = [1.0, 2.0, 3.0, 5.0]  # um
IRREGULAR = [0.5, 0.7, 1.9, 2.0, 6.0]  # um

CASES = [
    # (edges, kind, values, the numbers per bin)
    (
        LINEAR,
        "dM/dlogDp",
        [8, 27, 64],
        [0.8514414050982324, 0.323500299638, 0.24439936359568704],
    ),
    (
        LINEAR,
        "dV/dlogDp",
        [8, 27, 64],
        [0.8514414050982324, 0.323500299638, 0.24439936359568704],
    ),
    (
        IRREGULAR,
        "dM/dDp",
        [10, 4, 30, 1],
        [
            9.658905768325903,
            3.1294194388840424,
            0.40499145477045595,
            0.09622504486493763,
        ],
    ),
    (
        IRREGULAR,
        "dV/dlnDp",
        [10, 4, 30, 1],
        [
            16.24976813591076,
            2.604012942696586,
            0.20773345913983313,
            0.02642850419156517,
        ],
    ),
    # the bin values themselves: divided by d^3 only, 10 / (0.5 x 0.7)^1.5, ...
    (
        IRREGULAR,
        "mass",
        [10, 4, 30, 1],
        [48.29452884162952, 2.607849532403369, 4.049914547704556, 0.024056261216234408],
    ),
]


@pytest.mark.parametrize(
    ("edges", "kind", "values", "want"),
    CASES,
    ids=[c[1] + str(len(c[0])) for c in CASES],
)
def test_number_per_bin_known_answers(edges, kind, values, want):
    np.testing.assert_allclose(number_per_bin(edges, values, kind), want, rtol=1e-13)


@pytest.mark.parametrize(
    ("edges", "kind", "values", "want"),
    CASES[:4],
    ids=[c[1] + str(len(c[0])) for c in CASES[:4]],
)
def test_the_file_reader_gives_the_same_numbers(write_file, edges, kind, values, want):
    text = f"lower (um),upper (um),{kind}\n" + "".join(
        f"{a!r},{b!r},{v}\n"
        for a, b, v in zip(edges[:-1], edges[1:], values, strict=True)
    )
    bins, meta = read_size_bins(write_file("bins.csv", text))
    assert meta["values"] == kind and not bins.counted
    np.testing.assert_allclose(bins.edges_um, edges, rtol=0)
    np.testing.assert_allclose(bins.number, want, rtol=1e-13)


def test_a_mass_bin_is_the_number_times_the_midpoint_cubed():
    """The inverse, on particles of known number: 3 particles in [1, 4] um weigh
    3 x (1 x 4)^1.5 = 24 (d^3 units), 2 in [4, 5] weigh 2 x 20^1.5."""
    edges = [1.0, 4.0, 5.0]
    mass = [3 * 8.0, 2 * 20.0**1.5]
    np.testing.assert_allclose(
        number_per_bin(edges, mass, "mass"), [3.0, 2.0], rtol=1e-14
    )
