"""Real instrument files (tests/data/instruments, from SurfaceTopography's public
test data) read by microimpact and compared with SurfaceTopography's own reading:
spacing, units, heights (Rq, Sq), slopes (RΔq) and the missing-point mask. Every
file that cannot be read gives a one-line error and exit 2 (issue 21)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from microimpact.cli import main
from microimpact.errors import ProfileFormatError
from microimpact.io.areal import read_height_map
from microimpact.io.profiles import read_profile, read_profiles
from microimpact.surface.areal import areal_parameters
from microimpact.surface.roughness import characterise, profile_parameters

st = pytest.importorskip("SurfaceTopography")
from SurfaceTopography import open_topography  # noqa: E402
from SurfaceTopography.Support.UnitConversion import (  # noqa: E402
    get_unit_conversion_factor,
)

DATA = Path(__file__).parents[1] / "data" / "instruments"
# SurfaceTopography's own rms_* functions warn that they are being renamed
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

#: Line scans: file -> the arguments a user gives (a unit where the file has none).
LINE_SCANS = {
    "dektak-1.csv": {},
    "opdx-3.opdx": {},
    "mitutoyo_mock.xlsx": {},
    "mitutoyo_nonuniform_mock.xlsx": {},
    "nonuniform.asc": {"unit": "um"},
    "xy-1.txt": {"unit": "um"},
}
#: Height maps: file -> the arguments a user gives.
MAPS = {
    "sdf-1.sdf": {},
    "nc-1.nc": {},
    "frt-2.frt": {},
    "txt_example.txt": {},
    "10x10-one_channel_without_name.ibw": {"dx_um": 1.0, "z_unit": "nm"},
}
#: Files that no reader accepts as a line scan: one-line error, exit 2.
UNREADABLE = [
    "wrongnpyfile.npy",
    "nonsense_txt_file.txt",
    "not-yet-working-1.txt",
    "xyz-2.txt",
    "example-2d.npy",
    "10x10-one_channel_without_name.ibw",
]


def _st(name, unit=None):
    """SurfaceTopography's topography of `name` and metres per its unit (`unit`
    for a file without one, as the user gives it to microimpact)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = open_topography(str(DATA / name))
        kw = {} if reader.default_channel.unit is not None else {"unit": unit}
        topo = reader.topography(**kw)
    factor = 1e-6 if topo.unit == "um" else get_unit_conversion_factor(topo.unit, "m")
    return topo, factor


@pytest.mark.parametrize("name", sorted(LINE_SCANS))
def test_line_scans_match_surfacetopography(name):
    kw = LINE_SCANS[name]
    topo, factor = _st(name, kw.get("unit"))
    ps = read_profiles(DATA / name, **kw)
    assert len(ps) == 1
    p = ps[0]
    # positions: the same spacing (uniform) or the same real positions
    assert p.n_points == topo.nb_grid_pts[0]
    assert p.is_uniform == topo.is_uniform
    if topo.is_uniform:
        assert p.dx == pytest.approx(topo.pixel_size[0] * factor, rel=1e-9)
    else:
        x = np.asarray(topo.positions()) * factor
        np.testing.assert_allclose(p.x - p.x[0], x - x[0], rtol=1e-9, atol=1e-15)
    # heights in metres: a header unit ignored would be off by 10^3 or more
    par = profile_parameters(ps, detrend="mean")
    rq = topo.rms_height_from_profile() * factor
    assert par.Rq == pytest.approx(rq, rel=0.02)
    assert par.Rdq == pytest.approx(topo.rms_slope_from_profile(), rel=0.05)
    # every unit recorded with its origin
    origin = "argument" if kw else "file"
    assert p.metadata["z_unit_from"] == origin and p.metadata["x_unit_from"] == origin


@pytest.mark.parametrize("name", ["dektak-1.csv", "mitutoyo_mock.xlsx", "xy-1.txt"])
def test_line_scans_through_the_cli(tmp_path, capsys, name):
    kw = LINE_SCANS[name]
    topo, factor = _st(name, kw.get("unit"))
    out = tmp_path / "out"
    args = ["roughness", str(DATA / name), "--out", str(out), "--detrend", "mean"]
    if "unit" in kw:
        args += ["--unit", kw["unit"]]
    assert main([*args, "--contact-length-um", "50"]) == 0
    data = json.loads((out / "roughness.json").read_text())
    rq_um = topo.rms_height_from_profile() * factor * 1e6
    assert data["profile"]["Rq_um"] == pytest.approx(rq_um, rel=0.02)
    assert data["profile"]["Rdq"] == pytest.approx(
        topo.rms_slope_from_profile(), rel=0.05
    )
    assert data["sources"] == [name]  # the name, no folders
    text = capsys.readouterr().out
    origin = "argument" if kw else "file"
    assert f"z in {data['units']['z_unit']} ({origin})" in text
    if not topo.is_uniform:
        assert "real positions (no resampling)" in text
        assert data["data"]["non_uniform_scans"] == 1


@pytest.mark.parametrize("name", sorted(MAPS))
def test_maps_match_surfacetopography(name):
    kw = MAPS[name]
    topo, factor = _st(name, kw.get("z_unit"))
    hm = read_height_map(DATA / name, **kw)
    nx, ny = topo.nb_grid_pts
    assert (hm.nx, hm.ny) == (nx, ny)
    if "dx_um" not in kw:
        assert hm.dx == pytest.approx(topo.pixel_size[0] * factor, rel=1e-9)
        assert hm.dy == pytest.approx(topo.pixel_size[1] * factor, rel=1e-9)
    # the same mask
    heights = topo.heights()
    mask = np.ma.getmaskarray(heights).T if np.ma.isMaskedArray(heights) else False
    np.testing.assert_array_equal(~hm.valid, np.broadcast_to(mask, hm.shape))
    assert hm.metadata["masked_fraction"] == pytest.approx(np.mean(~hm.valid))
    # Sq about the mean, and after levelling the plane
    z = hm.z[hm.valid]
    sq = np.sqrt(np.mean((z - z.mean()) ** 2))
    assert sq == pytest.approx(topo.rms_height_from_area() * factor, rel=0.01)
    levelled = topo.detrend("height").rms_height_from_area() * factor
    if levelled > 1e-6 * sq:  # (a 3 x 4 map can be a plane)
        assert areal_parameters(hm).Sq == pytest.approx(levelled, rel=0.01)


@pytest.mark.parametrize(
    ("name", "span", "field"),
    [
        # '# Width: 12.34 µm' over 3 columns: 2 spacings of 4.113 µm
        ("gwyddion-export-english.txt", "15 m", "8.22667 µm"),
        ("matrix-6.txt", "11 m", "7.5 µm"),
    ],
)
def test_gwyddion_exports_honour_their_units_and_are_implausible(name, span, field):
    # '# Value units: m' with heights 1 ... 9: metres (the issue of issue 21: they
    # came out 10^6 too small), over a field of micrometres. SurfaceTopography's
    # toy files describe no surface: a height range of metres over µm is refused
    # (issue 30), naming the unit it was read in and the override
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(DATA / name)
    msg = str(info.value)
    assert f"a range of {span} (" in msg and f"over a field of {field}" in msg
    assert "read as m: was it µm?" in msg and "z_unit=" in msg
    # an argument that disagrees with the file is an error naming both
    with pytest.raises(ProfileFormatError, match=r"gives the unit 'm' but `z_unit`"):
        read_height_map(DATA / "gwyddion-export-english.txt", z_unit="nm")


def test_an_argument_disagreeing_with_an_instrument_file_names_both():
    with pytest.raises(ProfileFormatError) as info:
        read_profiles(DATA / "opdx-3.opdx", z_unit="nm")
    msg = str(info.value)
    assert "'µm'" in msg and "'nm'" in msg and "z_unit" in msg and "\n" not in msg
    # the same unit, however spelt, is no conflict
    p = read_profile(DATA / "opdx-3.opdx", unit="um")
    assert p.metadata["z_unit_from"] == "file"


def test_a_map_with_200_um_pixels_refuses_a_smaller_contact_and_masks_invalid():
    from microimpact.surface.areal import facet_angles

    hm = read_height_map(DATA / "frt-2.frt")
    assert hm.dx == pytest.approx(200e-6)
    assert 0.2 < hm.metadata["masked_fraction"] < 0.35
    for contact in (20.0, 100.0):
        with pytest.raises(ValueError) as info:
            facet_angles(hm, contact_diameter_um=contact)
        msg = str(info.value)
        assert f"{contact:g} µm" in msg and "200 µm" in msg and "at least 200" in msg
    # the hint, followed: a contact of at least one pixel
    fa = facet_angles(hm, contact_diameter_um=400.0)
    assert fa.phi_par.size > 0


def test_a_file_without_a_unit_names_the_arguments_and_the_hint_works(tmp_path):
    ibw = DATA / "10x10-one_channel_without_name.ibw"
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(ibw)
    msg = str(info.value)
    assert info.value.field == "unit"
    for arg in ("`dx_um`", "`dy_um`", "`z_unit`"):
        assert arg in msg
    hm = read_height_map(ibw, dx_um=0.5, z_unit="nm")  # followed
    assert (hm.dx, hm.dy) == (pytest.approx(0.5e-6), pytest.approx(0.5e-6))
    assert hm.metadata["z_unit_from"] == "argument"
    assert hm.metadata["dx_from"] == "argument"
    # its rows as profiles: positions in the µm of dx_um
    rows = read_profiles(ibw, dx_um=0.5, z_unit="nm")
    assert len(rows) == 10
    assert (rows[0].metadata["x_unit"], rows[0].metadata["x_unit_from"]) == (
        "um",
        "dx_um",
    )
    np.testing.assert_allclose(rows[0].x[:3], [0.0, 0.5e-6, 1e-6], rtol=1e-12)
    # dy_um given as well: its own spacing, not dx_um's
    hm = read_height_map(ibw, dx_um=0.5, dy_um=2.0, z_unit="nm")
    assert (hm.dx, hm.dy) == (pytest.approx(0.5e-6), pytest.approx(2e-6))
    # the same for a line scan: the message, then the hint followed
    xy = DATA / "nonuniform.asc"
    with pytest.raises(ProfileFormatError, match=r"no length unit.*`unit`"):
        read_profiles(xy)
    assert read_profiles(xy, unit="um")[0].metadata["x_unit_from"] == "argument"
    # and through the CLI
    code = main(["roughness", str(xy), "--out", str(tmp_path / "o"), "--unit", "um"])
    assert code == 0


def test_nan_in_a_two_column_scan_is_masked_as_maps_mask_it():
    p = read_profile(DATA / "xy-5.txt", unit="um")
    assert p.masked_fraction == pytest.approx(0.25)
    topo, _ = _st("xy-5.txt", "um")
    assert topo.has_undefined_data
    np.testing.assert_array_equal(~p.valid, np.ma.getmaskarray(topo.heights()))


@pytest.mark.parametrize("name", UNREADABLE)
def test_unreadable_files_are_one_line_errors_with_exit_2(tmp_path, capsys, name):
    code = main(["roughness", str(DATA / name), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and name in err
    assert "internal error" not in err and "Traceback" not in err


@pytest.mark.parametrize("name", sorted(n for n, kw in LINE_SCANS.items() if not kw))
def test_line_scans_asked_for_as_maps_point_to_read_profiles(name):
    with pytest.raises(ProfileFormatError, match="holds a line scan") as info:
        read_height_map(DATA / name)
    assert "\n" not in str(info.value) and "read_profiles" in str(info.value)
    assert len(read_profiles(DATA / name)) == 1  # the hint, followed


def test_non_uniform_angles_use_real_positions(tmp_path):
    # a ramp of slope 0.3 sampled at irregular positions: every segment slope is
    # exactly 0.3 only if the segment means use the real positions
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.uniform(0.05, 1.95, 4000))
    f = tmp_path / "ramp.csv"
    np.savetxt(
        f, np.column_stack([x, 0.3 * x]), delimiter=",", header="x_um,z_um", comments=""
    )
    ch = characterise(read_profiles(f), contact_length=20e-6, detrend=None)
    assert ch.non_uniform_scans == 1
    np.testing.assert_allclose(np.tan(ch.angles), 0.3, rtol=1e-9)
    assert ch.profile.Rdq == pytest.approx(0.3, rel=1e-9)


def test_a_spacing_argument_that_agrees_with_the_file_is_accepted():
    # frt-2.frt states 200 µm pixels: the same value given is no conflict, and
    # the spacing is still the file's
    hm = read_height_map(DATA / "frt-2.frt", dx_um=200.0)
    assert hm.dx == pytest.approx(200e-6) and hm.metadata["dx_from"] == "file"


def test_a_file_no_microimpact_reader_knows_is_named_with_the_docs():
    with pytest.raises(ProfileFormatError) as info:
        read_profiles(DATA / "wrongnpyfile.npy")
    assert str(info.value) == (
        f"{DATA / 'wrongnpyfile.npy'}: not a format that microimpact or "
        "SurfaceTopography reads (no reader recognises the file; see "
        "docs/roughness.md for the formats read)"
    )


@pytest.mark.parametrize(
    ("unit", "metres"), [("pm", 1e-12), ("km", 1e3), ("nm", 1e-9), ("s", None)]
)
def test_surfacetopography_units_are_metres_by_their_si_prefix(unit, metres):
    # units microimpact does not spell itself (pm, km) through SurfaceTopography's
    # table; a unit that is not a length is None
    from microimpact.io.instruments import surfacetopography_unit_factor

    factor = surfacetopography_unit_factor(unit)
    assert factor == (None if metres is None else pytest.approx(metres, rel=1e-12))


class _Proxy:
    """An object answering as `inner`, except for the attributes given."""

    def __init__(self, inner, **override):
        self._inner, self._override = inner, override

    def __getattr__(self, name):
        if name in self._override:
            return self._override[name]
        return getattr(self._inner, name)


def test_a_channel_that_is_not_a_height_is_refused_naming_the_file():
    # an AFM file's default channel can be a signal in volts (deflection):
    # the reader of sdf-1.sdf, its channel's unit made 'V'
    from SurfaceTopography import open_topography

    from microimpact.io.instruments import read_instrument

    path = DATA / "sdf-1.sdf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        real = open_topography(str(path))
    volts = _Proxy(real, default_channel=_Proxy(real.default_channel, unit="V"))
    with pytest.raises(ProfileFormatError) as info:
        read_instrument(path, want="map", reader=volts)
    assert info.value.field == "unit"
    assert str(info.value) == (
        f"{path}: unit: the file gives the unit 'V', which is not a length unit; "
        "allowed: a height topography (m, mm, µm, nm, Å)"
    )
