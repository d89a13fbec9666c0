"""Resuming from a checkpoint: what is restored is not recomputed, a checkpoint of
another run is reported and moved aside, and the file stays small.

These tests fail when resuming is broken (e.g. ``checkpoint.load`` returning None):
a rerun from scratch is bit-identical too, so each test also checks that the
restored blocks were *not* simulated again, by counting the kernel's blocks.
"""

from __future__ import annotations

import os
import zipfile

import numpy as np
import pytest
from engine_helpers import rough, same_runs, scenario
from numpy.testing import assert_array_equal

from microimpact.engine import checkpoint as ckpt
from microimpact.engine import kernel, montecarlo
from microimpact.engine.accumulators import E_BINS, MU_BINS, Moments, PointAccumulator
from microimpact.engine.checkpoint import Checkpoint, CheckpointWarning
from microimpact.engine.montecarlo import iter_blocks, run
from microimpact.engine.plan import BLOCK_SIZE


class KernelSpy:
    """Counts the block specifications the kernel simulates (whichever entry point
    the driver uses) and can raise after a number of blocks."""

    def __init__(self, monkeypatch, raise_after=None):
        self.blocks = []
        self.raise_after = raise_after
        real_block = kernel.simulate_block

        def block(plan, point, rep, b, n, **kw):
            if not kw.get("store"):
                self._count((point, rep, b, n))
            return real_block(plan, point, rep, b, n, **kw)

        monkeypatch.setattr(kernel, "simulate_block", block)
        real_specs = getattr(kernel, "simulate_specs", None)
        if real_specs is not None:

            def specs(plan, specs):
                for spec in specs:
                    self._count(spec)
                return real_specs(plan, specs)

            monkeypatch.setattr(kernel, "simulate_specs", specs)
        real_stacked = getattr(kernel, "simulate_specs_stacked", None)
        if real_stacked is not None:

            def stacked(plan, specs, groups=None):
                rows = real_stacked(plan, specs, groups)
                if rows is not None:
                    for spec in specs:
                        self._count(spec)
                return rows

            monkeypatch.setattr(kernel, "simulate_specs_stacked", stacked)
        real_task = getattr(kernel, "task_rows", None)
        if real_task is not None:

            def task_rows(plan, task):
                rows = real_task(plan, task)
                if rows is not None:
                    for group in task:
                        for spec in group:
                            self._count(spec)
                return rows

            monkeypatch.setattr(kernel, "task_rows", task_rows)

    def _count(self, spec):
        if self.raise_after is not None and len(self.blocks) >= self.raise_after:
            raise KeyboardInterrupt("interrupted by the test")
        self.blocks.append(tuple(spec))


def _scenario(**kw):
    base = dict(
        surfaces=(rough(10.0),),
        speeds_m_s=(0.2, 0.4, 0.6),
        angles_deg=(45.0,),
        samples=200_000,  # 7 blocks per point
    )
    base.update(kw)
    return scenario(**base)


@pytest.fixture
def small_tasks(monkeypatch):
    """Groups of 2 blocks, tasks of up to 4 blocks: several tasks per point."""
    monkeypatch.setattr(montecarlo, "BLOCKS_PER_TASK", 2)
    monkeypatch.setattr(montecarlo, "TASK_IMPACTS", 4 * BLOCK_SIZE)


def test_closed_generator_resumes_without_recomputing(
    tmp_path, monkeypatch, small_tasks
):
    sc = _scenario()
    full = run(sc)
    path = tmp_path / "run.npz"
    gen = iter_blocks(sc, checkpoint=Checkpoint(path, interval=0.0))
    last = {}
    for _ in range(5):  # interrupt part-way: groups of up to 2 blocks merged
        br = next(gen)
        last[br.point] = br.block
    gen.close()
    merged = sum(b + 1 for b in last.values())
    spy = KernelSpy(monkeypatch)
    ck = Checkpoint(path)
    seen = []
    ck.on_load = lambda c: seen.append(
        (c.restored_blocks, c.total_blocks, spy.blocks[:])
    )
    resumed = run(sc, checkpoint=ck)
    total = 3 * 7
    assert ck.restored_blocks == merged == 7 + 2  # point 0, 2 blocks of point 1
    assert ck.total_blocks == total
    assert seen == [(merged, total, [])]  # known before any block is simulated
    assert len(spy.blocks) == total - merged  # restored blocks were not run again
    run_again = {s[:3] for s in spy.blocks}
    assert not run_again & ({(0, 0, b) for b in range(7)} | {(1, 0, 0), (1, 0, 1)})
    assert resumed.provenance["resumed_blocks"] == merged
    assert resumed.provenance["total_blocks"] == total
    same_runs(full, resumed)
    # a finished checkpoint: everything restored, nothing simulated, same bits
    spy.blocks.clear()
    again = run(sc, checkpoint=ck)
    assert ck.restored_blocks == ck.total_blocks == total
    assert spy.blocks == []
    same_runs(full, again)


def test_interrupt_inside_the_kernel_keeps_the_merged_prefix(
    tmp_path, monkeypatch, small_tasks
):
    """Ctrl-C while a task runs: the checkpoint holds every group merged before."""
    sc = _scenario()
    full = run(sc)
    path = tmp_path / "run.npz"
    with monkeypatch.context() as m:
        KernelSpy(m, raise_after=6)  # dies in the second task
        with pytest.raises(KeyboardInterrupt):
            run(sc, checkpoint=path)
    spy = KernelSpy(monkeypatch)
    ck = Checkpoint(path)
    resumed = run(sc, checkpoint=ck)
    assert ck.restored_blocks == 4  # the first task (4 blocks) was merged
    assert len(spy.blocks) == 21 - 4
    same_runs(full, resumed)


def test_resume_on_two_workers_is_bit_identical(tmp_path, monkeypatch, small_tasks):
    sc = _scenario()
    full = run(sc)
    path = tmp_path / "run.npz"
    gen = iter_blocks(sc, checkpoint=path, workers=2)
    for _ in range(5):
        next(gen)
    gen.close()
    ck = Checkpoint(path)
    same_runs(full, run(sc, checkpoint=ck, workers=2))
    assert ck.restored_blocks == 9


def test_precision_run_resumes(tmp_path, monkeypatch):
    import microimpact as mi

    sc = scenario(
        speeds_m_s=(0.15, 0.25),
        precision=mi.scenario.Precision("capture_fraction", 0.002, 2_000_000),
    )
    full = run(sc)
    path = tmp_path / "run.npz"
    gen = iter_blocks(sc, checkpoint=path)
    for _ in range(3):
        next(gen)
    gen.close()
    spy = KernelSpy(monkeypatch)
    ck = Checkpoint(path)
    resumed = run(sc, checkpoint=ck)
    assert ck.restored_blocks == 3  # blocks 0, 1 of point 0, block 0 of point 1
    assert spy.blocks
    assert not {s[:3] for s in spy.blocks} & {(0, 0, 0), (0, 0, 1), (1, 0, 0)}
    same_runs(full, resumed)


# ------------------------------------------------------------------- mismatches
def _interrupted(path, sc, k=3):
    gen = iter_blocks(sc, checkpoint=path)
    for _ in range(k):
        next(gen)
    gen.close()
    assert path.exists()


@pytest.mark.parametrize(
    "change, reason, words",
    [
        (dict(seed=999), "seed", "different seed"),
        (dict(samples=250_000), "samples", "different sample counts"),
        (dict(speeds_m_s=(0.2, 0.4, 0.7)), "scenario", "different scenario"),
        (dict(surfaces=(rough(11.0),)), "scenario", "different scenario"),
    ],
)
def test_checkpoint_of_another_run_is_reported_and_moved_aside(
    tmp_path, monkeypatch, small_tasks, change, reason, words
):
    path = tmp_path / "run.npz"
    _interrupted(path, _scenario())
    saved = path.read_bytes()
    other = _scenario(**change)
    spy = KernelSpy(monkeypatch)
    ck = Checkpoint(path)
    with pytest.warns(CheckpointWarning, match=words) as rec:
        result = run(other, checkpoint=ck)
    msg = str(rec[0].message)
    assert str(path) in msg and str(ck.stale_path) in msg
    assert ck.rejected == reason and ck.restored_blocks == 0
    assert ck.stale_path == tmp_path / "run.npz.stale"
    assert ck.stale_path.read_bytes() == saved  # moved aside, not discarded
    assert len(spy.blocks) == ck.total_blocks  # everything simulated afresh
    assert result.provenance["resumed_blocks"] == 0
    same_runs(run(other), result)


def test_corrupt_and_old_checkpoints_are_reported(tmp_path):
    sc = scenario(samples=1000)
    path = tmp_path / "run.npz"
    path.write_bytes(b"not a zip file")
    ck = Checkpoint(path)
    with pytest.warns(CheckpointWarning, match="cannot be read"):
        run(sc, checkpoint=ck)
    assert ck.rejected == "corrupt"
    assert repr(ck) == (
        f"Checkpoint({str(path)!r}, restored_blocks=0, "
        f"total_blocks={ck.total_blocks}, rejected='corrupt')"
    )
    np.savez(path, fingerprint=np.array("abc"))  # format 1
    with pytest.warns(CheckpointWarning, match="another file format"):
        run(sc, checkpoint=ck)
    assert ck.rejected == "format"
    # a zip with the right version but truncated arrays
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("format_version.npy", b"\x93NUMPY garbage")
    with pytest.warns(CheckpointWarning, match="cannot be read"):
        run(sc, checkpoint=ck)


def test_matching_checkpoint_gives_no_warning(tmp_path, small_tasks):
    import warnings

    sc = _scenario()
    path = tmp_path / "run.npz"
    _interrupted(path, sc)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run(sc, checkpoint=path)
    assert not (tmp_path / "run.npz.stale").exists()


def test_stale_temporaries_are_removed_at_start(tmp_path):
    path = tmp_path / "run.npz"
    left = [tmp_path / ".run.npz.abc123.tmp", tmp_path / ".run.npz.x.tmp"]
    keep = [tmp_path / ".other.npz.abc.tmp", tmp_path / "run.npz.tmp"]
    for p in left + keep:
        p.write_bytes(b"partial")
    run(scenario(samples=100), checkpoint=path)
    assert not any(p.exists() for p in left)
    assert all(p.exists() for p in keep)


# ----------------------------------------------------------------- the file
def _acc(rng, n_bins_e, n_bins_mu, big=False):
    e = np.zeros(E_BINS, np.int64)
    mu = np.zeros(MU_BINS, np.int64)
    lo = rng.integers(0, E_BINS - n_bins_e)
    e[lo : lo + n_bins_e] = rng.integers(0, 50, n_bins_e)
    lo = rng.integers(0, MU_BINS - n_bins_mu)
    mu[lo : lo + n_bins_mu] = rng.integers(0, 50, n_bins_mu)
    if big:
        e[lo] = 3 << 31  # does not fit int32
    return PointAccumulator(
        *rng.integers(0, 1000, 5),
        e=Moments(5, *rng.normal(size=3)),
        mu=Moments(5, *rng.normal(size=3)),
        e_hist=e,
        mu_hist=mu,
    )


@pytest.mark.parametrize("big", [False, True])
def test_checkpoint_round_trip_is_exact(tmp_path, rng, big):
    state = {
        (p, r): (int(rng.integers(0, 9)), _acc(rng, 1 + p, 1 + 3 * p, big and p == 2))
        for p in range(4)
        for r in range(2)
    }
    state[(5, 0)] = (1, PointAccumulator(n=3, captured=3))  # empty histograms
    fp = {"seed": "1", "samples": "s", "scenario": "x"}
    ckpt.save(tmp_path / "c.npz", fp, state)
    back = ckpt.load(tmp_path / "c.npz", fp)
    assert back.keys() == state.keys()
    for k, (nxt, acc) in state.items():
        assert back[k][0] == nxt
        assert back[k][1] == acc
        assert_array_equal(back[k][1].e_hist, acc.e_hist)
        assert_array_equal(back[k][1].mu_hist, acc.mu_hist)
        assert back[k][1].lateral == acc.lateral
        assert_array_equal(back[k][1].lateral_hist, acc.lateral_hist)


def test_checkpoint_size_is_proportional_to_what_is_kept(tmp_path):
    """Many points with a few samples each: the file holds their occupied bins,
    not 3,202 histogram bins per point (26 kB dense)."""
    sc = scenario(
        speeds_m_s=tuple(np.linspace(0.1, 2.0, 100)), angles_deg=(30.0, 60.0, 90.0)
    )
    path = tmp_path / "run.npz"
    ck = Checkpoint(path)
    result = run(sc, samples=200, checkpoint=ck)
    occupied = sum(
        np.count_nonzero(a.e_hist)
        + np.count_nonzero(a.mu_hist)
        + np.count_nonzero(a.lateral_hist)
        for a in result.accumulators.values()
    )
    points = len(result.accumulators)
    size = path.stat().st_size
    assert size == ck.bytes_written
    # ~100 B per point of counts and moments, 4 B per occupied bin, before compression
    assert size < 2_000 + points * 100 + 4 * occupied
    assert size < points * (E_BINS + MU_BINS) * 8 / 20
    # and before compression (zeros compress well, so check what is stored)
    with zipfile.ZipFile(path) as z:
        stored = sum(info.file_size for info in z.infolist())
    # 184 B per point (3 moments, 3 spans), int32 bins
    assert stored < 2_000 + points * 200 + 8 * occupied


def test_writes_are_spaced_by_their_cost(tmp_path, monkeypatch):
    """The interval between writes is at least interval and 20 x the last write."""
    clock = [100.0]
    monkeypatch.setattr(ckpt.time, "monotonic", lambda: clock[0])
    ck = Checkpoint(tmp_path / "c.npz", interval=2.0)
    ck.open({"seed": "1", "samples": "s", "scenario": "x"}, interval=5.0)
    assert ck.min_interval == 2.0  # given explicitly: kept

    def fake_save(path, fp, state):
        clock[0] += 0.5  # a write that takes 0.5 s
        return 10

    monkeypatch.setattr(ckpt, "save", fake_save)
    clock[0] += 1.9
    assert not ck.due()
    clock[0] += 0.1
    assert ck.due()
    ck.write({})
    assert ck.writes == 1 and ck.write_seconds == 0.5
    clock[0] += 9.9
    assert not ck.due()  # 0.5 s / WRITE_FRACTION = 10 s
    clock[0] += 0.1
    assert ck.due()
    assert ckpt.WRITE_FRACTION == pytest.approx(1 / 20)


def test_default_interval_comes_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("MICROIMPACT_CHECKPOINT_INTERVAL", "7.5")
    ck = Checkpoint(tmp_path / "c.npz")
    run(scenario(samples=100), checkpoint=ck)
    assert ck.min_interval == 7.5 and ck.interval is None
    assert os.path.exists(tmp_path / "c.npz")


def test_run_closed_before_its_first_merge_resumes_from_nothing(tmp_path):
    path = tmp_path / "run.npz"
    gen = iter_blocks(scenario(samples=1000), checkpoint=path)
    gen.close()  # never started: no file
    assert not path.exists()
    fp = {"seed": "1", "samples": "s", "scenario": "x"}
    ckpt.save(path, fp, {})
    assert ckpt.load(path, fp) == {}


def test_keyed_array_checkpoints_keep_what_they_were_given(tmp_path):
    """The wall law keeps its finished diameters through the engine's checkpoint
    layer (issue 20: one resume mechanism): arrays back as written, another
    fingerprint or a damaged file refused with its reason, no file is None."""
    from microimpact.engine.checkpoint import (
        CheckpointMismatch,
        load_arrays,
        save_arrays,
    )

    path = tmp_path / "d.npz"
    assert load_arrays(path, "fp") is None
    arrays = {
        "e_n": np.linspace(0, 1, 7),
        "counts": np.arange(3),
        "seed": np.array("9"),
    }
    save_arrays(path, "fp", arrays)
    back = load_arrays(path, "fp")
    assert set(back) == set(arrays)
    for k, v in arrays.items():
        np.testing.assert_array_equal(back[k], v)
    with pytest.raises(CheckpointMismatch) as err:
        load_arrays(path, "another build")
    assert err.value.reason == "scenario"
    path.write_bytes(path.read_bytes()[:40])
    with pytest.raises(CheckpointMismatch) as err:
        load_arrays(path, "fp")
    assert err.value.reason == "corrupt"
    # the detail names what numpy's reader raised (a truncated zip archive)
    assert err.value.detail.startswith("BadZipFile: "), err.value.detail


@pytest.mark.parametrize("in_kernel", [False, True])
def test_a_checkpoint_of_many_points_builds_no_accumulator_per_point(
    tmp_path, monkeypatch, in_kernel
):
    """A sweep of many one-group points is checkpointed from the task rows' arrays
    (issue 22: at 10^6 points building one accumulator object per point for each
    write took 1.7 GiB and most of the run); what is written resumes to the same
    bits with nothing simulated again."""
    from microimpact.engine.summary import Stacked

    sc = _scenario(
        speeds_m_s=tuple(np.linspace(0.1, 1.0, 40)),
        angles_deg=tuple(np.linspace(10.0, 90.0, 50)),
        samples=50,
    )
    # task by task, or inside the kernel, paused at every poll for a write
    monkeypatch.setattr(montecarlo, "KERNEL_TASKS", in_kernel)
    monkeypatch.setattr(montecarlo, "KERNEL_POLL_S", 0.0)
    # (not a short run, which the kernel runs in the caller, in one go)
    monkeypatch.setattr(montecarlo, "BACKGROUND_IMPACTS", 0)
    full = run(sc)
    built = []
    real = Stacked.accumulator
    monkeypatch.setattr(
        Stacked, "accumulator", lambda self, i: built.append(i) or real(self, i)
    )
    path = tmp_path / "run.npz"
    ck = Checkpoint(path, interval=0.0)  # a write after every merge
    run(sc, checkpoint=ck)
    assert ck.writes > 1
    assert len(built) < 100  # 2,000 points: none rebuilt for the checkpoint
    monkeypatch.undo()
    saved = ckpt.load(path, ck._fingerprint)
    assert sorted(saved) == [(p, 0) for p in range(2000)]
    for (p, _r), (nxt, acc) in saved.items():
        assert nxt == 1 and acc == full.accumulators[p]
    spy = KernelSpy(monkeypatch)
    again = run(sc, checkpoint=Checkpoint(path))
    assert spy.blocks == []
    same_runs(full, again)


def test_a_state_saved_as_arrays_reads_back_as_the_accumulators(tmp_path):
    """``save`` of a StackedState and of the dict it came from give the same
    accumulators back (the array path is the one runs use)."""
    sc = _scenario(speeds_m_s=(0.1, 0.3, 0.9), samples=3000)
    res = run(sc)
    state = {(p, 0): (3, acc) for p, acc in res.accumulators.items()}
    state[(7, 1)] = (2, PointAccumulator())  # an empty accumulator survives too
    fp = {part: "x" for part in ckpt.FINGERPRINT_PARTS}
    ckpt.save(tmp_path / "a.npz", fp, ckpt.StackedState.of(state))
    ckpt.save(tmp_path / "b.npz", fp, state)
    for name in ("a.npz", "b.npz"):
        back = ckpt.load(tmp_path / name, fp)
        assert back == state
