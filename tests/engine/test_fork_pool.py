"""Worker processes forked with what they run (issue 31: design rows and
bootstrap refits hold the GIL for 40-85 % of their time, so threads wait for
one another; parallel.fork_pool)."""

from __future__ import annotations

import os
import threading

import pytest

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
