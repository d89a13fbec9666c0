"""The refusals of an experiments file, word for word, and combining tables.

test_io_experiments.py checks that each refusal names the file, the line and the
field; here each one's whole message is written out from the reader's contract
(``parse_number``'s documented "missing / non-numeric / bad value '<cell>';
allowed: ..." and the reader's own sentences), so that a message that loses its
value, its allowed range or its advice turns red.
"""

from __future__ import annotations

import math

import pandas as pd
import pytest
from ids import ascii_id

from microimpact.errors import DataFormatError
from microimpact.io.experiments import combine_experiments, read_experiments

HEAD = "speed_m_s,statistic,mean,half_width\n"

CASES = [
    (
        HEAD + "fast,e,0.5,0.1\n",
        "speed_m_s",
        "non-numeric value 'fast'; allowed: a finite speed > 0 [m/s]",
    ),
    (
        HEAD + "-1,e,0.5,0.1\n",
        "speed_m_s",
        "bad value '-1'; allowed: a finite speed > 0 [m/s]",
    ),
    (
        "angle_deg,statistic,mean,half_width\n95,e,0.5,0.1\n",
        "angle_deg",
        "bad value '95'; allowed: an angle in (0, 90] [deg]",
    ),
    (
        "angle_deg,statistic,mean,half_width\n0,e,0.5,0.1\n",
        "angle_deg",
        "bad value '0'; allowed: an angle in (0, 90] [deg]",
    ),
    (
        HEAD + "1,e,0.5,-0.1\n",
        "half_width",
        "bad value '-0.1'; allowed: a finite number >= 0",
    ),
    (
        "speed_m_s,statistic,mean,std,n\n1,e,0.5,0.1,2.5\n",
        "n",
        "bad value '2.5'; allowed: an integer >= 2",
    ),
    (
        "speed_m_s,statistic,mean,std,n\n1,e,0.5,-1,5\n",
        "std",
        "bad value '-1'; allowed: a finite number >= 0",
    ),
    (
        "speed_m_s,statistic,mean,half_width,confidence\n1,e,0.5,0.1,1\n",
        "confidence",
        "bad value '1'; allowed: a number in (0, 1)",
    ),
    (HEAD + "1,e,nan,0.1\n", "mean", "missing value 'nan'; allowed: a finite number"),
    (HEAD + "1,e,,0.1\n", "mean", "missing value; a number is required."),
    (
        HEAD + "1,rebound,0.5,0.1\n",
        "statistic",
        "unknown statistic 'rebound'; allowed: e, mu, e_relative, mu_relative, "
        "capture_fraction.",
    ),
    (
        HEAD + "1,mu_relativ,0.5,0.1\n",
        "statistic",
        "unknown statistic 'mu_relativ'; allowed: e, mu, e_relative, mu_relative, "
        "capture_fraction (did you mean 'mu_relative'?).",
    ),
    (
        HEAD + "1,capture_fraction,50,1\n",
        "mean",
        "bad value 50.0; a capture fraction must lie in [0, 1] (give a fraction, not "
        "a percentage).",
    ),
    (
        "speed_m_s,statistic,mean,ci_low,ci_high\n1,e,0.5,0.6,0.7\n",
        "ci_low",
        "interval [0.6, 0.7] does not contain the mean 0.5; ci_low <= mean <= "
        "ci_high is required.",
    ),
    (
        "speed_m_s,statistic,mean,ci_low,ci_high\n1,e,0.5,0.4,\n",
        "ci_high",
        "missing value; ci_low and ci_high must be given together.",
    ),
    (
        "speed_m_s,statistic,mean,half_width,std\n1,e,0.5,,0.1\n",
        "ci_low",
        "no interval on this row; give ci_low and ci_high, or half_width, or std "
        "and n.",
    ),
    (
        "speed_m_s,angle_deg,statistic,mean,half_width\n,,e,0.5,0.1\n",
        "speed_m_s/angle_deg",
        "missing value; each row needs speed_m_s or angle_deg.",
    ),
]


@pytest.mark.parametrize(
    ("text", "field", "message"), CASES, ids=[ascii_id(c[2][:40]) for c in CASES]
)
def test_each_refusal_in_full(tmp_path, text, field, message):
    path = tmp_path / "exp.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_experiments(path)
    err = info.value
    assert (err.source, err.line, err.field, err.message) == (
        str(path),
        2,
        field,
        message,
    )
    assert str(err) == f"{path}:2: {field}: {message}"


def test_tables_without_a_coordinate_column_are_combined_with_it_empty():
    """A user's own tables (not read from files) may lack angle_deg, speed_m_s or
    surface: the combined table has each, empty (NaN; None for the surface)."""
    base = {"statistic": ["e"], "mean": [0.5], "ci_low": [0.4], "ci_high": [0.6]}
    by_speed = pd.DataFrame({**base, "speed_m_s": [1.0]})
    by_angle = pd.DataFrame({**base, "angle_deg": [30.0]})
    out = combine_experiments([by_speed, by_angle])
    assert list(out["speed_m_s"].isna()) == [False, True]
    assert list(out["angle_deg"].isna()) == [True, False]
    only = combine_experiments(by_speed)
    assert math.isnan(only.loc[0, "angle_deg"])
    assert only.loc[0, "surface"] is None
