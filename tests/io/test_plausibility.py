"""Plausibility before any number (issue 30): real NanoFocus ``.nms`` maps read with
the spacing their header states (a second reading of the format, by hand, after
surfalize's parser), a Gwyddion ``.gwy`` that SurfaceTopography cannot read refused
in one line, every exception inside a third-party reader turned into our one-line
error, and every implausible spacing, field or height range refused naming the
likely unit slip and the override."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from microimpact.cli import main
from microimpact.errors import ProfileFormatError
from microimpact.io import instruments
from microimpact.io.areal import read_height_map
from microimpact.io.profiles import read_profile, read_profiles
from microimpact.surface.areal import areal_parameters

pytest.importorskip("SurfaceTopography")
DATA = Path(__file__).parents[1] / "data" / "instruments"
NMS = ["nms-1.nms", "nms-2.nms"]
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def _nms_by_hand(path):
    """The second reading: the NanoFocus layout as surfalize's parser reads it
    (fredericjs/surfalize, surfalize/file/nms.py): z range at byte 16 (two
    doubles, µm), nx, ny at byte 1368 (two uint32), dx, dy at byte 1376 (two
    doubles, nm), uint16 heights from byte 3468 scaled to the z range."""
    b = Path(path).read_bytes()
    zmin, zmax = struct.unpack_from("<2d", b, 16)
    nx, ny = struct.unpack_from("<2I", b, 1368)
    dx_nm, dy_nm = struct.unpack_from("<2d", b, 1376)
    raw = np.frombuffer(b, dtype="<u2", count=nx * ny, offset=3468).reshape(ny, nx)
    z_um = raw / (2**16 - 2) * (zmax - zmin) + zmin
    return z_um * 1e-6, dx_nm * 1e-9, dy_nm * 1e-9


def _levelled(z):
    ny, nx = z.shape
    yy, xx = np.mgrid[:ny, :nx]
    a = np.column_stack([np.ones(z.size), xx.ravel(), yy.ravel()])
    coef, *_ = np.linalg.lstsq(a, z.ravel(), rcond=None)
    return (z.ravel() - a @ coef).reshape(ny, nx)


@pytest.mark.parametrize("name", NMS)
def test_nms_maps_match_the_format_read_by_hand(name):
    z, dx, dy = _nms_by_hand(DATA / name)
    assert dx == pytest.approx(312.5e-9, rel=1e-6)  # 0.3125 µm pixels, 160 µm field
    hm = read_height_map(DATA / name)
    assert hm.shape == z.shape == (512, 512)
    assert hm.dx == pytest.approx(dx, rel=1e-3) and hm.dy == pytest.approx(dy, rel=1e-3)
    assert hm.metadata["spacing_read_by"].startswith("microimpact")
    ap = areal_parameters(hm)
    r = _levelled(z)
    assert ap.Sq == pytest.approx(np.sqrt(np.mean(r**2)), rel=0.02)
    gy, gx = np.gradient(r, dy, dx)  # central differences: an independent slope
    assert ap.Sdq == pytest.approx(np.sqrt(np.mean(gx**2 + gy**2)), rel=0.05)
    # the case: Sdq 0.021, not 2.1e-8
    if name == "nms-1.nms":
        assert ap.Sdq == pytest.approx(0.021, rel=0.02)


def test_nms_rows_read_as_profiles_have_the_stated_spacing():
    ps = read_profiles(DATA / "nms-1.nms")
    assert len(ps) == 512
    assert ps[0].dx == pytest.approx(312.5e-9, rel=1e-3)


def test_surfacetopographys_nms_spacing_is_refused_naming_the_override(monkeypatch):
    # without our own reading of the spacing field, SurfaceTopography's pixel
    # (312.5 read as mm) reaches the plausibility check: refused, never passed on
    monkeypatch.setattr(instruments, "_nms_spacing", lambda path: None)
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(DATA / "nms-1.nms")
    msg = str(info.value)
    assert "implausible lateral spacing dx = 312.5 mm" in msg
    assert "dx_um=" in msg and "\n" not in msg
    # the override, followed
    hm = read_height_map(DATA / "nms-1.nms", dx_um=0.3125)
    assert hm.dx == pytest.approx(312.5e-9) and hm.dy == pytest.approx(312.5e-9)
    assert hm.metadata["dx_from"].startswith("argument")


def test_nms_through_the_cli_advises_a_micrometre_contact(tmp_path, capsys):
    code = main(["roughness", str(DATA / "nms-2.nms"), "--out", str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "312500" not in out.replace(",", "")


def test_a_gwy_file_without_units_is_one_line_naming_format_and_reader(
    tmp_path, capsys
):
    # tuxu/gwyfile's tests/test.gwy (MIT): a data field with empty SI units;
    # SurfaceTopography's GWYReader lists no channel and then raises IndexError
    gwy = DATA / "gwyfile-test.gwy"
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(gwy)
    msg = str(info.value)
    assert "gwyfile-test.gwy" in msg and "GWYReader" in msg and " gwy file" in msg
    assert "finds no topography channel" in msg
    assert "\n" not in msg
    code = main(["roughness", str(gwy), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "GWYReader" in err and "internal error" not in err
    assert "Traceback" not in err


@pytest.mark.parametrize("where", ["channels", "topography", "heights"])
def test_any_exception_inside_the_reader_is_our_one_line_error(
    monkeypatch, tmp_path, capsys, where
):
    from SurfaceTopography.IO.SDF import SDFReader

    def boom(*args, **kwargs):
        raise IndexError("list index out of range")

    if where == "channels":
        monkeypatch.setattr(SDFReader, "channels", property(boom))
    elif where == "topography":
        monkeypatch.setattr(SDFReader, "topography", boom)
    else:  # a topography object that fails later (no heights())
        monkeypatch.setattr(SDFReader, "topography", lambda self, **kw: object())
    sdf = DATA / "sdf-1.sdf"
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(sdf)
    msg = str(info.value)
    assert "sdf-1.sdf" in msg and "SDFReader" in msg and " sdf file" in msg
    assert ("IndexError" if where != "heights" else "AttributeError") in msg
    code = main(["roughness", str(sdf), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "internal error" not in err


# ---------------------------------------------------------------- text files


def _grid(tmp_path, header, nx=32, ny=16, amp=0.2):
    rng = np.random.default_rng(3)
    z = amp * rng.standard_normal((ny, nx))
    p = tmp_path / "map.txt"
    body = "\n".join(" ".join(f"{v:.5f}" for v in row) for row in z)
    p.write_text(header + body + "\n", encoding="utf-8")
    return p


def test_a_spacing_read_as_mm_is_refused_naming_nm_and_the_override(tmp_path):
    p = _grid(tmp_path, "# dx_mm = 312.5\n# z_unit = um\n")
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(p)
    msg = str(info.value)
    assert "312.5 read as mm: was it nm?" in msg and "dx_um=" in msg
    # one map has no scans to number: no "(scan ...)", no None
    assert "was it nm?): outside 1 Å to 1 mm per point;" in msg
    assert "scan" not in msg and "None" not in msg
    hm = read_height_map(p, dx_um=0.3125)  # the override
    assert hm.dx == pytest.approx(312.5e-9)
    assert hm.metadata["dx_from"].startswith("argument")


def test_a_plausible_header_and_a_disagreeing_argument_are_still_an_error(tmp_path):
    p = _grid(tmp_path, "# dx_um = 0.5\n# z_unit = um\n")
    with pytest.raises(ProfileFormatError, match="but `dx_um` is"):
        read_height_map(p, dx_um=0.25)


def test_heights_read_in_mm_are_refused_naming_um(tmp_path):
    # 0.2 µm roughness typed as mm over a 15.5 µm field
    p = _grid(tmp_path, "# dx_um = 0.5\n")
    with pytest.raises(ProfileFormatError) as info:
        read_height_map(p, z_unit="mm")
    msg = str(info.value)
    assert "implausible heights" in msg and "read as mm: was it µm?" in msg
    assert msg.endswith("if the file's height unit is wrong, give it with z_unit=...")
    assert "scan" not in msg and "None" not in msg
    assert read_height_map(p, z_unit="um").metadata["z_unit"] == "um"  # followed


def test_a_field_of_a_metre_or_more_is_refused(tmp_path):
    p = _grid(tmp_path, "# dx_mm = 0.9\n# z_unit = um\n", nx=1200, ny=2)
    with pytest.raises(ProfileFormatError, match=r"field of view of 1\.0791 m"):
        read_height_map(p)


def test_a_profile_in_nm_read_as_mm_is_refused(write_file):
    p = write_file(
        "scan.csv", "x_mm,z_nm\n" + "".join(f"{i * 50},{i % 7}\n" for i in range(40))
    )
    with pytest.raises(ProfileFormatError) as info:
        read_profile(p)
    msg = str(info.value)
    # 50 nm is nearer a profilometer's usual 1 µm than 50 µm is
    assert "dx = 50 mm (50 read as mm: was it nm?)" in msg and "x_unit=" in msg
    assert msg.startswith(f"{p}: dx: implausible lateral spacing")  # the file named


@settings(max_examples=60, deadline=None)
@given(
    spacing=st.floats(1e-3, 1e4, allow_nan=False),
    unit=st.sampled_from(["mm", "um", "nm"]),
    n=st.integers(2, 40),
)
def test_every_spacing_is_read_exactly_or_refused_in_one_line(
    tmp_path_factory, spacing, unit, n
):
    # a property over the public API: a spacing that lies in 0.1 nm .. 1 mm with
    # a field under 1 m is read to the last digit; any other is refused in one
    # line naming the value as typed, the unit and the override
    tmp = tmp_path_factory.mktemp("p")
    p = _grid(tmp, f"# dx_{unit} = {spacing!r}\n# z_unit = nm\n", nx=n, ny=3)
    metres = spacing * {"mm": 1e-3, "um": 1e-6, "nm": 1e-9}[unit]
    plausible = 1e-10 <= metres <= 1e-3 and metres * (n - 1) < 1.0
    try:
        hm = read_height_map(p)
    except ProfileFormatError as exc:
        msg = str(exc)
        assert not plausible, msg
        shown = {"um": "µm"}.get(unit, unit)
        assert "read as " + shown in msg and "dx_um=" in msg
        assert "\n" not in msg and "np.float64" not in msg
    else:
        assert plausible
        assert hm.dx == pytest.approx(metres, rel=1e-12)


def test_real_files_of_the_fixture_pass_the_check():
    # the plausibility check refuses no real instrument map of the fixture
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("sdf-1.sdf", "nc-1.nc", "frt-2.frt", "txt_example.txt", *NMS):
            read_height_map(DATA / name)
        for name in ("dektak-1.csv", "opdx-3.opdx", "mitutoyo_mock.xlsx"):
            read_profiles(DATA / name)


def test_an_exception_in_a_text_exports_reader_is_our_one_line_error(monkeypatch):
    # a Dektak CSV is tried by our text reader first, then by SurfaceTopography's:
    # an exception inside the latter's metadata is still one line naming it
    from SurfaceTopography.IO.Reader import ReaderBase

    def boom(self):
        raise KeyError("unit")

    monkeypatch.setattr(ReaderBase, "default_channel", property(boom))
    for read in (read_profiles, read_height_map):
        with pytest.raises(ProfileFormatError) as info:
            read(DATA / "dektak-1.csv")
        msg = str(info.value)
        assert "dektak-1.csv" in msg and "KeyError" in msg and "reader (" in msg


def test_nms_rows_give_rq_and_rdq_of_the_hand_reading():
    # the rows of nms-1 as line scans (as `microimpact roughness` reads a map):
    # Rq about each row's mean line and RΔq of the interval slopes, pooled, equal
    # the hand reading's within 2 % and 5 %
    from microimpact.surface.roughness import profile_parameters

    z, dx, _ = _nms_by_hand(DATA / "nms-1.nms")
    par = profile_parameters(read_profiles(DATA / "nms-1.nms"), detrend="line")
    x = np.arange(z.shape[1]) * dx
    res = np.array([row - np.polyval(np.polyfit(x, row, 1), x) for row in z])
    assert par.Rq == pytest.approx(np.sqrt(np.mean(res**2)), rel=0.02)
    slopes = np.diff(res, axis=1) / dx
    assert par.Rdq == pytest.approx(np.sqrt(np.mean(slopes**2)), rel=0.05)


def test_an_implausible_scan_of_several_is_named_by_its_scan(write_file):
    # scan 1 at 0.5 mm per point is plausible, scan 2 at 5 mm is not: the
    # message says which scan
    text = "scan,x_mm,z_nm\n" + "".join(
        f"{s},{i * step},{i % 3}\n" for s, step in ((1, 0.5), (2, 5)) for i in range(6)
    )
    p = write_file("scans.csv", text)
    with pytest.raises(ProfileFormatError) as info:
        read_profiles(p)
    assert str(info.value).startswith(
        f"{p}: dx: implausible lateral spacing dx = 5 mm (5 read as mm: was it µm?) "
        "(scan 2): outside 1 Å to 1 mm per point;"
    )
