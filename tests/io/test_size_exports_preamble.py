"""An APS-style export with a key/value preamble before its header (E) and a
wide export whose midpoints are not log-spaced with the bin edges given (A):
``sizes`` (read_size_bins) and ``run`` ([particles] file) read them the same way.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from microimpact.errors import DataFormatError
from microimpact.io import read_size_bins, read_size_data
from microimpact.scenario.scenario import scenario_from_dict

MIDS = [0.542, 0.583, 0.626, 0.673, 0.723, 0.777]
VALUES = [120.5, 230.1, 410.0, 600.2, 480.0, 210.0]
TABLE = "Channel,Midpoint (um),dN/dlogDp\n" + "".join(
    f"{i + 1},{m},{v}\n" for i, (m, v) in enumerate(zip(MIDS, VALUES, strict=True))
)
PREAMBLE = (
    "Sample File,C:\\data\\aps_run3.A21\nInstrument,APS 3321\nStokes Correction,ON\n"
)


def _scenario(path, **keys):
    particles = {"distribution": "histogram", "file": str(path), **keys}
    return scenario_from_dict(
        {
            "particles": particles,
            "coefficients": {"k1": 4.0, "k2": 0.05, "v_c": 0.2},
            "sweep": {"speed_m_s": [0.5, 1.0]},
        }
    )


def test_a_key_value_preamble_before_the_header_is_skipped(tmp_path):
    plain, aps = tmp_path / "plain.csv", tmp_path / "aps.txt"
    plain.write_text(TABLE)
    aps.write_text(PREAMBLE + TABLE)
    want, _ = read_size_bins(plain)  # the oracle: the same table without preamble
    got, meta = read_size_bins(aps)
    assert_allclose(got.edges_um, want.edges_um, rtol=1e-15)
    assert_allclose(got.number, want.number, rtol=1e-15)
    assert meta["layout"] == "midpoints" and meta["values"] == "dN/dlogDp"
    assert read_size_data(aps)[1]["layout"] == "midpoints"
    # run reads it the same way (one code path)
    ppf = _scenario(aps).particles.ppf(np.array([0.2, 0.5, 0.8]))
    assert_allclose(ppf, _scenario(plain).particles.ppf(np.array([0.2, 0.5, 0.8])))


def test_a_bad_cell_below_a_preamble_names_the_files_line(tmp_path):
    aps = tmp_path / "aps.txt"
    aps.write_text(PREAMBLE + TABLE.replace("410.0", "abc"))
    with pytest.raises(DataFormatError, match=r"aps\.txt:7"):
        read_size_bins(aps)


# -- A: a wide export whose header sizes are not log-spaced, with edges_um -----------
GRIMM = (
    "timestamp,0.3,0.4,0.5,0.65,0.8,1.0,1.6,2.0\n"
    "2026-01-01T10:00:00Z,120,80,60,30,15,8,3,1\n"
    "2026-01-01T10:01:00Z,130,82,58,33,14,9,2,1\n"
)
THRESHOLDS = [0.3, 0.4, 0.5, 0.65, 0.8, 1.0, 1.6, 2.0, 3.0]


def test_a_wide_export_without_log_spacing_asks_for_edges_um(tmp_path):
    path = tmp_path / "grimm.csv"
    path.write_text(GRIMM)
    with pytest.raises(DataFormatError) as info:
        read_size_bins(path, unit="um", values="count", sample="sum", syntax="cli")
    assert "--edges-um" in str(info.value) and "lower and upper" not in str(info.value)
    with pytest.raises(DataFormatError, match="edges_um = "):
        read_size_bins(path, unit="um", values="count", sample="sum", syntax="toml")


def test_a_wide_export_of_channel_thresholds_reads_with_edges_um(tmp_path):
    path = tmp_path / "grimm.csv"
    path.write_text(GRIMM)
    bins, _ = read_size_bins(
        path, unit="um", values="count", sample="sum", edges_um=THRESHOLDS
    )
    assert_allclose(bins.edges_um, THRESHOLDS, rtol=0)
    assert_allclose(bins.number, [250, 162, 118, 63, 29, 17, 5, 2], rtol=0)
    assert bins.counted and any("lower boundaries" in t for t in bins.notes)
    assert bins.notes[0].endswith(
        "bin edges as given (9 edges_um); the header sizes are the bins' lower "
        "boundaries (channel thresholds)"
    )
    # run reads the same bins from [particles] edges_um
    sc = _scenario(path, unit="um", values="count", sample="sum", edges_um=THRESHOLDS)
    assert_allclose(sc.particles.params["edges_um"], THRESHOLDS, rtol=1e-15)


def test_edges_um_that_do_not_hold_the_header_sizes_are_refused(tmp_path):
    path = tmp_path / "grimm.csv"
    path.write_text(GRIMM)
    bad = [0.35, *THRESHOLDS[1:]]  # 0.3 falls below its bin
    with pytest.raises(DataFormatError, match=r"edges_um: the bin column 0\.3"):
        read_size_bins(path, unit="um", values="count", sample="sum", edges_um=bad)
    with pytest.raises(DataFormatError, match="9 increasing boundaries") as info:
        read_size_bins(
            path, unit="um", values="count", sample="sum", edges_um=THRESHOLDS[:-1]
        )
    assert info.value.field == "edges_um"
