"""Checkpoints: finished work survives a killed run.

The driver merges per-block accumulators in key order, so the state of a sweep point
is fully described by "blocks ``[0, k)`` are merged into this accumulator". A
checkpoint stores that prefix for every (point, replicate), plus a fingerprint of the
plan. It is written to a temporary file in the same folder and renamed over the old
one, so at any instant (even under SIGKILL) the file on disk is a complete earlier
checkpoint. Re-running the same command loads it, checks the fingerprint and skips
the finished blocks: the final result is bit-identical to an uninterrupted run.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from .._files import atomic_write
from .accumulators import PointAccumulator

FORMAT_VERSION = 1


def plan_fingerprint(plan, targets) -> str:
    """Hash of everything that determines the result of a run."""
    h = hashlib.sha256()
    h.update(
        f"v{FORMAT_VERSION}|{plan.entropy}|{plan.shadowing}|{plan.sampling}|"
        f"{plan.replicates}|{plan.block_size}|{plan.table_bits}|"
        f"{plan.p}|{plan.q}|{plan.friction}|".encode()
    )
    for sp in plan.points:
        h.update(repr((sp.surface, sp.speed, sp.angle_deg)).encode())
    for arr in (plan.diameter, plan.inv_k1, plan.inv_k2, plan.v_c, plan.speed_factor):
        h.update(b"|" if arr is None else np.ascontiguousarray(arr).tobytes())
    for atoms in plan.surface_atoms:
        h.update(b"|" if atoms is None else np.ascontiguousarray(atoms).tobytes())
    h.update(repr(targets).encode())
    return h.hexdigest()


def save(path, fingerprint: str, state: dict) -> None:
    """Atomically write `state` = {(point, rep): (next_block, accumulator)}."""
    path = Path(path)
    arrays = {"fingerprint": np.array(fingerprint)}
    for (point, rep), (nxt, acc) in state.items():
        prefix = f"p{point}_r{rep}_"
        arrays[prefix + "next"] = np.array(nxt)
        for k, v in acc.to_arrays().items():
            arrays[prefix + k] = v

    def write(tmp):
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())  # durable before the rename: survives SIGKILL

    atomic_write(path, write)


def load(path, fingerprint: str) -> dict | None:
    """The saved state if `path` holds a checkpoint of the same run, else None."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path) as z:
            if str(z["fingerprint"]) != fingerprint:
                return None
            state = {}
            for key in z.files:
                if not key.endswith("_next"):
                    continue
                prefix = key[: -len("next")]
                point, rep = prefix.strip("_").split("_")
                acc = PointAccumulator.from_arrays(
                    {
                        k: z[prefix + k]
                        for k in ("counts", "e", "mu", "e_hist", "mu_hist")
                    }
                )
                state[(int(point[1:]), int(rep[1:]))] = (int(z[key]), acc)
            return state
    except (OSError, ValueError, KeyError):
        return None  # unreadable: start afresh rather than trust it
