"""Choosing a sample of a real multi-sample export: the refusals in full.

``aim_smps_column_pysmps.txt`` is a TSI AIM column export of 15 SMPS samples
from py-smps' test data (MIT; tests/data/size_exports/README.md). Asked without a
sample, or for a sample it does not hold, or a range that runs backwards, the
reader answers with the samples the file holds and every way to choose, each
message written out here from the reader's contract.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from microimpact.errors import DataFormatError
from microimpact.io.size_bins import read_size_bins

AIM = Path(__file__).resolve().parents[1] / "data" / "size_exports"
AIM = AIM / "aim_smps_column_pysmps.txt"
NOT_IN = (
    "is not in the AIM column export; allowed: a Sample # (1..15), 'mean', 'sum', "
    "'A..B' or 'sum A..B'"
)

CASES = [
    (
        None,
        "the AIM column export holds 15 samples (1..15); choose one: sample=1 (one "
        "sample: its Sample #, else its row number); sample='mean' (the mean of all "
        "samples); sample='sum' (the sum of all samples); sample='1..15' (the mean "
        "of a range)",
    ),
    (999, f"sample '999' {NOT_IN}"),
    ("1..zz", f"sample 'zz' {NOT_IN}"),
    (
        "3..1",
        "sample range '3..1' runs backwards; allowed: A..B with A before B in the file",
    ),
]


@pytest.mark.parametrize(("sample", "message"), CASES, ids=[str(c[0]) for c in CASES])
def test_choosing_a_sample_is_refused_in_full(sample, message):
    kw = {} if sample is None else {"sample": sample}
    with pytest.raises(DataFormatError) as info:
        read_size_bins(AIM, **kw)
    err = info.value
    assert (err.source, err.field, err.message) == (str(AIM), "sample", message)


def test_a_range_is_the_mean_of_its_samples():
    """'2..4' is the mean of samples 2, 3 and 4 (read one by one here)."""
    import numpy as np

    one = [read_size_bins(AIM, sample=k)[0].number for k in (2, 3, 4)]
    bins, meta = read_size_bins(AIM, sample="2..4")
    np.testing.assert_allclose(bins.number, np.mean(one, axis=0), rtol=1e-12)
    assert (meta["aggregate"], meta["n_samples_used"]) == ("mean", 3)
    summed, meta = read_size_bins(AIM, sample="sum 2..4")
    np.testing.assert_allclose(summed.number, np.sum(one, axis=0), rtol=1e-12)
    assert meta["aggregate"] == "sum"
