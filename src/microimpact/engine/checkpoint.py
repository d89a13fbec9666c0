"""Checkpoints: finished work survives a killed run, and a resume can be inspected.

The driver merges per-block accumulators in key order, so the state of a sweep point
is fully described by "blocks ``[0, k)`` are merged into this accumulator". A
checkpoint stores that prefix for every (point, replicate), plus a fingerprint of the
run in three parts (seed, sample counts, scenario and tables), so that a checkpoint
that does not match can be reported with its cause.

The file is a compressed ``.npz`` of flat arrays (format 3): per (point, replicate)
its next block, its counts and moments (e_m, mu_m and the folded lateral angle;
format 2 had no lateral angle and is reported as another format, not misread), and
each histogram as its occupied span of
bins (offset, length, counts in the narrowest integer type that holds them), all
spans concatenated. Its size
is proportional to what is kept, not to the number of histogram bins. It is written to
a temporary file in the same folder (``.<name>.<random>.tmp``), flushed to disk and
renamed over the old one, so at any instant (even under SIGKILL) the file on disk is a
complete earlier checkpoint; temporary files left by a killed run are removed when
the next run starts.

:class:`Checkpoint` is the object a run uses (in the spirit of emcee's backends): it
loads, says what it restored (:attr:`Checkpoint.restored_blocks` of
:attr:`Checkpoint.total_blocks`) or why it restored nothing
(:attr:`Checkpoint.rejected`), and decides when to write.
"""

from __future__ import annotations

import hashlib
import os
import time
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._core.files import atomic_write
from .accumulators import E_BINS, LATERAL_BINS, MU_BINS, Moments, PointAccumulator
from .summary import Stacked, compact_counts

#: Version of the file layout; a file of another version is reported, not read.
#: 3: the lateral angle's moments and histogram (format 2 lacks them).
FORMAT_VERSION = 3
#: The histograms a checkpoint stores: name -> dense size.
_HISTOGRAMS = (("e", E_BINS), ("mu", MU_BINS), ("lateral", LATERAL_BINS))
#: The parts of the fingerprint, in the order a mismatch is reported.
FINGERPRINT_PARTS = ("seed", "samples", "scenario")
#: Reasons a checkpoint file is not used (:attr:`Checkpoint.rejected`).
REASONS = ("corrupt", "format", *FINGERPRINT_PARTS)
#: Checkpoint writes take at most this fraction of the run time: the interval between
#: writes is at least ``last write time / WRITE_FRACTION``.
WRITE_FRACTION = 0.05
_CAUSES = {
    "corrupt": "it cannot be read",
    "format": "it was written in another file format",
    "seed": "it was written with a different seed",
    "samples": "it was written for different sample counts or precision target",
    "scenario": "it was written for a different scenario or input tables",
}


class CheckpointWarning(UserWarning):
    """A checkpoint file exists but is not used to resume (see the message)."""


class CheckpointMismatch(Exception):
    """Raised by :func:`load` when `path` is not a checkpoint of this run."""

    def __init__(self, reason: str, detail: str = ""):
        self.reason = reason
        self.detail = detail
        super().__init__(f"{reason}: {detail}" if detail else reason)


def plan_fingerprint(plan, targets) -> dict[str, str]:
    """``{"seed", "samples", "scenario"}``: hashes of everything that determines the
    result of a run (`targets`: the sample counts or precision target)."""
    h = hashlib.sha256()
    h.update(
        f"{plan.shadowing}|{plan.sampling}|{plan.replicates}|{plan.block_size}|"
        f"{plan.table_bits}|{plan.p}|{plan.q}|{plan.friction}|".encode()
    )
    h.update(
        repr([(sp.surface, sp.speed, sp.angle_deg) for sp in plan.points]).encode()
    )
    for arr in (plan.diameter, plan.coefficients, plan.speed_factor):
        h.update(b"|" if arr is None else np.ascontiguousarray(arr).tobytes())
    for atoms in plan.surface_atoms:
        h.update(b"|" if atoms is None else np.ascontiguousarray(atoms).tobytes())
    for k in range(len(plan.surfaces)):  # how a pair is drawn, where it changed
        algorithm = plan.pair_algorithm(k)
        if algorithm:
            h.update(algorithm.encode())
    return {
        "seed": str(plan.entropy),
        "samples": hashlib.sha256(repr(targets).encode()).hexdigest(),
        "scenario": h.hexdigest(),
    }


@dataclass(frozen=True)
class StackedState:
    """A run's finished work as arrays, for :func:`save`: the ``(K, 2)`` keys
    ``(point, rep)`` in sorted order, their ``next_block`` and their accumulators as
    the rows of one :class:`~.summary.Stacked`. A sweep of 10^6 points is written
    from these without building an accumulator object per point."""

    keys: np.ndarray
    next_block: np.ndarray
    stacked: Stacked

    @classmethod
    def of(cls, state: dict) -> StackedState:
        """From ``{(point, rep): (next_block, accumulator)}``."""
        keys = sorted(state)
        return cls(
            np.array(keys, dtype=np.int64).reshape(-1, 2),
            np.array([state[k][0] for k in keys], dtype=np.int64),
            Stacked.of(state[k][1] for k in keys),
        )


def save(path, fingerprint: dict, state) -> int:
    """Atomically write `state` ({(point, rep): (next_block, accumulator)} or a
    :class:`StackedState`); returns the size of the file [bytes]."""
    path = Path(path)
    if not isinstance(state, StackedState):
        state = StackedState.of(state)
    st = state.stacked
    arrays = {
        "format_version": np.array(FORMAT_VERSION),
        **{f"fingerprint_{k}": np.array(fingerprint[k]) for k in FINGERPRINT_PARTS},
        "keys": np.asarray(state.keys, dtype=np.int64).reshape(-1, 2),
        "next_block": np.asarray(state.next_block, dtype=np.int64),
        "counts": np.asarray(st.counts, dtype=np.int64).reshape(-1, 5),
        # (K, 12): e, mu, lateral side by side, written a slice of rows at a time
        "moments": _Columns((st.e, st.mu, st.lateral)),
    }
    for name, spans in (
        ("e", st.e_spans),
        ("mu", st.mu_spans),
        ("lateral", st.lateral_spans),
    ):
        arrays[f"{name}_lo"] = spans.offset.astype(np.int32)
        arrays[f"{name}_len"] = spans.length.astype(np.int32)
        # the narrowest integer type that holds every count (uint8 for a sweep of
        # a few hundred impacts per point); read back as int64
        arrays[f"{name}_counts"] = compact_counts(spans.counts)

    return _write_arrays(path, arrays)


def _write_arrays(path, arrays: dict) -> int:
    """Write `arrays` as an ``.npz`` atomically and durably; returns its size."""
    path = Path(path)

    def write(tmp):
        with open(tmp, "wb") as f:
            # an .npz (np.load reads it) compressed at zlib level 1: 3x faster to
            # write than np.savez_compressed's level 6, for a few % more bytes
            with zipfile.ZipFile(
                f, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1
            ) as z:
                for key, value in arrays.items():
                    with z.open(key + ".npy", "w", force_zip64=True) as member:
                        if isinstance(value, _Columns):
                            value.write(member)
                        else:
                            np.lib.format.write_array(member, value, allow_pickle=False)
            f.flush()
            os.fsync(f.fileno())  # durable before the rename: survives SIGKILL

    atomic_write(path, write)
    return path.stat().st_size


class _Columns:
    """Moments arrays of equal rows (4 columns each), stored side by side as one
    ``.npy`` array (what ``np.hstack`` would give) without forming it: the rows
    are written :data:`ROWS` at a time (a sweep of 10^6 points: ~6 MB, not 96)."""

    ROWS = 2**16

    def __init__(self, parts):
        self.parts = [np.asarray(p, dtype=float).reshape(len(p), 4) for p in parts]

    def write(self, fh) -> None:
        rows = self.parts[0].shape[0]
        cols = sum(p.shape[1] for p in self.parts)
        header = {"descr": "<f8", "fortran_order": False, "shape": (rows, cols)}
        np.lib.format.write_array_header_2_0(fh, header)
        for lo in range(0, rows, self.ROWS):
            hi = min(rows, lo + self.ROWS)
            block = np.hstack([p[lo:hi] for p in self.parts]).astype("<f8")
            fh.write(block.tobytes())


def save_arrays(path, fingerprint: str, arrays: dict) -> int:
    """Keep finished work that is not a run's accumulators (a wall law's finished
    diameters): `arrays` (name -> ndarray) with the format version and
    `fingerprint` (what the work depends on), written as a run's checkpoint is:
    atomically and durably. Returns the file's size [bytes]."""
    data = {
        "format_version": np.array(FORMAT_VERSION),
        "fingerprint": np.array(str(fingerprint)),
    }
    for name, value in arrays.items():
        data[f"array_{name}"] = np.asarray(value)
    return _write_arrays(path, data)


def load_arrays(path, fingerprint: str) -> dict | None:
    """The arrays :func:`save_arrays` kept in `path`; None if there is no file.

    Raises :class:`CheckpointMismatch` (reason ``"format"``, ``"scenario"`` for
    another fingerprint, or ``"corrupt"``) as :func:`load` does."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path) as z:
            if "format_version" not in z.files or "fingerprint" not in z.files:
                raise CheckpointMismatch("format", "not a keyed-array checkpoint")
            version = int(z["format_version"])
            if version != FORMAT_VERSION:
                raise CheckpointMismatch(
                    "format", f"format {version}, this version reads {FORMAT_VERSION}"
                )
            if str(z["fingerprint"]) != str(fingerprint):
                raise CheckpointMismatch("scenario", "another build's work")
            return {
                k.removeprefix("array_"): z[k]
                for k in z.files
                if k.startswith("array_")
            }
    except CheckpointMismatch:
        raise
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CheckpointMismatch("corrupt", f"{type(exc).__name__}: {exc}") from None


def load(path, fingerprint: dict) -> dict | None:
    """The state saved in `path`: ``{(point, rep): (next_block, accumulator)}``.

    Returns None if there is no file. Raises :class:`CheckpointMismatch` (with the
    reason, one of :data:`REASONS`) if the file is unreadable, of another format, or
    a checkpoint of another run.
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path) as z:
            if "format_version" not in z.files:
                raise CheckpointMismatch("format", "format 1 (an older microimpact)")
            version = int(z["format_version"])
            if version != FORMAT_VERSION:
                raise CheckpointMismatch(
                    "format", f"format {version}, this version reads {FORMAT_VERSION}"
                )
            for part in FINGERPRINT_PARTS:
                saved = str(z[f"fingerprint_{part}"])
                if saved != fingerprint[part]:
                    detail = ""
                    if part == "seed":
                        detail = f"seed entropy {saved}, this run {fingerprint[part]}"
                    raise CheckpointMismatch(part, detail)
            return _unpack({k: z[k] for k in z.files})
    except CheckpointMismatch:
        raise
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CheckpointMismatch("corrupt", f"{type(exc).__name__}: {exc}") from None


def _unpack(z) -> dict:
    keys, nxt = z["keys"], z["next_block"]
    counts, moments = z["counts"], z["moments"]
    spans = {}
    for name, size in _HISTOGRAMS:
        lo, length = z[f"{name}_lo"], z[f"{name}_len"]
        flat = z[f"{name}_counts"].astype(np.int64)
        ends = np.cumsum(length)
        if (
            not len(lo) == len(length) == len(keys)
            or (ends[-1] if len(ends) else 0) != flat.size
            or np.any(lo < 0)
            or np.any(lo.astype(np.int64) + length > size)
        ):
            raise ValueError(f"inconsistent {name} histogram spans")
        lo_list = lo.tolist()
        parts = np.split(flat, ends[:-1]) if len(ends) else []
        spans[name] = list(zip(lo_list, parts, strict=True))
    if not len(keys) == len(nxt) == len(counts) == len(moments):
        raise ValueError("inconsistent array lengths")
    if moments.ndim != 2 or moments.shape[1] != 12:
        raise ValueError(f"moments of shape {moments.shape}, expected (n, 12)")
    state = {}
    rows = zip(
        keys.tolist(),
        nxt.tolist(),
        counts.tolist(),
        moments.tolist(),
        spans["e"],
        spans["mu"],
        spans["lateral"],
        strict=True,
    )
    for (point, rep), next_block, c, m, e_span, mu_span, lat_span in rows:
        acc = PointAccumulator(
            *c,
            e=Moments(int(m[0]), m[1], m[2], m[3]),
            mu=Moments(int(m[4]), m[5], m[6], m[7]),
            e_span=e_span,
            mu_span=mu_span,
            lateral=Moments(int(m[8]), m[9], m[10], m[11]),
            lateral_span=lat_span,
        )
        state[(point, rep)] = (next_block, acc)
    return state


class Checkpoint:
    """The checkpoint file of a run, and what the run did with it.

    Pass one as ``checkpoint=`` to :func:`microimpact.run` (a plain path makes
    one) and read it afterwards, or in `on_load` before any block is simulated.

    Parameters
    ----------
    path : path-like
        The checkpoint file.
    interval : float, optional
        Least number of seconds between writes; default: the engine's
        (``MICROIMPACT_CHECKPOINT_INTERVAL``, else 2 s). Writes are further spaced so
        that they take at most :data:`WRITE_FRACTION` of the run time.
    on_load : callable, optional
        Called with this object once the file was examined (restored or not), before
        the run starts; e.g. to print "resumed N of M blocks".

    Attributes
    ----------
    restored_blocks : int
        Blocks restored from the file (0 for a fresh start).
    total_blocks : int
        Blocks of the whole run (for a precision target: at the sample cap).
    rejected : str or None
        Why an existing file was not used: ``"corrupt"``, ``"format"``, ``"seed"``,
        ``"samples"`` or ``"scenario"``; None if it was used or there was none.
    message : str or None
        The warning issued for a rejected file.
    stale_path : Path or None
        Where the rejected file was moved (``<path>.stale``).
    min_interval : float
        The least interval between writes of the current run [s].
    writes, bytes_written, write_seconds : int, int, float
        Number of writes, size of the last file [bytes], total time writing [s].
    """

    def __init__(self, path, *, interval=None, on_load=None):
        self.path = Path(path)
        self.interval = interval
        self.on_load = on_load
        self._reset()

    def _reset(self):
        self.restored_blocks = 0
        self.total_blocks = 0
        self.rejected = None
        self.message = None
        self.stale_path = None
        self.writes = 0
        self.bytes_written = 0
        self.write_seconds = 0.0
        self.min_interval = self.interval
        self._last_write = None  # monotonic time of the last write
        self._last_cost = 0.0

    @property
    def resumed(self) -> bool:
        """True if the run continued from the file."""
        return self.restored_blocks > 0

    def __repr__(self):
        return (
            f"Checkpoint({str(self.path)!r}, restored_blocks={self.restored_blocks}, "
            f"total_blocks={self.total_blocks}, rejected={self.rejected!r})"
        )

    def open(self, fingerprint: dict, *, interval: float) -> dict:
        """Start a run: remove stale temporary files, load the file if it belongs to
        this run (else warn and move it aside) and return the restored state."""
        self._reset()
        self.min_interval = interval if self.interval is None else self.interval
        self._fingerprint = fingerprint
        self._remove_temporaries()
        try:
            state = load(self.path, fingerprint) or {}
        except CheckpointMismatch as exc:
            self._reject(exc)
            state = {}
        self._last_write = time.monotonic()
        return state

    def started(self, restored_blocks: int, total_blocks: int) -> None:
        """Record what was restored and call `on_load`."""
        self.restored_blocks = int(restored_blocks)
        self.total_blocks = int(total_blocks)
        if self.on_load is not None:
            self.on_load(self)

    def due(self) -> bool:
        """True when the next write is due: at least `interval` seconds and
        ``last write time / WRITE_FRACTION`` after the last write."""
        wait = max(self.min_interval, self._last_cost / WRITE_FRACTION)
        return time.monotonic() - self._last_write >= wait

    def write(self, state) -> None:
        """Write `state` ({(point, rep): (next_block, accumulator)} or a
        :class:`StackedState`) now."""
        t0 = time.monotonic()
        self.bytes_written = save(self.path, self._fingerprint, state)
        self._last_write = time.monotonic()
        self._last_cost = self._last_write - t0
        self.write_seconds += self._last_cost
        self.writes += 1

    def _remove_temporaries(self):
        # atomic_write's temporary files: '.<name>.<random>.tmp' next to the file,
        # left behind only by a killed process (a live one renames or removes them)
        for tmp in self.path.parent.glob(f".{self.path.name}.*.tmp"):
            tmp.unlink(missing_ok=True)

    def _reject(self, exc: CheckpointMismatch):
        self.rejected = exc.reason
        self.stale_path = self.path.with_name(self.path.name + ".stale")
        os.replace(self.path, self.stale_path)
        detail = f" ({exc.detail})" if exc.detail else ""
        self.message = (
            f"checkpoint {self.path} was not used: {_CAUSES[exc.reason]}{detail}; "
            f"it was moved to {self.stale_path} and this run starts afresh"
        )
        warnings.warn(self.message, CheckpointWarning, stacklevel=3)
