"""Issue 22 (item 7): every problem of a scenario file in one run, in file order."""

from __future__ import annotations

import pytest

from microimpact.cli import main
from microimpact.errors import ScenarioError, ScenarioErrors
from microimpact.scenario import scenario_from_toml

SIX = """\
seed = -1
samples = 0
[particles]
distribution = "normal"
mean_um = 50
std_um = -5
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2
friction = "lots"
[[surfaces]]
name = "a"
kind = "normal"
std_deg = "ten"
[sweep]
speed_m_s = [1.0, -2.0]
"""

FIELDS = [
    "seed",
    "samples",
    "particles.std_um",
    "coefficients.friction",
    "surfaces[0].std_deg",
    "sweep.speed_m_s",
]


def test_six_wrong_values_are_reported_in_one_run(tmp_path, capsys):
    path = tmp_path / "six.toml"
    path.write_text(SIX)
    with pytest.raises(ScenarioErrors) as err:
        scenario_from_toml(path)
    assert [e.field for e in err.value.errors] == FIELDS  # the file's order
    assert all(str(path) in str(e) for e in err.value.errors)
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[0].endswith(f"6 problems in {path}:")
    assert [line.split(": ")[1] for line in lines[1:]] == FIELDS


ONE = """\
seed = -1
[particles]
distribution = "normal"
mean_um = 50
std_um = 5
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2
[sweep]
speed_m_s = [1.0]
"""


def test_one_wrong_value_is_one_line(tmp_path):
    path = tmp_path / "one.toml"
    path.write_text(ONE)
    with pytest.raises(ScenarioError) as err:
        scenario_from_toml(path)
    assert not isinstance(err.value, ScenarioErrors)
    assert err.value.field == "seed" and "\n" not in str(err.value)
