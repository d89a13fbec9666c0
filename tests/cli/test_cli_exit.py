"""Exit codes keep causes apart: 2 the user's input, 3 the environment, 1 our bug
(with the traceback saved), 130/143 interrupted/terminated (checkpoint kept)."""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from microimpact.cli import main

SCENARIO = """
name = "exit"
seed = 3
samples = 400
[particles]
distribution = "normal"
mean_um = 50
std_um = 10
[coefficients]
k1 = 4.0
k2 = 0.05
v_c = 0.2
[sweep]
speed_m_s = [0.2, 0.5]
"""


def _scenario(tmp_path, text=SCENARIO):
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_user_error_is_2_with_one_line(tmp_path, capsys):
    p = _scenario(tmp_path, SCENARIO.replace("std_um", "std_umm"))
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "s.toml" in err and "std_umm" in err


def test_environment_error_is_3_naming_the_path_and_cause(
    tmp_path, capsys, monkeypatch
):
    import microimpact.pipeline.folder as outdir

    def full(path, write):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(outdir, "atomic_write", full)
    p = _scenario(tmp_path)
    out = tmp_path / "o"
    assert main(["run", str(p), "--out", str(out), "--quiet", "--no-figures"]) == 3
    err = capsys.readouterr().err.strip()
    assert "no space left on the device" in err and str(out) in err
    assert "\n" not in err


def test_closed_pipe_is_an_environment_error(tmp_path):
    proc = subprocess.Popen(
        [sys.executable, "-m", "microimpact.cli", "presets"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    proc.stdout.close()  # the reader goes away before the first line
    err = proc.stderr.read()
    assert proc.wait() == 3, err
    assert "pipe" in err and "Traceback" not in err


def test_library_bug_is_1_with_the_traceback_saved(tmp_path, capsys, monkeypatch):
    import microimpact.pipeline.study as study

    def broken(*args, **kwargs):
        raise ValueError("a bug of ours")  # a ValueError is not the user's mistake

    monkeypatch.setattr(study, "run", broken)
    p = _scenario(tmp_path)
    assert main(["run", str(p), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "internal error" in err and "a bug of ours" in err
    path = re.search(r"traceback is in (\S+?);", err).group(1)
    text = Path(path).read_text()
    assert "Traceback" in text and "a bug of ours" in text
    Path(path).unlink()


def test_sigterm_keeps_the_checkpoint_and_exits_143(tmp_path):
    text = SCENARIO.replace("samples = 400", "samples = 4000000").replace(
        "[0.2, 0.5]", "{start = 0.1, stop = 2.0, num = 40}"
    )
    p = _scenario(tmp_path, text)
    out = tmp_path / "o"
    env = {**os.environ, "MICROIMPACT_CHECKPOINT_INTERVAL": "0.2"}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "microimpact.cli",
            "run",
            str(p),
            "--out",
            str(out),
            "--quiet",
            "--no-figures",
        ],
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    ckpt = out / ".microimpact-checkpoint.npz"
    deadline = time.monotonic() + 60
    while not ckpt.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    if proc.poll() is not None:
        pytest.skip("the run finished before it could be terminated")
    proc.send_signal(signal.SIGTERM)
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 143, err
    assert "terminated" in err and "checkpoint" in err
    assert ckpt.exists()
    assert not (out / "summary.csv").exists()


def test_python_dash_m_microimpact_runs_the_command_line():
    # found by a user: `python -m microimpact --version` gave "No module named
    # microimpact.__main__" (only `python -m microimpact.cli` worked)
    src = str(Path(__file__).resolve().parents[2] / "src")
    env = {
        **os.environ,
        "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", ""),
    }
    out = subprocess.run(
        [sys.executable, "-m", "microimpact", "--version"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("microimpact ")
    bad = subprocess.run(
        [sys.executable, "-m", "microimpact", "run", "no-such.toml", "--out", "o"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert bad.returncode == 2 and "no-such.toml" in bad.stderr
