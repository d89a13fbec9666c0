"""The share of a path's wall time that holds the GIL, sampled with py-spy, and
the Amdahl projection it implies (issue 31, item 4).

Each path runs in a child process twice under ``py-spy record``: once sampling
every active moment (``--format raw``), once only the moments that hold the GIL
(``--gil``). Only the samples inside the path's own call (the frame named below)
count, so imports and planning outside it do not. The GIL share g bounds the
speed-up of n threads by Amdahl's law, ``1 / (g + (1 - g) / n)``.

A second reading needs no sampler: the child also runs once alone, timing the
path's calls and the compiled kernel's own count of the time it ran with the
GIL released (``_ckernel.released_ns``). With one worker, one minus that share
is an upper bound of the GIL's share (the "kernel bound"): every moment outside
the kernel counts as held, NumPy's own GIL-free loops too. It is tight where
the path's time outside the kernel is Python (``run``, ``grid``) and loose where
NumPy works on large arrays (the wall law sorts its rebounds for the quantiles).

One path's py-spy recordings vary more than their binomial error (2-5 % for the
same ``run()`` on a 2-core VM: each recording is a separate process, with its
own memory layout and neighbours). ``--recordings R`` pools R of them, with a
standard error from their spread.

    pip install py-spy                      # not a dependency of the package
    python benchmarks/gil_share.py          # about a minute on 2 cores
    python benchmarks/gil_share.py --json out.json
    python benchmarks/gil_share.py --starts warm --repeat 8 --recordings 5

Each path is measured twice: ``cold``, its first call in a fresh process (the
imports of xarray, SciPy and the first-call set-up fall inside it: a one-off cost
per process, which dominates a path that runs for about a second), and ``warm``,
after a tiny call of the same path (the share that grows with the work and bounds
the scaling of a large job).

Paths, one worker each (the sizes of issue 31's targets):

* ``run``: ``run()`` over 64 points of 10^6 impacts (sst76-formica-oblique physics);
* ``grid``: a 60 x 60 speed-angle grid at 8,000 impacts per point;
* ``wall_law``: a 16^3 wall law at 2,000 impacts per node;
* ``sensitivity``: ``sobol_sensitivity`` over 4 coefficient parameters,
  ``base_size=4`` (24 design rows, each a run of the preset's 20 sweep points at
  20,000 impacts);
* ``calibration``: a least-squares ``calibrate`` of a surface's spread and v_c to
  the mean e and mu of 8 points (a fit of ~30 model runs of 8 points at 20,000
  impacts), the data made by the model itself at known values.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

#: Each child starts with this: ``WARM`` set means the path runs once at a tiny
#: size before the measured call (imports, lazy set-up and caches done).
PRELUDE = (
    "import os\nWARM = os.environ.get('MICROIMPACT_GIL_WARM') == '1'\n"
    "REPEAT = int(os.environ.get('MICROIMPACT_GIL_REPEAT', '1'))\n"
)

CHILD = {
    "run": (
        "from microimpact.scenario import load_preset\n"
        "from microimpact.engine.montecarlo import run\n"
        "sc = load_preset('sst76-formica-oblique').with_options(\n"
        "    surfaces=load_preset('sst76-formica-oblique').surfaces[:1],\n"
        "    speeds_m_s=(0.5, 1.0, 2.0, 5.0),\n"
        "    angles_deg=tuple(range(10, 90, 5))[:16])\n"
        "def path():\n"
        "    run(sc, samples=1_000_000, workers=1)\n"
        "if WARM:\n"
        "    run(sc, samples=1000, workers=1, seed=2)\n"
        "path()\n"
    ),
    "grid": (
        "import numpy as np\n"
        "from microimpact.scenario import load_preset\n"
        "from microimpact.engine.montecarlo import run\n"
        "base = load_preset('sst76-formica-oblique')\n"
        "sc = base.with_options(surfaces=base.surfaces[:1],\n"
        "    speeds_m_s=tuple(np.linspace(0.2, 5.0, 60)),\n"
        "    angles_deg=tuple(np.linspace(5.0, 90.0, 60)))\n"
        "def path():\n"
        "    run(sc, samples=8000, workers=1)\n"
        "if WARM:\n"
        "    run(sc, samples=100, workers=1, seed=2)\n"
        "path()\n"
    ),
    "wall_law": (
        "import numpy as np\n"
        "from microimpact.scenario import load_preset\n"
        "from microimpact.wall_law import WallLawSpec, build_wall_law\n"
        "base = load_preset('sst76-formica-oblique')\n"
        "sc = base.with_options(surfaces=base.surfaces[:1])\n"
        "spec = WallLawSpec(diameters_um=tuple(np.geomspace(10, 80, 16)),\n"
        "    speeds_m_s=tuple(np.geomspace(0.2, 10, 16)),\n"
        "    angles_deg=tuple(np.linspace(6, 90, 16)), samples=2000, reservoir=64)\n"
        "def path():\n"
        "    build_wall_law(sc, spec, workers=1, seed=1)\n"
        "if WARM:\n"
        "    build_wall_law(sc, WallLawSpec(diameters_um=(10.0, 20.0),\n"
        "        speeds_m_s=(1.0, 2.0), angles_deg=(30.0, 60.0), samples=100,\n"
        "        reservoir=8), workers=1, seed=2)\n"
        "path()\n"
    ),
    "sensitivity": (
        "import microimpact as mi\n"
        "PARAMETERS = {\n"
        "    'coefficients.friction': {'low': 0.1, 'high': 0.3},\n"
        "    'coefficients.k1': {'low': 3.0, 'high': 5.0},\n"
        "    'coefficients.v_c.a_m_s': {'low': 0.15, 'high': 0.25},\n"
        "    'coefficients.k2.a_m_s': {'low': 0.04, 'high': 0.06}}\n"
        "def go(samples, seed):\n"
        "    mi.sobol_sensitivity('sst76-formica-oblique', PARAMETERS, base_size=4,\n"
        "        samples=samples, seed=seed, workers=1, n_resamples=10,\n"
        "        progress=False)\n"
        "def path():\n"
        "    go(20000, 1)\n"
        "if WARM:\n"
        "    go(200, 2)\n"
        "path()\n"
    ),
    "calibration": (
        "import microimpact as mi\n"
        "from microimpact.analysis.calibration import calibrate\n"
        "from microimpact.analysis.compare import experiments_from_summary\n"
        "from microimpact.scenario.parameters import with_values\n"
        "from microimpact.scenario.scenario import scenario_from_dict\n"
        "STD, VC = 'surfaces.rough.std_deg', 'coefficients.v_c.a_m_s'\n"
        "data = {'name': 'bench', 'seed': 1, 'samples': 20000,\n"
        "    'particles': {'distribution': 'monodisperse', 'diameter_um': 50.0},\n"
        "    'coefficients': {'k1': 4.0,\n"
        "        'k2': {'law': 'power', 'a_m_s': 0.05, 'b': -1.58, 'd_ref_um': 52.8},\n"
        "        'v_c': {'law': 'power', 'a_m_s': 0.2, 'b': -1.58, 'd_ref_um': 52.8},\n"
        "        'p': 1.0, 'q': 1.0, 'friction': 0.15},\n"
        "    'surfaces': [{'name': 'rough', 'kind': 'normal', 'std_deg': 10.0}],\n"
        "    'sweep': {'speed_m_s': [1.0, 3.0],\n"
        "              'angle_deg': [20.0, 40.0, 60.0, 80.0]}}\n"
        "truth = with_values(data, {STD: 12.0, VC: 0.22})\n"
        "s = mi.run(scenario_from_dict(truth), seed=7, progress=False).summary\n"
        "exp = experiments_from_summary(s, ('e', 'mu'), by_surface=False)\n"
        "def go(samples):\n"
        "    calibrate(data, exp, {STD: (2.0, 30.0), VC: (0.1, 0.4)},\n"
        "        samples=samples, workers=1, bootstrap=0, progress=False)\n"
        "def path():\n"
        "    go(20000)\n"
        "if WARM:\n"
        "    go(2000)\n"
        "path()\n"
    ),
}
#: The frames of the path's own work: its call, and the worker threads of a run
#: whose tasks run inside the compiled kernel (``KernelTasks.run``: their stacks
#: start in the thread, not in the path's call, while the caller only waits).
FRAMES = ("path (child.py:", "KernelTasks.run (")


def _samples(raw: Path, where: collections.Counter | None = None) -> int:
    """Samples inside the path's call; `where` counts them by their deepest
    microimpact frame (or the leaf frame where there is none)."""
    n = 0
    for line in raw.read_text(encoding="utf-8").splitlines():
        stack, _, count = line.rpartition(" ")
        if any(f in stack for f in FRAMES):
            n += int(count)
            if where is not None:
                frames = stack.split(";")
                own = [f for f in frames if "microimpact" in f]
                where[(own or frames)[-1]] += int(count)
    return n


def measure(
    name: str, pyspy: str, rate: int = 250, *, warm: bool = False, repeat: int = 1
) -> dict:
    """GIL share of path `name`: in a fresh process (cold: the path's first call
    pays the imports and lazy set-up) or after a tiny warm-up call (warm)."""
    where = collections.Counter()
    env = dict(
        os.environ,
        MICROIMPACT_GIL_WARM="1" if warm else "0",
        MICROIMPACT_GIL_REPEAT=str(repeat),
    )
    with tempfile.TemporaryDirectory() as tmp:
        child = Path(tmp) / "child.py"
        # the path's call `repeat` times (more samples, the same share), timed
        # with the kernel's own count of its GIL-free time
        body = CHILD[name].replace("\npath()\n", TIMED)
        child.write_text(PRELUDE + body, encoding="utf-8")
        # the second reading, without py-spy: one minus the kernel's GIL-free
        # share of the wall time (an upper bound of the GIL's share with one
        # worker: every moment outside the kernel counts as held, also NumPy's
        # own GIL-free loops)
        plain = subprocess.run(
            [sys.executable, str(child)],
            check=True,
            capture_output=True,
            text=True,
            cwd=tmp,
            env=env,
        )
        wall, released = _released(plain.stdout)
        counts = {}
        for kind, extra in (("all", []), ("gil", ["--gil"])):
            raw = Path(tmp) / f"{kind}.txt"
            subprocess.run(
                [
                    pyspy,
                    "record",
                    "--rate",
                    str(rate),
                    "--format",
                    "raw",
                    *extra,
                    "-o",
                    str(raw),
                    "--",
                    sys.executable,
                    str(child),
                ],
                check=True,
                capture_output=True,
                cwd=tmp,
                env=env,
            )
            counts[kind] = _samples(raw, where if kind == "gil" else None)
    n = counts["all"]
    g = min(counts["gil"] / n, 1.0) if n else float("nan")
    return {
        "path": name,
        "start": "warm" if warm else "cold",
        "samples": n,
        "gil_samples": counts["gil"],
        "gil_share": g,
        # the two recordings are separate runs: a binomial standard error of the
        # share, as if the GIL samples were a subset of the active ones
        "gil_share_se": (g * (1.0 - g) / n) ** 0.5 if n else float("nan"),
        "amdahl_16": 1.0 / (g + (1.0 - g) / 16.0),
        "amdahl_64": 1.0 / (g + (1.0 - g) / 64.0),
        "gil_frames": where.most_common(5),
        "wall_s": wall,
        "released_s": released,
        "kernel_bound": 1.0 - released / wall if wall > 0 else float("nan"),
    }


#: The path's calls, timed: the wall time and the kernel's GIL-free time
#: (``_ckernel.released_ns``; NaN without the compiled kernel, or with one built
#: before it counted) on one line.
TIMED = (
    "\nimport time as _time\n"
    "from microimpact.engine import _compiled as _c\n"
    "_ns = getattr(_c.ckernel, 'released_ns', None)\n"
    "_r0, _w0 = (_ns() if _ns else 0), _time.perf_counter()\n"
    "for _ in range(REPEAT):\n    path()\n"
    "_w = _time.perf_counter() - _w0\n"
    "_r = (_ns() - _r0) / 1e9 if _ns else float('nan')\n"
    "print('MICROIMPACT_RELEASED', repr(_w), repr(_r))\n"
)


def _released(stdout: str) -> tuple[float, float]:
    """The (wall, GIL-free) seconds a child printed (:data:`TIMED`)."""
    for line in stdout.splitlines():
        if line.startswith("MICROIMPACT_RELEASED "):
            _, wall, released = line.split()
            return float(wall), float(released)
    raise RuntimeError("the child printed no timing line")


def pooled(records: list[dict]) -> dict:
    """One row from several recordings of a path: the share of the pooled
    samples, with a standard error from the spread between the recordings
    (one recording's binomial error where there is one). The recordings of one
    path vary more than binomially (2-4 % for the same grid on one machine):
    each is a separate process, with its own memory layout and neighbours."""
    if len(records) == 1:
        return records[0]
    n = sum(r["samples"] for r in records)
    held = sum(r["gil_samples"] for r in records)
    g = min(held / n, 1.0) if n else float("nan")
    shares = [r["gil_share"] for r in records]
    mean = sum(shares) / len(shares)
    spread = (sum((x - mean) ** 2 for x in shares) / (len(shares) - 1)) ** 0.5
    where = collections.Counter()
    for r in records:
        where.update(dict((f, c) for f, c in r["gil_frames"]))
    return {
        **records[0],
        "samples": n,
        "gil_samples": held,
        "gil_share": g,
        "gil_share_se": spread / len(shares) ** 0.5,
        "recordings": shares,
        "amdahl_16": 1.0 / (g + (1.0 - g) / 16.0),
        "amdahl_64": 1.0 / (g + (1.0 - g) / 64.0),
        "gil_frames": where.most_common(5),
        "wall_s": sum(r["wall_s"] for r in records),
        "released_s": sum(r["released_s"] for r in records),
        "kernel_bound": 1.0
        - sum(r["released_s"] for r in records) / sum(r["wall_s"] for r in records),
        "kernel_bounds": [r["kernel_bound"] for r in records],
    }


def _cpu() -> str:
    try:
        info = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.processor()
    model = next(
        (
            x.split(":", 1)[1].strip()
            for x in info.splitlines()
            if x.startswith("model name")
        ),
        "?",
    )
    flags = next((x for x in info.splitlines() if x.startswith("flags")), "")
    return f"{model}, {os.cpu_count()} CPUs, AVX-512 {'avx512f' in flags}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", nargs="+", default=list(CHILD), choices=list(CHILD))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--rate", type=int, default=250, help="py-spy samples per second")
    ap.add_argument(
        "--repeat", type=int, default=1, help="calls of each path per recording"
    )
    ap.add_argument(
        "--starts",
        nargs="+",
        default=["cold", "warm"],
        choices=["cold", "warm"],
        help="cold: the path's first call in a fresh process; warm: after a tiny one",
    )
    ap.add_argument(
        "--recordings",
        type=int,
        default=1,
        help="recordings of each path, pooled (the spread between them gives the "
        "standard error)",
    )
    args = ap.parse_args(argv)
    for name in ("repeat", "recordings", "rate"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be at least 1; got {getattr(args, name)}")
    pyspy = shutil.which("py-spy") or str(Path(sys.executable).with_name("py-spy"))
    if not Path(pyspy).exists():
        print("py-spy is not installed: pip install py-spy", file=sys.stderr)
        return 2
    rows = [
        pooled(
            [
                measure(
                    name, pyspy, args.rate, warm=start == "warm", repeat=args.repeat
                )
                for _ in range(args.recordings)
            ]
        )
        for name in args.paths
        for start in args.starts
    ]
    print(f"CPU: {_cpu()}")
    print(
        "| path | start | samples | GIL held (py-spy) | kernel bound | "
        "Amdahl 16 cores | Amdahl 64 cores |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        share = f"{100 * r['gil_share']:.1f} ± {100 * r['gil_share_se']:.1f} %"
        if "recordings" in r:
            each = " / ".join(f"{100 * x:.1f}" for x in r["recordings"])
            share += f" ({each})"
        bound = f"{100 * r['kernel_bound']:.1f} %"
        if "kernel_bounds" in r:
            bound += f" ({' / '.join(f'{100 * x:.1f}' for x in r['kernel_bounds'])})"
        print(
            f"| `{r['path']}` | {r['start']} | {r['samples']} | {share} | {bound} | "
            f"{r['amdahl_16']:.1f}x | {r['amdahl_64']:.1f}x |"
        )
    print("\nWhere the GIL samples are (deepest microimpact frame):")
    for r in rows:
        top = ", ".join(f"{f} {c}" for f, c in r["gil_frames"][:3])
        print(f"- {r['path']} ({r['start']}): {top}")
    if args.json:
        args.json.write_text(json.dumps({"cpu": _cpu(), "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
