"""The refusals of a diameters file and of a histogram file, word for word.

Each case writes a small file and compares the error's source, line, field and
whole message with the reader's contract written out here: parse_number's
"non-numeric / bad value '<cell>'; allowed: ..." and the readers' own sentences
(the layouts a histogram may have, the unit a header names, the plausible median
of 10 nm to 10 mm).
"""

from __future__ import annotations

import pytest
from ids import ascii_id

from microimpact.errors import DataFormatError
from microimpact.io.diameters import read_diameters, read_histogram

LAYOUTS = (
    "columns 'lower, upper, count' (one row per bin) or two rows 'edges' (k + 1 "
    "values) and 'counts' (k values)"
)

HISTOGRAMS = [
    # (text, line, field, message)
    ("1,2,5\n2,3\n3,4,1\n", 2, None, f"row has 2 cells; expected {LAYOUTS}"),
    (
        "1,2,5\n2,3,4,5\n",
        2,
        None,
        f"row has 4 cells; expected {LAYOUTS}; the decimal separator must be '.'",
    ),
    (
        "1,2,5\n3,2,4\n",
        2,
        "column 1 (upper edge)",
        "upper edge '2' is not above lower edge '3'; allowed: upper > lower",
    ),
    (
        "1,2,x\n",
        1,
        "column 2 (count)",
        "non-numeric value 'x'; allowed: a number >= 0",
    ),
    (
        "1,-2,3\n",
        1,
        "column 1 (upper edge)",
        "bad value '-2'; allowed: a number >= 0 in um",
    ),
    (
        "1,2,3\n",
        None,
        "count",
        None,  # set below: no positive total
    ),
    (
        "1,3,2\n5,4\n",
        1,
        "column 2",
        "bin edges must be strictly increasing; got '2' after '3'",
    ),
]
HISTOGRAMS[5] = (
    "1,2,0\n2,3,0\n",
    None,
    "count",
    "all counts are zero; allowed: counts >= 0 with a positive total",
)


@pytest.mark.parametrize(
    ("text", "line", "field", "message"),
    HISTOGRAMS,
    ids=[ascii_id(c[3][:40]) for c in HISTOGRAMS],
)
def test_each_histogram_refusal_in_full(tmp_path, text, line, field, message):
    path = tmp_path / "h.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_histogram(path)
    err = info.value
    assert (err.source, err.line, err.field, err.message) == (
        str(path),
        line,
        field,
        message,
    )


def test_a_header_only_histogram_and_a_wide_header(tmp_path):
    path = tmp_path / "h.csv"
    path.write_text("lower,upper,count\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_histogram(path)
    assert info.value.message == f"no bins found (only a header); expected {LAYOUTS}"
    path.write_text("a,b,c,d\n1,2,3,4\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_histogram(path)
    assert (info.value.line, info.value.message) == (
        1,
        f"header has 4 columns; expected {LAYOUTS}",
    )


def test_diameter_refusals_in_full(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("diameter_um\n12\n-3\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_diameters(path)
    err = info.value
    assert (err.line, err.field, err.message) == (
        3,
        "column 'diameter_um'",
        "bad value '-3'; allowed: a diameter > 0 in um",
    )
    path.write_text("a,b\n1,2\n3,4\n", encoding="utf-8")
    for syntax, how in (
        ("python", "pass `column=`"),
        ("cli", "pass --column with"),
        ("toml", "set the key column = to"),
    ):
        with pytest.raises(DataFormatError) as info:
            read_diameters(path, syntax=syntax)
        assert info.value.field == "column"
        assert info.value.message == (
            f"the file has 2 columns; {how} one of 'a', 'b' (a header name or a "
            "0-based index)"
        )


def test_an_implausible_median_names_the_unit_and_the_fix(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("d\n12e-6\n15e-6\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_diameters(path, unit="um")
    assert info.value.field == "column 'd'"
    assert info.value.message == (
        "the median diameter read as 'um' is 1.35e-05 um, below 10 nm, which is not "
        "a particle diameter: the values are probably in another unit; give the "
        "unit the file holds (unit='m', 'mm', 'nm'; --unit on the CLI)"
    )
    path.write_text("diameter_mm\n12\n15\n", encoding="utf-8")
    with pytest.raises(DataFormatError) as info:
        read_diameters(path)
    assert info.value.message == (
        "the median diameter read as 'mm' is 13500 um, above 10 mm, which is not a "
        "particle diameter: the values are probably in another unit; the header "
        "names 'mm'; if the file holds another unit, correct the header (e.g. "
        "diameter_m, diameter_mm)"
    )
    with pytest.raises(DataFormatError) as info:
        read_diameters(path, unit="um")
    assert info.value.field == "unit"
    assert info.value.message == (
        "the header 'diameter_mm' gives the unit 'mm' but the unit given is 'um'; "
        "allowed: the same unit, or leave the unit out to use the file's"
    )
