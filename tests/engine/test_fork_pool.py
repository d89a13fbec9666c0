"""Worker processes forked with what they run (issue 31: design rows and
bootstrap refits hold the GIL for 40-85 % of their time, so threads wait for
one another; parallel.fork_pool)."""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

import pytest

import microimpact
from microimpact._core.progress import Progress
from microimpact.engine import parallel
from microimpact.engine.parallel import fork_pool, map_held

pytestmark = pytest.mark.skipif(
    "fork" not in __import__("multiprocessing").get_all_start_methods(),
    reason="needs fork",
)


@pytest.fixture
def can_fork(monkeypatch):
    # a thread another test left running (a Dask client's IO loop) would make
    # the pool refuse to fork; these tests are about what happens when it can
    monkeypatch.setattr(parallel, "start_method", lambda: "fork")


def test_a_forked_pool_runs_what_it_holds_unpickled_in_order(can_fork):
    """The held callable is inherited, not pickled (a closure over a lock is
    not picklable), runs in other processes, and its values come in order."""
    lock = threading.Lock()
    offset = 1000

    def held(i):
        with lock:
            return i + offset, os.getpid()

    with fork_pool(2, held) as pool:
        out = list(map_held(pool, range(40)))
    assert [v for v, _ in out] == list(range(1000, 1040))
    pids = {p for _, p in out}
    assert os.getpid() not in pids
    assert 1 <= len(pids) <= 2


def test_no_pool_for_one_worker_or_where_another_thread_runs():
    assert fork_pool(1, abs) is None
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert fork_pool(2, abs) is None  # fork with a thread running: unsafe
    finally:
        stop.set()
        other.join()


def test_a_progress_bar_starts_no_thread():
    """tqdm's monitor thread would keep a run with a bar from forking."""
    pytest.importorskip("tqdm")
    before = threading.active_count()
    with Progress(True, total=10, unit="rows") as bar:
        bar.update(3)
        assert threading.active_count() == before


def _killed(i):
    if i == 3:
        os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer does
    return i


def _crashed(i):
    if i == 3:
        os._exit(70)  # ended otherwise (a crash of ours ends by its own signal)
    return i


def test_a_worker_killed_by_the_system_is_an_environment_failure(can_fork):
    """SIGKILL (the out-of-memory killer) comes back as MemoryError, which the
    CLI reports as the environment's (exit 3); a crash stays a bug of ours."""
    from concurrent.futures.process import BrokenProcessPool

    with fork_pool(2, _killed) as pool, pytest.raises(MemoryError, match="SIGKILL"):
        list(map_held(pool, range(8)))
    with fork_pool(2, _crashed) as pool, pytest.raises(BrokenProcessPool):
        list(map_held(pool, range(8)))


def test_the_cli_reports_a_killed_worker_as_the_environment(
    can_fork, monkeypatch, tmp_path, capsys
):
    from microimpact.analysis import sensitivity
    from microimpact.cli import main

    monkeypatch.setattr(sensitivity, "cap_workers", lambda w: w)
    real = sensitivity.EngineModel.__call__
    parent = os.getpid()

    def dying(self, rows):
        if os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(self, rows)

    monkeypatch.setattr(sensitivity.EngineModel, "__call__", dying)
    preset = Path(microimpact.__file__).parent / "scenario/presets"
    code = main(
        [
            "sensitivity",
            str(preset / "sst76-formica-oblique.toml"),
            "--out",
            str(tmp_path / "s"),
            "--parameter",
            "coefficients.friction=0.1:0.3",
            "--base-size",
            "4",
            "--samples",
            "200",
            "--workers",
            "2",
            "--yes",
        ]
    )
    err = capsys.readouterr().err
    assert code == 3, err
    assert "out of memory" in err and "Traceback" not in err
