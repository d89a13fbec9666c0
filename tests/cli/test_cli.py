"""The command line: every verb end to end, exit codes, bad input, and resume after
SIGKILL."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from numpy.testing import assert_array_equal

from microimpact.cli import main

BAD = Path(__file__).parents[1] / "data" / "bad_scenarios"

SMALL = """\
name = "cli-test"
seed = 7
samples = {samples}

[particles]
distribution = "normal"
mean_um = 52.8
std_um = 15.3

[coefficients]
k1 = 4.0
k2 = 0.05
v_c = {{ law = "power", a_m_s = 0.2, b = -1.5, d_ref_um = 52.8 }}
friction = 0.15

[[surfaces]]
name = "rough"
kind = "normal"
std_deg = 10.0

[sweep]
speed_m_s = [0.2, 0.5]
angle_deg = [{angles}]
"""


def _scenario(tmp_path, samples=2000, angles="30, 85"):
    p = tmp_path / "small.toml"
    p.write_text(SMALL.format(samples=samples, angles=angles))
    return p


def test_run_writes_every_output(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(
        [
            "run",
            str(_scenario(tmp_path)),
            "--out",
            str(out),
            "--quiet",
            "--formats",
            "png",
        ]
    )
    assert code == 0
    for name in ("summary.csv", "results.nc", "capture_speed.csv", "report.html"):
        assert (out / name).stat().st_size > 0, name
    assert list(out.glob("*.png"))
    assert not (out / ".microimpact-checkpoint.npz").exists()
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == 4 and (summary["n"] == 2000).all()
    with xr.open_dataset(out / "results.nc") as ds:
        assert ds.attrs["seed_entropy"] == "7"
        assert ds["e_hist"].sum() == summary["n"].sum() - (
            summary["n"] * summary["capture_fraction"]
        ).round().sum() - (ds["e_hist_underflow"].sum() + ds["e_hist_overflow"].sum())


def test_run_seed_flag_reproduces_and_overrides(tmp_path):
    sc = str(_scenario(tmp_path))
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    for d, seed in ((a, "3"), (b, "3"), (c, "4")):
        assert (
            main(
                ["run", sc, "--out", str(d), "--seed", seed, "--quiet", "--no-figures"]
            )
            == 0
        )
    sa, sb, sc_ = (pd.read_csv(d / "summary.csv") for d in (a, b, c))
    assert_array_equal(sa["e_mean"], sb["e_mean"])
    assert not np.array_equal(sa["e_mean"], sc_["e_mean"])


def test_precision_flag(tmp_path):
    out = tmp_path / "p"
    assert (
        main(
            [
                "run",
                str(_scenario(tmp_path)),
                "--out",
                str(out),
                "--precision",
                "0.02",
                "--quiet",
                "--no-figures",
            ]
        )
        == 0
    )
    s = pd.read_csv(out / "summary.csv")
    assert ((s["capture_ci_high"] - s["capture_ci_low"]) / 2 <= 0.02).all()


@pytest.mark.parametrize("path", sorted(BAD.glob("*.toml")), ids=lambda p: p.stem)
def test_bad_scenarios_exit_2_with_one_line_naming_the_key(path, tmp_path, capsys):
    first = path.read_text().splitlines()[0]
    key = re.match(r"#\s*expect:\s*(\S+)", first).group(1)
    code = main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert "\n" not in err and "Traceback" not in err
    assert key in err


@pytest.mark.parametrize(
    "argv",
    [
        ["run"],
        ["run", "x.toml"],
        ["run", "x.toml", "--out", "o", "--workers", "0"],
        ["run", "x.toml", "--out", "o", "--backend", "mpi"],
        ["run", "x.toml", "--out", "o", "--samples", "many"],
        ["run", "x.toml", "--out", "o", "--formats", "gif"],
        ["frobnicate"],
        ["run", "no-such-file.toml", "--out", "o"],
        ["run", "no-such-preset", "--out", "o"],
        ["compare", "missing-dir", "missing.csv"],
        ["sizes", "missing.csv"],
        ["run", "sst65-silicon-normal", "--out", "o", "--scheduler", "tcp://h:1"],
    ],
)
def test_user_errors_exit_2(argv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.strip()


def test_samples_and_precision_are_exclusive(tmp_path, capsys):
    code = main(
        [
            "run",
            str(_scenario(tmp_path)),
            "--out",
            str(tmp_path / "o"),
            "--samples",
            "100",
            "--precision",
            "0.01",
            "--quiet",
        ]
    )
    assert code == 2
    assert "--precision" in capsys.readouterr().err


def test_roughness_command(tmp_path, capsys):
    rng = np.random.default_rng(3)
    x = np.arange(4000) * 0.5
    z = np.cumsum(rng.normal(0, 0.4, x.size))
    f = tmp_path / "scan.csv"
    pd.DataFrame({"x_um": x, "z_um": z}).to_csv(f, index=False)
    out = tmp_path / "r"
    assert main(["roughness", str(f), "--out", str(out), "--n-angles", "500"]) == 0
    for name in ("roughness.json", "angles.txt", "angle_pdf.png", "profile.png"):
        assert (out / name).exists(), name
    angles = [
        ln
        for ln in (out / "angles.txt").read_text().splitlines()
        if ln.strip() and not ln.startswith("#")
    ]
    assert len(angles) == 500


def test_roughness_bad_profile(tmp_path, capsys):
    f = tmp_path / "bad.csv"
    f.write_text("x_um,z_um\n0,1\n0.5,abc\n1.0,2\n")
    assert main(["roughness", str(f), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and "Traceback" not in err


def test_sizes_command(tmp_path, capsys):
    d = np.random.default_rng(5).normal(52.8, 15.3, 800)
    d = d[d > 0]
    f = tmp_path / "d.csv"
    f.write_text("diameter_um\n" + "\n".join(f"{v:.3f}" for v in d))
    assert main(["sizes", str(f), "--out", str(tmp_path / "s")]) == 0
    assert (tmp_path / "s" / "size_distribution.png").exists()
    assert "chi-squared" in capsys.readouterr().out


def test_fit_command(tmp_path, capsys):
    rng = np.random.default_rng(11)
    rows = []
    for d_um in (30.0, 50.0, 70.0):
        vc = 0.2 * (d_um / 50) ** -1.5
        v = np.linspace(vc * 1.2, 3.0, 40)
        e = 4.0 / (4.0 + v) * (1 - 0.05 / (0.05 + v - vc))
        e += rng.normal(0, 0.005, v.size)
        rows += [(d_um, vi, ei) for vi, ei in zip(v, e, strict=True)]
    f = tmp_path / "impacts.csv"
    pd.DataFrame(rows, columns=["diameter_um", "v_n_m_s", "e"]).to_csv(f, index=False)
    assert main(["fit", str(f), "--out", str(tmp_path / "f")]) == 0
    table = pd.read_csv(tmp_path / "f" / "coefficients_by_diameter.csv")
    assert len(table) == 3


@pytest.mark.parametrize(
    ("verb", "text", "message"),
    [
        ("sizes", "d\n50\n", "needs at least 2 values; got 1"),
        ("sizes", "d\n50\n50\n", "all equal"),
        ("sizes", "d\n50\n60\n70\n", "too few diameters for the chi-squared test"),
        (
            "fit",
            "diameter_um,v_n_m_s,e\n50,1,0.6\n50,2,0.5\n60,1,0.6\n",
            "no diameter has the 5 or more impacts",
        ),
    ],
)
def test_too_little_data_names_the_file(tmp_path, capsys, verb, text, message):
    f = tmp_path / "few.csv"
    f.write_text(text)
    assert main([verb, str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"{f}: " in err and message in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_sizes_column_by_negative_index(tmp_path, capsys):
    d = np.random.default_rng(6).normal(52.8, 15.3, 400)
    f = tmp_path / "d.csv"
    f.write_text(
        "id,diameter_um\n" + "\n".join(f"{i},{v:.3f}" for i, v in enumerate(d))
    )
    assert main(["sizes", str(f), "--column", "-1"]) == 0
    assert f"n = {d.size}" in capsys.readouterr().out


def test_convergence_command(tmp_path, capsys):
    sc = _scenario(tmp_path, angles="90")
    assert (
        main(["convergence", str(sc), "--n-max", "3000", "--out", str(tmp_path / "c")])
        == 0
    )
    assert (tmp_path / "c" / "convergence.csv").exists()
    assert "settled" in capsys.readouterr().out


def test_convergence_says_when_no_point_has_a_transition(tmp_path, capsys):
    """Speeds far above capture everywhere: the default point never varies, and
    "settled after N = 1" alone would read as a converged study."""
    p = tmp_path / "fast.toml"
    p.write_text(
        SMALL.format(samples=2000, angles="90").replace(
            "speed_m_s = [0.2, 0.5]", "speed_m_s = [50, 80]"
        )
    )
    assert main(["convergence", str(p), "--n-max", "2000"]) == 0
    err = capsys.readouterr().err
    assert "capture is 0 or 1 at every sweep point" in err and "--point" in err
    assert main(["convergence", str(_scenario(tmp_path, angles="90"))]) == 0
    assert "every sweep point" not in capsys.readouterr().err


def test_compare_command(tmp_path, capsys):
    out = tmp_path / "run"
    assert (
        main(
            [
                "run",
                str(_scenario(tmp_path)),
                "--out",
                str(out),
                "--quiet",
                "--no-figures",
            ]
        )
        == 0
    )
    s = pd.read_csv(out / "summary.csv")
    row = s.iloc[0]
    exp = tmp_path / "exp.csv"
    exp.write_text(
        "surface,speed_m_s,angle_deg,statistic,mean,ci_low,ci_high\n"
        f"rough,{row.speed_m_s},{row.angle_deg},e,"
        f"{row.e_rebound_mean},{row.e_rebound_mean - 0.05},"
        f"{row.e_rebound_mean + 0.05}\n"
    )
    assert main(["compare", str(out), str(exp), "--out", str(tmp_path / "cmp")]) == 0
    assert "1 of 1 compared points agree" in capsys.readouterr().out


def test_presets_command(capsys):
    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    for name in (
        "sst65-silicon-normal",
        "sst125-silicon-normal",
        "sst76-formica-oblique",
        "lycopodium-formica-oblique",
    ):
        assert name in out


def _console(*args, **kw):
    exe = Path(sys.executable).with_name("microimpact")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, **kw)


def test_console_script_smoke():
    r = _console("--version")
    assert r.returncode == 0 and "microimpact" in r.stdout
    r = _console("run", "nothing.toml", "--out", "/tmp/never")
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_sigkill_then_rerun_is_bit_identical(tmp_path):
    """Kill a long run with SIGKILL mid-way; the re-run resumes from the checkpoint
    and produces exactly the uninterrupted results."""
    sc = _scenario(tmp_path, samples=12_000_000, angles="30")
    ref, out = tmp_path / "ref", tmp_path / "out"
    args = ["--quiet", "--no-figures"]
    assert _console("run", str(sc), "--out", str(ref), *args).returncode == 0
    exe = Path(sys.executable).with_name("microimpact")
    proc = subprocess.Popen(
        [str(exe), "run", str(sc), "--out", str(out), *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "MICROIMPACT_CHECKPOINT_INTERVAL": "0.2"},
    )
    ck = out / ".microimpact-checkpoint.npz"
    deadline = time.monotonic() + 60
    while not ck.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    killed = proc.poll() is None
    if killed:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    if not killed or (out / "summary.csv").exists():
        # the checkpoint seen was the final one, written as the run ended
        pytest.skip("the run finished before it could be killed")
    rerun = _console("run", str(sc), "--out", str(out), *args)
    assert rerun.returncode == 0
    # the re-run says, before it simulates, how much it restored (a run that
    # ignored its checkpoint would be bit-identical too: this is what tells)
    said = re.search(r"resumed (\d+) of (\d+) blocks", rerun.stderr)
    assert said and 0 < int(said.group(1)) < int(said.group(2)), rerun.stderr
    from microimpact.engine.result import open_result

    prov = open_result(out).provenance
    assert prov["resumed_blocks"] == int(said.group(1))
    assert prov["total_blocks"] == int(said.group(2))
    a = pd.read_csv(ref / "summary.csv")
    b = pd.read_csv(out / "summary.csv")
    num = a.select_dtypes("number").columns
    assert_array_equal(a[num].to_numpy(), b[num].to_numpy())


@pytest.mark.parametrize("value", ["0", "-1", "soon", "nan"])
def test_bad_checkpoint_interval_is_a_user_error(tmp_path, monkeypatch, capsys, value):
    monkeypatch.setenv("MICROIMPACT_CHECKPOINT_INTERVAL", value)
    code = main(["run", str(_scenario(tmp_path)), "--out", str(tmp_path / "o")])
    assert code == 2
    err = capsys.readouterr().err
    assert "MICROIMPACT_CHECKPOINT_INTERVAL" in err and repr(value) in err


# ------------------------------------------------------------- review fixes
def _one_line_error(capsys):
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("verb", ["run", "reproduce", "roughness", "sizes"])
def test_out_that_is_a_file_is_a_user_error(tmp_path, capsys, verb):
    f = tmp_path / "taken.txt"
    f.write_text("not a folder\n")
    args = {
        "run": ["run", str(_scenario(tmp_path))],
        "reproduce": ["reproduce", "--quick"],
        "roughness": ["roughness", str(f)],
        "sizes": ["sizes", str(f)],
    }[verb]
    for out in (f, f / "sub"):
        assert main([*args, "--out", str(out)]) == 2
        err = _one_line_error(capsys)
        assert "--out" in err and str(f) in err and "not a folder" in err
    assert f.read_text() == "not a folder\n"


def test_svg_only_figures_are_drawn_into_the_report(tmp_path):
    out = tmp_path / "out"
    sc = str(_scenario(tmp_path))
    assert main(["run", sc, "--out", str(out), "--quiet", "--formats", "svg"]) == 0
    svgs = sorted(p.stem for p in out.glob("*.svg"))
    assert svgs and not list(out.glob("*.png")) and not list(out.glob("*.pdf"))
    html = (out / "report.html").read_text(encoding="utf-8")
    imgs = re.findall(r"<img ", html)
    assert len(imgs) == len(svgs)  # every figure saved is also in the report
    assert html.count('src="data:image/png;base64,') == len(imgs)


def test_png_figures_are_reused_in_the_report(tmp_path):
    out = tmp_path / "out"
    sc = str(_scenario(tmp_path))
    assert main(["run", sc, "--out", str(out), "--quiet", "--formats", "png,svg"]) == 0
    html = (out / "report.html").read_text(encoding="utf-8")
    assert len(re.findall(r"<img ", html)) == len(list(out.glob("*.png")))


def _with_outputs(tmp_path, outputs):
    p = _scenario(tmp_path)
    p.write_text(p.read_text() + "\n[outputs]\n" + outputs + "\n")
    return p


def test_scenario_figures_give_the_formats(tmp_path):
    sc = _with_outputs(tmp_path, 'figures = ["svg"]')
    out = tmp_path / "a"
    assert main(["run", str(sc), "--out", str(out), "--quiet"]) == 0
    assert list(out.glob("*.svg"))
    assert not list(out.glob("*.png")) and not list(out.glob("*.pdf"))
    out = tmp_path / "b"  # --formats wins
    assert main(["run", str(sc), "--out", str(out), "--quiet", "--formats", "pdf"]) == 0
    assert list(out.glob("*.pdf")) and not list(out.glob("*.svg"))


def test_default_formats_without_scenario_figures(tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(_scenario(tmp_path)), "--out", str(out), "--quiet"]) == 0
    stems_png = {p.stem for p in out.glob("*.png")}
    assert stems_png and stems_png == {p.stem for p in out.glob("*.pdf")}


def test_malformed_experiments_fail_before_any_output(tmp_path, capsys):
    (tmp_path / "exp.csv").write_text(
        "speed_m_s,statistic,mean,half_width\n0.2,e,0.5,0.1\n0.5,e,abc,0.1\n"
    )
    sc = _with_outputs(tmp_path, 'experiments = "exp.csv"')
    out = tmp_path / "out"
    t0 = time.perf_counter()
    assert main(["run", str(sc), "--out", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert "exp.csv:3" in err and "mean" in err and "'abc'" in err
    assert not out.exists()  # nothing written, not even the folder
    assert time.perf_counter() - t0 < 5  # and no simulation ran


def test_experiments_are_read_once(tmp_path, monkeypatch):
    import microimpact.io.experiments as ioe

    (tmp_path / "exp.csv").write_text(
        "speed_m_s,angle_deg,statistic,mean,half_width\n0.2,30,e,0.5,0.1\n"
    )
    sc = _with_outputs(tmp_path, 'experiments = "exp.csv"')
    calls = []
    read = ioe.read_experiments
    monkeypatch.setattr(
        ioe, "read_experiments", lambda p: calls.append(p) or read(p), raising=True
    )
    out = tmp_path / "out"
    assert main(["run", str(sc), "--out", str(out), "--quiet"]) == 0
    assert len(calls) == 1
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "Comparison with experiments" in html
    assert (out / "comparison.png").exists()


def test_precision_flag_keeps_the_scenario_precision(tmp_path, monkeypatch):
    import microimpact.pipeline.study as study
    from microimpact.errors import InputError

    p = _scenario(tmp_path)
    p.write_text(
        p.read_text()
        + "\n[precision]\nstatistic = 'e_mean'\nmin_samples = 3000\n"
        + "max_samples = 50000\n"
    )
    seen = []

    def fake_execute(self, out_dir, **kw):
        seen.append(self.scenario)
        raise InputError("stop here")

    monkeypatch.setattr(study.Study, "execute", fake_execute)
    args = ["run", str(p), "--out", str(tmp_path / "o"), "--precision", "0.02"]
    assert main(args) == 2
    (sc,) = seen
    assert sc.precision.half_width == 0.02
    assert (sc.precision.statistic, sc.precision.min_samples) == ("e_mean", 3000)
    assert sc.precision.max_samples == 50000 and sc.sampling == "mc"


def test_surface_names_do_not_escape_the_output_folder(tmp_path):
    p = _scenario(tmp_path)
    p.write_text(p.read_text().replace('name = "rough"', 'name = "/../../esc/ape"'))
    out = tmp_path / "deep" / "out"
    assert main(["run", str(p), "--out", str(out), "--quiet", "--formats", "png"]) == 0
    assert (out / "angle_pdf________esc_ape.png").exists()
    assert all(f.parent == out for f in out.rglob("*"))
    assert sorted(f.name for f in tmp_path.iterdir()) == ["deep", "small.toml"]
    assert [f.name for f in (tmp_path / "deep").iterdir()] == ["out"]


def test_warnings_are_one_line(tmp_path, capsys):
    p = _scenario(tmp_path, angles="90")
    p.write_text(
        p.read_text()
        + "\n[precision]\nhalf_width = 0.0001\nmin_samples = 100\nmax_samples = 200\n"
    )
    out = tmp_path / "o"
    assert main(["run", str(p), "--out", str(out), "--quiet", "--no-figures"]) == 0
    err = capsys.readouterr().err.strip()
    assert err.startswith("microimpact run: warning: ")
    assert "did not reach the precision target" in err
    assert "\n" not in err and "warnings.warn" not in err


def test_unknown_preset_suggests_a_name(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "sst65-silicon", "--out", "o"]) == 2
    err = _one_line_error(capsys)
    assert "did you mean 'sst65-silicon-normal'" in err
    assert main(["run", "missing.toml", "--out", "o"]) == 2
    assert "missing.toml" in _one_line_error(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("verb", ["sizes", "roughness"])
def test_unit_must_be_a_known_length_unit(tmp_path, capsys, verb):
    f = tmp_path / "d.csv"
    f.write_text("1\n2\n3\n")
    argv = [verb, str(f), "--unit", "furlong"]
    if verb == "roughness":
        argv += ["--out", str(tmp_path / "r")]
    assert main(argv) == 2
    err = _one_line_error(capsys)
    assert "--unit" in err and "'furlong'" in err and "'nm'" in err


def test_run_names_the_points_with_heavy_tails(tmp_path, capsys):
    """Issue 25: a point whose mean rests on a few impacts is named on the terminal
    (SST65 near capture: 0.07 and 0.08 m/s leave 2 and 12 rebounds)."""
    code = main(
        [
            "run",
            "sst65-silicon-normal",
            "--out",
            str(tmp_path / "o"),
            "--formats",
            "png",
        ]
    )
    assert code == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "heavy tails" in x)
    summary = pd.read_csv(tmp_path / "o" / "summary.csv")
    flagged = summary[summary["heavy_tail"] == 1.0]
    assert len(flagged) >= 1
    assert f"the mean of {len(flagged)} point(s)" in line
    for _, r in flagged.head(6).iterrows():
        assert f"{r['speed_m_s']:g} m/s" in line
