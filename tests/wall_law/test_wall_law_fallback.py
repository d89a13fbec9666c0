"""The no-compile OpenFOAM fallback says what it applies (issue 33, item 5).

OpenFOAM's ``localInteraction`` has no sticking probability: the fallback writes
each surface's mean rebound at one node, and used to write ``type stick;`` for a
surface whose middle node captured everything (so every parcel stuck), under a
comment calling the capture probability "not applied", with nothing on the
terminal. Now such a surface gets the mean rebound over the whole table (each
node weighted by its rebounds), a comment saying so, and a warning; a stick is
written only where the user gave that node, or the table has no rebound at all,
and is said on the terminal too. The expected means are pooled here from the raw
rebounds (e_t recomputed from e_n and the impulse ratio), not read from the
table's statistics.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from test_wall_law_openfoam import ANGLES, _law, _patches, make_dataset

from microimpact.wall_law.openfoam import (
    LOCAL_INTERACTION_FILE,
    LOCAL_PATCHES_FILE,
    OpenFOAMFallbackWarning,
    fallback_condition,
    write_openfoam,
)


def _capture_the_middle_node(ds, surface):
    """`ds` with surface `surface` capturing every impact at the fallback's
    default node; returns (dataset, that node)."""
    cond = fallback_condition(ds)
    node = tuple(cond[a][0] for a in ("diameter_um", "speed_m_s", "angle_deg"))
    ds = ds.copy(deep=True)
    s = list(ds["surface"].values).index(surface)
    at = (s, *node)
    ds["capture_probability"].values[at] = 1.0
    ds["n_rebounds"].values[at] = 0
    ds["reservoir_count"].values[at] = 0
    for k in ("e_n", "e_t", "mu"):
        for stat in ("mean", "std"):
            ds[f"{k}_{stat}"].values[at] = np.nan
    return ds, node


def _pooled(raw, si, skip):
    """Mean e_n and OpenFOAM's mu = 1 - mean e_t over every raw rebound of
    surface `si` except at node `skip` (e_t over the oblique nodes)."""
    e_n, e_t = [], []
    for (s, di, vi, ai), (en, mu, _) in raw.items():
        if s != si or (di, vi, ai) == skip:
            continue
        e_n.append(en)
        if ANGLES[ai] < 90.0:
            e_t.append(1.0 - mu * (1.0 + en) * math.tan(math.radians(ANGLES[ai])))
    return float(np.mean(np.concatenate(e_n))), 1.0 - float(
        np.mean(np.concatenate(e_t))
    )


def test_a_middle_node_that_captures_everything_gets_the_table_mean(tmp_path):
    ds, raw = make_dataset()
    ds, node = _capture_the_middle_node(ds, "glass")
    with pytest.warns(OpenFOAMFallbackWarning, match="'glass' captures every impact"):
        write_openfoam(_law(ds), tmp_path)
    e, mu = _pooled(raw, 1, node)
    for name in (LOCAL_INTERACTION_FILE, LOCAL_PATCHES_FILE):
        path = tmp_path / "openfoam" / name
        patch = _patches(path)["glass"]
        assert patch["type"] == "rebound"  # not a wall where everything sticks
        assert float(patch["e"]) == pytest.approx(e, rel=1e-9)
        assert float(patch["mu"]) == pytest.approx(mu, rel=1e-9)
        text = path.read_text()
        assert "surface 'glass': captures every impact at the node" in text
        assert "the mean rebound over the whole table" in text
        assert "(not applied)" not in text
        assert "capture probability 0.06 there is NOT applied" in text  # steel


def test_a_stick_is_written_only_when_asked_for_and_said(tmp_path):
    ds, _ = make_dataset()
    ds, node = _capture_the_middle_node(ds, "glass")
    given = {
        a: float(ds[a].values[i])
        for a, i in zip(("diameter_um", "speed_m_s", "angle_deg"), node, strict=True)
    }
    with pytest.warns(OpenFOAMFallbackWarning, match="every parcel that strikes it"):
        write_openfoam(_law(ds), tmp_path, **given)
    path = tmp_path / "openfoam" / LOCAL_INTERACTION_FILE
    assert _patches(path)["glass"] == {"type": "stick"}
    assert "EVERY parcel that strikes it sticks" in path.read_text()


def test_a_surface_that_never_rebounds_sticks_with_a_warning(tmp_path):
    ds, _ = make_dataset(capture="glass")
    with pytest.warns(OpenFOAMFallbackWarning, match="no rebound anywhere"):
        write_openfoam(_law(ds), tmp_path)
    assert _patches(tmp_path / "openfoam" / LOCAL_PATCHES_FILE)["glass"] == {
        "type": "stick"
    }


def test_an_ordinary_table_warns_nobody(tmp_path):
    ds, _ = make_dataset()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_openfoam(_law(ds), tmp_path)


def test_the_cli_says_it_on_the_terminal(tmp_path, capsys):
    """A real build whose middle node (0.2 m/s, 30 deg: below v_c = 0.4 m/s)
    captures every impact: the command says what the fallback applies instead."""
    from test_wall_law import _toml

    from microimpact.cli import main

    path = _toml(
        tmp_path,
        "[wall_law]\ndiameter_um = [10]\nspeed_m_s = [0.1, 0.2, 20]\n"
        "angle_deg = [30, 60, 90]\nreservoir = 8\nsamples = 200",
    )
    out = tmp_path / "out"
    assert main(["wall-law", str(path), "--out", str(out), "--quiet", "--no-c"]) == 0
    err = capsys.readouterr().err
    assert "warning: OpenFOAM fallback: surface 'rough' captures every impact" in err
    assert err.count("\n") == 1  # one line
    patch = _patches(out / "openfoam" / LOCAL_INTERACTION_FILE)["rough"]
    assert patch["type"] == "rebound"
