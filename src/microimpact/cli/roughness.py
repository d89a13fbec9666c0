"""``microimpact roughness PROFILE... --out DIR``: characterise a profilometer scan."""

from __future__ import annotations

from pathlib import Path

from . import _common as c
from .sizes import column_arg

HELP = "characterise a profilometer scan (roughness angles, statistics, Fig. 4)"


def cli_parse(sp):
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..units import LENGTH_UNITS

    units = tuple(LENGTH_UNITS)
    sp.add_argument("profile", type=Path, nargs="+", help="profile file(s)")
    sp.add_argument("--out", required=True, type=c.out_dir)
    sp.add_argument("--contact-length-um", type=c.positive_float, default=20.0)
    sp.add_argument("--method", choices=("slope", "paper"), default="slope")
    sp.add_argument(
        "--detrend",
        choices=("line", "mean", "none"),
        default="line",
        help="per-scan form removal before the angles and parameters: the "
        "least-squares line (default), the mean height, or none",
    )
    sp.add_argument(
        "--cutoff-um",
        type=c.positive_float,
        default=None,
        help="ISO 16610-21 Gaussian filter cutoff [um] applied to each scan after "
        "detrending (default: no filter; needs a uniformly spaced scan)",
    )
    for flag, what in (
        ("--unit", "both columns"),
        ("--x-unit", "the positions"),
        ("--z-unit", "the heights"),
    ):
        sp.add_argument(
            flag,
            default=None,
            choices=units,
            metavar="UNIT",
            help=f"length unit of {what}, one of {', '.join(units)} (default: the "
            "unit in the file, e.g. a z_nm or 'height [nm]' column header or an "
            "instrument file's own unit; a file without a unit needs one; an explicit "
            "unit that contradicts the file is an error)",
        )
    sp.add_argument(
        "--scan-column",
        default=None,
        help="column holding the scan id (default: a column named scan or scan_id)",
    )
    sp.add_argument(
        "--dx-um",
        type=c.positive_float,
        help="sampling interval [um] when the file holds heights only (or gives no "
        "lateral size)",
    )
    sp.add_argument(
        "--n-angles",
        type=c.positive_int,
        default=4000,
        help="angles in the exported sample file (paper: 4,000)",
    )
    sp.add_argument("--seed", type=c.nonneg_int, default=0)


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.files import atomic_write

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from .._core.toml import surface_snippet

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..io.profiles import read_profiles

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting.roughness import plot_angle_pdf, plot_profile

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..surface.roughness import characterise, write_angle_file

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..units import um_to_m

    kw = {"unit": args.unit, "x_unit": args.x_unit, "z_unit": args.z_unit}
    if args.dx_um is not None:
        kw["dx_um"] = args.dx_um
    if args.scan_column is not None:
        kw["scan_column"] = column_arg(args.scan_column)
    profiles = read_profiles(args.profile, **kw)  # a file may hold several scans
    profile = profiles[0] if len(profiles) == 1 else profiles
    ch = characterise(
        profile,
        contact_length=float(um_to_m(args.contact_length_um)),
        method=args.method,
        detrend=None if args.detrend == "none" else args.detrend,
        cutoff=None if args.cutoff_um is None else float(um_to_m(args.cutoff_um)),
    )
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    first = profiles[0].metadata
    units = {
        k: first.get(k)
        for k in ("x_unit", "x_unit_from", "z_unit", "z_unit_from", "reader", "format")
    }
    text = ch.to_json(units=units)
    atomic_write(out / "roughness.json", lambda t: Path(t).write_text(text))
    write_angle_file(
        out / "angles.txt",
        ch.angles_deg,
        n=args.n_angles,
        rng=args.seed,
        metadata={
            "source": ", ".join(p.name for p in args.profile),
            "contact_length_um": args.contact_length_um,
            "method": args.method,
            "detrend": args.detrend,
            "cutoff_um": args.cutoff_um,
            "x_unit": f"{units['x_unit']} ({units['x_unit_from']})",
            "z_unit": f"{units['z_unit']} ({units['z_unit_from']})",
        },
    )
    snippet = surface_snippet(
        "angles.txt",
        name="measured",
        comment=f"roughness angles of {', '.join(p.name for p in args.profile)} "
        f"({args.method}, contact length {args.contact_length_um:g} um); the path "
        "is relative to the scenario file: copy angles.txt next to it",
    )
    atomic_write(out / "surface.toml", lambda t: Path(t).write_text(snippet))
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting._style import use_agg

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..plotting.results import save_figures

    use_agg()

    save_figures([("angle_pdf", lambda: plot_angle_pdf(ch))], out, ("png", "pdf"))
    save_figures([("profile", lambda: plot_profile(profile))], out, ("png",))
    print(ch.summary())
    print(
        f"  units: x in {units['x_unit']} ({units['x_unit_from']}), z in "
        f"{units['z_unit']} ({units['z_unit_from']}); read by {units['reader']} "
        f"({units['format']})"
    )
    print(f"-> {out}")
    return c.EXIT_OK
