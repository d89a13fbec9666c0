"""Benchmark of a whole study at scale: time and peak memory of each stage of
``microimpact run`` (issue 22, item 4), at 10^4, 10^5 and 10^6 sweep points.

The study is the ``sst76-formica-oblique`` preset (two surfaces: the Formica
angles and a molecularly smooth one) swept over ``speeds`` log-spaced speeds in
[0.05, 5] m/s and ``angles`` angles in [5, 90] deg, 100 impacts per point, one
worker. Each size runs in a fresh process, stage after stage as ``Study.execute``
runs them:

1. ``simulate``: :meth:`Study.run` with a checkpoint file (as the CLI keeps one);
2. ``summary``: the summary table (``result.summary``);
3. ``capture_speed``: ``result.capture_speed()`` (one probit fit per curve);
4. ``summary_csv``: ``summary.csv``;
5. ``netcdf``: ``results.nc`` (the Dataset is built here);
6. ``figures``: every figure of the result, PNG;
7. ``report``: ``report.html`` with those figures embedded.

For each stage: its wall time [s] and the peak RSS of the process after it [MiB]
(the peak is monotonic: a stage that raises it is the one that needed the memory).
The HTML size is reported too.

Then, as ``microimpact report`` does, a second fresh process reopens the run's
``results.nc`` (``open``: :func:`open_result`, the Dataset loaded) and runs the
stages after the simulation again (``summary``, ``capture_speed``, ``netcdf``:
the file written anew, ``figures``, ``report``): their memory, without the
simulation's peak above them. Timings on a shared machine are noisy.

Usage::

    python benchmarks/study_scale.py [--sizes 1e4,1e5,1e6] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Sweep shapes (surfaces are the preset's two): points -> (speeds, angles).
SHAPES = {10**4: (100, 50), 10**5: (250, 200), 10**6: (1000, 500)}
SAMPLES = 100


def scenario(points: int):
    """The benchmark study of `points` sweep points (a key of :data:`SHAPES`)."""
    import numpy as np

    import microimpact as mi

    speeds, angles = SHAPES[points]
    return mi.Scenario.from_preset("sst76-formica-oblique").with_options(
        speeds_m_s=tuple(np.geomspace(0.05, 5.0, speeds)),
        angles_deg=tuple(np.linspace(5.0, 90.0, angles)),
    )


def peak_mib() -> float:
    """Peak RSS of this process so far [MiB] (Linux: ru_maxrss is in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def stages(points: int, out: Path, *, reopen: bool = False) -> dict:
    """Run the stages at `points` points into `out` (with `reopen`, those after
    the simulation, on ``out/results.nc``); ``{stage: (s, MiB)}``."""
    from microimpact.engine.result import open_result
    from microimpact.pipeline.figures import figures_for_result
    from microimpact.pipeline.report import input_figures, write_report
    from microimpact.pipeline.study import Outputs, Study
    from microimpact.plotting._style import use_agg
    from microimpact.plotting.results import save_figures

    use_agg()
    times = {"start": (0.0, peak_mib())}

    def timed(name, fn):
        t = time.perf_counter()
        value = fn()
        times[name] = (time.perf_counter() - t, peak_mib())
        return value

    if reopen:
        result = timed("open", lambda: open_result(out))
    else:
        study = Study(scenario(points), outputs=Outputs(figures=("png",)))
        timed(
            "simulate",
            lambda: study.run(
                samples=SAMPLES,
                seed=1,
                workers=1,
                progress=False,
                checkpoint=out / "checkpoint.npz",
            ),
        )
        result = study.result
    timed("summary", lambda: result.summary)
    timed("capture_speed", result.capture_speed)
    if not reopen:
        timed("summary_csv", lambda: result.to_csv(out / "summary.csv"))
    timed("netcdf", lambda: result.to_netcdf(out / "results.nc"))

    def figures():
        paths = figures_for_result(result, out, formats=("png",))
        items = [(name, fig) for name, _caption, fig in input_figures(result)]
        return paths + save_figures(items, out, ("png",))

    paths = timed("figures", figures)
    timed(
        "report",
        lambda: write_report(
            [result],
            out / "report.html",
            extra_figures={result.scenario.name: [Path(p) for p in paths]},
            csv_paths=[out / "summary.csv"],
        ),
    )
    return {
        "points": points,
        "stages": times,
        "report_mb": (out / "report.html").stat().st_size / 1e6,
        "total_s": sum(t for t, _ in times.values()),
        "peak_rss_mib": peak_mib(),
    }


def cpu() -> str:
    """CPU model and vector extensions (``lscpu``)."""
    try:
        text = subprocess.run(
            ["lscpu"], capture_output=True, text=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return platform.processor() or "unknown"
    model = flags = ""
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "Model name":
            model = value.strip()
        elif key.strip() == "Flags":
            flags = " ".join(
                f for f in value.split() if f.startswith(("avx", "sse4", "fma", "amx"))
            )
    return f"{model} ({flags})"


def _print(row) -> None:
    parts = ", ".join(
        f"{k} {t:.1f} s ({m:.0f} MiB)"
        for k, (t, m) in row["stages"].items()
        if k != "start"
    )
    what = "reopened" if row["reopened"] else "run"
    print(
        f"{row['points']:>9,} points, {what}: total {row['total_s']:.1f} s, peak "
        f"RSS {row['peak_rss_mib']:.0f} MiB, report {row['report_mb']:.2f} MB; "
        f"{parts}",
        flush=True,
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="comma list of points")
    ap.add_argument("--json", type=Path, help="write the numbers here")
    ap.add_argument("--child", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--folder", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--reopen", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:  # one size, in this fresh process
        row = stages(int(args.child), args.folder, reopen=args.reopen)
        print(json.dumps(row))
        return 0
    rows = []
    for size in (int(float(s)) for s in args.sizes.split(",")):
        if size not in SHAPES:
            ap.error(f"--sizes: {size} is not one of {sorted(SHAPES)}")
        with tempfile.TemporaryDirectory() as tmp:
            for reopen in (False, True):
                proc = subprocess.run(
                    [sys.executable, __file__, "--child", str(size), "--folder", tmp]
                    + (["--reopen"] if reopen else []),
                    capture_output=True,
                    text=True,
                    check=True,
                )
                row = json.loads(proc.stdout.strip().splitlines()[-1])
                row["reopened"] = reopen
                rows.append(row)
                _print(row)
    info = {"cpu": cpu(), "python": platform.python_version(), "sizes": rows}
    print(f"CPU: {info['cpu']}")
    if args.json:
        args.json.write_text(json.dumps(info, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
