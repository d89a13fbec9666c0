"""A run's cost is checked before any work (issue 33, item 1): a sweep too big for
the machine is refused at once with the numbers and how to cut it (``--yes`` goes
on); the stages after the simulation show their progress; Ctrl-C names only a
checkpoint that exists."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
import time

import pytest

from microimpact._core import footprint as fp_module
from microimpact._core import progress as progress_module
from microimpact._core.progress import stage, stages
from microimpact.cli import main
from microimpact.engine.footprint import footprint
from microimpact.scenario.scenario import read_scenario

SCENARIO = """
name = "cost"
seed = 3
samples = {samples}
[particles]
distribution = "normal"
mean_um = 50
std_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2
[[surfaces]]
name = "flat"
kind = "smooth"
[sweep]
speed_m_s = {speeds}
angle_deg = {angles}
"""

#: The issue's case: 10^5 speeds x 1,000 angles = 10^8 points.
HUGE = SCENARIO.format(
    samples=100,
    speeds="{ start = 0.1, stop = 10, num = 100000 }",
    angles="{ start = 1, stop = 90, num = 1000 }",
)
SMALL = SCENARIO.format(samples=200, speeds="[0.2, 0.5]", angles="[30, 90]")


def _write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.fixture
def machine_of_16_gb(monkeypatch):
    """A machine with 16 GB available, whatever runs the tests."""
    monkeypatch.setattr(fp_module, "_memory_available", lambda: 16 * 10**9)


def test_a_1e8_point_sweep_is_refused_within_a_second(
    tmp_path, capsys, machine_of_16_gb
):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    code = main(["run", str(_write(tmp_path, HUGE)), "--out", str(out)])
    seconds = time.perf_counter() - t0
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert seconds < 1.0, seconds
    assert len(err.splitlines()) == 1, err
    # the numbers: the points, their factors, the impacts, memory against memory
    assert "100,000,000 points (1 surface x 100,000 speeds x 1,000 angles)" in err
    assert "x 100 impacts" in err
    assert re.search(r"about \d+ GB of memory \(16 GB available\)", err), err
    # and how to cut them, or go on
    assert re.search(r"at most about [\d,]+ points", err), err
    assert "--yes" in err
    assert not out.exists()  # nothing was started


def test_the_largest_sweep_said_to_fit_is_not_refused(tmp_path, machine_of_16_gb):
    """The "at most about N points" of the refusal is an honest bound: N points
    of the same scenario pass the check."""
    from microimpact.engine.footprint import check_footprint, machine

    scenario = read_scenario(_write(tmp_path, HUGE)).scenario
    with pytest.raises(Exception, match="at most about") as info:
        check_footprint(footprint(scenario), machine(tmp_path))
    most = re.search(r"at most about ([\d,]+)", str(info.value))[1]
    most = int(most.replace(",", ""))
    fits = scenario.with_options(speeds_m_s=[1.0] * (most // 1000))
    check_footprint(footprint(fits), machine(tmp_path))  # no exception


def test_yes_starts_a_run_that_does_not_fit(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(fp_module, "_memory_available", lambda: 10**6)  # 1 MB
    p = _write(tmp_path, SMALL)
    assert main(["run", str(p), "--out", str(tmp_path / "a"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "(1.0 MB available)" in err and "--yes" in err
    args = ["run", str(p), "--out", str(tmp_path / "b"), "--no-figures", "--yes"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "microimpact: 4 points (1 surface x 2 speeds x 2 angles)" in err
    assert (tmp_path / "b" / "summary.csv").exists()


def test_convergence_checks_its_pilot_sweep(tmp_path, capsys, machine_of_16_gb):
    code = main(["convergence", str(_write(tmp_path, HUGE))])
    err = capsys.readouterr().err
    assert code == 2 and "100,000,000 points" in err and "x 1,000 impacts" in err


@pytest.mark.slow
def test_the_estimate_bounds_a_measured_run(tmp_path):
    """Memory and files of a real 20,000-point run (peak resident memory of the
    process, bytes on disk) lie below the estimate and within a factor 4 of it
    (the estimate bounds smooth and rough surfaces alike: a smooth surface's
    histograms and files are the smallest)."""
    text = SCENARIO.format(
        samples=100,
        speeds="{ start = 0.1, stop = 10, num = 200 }",
        angles="{ start = 1, stop = 90, num = 100 }",
    )
    p = _write(tmp_path, text)
    out = tmp_path / "out"
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    subprocess.run(
        [sys.executable, "-m", "microimpact", "run", str(p), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024  # kB
    assert peak > before * 1024  # this child set the peak
    files = sum(f.stat().st_size for f in out.iterdir())
    est = footprint(read_scenario(p).scenario)
    assert est.points == 20_000
    assert peak <= est.memory_bytes <= 4 * peak, (peak, est.memory_bytes)
    assert files <= est.output_bytes <= 4 * files, (files, est.output_bytes)


# ------------------------------------------------------------------ progress
def test_every_stage_after_the_simulation_reports_itself(tmp_path):
    """Within ``stages``, the statistics and each output file are stages (a file
    written inside another stage, as results.nc's temporary file, is part of it)."""
    from microimpact.pipeline.study import Study

    seen = []
    study = Study(_write(tmp_path, SMALL))
    with stages(lambda desc, seconds: seen.append((desc, seconds))):
        study.execute(tmp_path / "out", progress=False)
    started = [d for d, s in seen if s is None]
    ended = [d for d, s in seen if s is not None]
    assert started == ended  # each stage ends, in order, none nested
    order = [
        "planning the sweep",
        "statistics of 4 sweep points",
        *(f"writing {n}" for n in ("summary.csv", "results.nc", "capture_speed.csv")),
        "writing report.html",
    ]
    assert [d for d in started if d in order] == order
    assert not [d for d in started if d.endswith(".tmp")]


def test_a_stage_shows_its_name_and_time_only_when_slow(capsys, monkeypatch):
    with stages(True), stage("quick"):
        pass
    assert capsys.readouterr().err == ""  # under STAGE_DELAY_S: silent
    monkeypatch.setattr(progress_module, "STAGE_DELAY_S", 0.0)
    monkeypatch.setattr(progress_module, "STAGE_REFRESH_S", 0.01)
    with stages(True), stage("writing big.csv"):
        time.sleep(0.1)
    err = capsys.readouterr().err
    assert err.startswith("writing big.csv ...\n")
    assert re.fullmatch(r"writing big.csv ...\nwriting big.csv: done in 0\.\d s\n", err)
    with stages(False), stage("writing big.csv"):
        time.sleep(0.05)
    assert capsys.readouterr().err == ""
    with stage("outside any stages block"):  # the library alone prints nothing
        time.sleep(0.05)
    assert capsys.readouterr().err == ""


# ------------------------------------------------------------------ Ctrl-C
def _interrupt(monkeypatch, before=None):
    from microimpact.pipeline.study import Study

    def execute(self, out_dir, **options):
        if before is not None:
            before(out_dir)
        raise KeyboardInterrupt

    monkeypatch.setattr(Study, "execute", execute)


def test_ctrl_c_before_any_checkpoint_claims_none(tmp_path, capsys, monkeypatch):
    _interrupt(monkeypatch)
    out = tmp_path / "out"
    assert main(["run", str(_write(tmp_path, SMALL)), "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "no checkpoint was kept" in err
    assert "kept in" not in err and "resumes" not in err


def test_ctrl_c_names_the_checkpoint_that_exists(tmp_path, capsys, monkeypatch):
    def checkpoint(out_dir):
        out_dir.mkdir()
        (out_dir / ".microimpact-checkpoint.npz").write_bytes(b"x")

    _interrupt(monkeypatch, checkpoint)
    out = tmp_path / "out"
    assert main(["run", str(_write(tmp_path, SMALL)), "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert f"kept in {out / '.microimpact-checkpoint.npz'}" in err
    assert "the same command resumes it" in err


def test_too_many_impacts_per_point_are_cut_per_point(tmp_path, capsys):
    """When the impacts per point, not the points, make the run too long, the
    message says how many impacts per point fit and names the command's flag:
    24 points x 10^12 impacts at IMPACTS_PER_S = 2e7 on one worker is 1.2e6 s;
    an hour holds 3600 * 2e7 / 4 = 1.8e10 impacts per point."""
    p = _write(tmp_path, SMALL)
    args = ["run", str(p), "--out", str(tmp_path / "o"), "--samples", "1e12"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "4 points (1 surface x 2 speeds x 2 angles) x 1,000,000,000,000" in err
    assert "cut the impacts to at most about 18,000,000,000 per point" in err
    assert "per point (--samples)" in err
    assert "cut the sweep" not in err  # the points are not the problem
    args = ["convergence", str(p), "--point", "1", "--n-max", "1e12"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "1 of 4 points" in err and "(--n-max)" in err and "--workers" not in err
    # 3600 * 2e7 / 1 point = 7.2e10
    assert "at most about 72,000,000,000 per point" in err


def test_reproduce_checks_each_preset_and_names_it(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "--samples", "1e12"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("microimpact reproduce: error: preset sst65-silicon-normal:")
    assert not out.exists()


def test_a_huge_sweep_is_refused_before_scipy_loads(tmp_path):
    """The pre-check reads the scenario file's text alone: in a fresh process a
    10^8-point sweep is refused (exit 2, the numbers) without importing SciPy,
    the engine or the scenario reader, in well under a second."""
    import subprocess
    import sys
    import textwrap
    import time

    path = tmp_path / "big.toml"
    path.write_text(
        textwrap.dedent(
            """\
            name = "big"
            samples = 4000
            [particles]
            distribution = "normal"
            mean_um = 52.8
            std_um = 15.3
            [coefficients]
            k1 = 4.0
            k2 = 0.05
            v_c = 0.2
            [sweep]
            speed_m_s = { start = 0.01, stop = 10, num = 100000 }
            angle_deg = { start = 1, stop = 90, num = 1000 }
            """
        )
    )
    code = (
        "import sys\n"
        "from microimpact.cli import main\n"
        f"rc = main(['run', {str(path)!r}, '--out', {str(tmp_path / 'o')!r}])\n"
        "loaded = [m for m in ('scipy', 'microimpact.engine', "
        "'microimpact.scenario.file') if m in sys.modules]\n"
        "print(rc, loaded)\n"
    )
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60
    )
    elapsed = time.perf_counter() - t0
    assert done.stdout.strip() == "2 []", done.stdout + done.stderr
    assert "100,000,000 points" in done.stderr
    assert elapsed < 5.0  # ~0.2 s on this machine; generous for loaded CI
