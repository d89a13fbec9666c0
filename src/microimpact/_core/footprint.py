"""What a run will cost, known before it starts: points, impacts, memory, output.

A sweep is the product of its axes, so three modest ranges can ask for 10^8 points:
hours of work, a terabyte of memory and of files. :func:`footprint` computes the
cost from the scenario alone (no plan is built, so it takes microseconds at any
size), :func:`machine` measures what this machine has, and :func:`check_footprint`
refuses a run that does not fit, with the numbers and how to cut them, unless the
caller says to go on anyway (the command line's ``--yes``).

The memory and output sizes per point are measured, not derived: the peak
resident memory and the files of ``microimpact run`` over 10^4 to 10^6 points, on
smooth and rough surfaces with 100 to 4,000 impacts per point (2.5 to 14 kB of
memory and 0.7 to 1.2 kB of files per point; docs/performance.md). The constants
below bound those measurements from above.
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError

__all__ = ["Footprint", "Machine", "check_footprint", "footprint", "machine"]

#: Memory of the process before any point [bytes] (NumPy, SciPy, xarray, pandas,
#: Matplotlib for the figures and the report: ~270 MB measured).
BASE_MEMORY_BYTES = 320 * 2**20
#: Memory per sweep point that does not depend on the impacts [bytes]: the plan,
#: the summary columns, the Dataset and their copies while files are written.
POINT_MEMORY_BYTES = 3_000
#: Memory per occupied histogram bin of one point [bytes] (three histograms, each
#: span held once in the accumulators and once in the Dataset).
BIN_MEMORY_BYTES = 24
#: A point's histograms occupy at most this many bins however many impacts it has.
MAX_OCCUPIED_BINS = 400
#: Files per sweep point [bytes]: summary.csv (~750) and results.nc (~500).
POINT_OUTPUT_BYTES = 1_250
#: Files that do not grow with the sweep [bytes]: figures, report, manifest.
BASE_OUTPUT_BYTES = 10 * 2**20
#: Impacts one worker simulates per second, order of magnitude (measured 1e7 to
#: 3e7 with the compiled kernel); only used to say how long a refused run would take.
IMPACTS_PER_S = 2e7
#: A run must fit in this share of the memory available now.
MEMORY_SHARE = 0.8
#: A run whose impacts would take longer than this at :data:`IMPACTS_PER_S` on the
#: workers given [s] asks for ``--yes`` too.
MAX_UNASKED_S = 3600.0
#: Above this many points (or this much memory or output) the command says what the
#: run will cost before it starts.
ANNOUNCE_POINTS = 100_000


@dataclass(frozen=True)
class Footprint:
    """The cost of a run, from its scenario.

    Attributes
    ----------
    shape : tuple of int
        Surfaces, speeds and angles of the sweep.
    impacts_per_point : int
        Impacts per point (the most a precision target may run).
    replicates : int
        Independent replicates per point (QMC sampling), else 1.
    runs : int
        How many times the sweep runs (design rows of a sensitivity study), else 1.
    simulated : int or None
        Points that are simulated, where fewer than all (a convergence study of one
        point plans the whole sweep but runs one point); None: all.
    memory_bytes : int
        Peak memory of the process, about [bytes].
    output_bytes : int
        Size of the files written, about [bytes].
    """

    shape: tuple
    impacts_per_point: int
    replicates: int
    runs: int
    memory_bytes: int
    output_bytes: int
    simulated: int | None = None

    @property
    def points(self) -> int:
        """Sweep points of one run."""
        return math.prod(self.shape)

    @property
    def impacts(self) -> int:
        """Impacts of every run together: the total work."""
        n = self.points if self.simulated is None else self.simulated
        return n * self.impacts_per_point * self.replicates * self.runs

    def seconds(self, workers: int = 1) -> float:
        """Rough wall time of the impacts on `workers` workers [s]."""
        return self.impacts / (IMPACTS_PER_S * max(1, workers))


@dataclass(frozen=True)
class Machine:
    """What this machine has now; None where it cannot be known.

    Attributes
    ----------
    memory_available : int or None
        Memory available to a new process [bytes] (Linux ``MemAvailable``).
    disk_free : int or None
        Free space where the outputs go [bytes].
    disk_path : Path or None
        The folder whose free space that is.
    """

    memory_available: int | None
    disk_free: int | None
    disk_path: Path | None = None


def footprint(
    scenario, *, samples=None, runs=1, outputs=True, simulated=None
) -> Footprint:
    """The cost of running `scenario` (a
    :class:`~microimpact.scenario.scenario.Scenario`) `runs` times with `samples`
    impacts per point (default: the scenario's, or its precision target's
    ``max_samples``); `outputs` False: nothing is written per point; `simulated`:
    how many of the points are simulated, where not all are (all are planned)."""
    if samples is None:
        precision = getattr(scenario, "precision", None)
        samples = precision.max_samples if precision else scenario.samples
    samples = int(samples)
    qmc = getattr(scenario, "sampling", "") == "qmc"
    replicates = int(scenario.qmc_replicates) if qmc else 1
    shape = (
        len(scenario.surfaces),
        len(scenario.speeds_m_s),
        len(scenario.angles_deg),
    )
    points = math.prod(shape)
    bins = min(samples, MAX_OCCUPIED_BINS) * replicates
    memory = BASE_MEMORY_BYTES + points * (POINT_MEMORY_BYTES + BIN_MEMORY_BYTES * bins)
    output = BASE_OUTPUT_BYTES + points * POINT_OUTPUT_BYTES if outputs else 0
    return Footprint(shape, samples, replicates, int(runs), memory, output, simulated)


def _memory_available() -> int | None:
    try:  # Linux: what a new allocation can get without swapping
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:  # other POSIX systems: the free physical pages
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def machine(out_dir=None) -> Machine:
    """What this machine has now: available memory and, with `out_dir`, the free
    space of the disk it is on (of its first existing parent)."""
    disk_free = disk_path = None
    if out_dir is not None:
        path = Path(out_dir).absolute()
        for p in (path, *path.parents):
            if p.is_dir():
                try:
                    disk_free, disk_path = shutil.disk_usage(p).free, p
                except OSError:
                    pass
                break
    return Machine(_memory_available(), disk_free, disk_path)


def size_text(n: float) -> str:
    """`n` bytes as "12 MB", "1.0 TB" (powers of 1000, as disks are sold)."""
    for unit in ("bytes", "kB", "MB", "GB", "TB"):
        if n < 999.5 or unit == "TB":
            digits = 0 if n >= 10 or unit == "bytes" else 1
            return f"{n:.{digits}f} {unit}"
        n /= 1000
    raise AssertionError  # pragma: no cover


def _duration_text(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.0f} h"
    return f"{seconds / 86400:.0f} days"


def describe(fp: Footprint) -> str:
    """ "100,000,000 points (1 surface x 100,000 speeds x 1,000 angles) x 4,000
    impacts", with the runs and replicates where there are several."""
    s, v, a = fp.shape
    of = "" if fp.simulated is None else f"{fp.simulated:,} of "
    text = (
        f"{of}{fp.points:,} points ({s:,} surface{'s' * (s != 1)} x {v:,} "
        f"speed{'s' * (v != 1)} x {a:,} angle{'s' * (a != 1)}) x "
        f"{fp.impacts_per_point:,} impacts"
    )
    if fp.replicates > 1:
        text += f" x {fp.replicates} replicates"
    if fp.runs > 1:
        text += f" x {fp.runs:,} runs"
    return text


def check_footprint(
    fp: Footprint,
    where: Machine,
    *,
    workers: int = 1,
    yes: bool = False,
    samples_flag: str | None = "--samples",
    workers_flag: str | None = "--workers",
    field: str = "sweep",
) -> str | None:
    """Refuse a run that does not fit `where`, unless `yes`.

    A run is refused when its memory exceeds :data:`MEMORY_SHARE` of the memory
    available, its files exceed the free disk, or its impacts would take longer
    than :data:`MAX_UNASKED_S` on `workers` workers.

    Returns
    -------
    str or None
        A one-line summary of the cost for a run worth announcing (over
        :data:`ANNOUNCE_POINTS` points, or one that goes on with `yes`), else None.

    Raises
    ------
    InputError
        With the numbers, what exceeds what, and how to cut the run (``--yes``;
        `samples_flag` and `workers_flag` name the options that set the impacts
        per point and the workers, None where the command has none; `field`
        what the message is about).
    """
    problems, size = [], False
    mem, disk = where.memory_available, where.disk_free
    if mem is not None and fp.memory_bytes > MEMORY_SHARE * mem:
        size = True
        problems.append(
            f"it needs about {size_text(fp.memory_bytes)} of memory "
            f"({size_text(mem)} available)"
        )
    if disk is not None and fp.output_bytes > disk:
        size = True
        problems.append(
            f"it writes about {size_text(fp.output_bytes)} "
            f"({size_text(disk)} free in {where.disk_path})"
        )
    seconds = fp.seconds(workers)
    if seconds > MAX_UNASKED_S:
        size = size or fp.simulated is None  # the time grows with the sweep
        problems.append(
            f"its {fp.impacts:.1e} impacts take roughly {_duration_text(seconds)} "
            f"on {workers} worker{'s' * (workers != 1)}"
        )
    flags = (samples_flag, workers_flag)
    if problems and not yes:
        raise InputError(
            f"the run is too big to start unasked: {describe(fp)}; "
            + "; ".join(problems)
            + f"; {_how_to_cut(fp, where, workers, size, flags)}, or pass --yes to "
            "start anyway",
            field=field,
        )
    if problems or fp.points > ANNOUNCE_POINTS:
        cost = [f"about {size_text(fp.memory_bytes)} of memory"]
        if mem is not None:
            cost[-1] += f" ({size_text(mem)} available)"
        if fp.output_bytes:
            cost.append(f"about {size_text(fp.output_bytes)} of files")
        return f"{describe(fp)}: {', '.join(cost)}"
    return None


def _how_to_cut(fp: Footprint, where: Machine, workers, size, flags) -> str:
    """How far to cut: the most points that fit, and (when time is the limit) the
    most impacts per point."""
    limits = []
    per_point_mem = (fp.memory_bytes - BASE_MEMORY_BYTES) / fp.points
    if where.memory_available is not None:
        room = MEMORY_SHARE * where.memory_available - BASE_MEMORY_BYTES
        limits.append(room / per_point_mem)
    if where.disk_free is not None and fp.output_bytes:
        limits.append((where.disk_free - BASE_OUTPUT_BYTES) / POINT_OUTPUT_BYTES)
    if fp.simulated is None:  # else the time does not grow with the sweep
        per_point_s = fp.seconds(workers) / fp.points
        limits.append(MAX_UNASKED_S / per_point_s)
    most = int(min(limits))
    ways = []
    if size and most >= 1:
        ways.append(
            f"cut the sweep to at most about {most:,} points (fewer speeds or angles "
            "in [sweep], or split it over several runs)"
        )
    if fp.seconds(workers) > MAX_UNASKED_S:
        per_impact_s = fp.seconds(workers) / fp.impacts
        points = fp.points if fp.simulated is None else fp.simulated
        impacts = MAX_UNASKED_S / per_impact_s / (points * fp.replicates * fp.runs)
        samples_flag, workers_flag = flags
        if impacts >= 1 and samples_flag:
            ways.append(
                f"cut the impacts to at most about {int(impacts):,} per point "
                f"({samples_flag})"
            )
        if workers_flag:
            ways.append(f"use more {workers_flag}")
    return ", or ".join(ways) if ways else "use a bigger machine"
