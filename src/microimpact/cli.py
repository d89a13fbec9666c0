"""The ``microimpact`` command line: a thin layer over the library.

It parses arguments, builds a Scenario or reads data, calls the library and writes
the outputs. Exit codes: 0 success; 2 a user error (bad flag, bad file, bad scenario),
reported as one line without a traceback; 1 an internal error (set
``MICROIMPACT_DEBUG=1`` to see the traceback).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path

from . import __version__
from .errors import DataFormatError, InputError, _one_line

EXIT_OK, EXIT_INTERNAL, EXIT_USER = 0, 1, 2
CHECKPOINT_NAME = ".microimpact-checkpoint.npz"
#: Figure formats of ``run``/``reproduce`` when neither ``--formats`` nor the
#: scenario's ``[outputs] figures`` gives them.
DEFAULT_FORMATS = ("png", "pdf")


# ----------------------------------------------------------------- arg types
def _int_at_least(minimum):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a whole number; got {text!r}"
            ) from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}; got {v}")
        return v

    return parse


_positive_int = _int_at_least(1)
_nonneg_int = _int_at_least(0)


def _positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0; got {text}")
    return v


def _fraction(text):
    v = _positive_float(text)
    if not v < 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1); got {text}")
    return v


def _formats(text):
    from .plotting.results import FIGURE_FORMATS

    fmts = [f.strip().lower() for f in text.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FIGURE_FORMATS]
    if bad or not fmts:
        raise argparse.ArgumentTypeError(
            f"formats must be a comma list of {', '.join(FIGURE_FORMATS)}; got {text!r}"
        )
    return tuple(dict.fromkeys(fmts))


def _out_dir(text):
    """An output folder: new (created when needed) or existing, never a file."""
    path = Path(text)
    for p in (path, *path.parents):  # the first part that exists must be a folder
        if p.exists():
            if not p.is_dir():
                what = repr(text) if p == path else f"{str(p)!r} (in {text!r})"
                raise argparse.ArgumentTypeError(
                    f"{what} is a file, not a folder; give a new or existing folder"
                )
            break
    return path


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse's own convention)
        self.exit(EXIT_USER, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    from .units import LENGTH_UNITS

    units = tuple(LENGTH_UNITS)
    unit_help = f"length unit of the data, one of {', '.join(units)} (default um)"
    p = _Parser(
        prog="microimpact",
        description="Monte Carlo analysis of polydisperse microparticle impacts "
        "with rough surfaces (Li, Dunn & Brach 2000).",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    def common_run(sp):
        sp.add_argument(
            "--seed", type=_nonneg_int, help="root seed (overrides the file)"
        )
        sp.add_argument(
            "--workers",
            type=_positive_int,
            default=1,
            help="worker processes (default 1)",
        )
        sp.add_argument("--backend", choices=("process", "dask"), default="process")
        sp.add_argument(
            "--scheduler",
            metavar="ADDRESS",
            help="Dask scheduler address (default: a LocalCluster)",
        )
        sp.add_argument("--quiet", action="store_true", help="no progress bar")
        sp.add_argument(
            "--formats",
            type=_formats,
            default=None,
            help="figure formats, e.g. png,pdf (default: the scenario's "
            "[outputs] figures, else png,pdf)",
        )

    r = sub.add_parser("run", help="run a scenario file")
    r.add_argument("scenario", help="scenario TOML file or preset name")
    r.add_argument("--out", required=True, type=_out_dir, help="output folder")
    r.add_argument("--samples", type=_positive_int, help="impacts per sweep point")
    r.add_argument(
        "--precision",
        type=_positive_float,
        metavar="X",
        help="stop each point at this CI half-width of the scenario's "
        "precision statistic (default capture_fraction)",
    )
    r.add_argument("--no-figures", action="store_true")
    common_run(r)

    rp = sub.add_parser("reproduce", help="run the paper's four presets + report")
    rp.add_argument("--out", type=_out_dir, default="out")
    rp.add_argument("--quick", action="store_true", help="1,000 samples per point")
    rp.add_argument(
        "--samples",
        type=_positive_int,
        help="impacts per sweep point (default: each preset's, 4,000)",
    )
    common_run(rp)

    rg = sub.add_parser("roughness", help="characterise a profilometer scan")
    rg.add_argument("profile", type=Path, nargs="+", help="profile file(s)")
    rg.add_argument("--out", required=True, type=_out_dir)
    rg.add_argument("--contact-length-um", type=_positive_float, default=20.0)
    rg.add_argument("--method", choices=("slope", "paper"), default="slope")
    rg.add_argument(
        "--unit", default="um", choices=units, metavar="UNIT", help=unit_help
    )
    rg.add_argument(
        "--dx-um",
        type=_positive_float,
        help="sampling interval when the file holds heights only",
    )
    rg.add_argument(
        "--n-angles",
        type=_positive_int,
        default=4000,
        help="angles in the exported sample file (paper: 4,000)",
    )
    rg.add_argument("--seed", type=_nonneg_int, default=0)

    sz = sub.add_parser("sizes", help="fit diameters, chi-squared test, plot")
    sz.add_argument("data", type=Path)
    sz.add_argument("--out", type=_out_dir, default=None)
    sz.add_argument("--column", default=None, help="column name or 0-based index")
    sz.add_argument(
        "--unit", default="um", choices=units, metavar="UNIT", help=unit_help
    )
    sz.add_argument("--alpha", type=_fraction, default=0.05)

    ft = sub.add_parser("fit", help="least-squares k1, k2, v_c from impact data")
    ft.add_argument("data", type=Path, help="CSV: diameter_um, v_n_m_s, e")
    ft.add_argument("--out", type=_out_dir, default=None)
    ft.add_argument(
        "--form", choices=("power", "polynomial", "constant"), default="power"
    )

    cv = sub.add_parser("convergence", help="the paper's convergence study")
    cv.add_argument("scenario", help="scenario TOML file or preset name")
    cv.add_argument("--out", type=_out_dir, default=None)
    cv.add_argument(
        "--point",
        type=_nonneg_int,
        default=None,
        help="sweep-point index (default: the one nearest 50 %% capture)",
    )
    cv.add_argument("--n-max", type=_positive_int, default=20_000)
    cv.add_argument("--tolerance", type=_fraction, default=0.03)
    cv.add_argument("--seed", type=_nonneg_int)

    cp = sub.add_parser("compare", help="simulation vs experiment at 95 %% level")
    cp.add_argument("results", type=Path, help="summary.csv, results.nc or run folder")
    cp.add_argument("experiment", type=Path, help="experimental CSV")
    cp.add_argument("--out", type=_out_dir, default=None)
    cp.add_argument("--confidence", type=_fraction, default=0.95)

    sub.add_parser("presets", help="list the shipped presets")
    return p


# ----------------------------------------------------------------- helpers
def _load_scenario(text):
    from .config import preset_path
    from .scenario import Scenario

    path = Path(text)
    if path.suffix.lower() != ".toml" and not path.exists():
        try:
            path = preset_path(text)
        except ValueError as err:  # names the presets, with "did you mean"
            msg = str(err).removeprefix("`name` ")
            raise InputError(
                f"not a scenario file; a preset name {msg}", source=text
            ) from None
    return Scenario.from_toml(path)  # a missing file: an error naming it


def _figure_formats(args, scenario):
    """``--formats``, else the scenario's ``[outputs] figures``, else png, pdf."""
    if args.formats is not None:
        return args.formats
    config = getattr(scenario, "config", None) or {}
    figures = config.get("outputs", {}).get("figures") or ()
    return tuple(dict.fromkeys(figures)) or DEFAULT_FORMATS


def _use_agg():
    """Draw without a display (the CLI only writes files)."""
    import matplotlib

    matplotlib.use("Agg")


def _say(args, msg):
    if not getattr(args, "quiet", False):
        print(msg)


def _run_one(scenario, out_dir, args, samples=None, *, experiments=None, formats=None):
    """Run `scenario` into `out_dir`: results, capture speeds and, unless
    ``--no-figures``, the figures in `formats`. `experiments` is the scenario's
    experiments table, read before the run (None: none)."""
    from ._files import atomic_write
    from .engine.montecarlo import run

    if args.scheduler is not None and args.backend != "dask":
        raise InputError(
            f"{args.scheduler!r} needs --backend dask", field="--scheduler"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    ck = out_dir / CHECKPOINT_NAME
    try:
        result = run(
            scenario,
            samples=samples,
            seed=getattr(args, "seed", None),
            workers=args.workers,
            backend=args.backend,
            address=args.scheduler,
            checkpoint=ck,
            progress=False if args.quiet else None,
        )
    except InputError as err:
        if err.field != "address":
            raise
        raise InputError(err.message, field="--scheduler") from None
    result.to_files(out_dir)
    atomic_write(
        out_dir / "capture_speed.csv",
        lambda t: result.capture_speed().to_csv(t, index=False),
    )
    figures = []
    if not getattr(args, "no_figures", False):
        _use_agg()
        from .plotting.results import figures_for_result, save_figures
        from .report import input_figures

        formats = formats or DEFAULT_FORMATS
        figures = figures_for_result(
            result, out_dir, formats=formats, experiments=experiments
        )
        # Fig. 2 (diameters) and Fig. 4 (roughness angles)
        figures += save_figures(
            [(name, fig) for name, _caption, fig in input_figures(result)],
            out_dir,
            formats,
        )
    ck.unlink(missing_ok=True)
    return result, figures


def _print_capture(result):
    cs = result.capture_speed()
    for _, r in cs.dropna(subset=["speed_m_s"]).iterrows():
        print(
            f"  {r['surface']}, {r['angle_deg']:g} deg: {r['quantile']:.0%} capture at "
            f"{r['speed_m_s']:.3f} m/s [{r['speed_ci_low']:.3f}, "
            f"{r['speed_ci_high']:.3f}]"
        )


# ----------------------------------------------------------------- commands
def _write_outputs(out, *, tables=None, texts=None, figures=None):
    """Write tables (CSV), texts and figures (PNG + PDF) to `out`, each atomically.

    `figures` maps a file stem to a zero-argument function that draws and returns
    an Axes; matplotlib is imported (with the Agg backend) only when needed.
    """
    from ._files import atomic_write

    out.mkdir(parents=True, exist_ok=True)
    for name, table in (tables or {}).items():
        atomic_write(out / name, lambda t, df=table: df.to_csv(t, index=False))
    for name, text in (texts or {}).items():
        atomic_write(out / name, lambda t, x=text: Path(t).write_text(x))
    if figures:
        _use_agg()
        from .plotting.results import save_figures

        save_figures(figures.items(), out, ("png", "pdf"))
    print(f"-> {out}")


def cmd_run(args):
    from dataclasses import replace

    from .io.experiments import scenario_experiments
    from .report import write_report
    from .scenario import Precision

    scenario = _load_scenario(args.scenario)
    if args.precision is not None:
        if args.samples is not None:
            raise InputError(
                "give either --samples or --precision, not both", field="--precision"
            )
        precision = scenario.precision or Precision()
        scenario = scenario.with_options(
            precision=replace(precision, half_width=args.precision), sampling="mc"
        )
    experiments = scenario_experiments(scenario)  # checked before any output
    t0 = time.perf_counter()
    result, figures = _run_one(
        scenario,
        args.out,
        args,
        samples=args.samples,
        experiments=experiments,
        formats=_figure_formats(args, scenario),
    )
    write_report(
        [result],
        args.out / "report.html",
        extra_figures={scenario.name: figures},
        experiments={scenario.name: experiments},
        csv_paths=[args.out / "summary.csv"],
    )
    _say(
        args,
        f"{scenario.name}: {len(result.summary)} sweep points, "
        f"seed entropy {result.seed_entropy}, "
        f"{time.perf_counter() - t0:.1f} s -> {args.out}",
    )
    if not args.quiet:
        _print_capture(result)
    return EXIT_OK


def cmd_reproduce(args):
    from .config import PRESETS, load_preset
    from .io.experiments import scenario_experiments
    from .report import write_report

    samples = args.samples or (1000 if args.quick else None)
    results, figures = [], {}
    scenarios = {name: load_preset(name) for name in PRESETS}
    experiments = {  # checked before any output
        sc.name: scenario_experiments(sc) for sc in scenarios.values()
    }
    t0 = time.perf_counter()
    for name, scenario in scenarios.items():
        result, figs = _run_one(
            scenario,
            args.out / name,
            args,
            samples=samples,
            experiments=experiments[scenario.name],
            formats=_figure_formats(args, scenario),
        )
        results.append(result)
        figures[scenario.name] = figs
        _say(
            args,
            f"{name}: {len(result.summary)} points, "
            f"{result.elapsed_s:.1f} s -> {args.out / name}",
        )
        if not args.quiet:
            _print_capture(result)
    path = write_report(
        results,
        args.out / "report.html",
        extra_figures=figures,
        experiments=experiments,
        csv_paths=[args.out / name / "summary.csv" for name in PRESETS],
        title="microimpact: reproducing Li, Dunn & Brach (2000)",
    )
    _say(args, f"report: {path} ({time.perf_counter() - t0:.1f} s in all)")
    return EXIT_OK


def cmd_roughness(args):
    from ._files import atomic_write
    from .io.profiles import read_profile, read_profiles
    from .plotting.roughness import plot_angle_pdf, plot_profile
    from .surface.roughness import characterise, write_angle_file
    from .units import um_to_m

    kw = {"unit": args.unit}
    if args.dx_um is not None:
        kw["dx_um"] = args.dx_um
    if len(args.profile) == 1:
        profile = read_profile(args.profile[0], **kw)
    else:
        profile = read_profiles(args.profile, **kw)
    ch = characterise(
        profile,
        contact_length=float(um_to_m(args.contact_length_um)),
        method=args.method,
    )
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    stats = _roughness_stats(ch, args)
    atomic_write(
        out / "roughness.json",
        lambda t: Path(t).write_text(json.dumps(stats, indent=2, default=str)),
    )
    write_angle_file(
        out / "angles.txt",
        ch.angles_deg,
        n=args.n_angles,
        rng=args.seed,
        metadata={
            "source": ", ".join(map(str, args.profile)),
            "contact_length_um": args.contact_length_um,
            "method": args.method,
        },
    )
    _use_agg()
    from .plotting.results import save_figures

    save_figures([("angle_pdf", lambda: plot_angle_pdf(ch))], out, ("png", "pdf"))
    save_figures([("profile", lambda: plot_profile(profile))], out, ("png",))
    for k, v in stats.items():
        if isinstance(v, int | float):
            print(f"  {k:>24s} = {v:.6g}")
    print(f"-> {out}")
    return EXIT_OK


def _roughness_stats(ch, args):
    """Interface-unit (µm, degrees) statistics of a RoughnessCharacterisation."""
    from .units import m_to_um, rad_to_deg

    p = ch.profile
    return {
        "sources": [str(s) for s in args.profile],
        "method": ch.method,
        "contact_length_um": float(m_to_um(ch.contact_length)),
        "n_scans": int(ch.n_scans),
        "n_angles": int(ch.n_segments),
        "angle_mean_deg": float(rad_to_deg(ch.mean_angle)),
        "angle_std_deg": float(rad_to_deg(ch.std_angle)),
        "angle_skewness": float(ch.skewness_angle),
        "angle_kurtosis": float(ch.kurtosis_angle),
        "Ra_um": float(m_to_um(p.Ra)),
        "Rq_um": float(m_to_um(p.Rq)),
        "Rsk": float(p.Rsk),
        "Rku": float(p.Rku),
        "Rdq": float(p.Rdq),
        "conditioning": ch.conditioning,
    }


@contextlib.contextmanager
def _data_of(path):
    """Report a ``ValueError`` raised while analysing the data of file `path` (too
    few values, all equal, ...) as an error of that file."""
    try:
        yield
    except ValueError as exc:
        raise DataFormatError(str(exc), source=path) from None


def cmd_sizes(args):
    from .io.diameters import read_diameters
    from .population.distributions import chi2_normality, fit_lognormal, fit_normal
    from .units import m_to_um

    column = args.column
    with contextlib.suppress(TypeError, ValueError):
        column = int(column)  # a 0-based index (negative from the end), else a name
    diameters, _meta = read_diameters(args.data, column=column, unit=args.unit)
    d_um = m_to_um(diameters)
    with _data_of(args.data):
        normal, lognormal = fit_normal(d_um), fit_lognormal(d_um)
        chi = chi2_normality(d_um, alpha=args.alpha)
    print(f"{args.data}: n = {d_um.size}")
    print(f"  normal fit     : {normal}")
    print(f"  log-normal fit : {lognormal}")
    print(
        f"  chi-squared    : statistic {chi.statistic:.3f}, dof {chi.dof}, "
        f"p = {chi.pvalue:.4g} -> {chi.decision} (alpha {args.alpha})"
    )
    if args.out is not None:
        from .plotting.sizes import plot_size_distribution

        report = {
            "n": int(d_um.size),
            "normal": str(normal),
            "lognormal": str(lognormal),
            "chi2": {
                "statistic": chi.statistic,
                "dof": chi.dof,
                "pvalue": chi.pvalue,
                "reject": bool(chi.reject),
                "decision": chi.decision,
                "alpha": args.alpha,
            },
        }
        _write_outputs(
            args.out,
            texts={"sizes.json": json.dumps(report, indent=2, default=str)},
            figures={
                "size_distribution": lambda: plot_size_distribution(
                    d_um, fit=getattr(normal, "distribution", None)
                )
            },
        )
    return EXIT_OK


def cmd_fit(args):
    from .io.impact_data import read_impact_data
    from .physics.fitting import fit_coefficient_laws, fit_impact_coefficients

    data = read_impact_data(args.data)
    with _data_of(args.data):
        table = fit_impact_coefficients(
            data["diameter"].to_numpy(), data["v_n"].to_numpy(), data["e"].to_numpy()
        )
        laws = fit_coefficient_laws(table, form=args.form)
    print(table.to_string(index=False))
    print(json.dumps(laws.describe(), indent=2, default=str))
    if args.out is not None:
        _write_outputs(
            args.out,
            tables={"coefficients_by_diameter.csv": table},
            texts={
                "coefficient_laws.json": json.dumps(
                    laws.describe(), indent=2, default=str
                )
            },
        )
    return EXIT_OK


def cmd_convergence(args):
    from .engine.convergence import convergence_study
    from .engine.montecarlo import run

    scenario = _load_scenario(args.scenario)
    point = args.point
    n_points = (
        len(scenario.surfaces) * len(scenario.speeds_m_s) * len(scenario.angles_deg)
    )
    if point is None:  # the point nearest 50 % capture in a quick pilot
        pilot = run(scenario, samples=1000, seed=args.seed, progress=False).summary
        point = int((pilot["capture_fraction"] - 0.5).abs().to_numpy().argmin())
    elif point >= n_points:
        raise InputError(
            f"must be < {n_points} (the number of sweep points)", field="--point"
        )
    res = convergence_study(
        scenario,
        point=point,
        n_max=args.n_max,
        tolerance=args.tolerance,
        seed=args.seed,
    )
    pt = res.point
    print(
        f"{scenario.name}: point {point} ({pt['surface']}, {pt['speed_m_s']} m/s, "
        f"{pt['angle_deg']} deg)"
    )
    print(f"  capture fraction after {args.n_max} impacts: {res.final:.4f}")
    print(f"  settled within +-{res.tolerance:.3f} after N = {res.n_settled}")
    print(
        f"  N for a {res.confidence:.0%} half-width of {res.tolerance:.3f}: "
        f"{res.n_required} (worst case {res.n_required_worst_case})"
    )
    if args.out is not None:
        from .plotting.results import plot_convergence

        _write_outputs(
            args.out,
            tables={"convergence.csv": res.table},
            figures={"convergence": lambda: plot_convergence(res)},
        )
    return EXIT_OK


def _read_results(path: Path):
    import pandas as pd

    if path.is_dir():
        path = path / "summary.csv"
    if not path.exists():
        raise InputError(
            "no such results file (give summary.csv, results.nc or a run folder)",
            source=path,
        )
    if path.suffix == ".nc":
        import xarray as xr

        with xr.open_dataset(path) as ds:
            dims = ["surface", "speed_m_s", "angle_deg"]
            keep = [v for v in ds.data_vars if set(ds[v].dims) == set(dims)]
            return ds[keep].to_dataframe().reset_index()
    try:
        return pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise InputError(f"cannot read results: {err}", source=path) from None


def cmd_compare(args):
    from .compare import compare, plot_comparison
    from .io.experiments import read_experiments

    summary = _read_results(args.results)
    exp = read_experiments(args.experiment)
    table = compare(summary, exp, confidence=args.confidence)
    print(table.to_string(index=False))
    n_agree = int(table["agree"].sum())
    print(
        f"{n_agree} of {len(table)} points agree at the "
        f"{args.confidence:.0%} confidence level"
    )
    if args.out is not None:
        _write_outputs(
            args.out,
            tables={"comparison.csv": table},
            figures={"comparison": lambda: plot_comparison(table)},
        )
    return EXIT_OK


def cmd_presets(args):
    from .config import PRESETS, load_preset

    for name in PRESETS:
        sc = load_preset(name)
        print(f"{name:28s} {sc.description}")
    return EXIT_OK


COMMANDS = {
    "run": cmd_run,
    "reproduce": cmd_reproduce,
    "roughness": cmd_roughness,
    "sizes": cmd_sizes,
    "fit": cmd_fit,
    "convergence": cmd_convergence,
    "compare": cmd_compare,
    "presets": cmd_presets,
}


def _warning_printer(command):
    """A ``warnings.showwarning`` that prints one line, without the source line."""

    def show(message, category, filename, lineno, file=None, line=None):
        print(f"microimpact {command}: warning: {_one_line(message)}", file=sys.stderr)

    return show


def main(argv=None) -> int:
    """Entry point of the ``microimpact`` command; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error
        return int(exc.code or 0)
    try:
        with warnings.catch_warnings():  # restores the default printer after
            warnings.showwarning = _warning_printer(args.command)
            return COMMANDS[args.command](args)
    except InputError as err:
        print(f"microimpact {args.command}: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_USER
    except (
        ValueError,
        TypeError,
        FileNotFoundError,
        IsADirectoryError,
        PermissionError,
    ) as err:
        if os.environ.get("MICROIMPACT_DEBUG"):
            raise
        print(f"microimpact {args.command}: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print(
            "interrupted; finished work is kept in the checkpoint and a re-run "
            "resumes it",
            file=sys.stderr,
        )
        return 130
    except Exception as err:  # an internal error: say so, keep it short
        if os.environ.get("MICROIMPACT_DEBUG"):
            raise
        print(
            f"microimpact {args.command}: internal error: "
            f"{type(err).__name__}: {_one_line(err)} (set MICROIMPACT_DEBUG=1 for the "
            "traceback and please report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
