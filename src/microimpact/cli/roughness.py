"""``microimpact roughness PROFILE... --out DIR``: characterise a profilometer scan."""

from __future__ import annotations

import json
from pathlib import Path

from . import _common as c

HELP = "characterise a profilometer scan (roughness angles, statistics, Fig. 4)"


def cli_parse(sp):
    from ..units import LENGTH_UNITS

    units = tuple(LENGTH_UNITS)
    sp.add_argument("profile", type=Path, nargs="+", help="profile file(s)")
    sp.add_argument("--out", required=True, type=c.out_dir)
    sp.add_argument("--contact-length-um", type=c.positive_float, default=20.0)
    sp.add_argument("--method", choices=("slope", "paper"), default="slope")
    sp.add_argument(
        "--unit",
        default="um",
        choices=units,
        metavar="UNIT",
        help=f"length unit of the data, one of {', '.join(units)} (default um)",
    )
    sp.add_argument(
        "--dx-um",
        type=c.positive_float,
        help="sampling interval when the file holds heights only",
    )
    sp.add_argument(
        "--n-angles",
        type=c.positive_int,
        default=4000,
        help="angles in the exported sample file (paper: 4,000)",
    )
    sp.add_argument("--seed", type=c.nonneg_int, default=0)


def cli_action(args) -> int:
    from .._files import atomic_write
    from ..io.profiles import read_profile, read_profiles
    from ..plotting.roughness import plot_angle_pdf, plot_profile
    from ..surface.roughness import characterise, write_angle_file
    from ..units import um_to_m

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
    c.use_agg()
    from ..plotting.results import save_figures

    save_figures([("angle_pdf", lambda: plot_angle_pdf(ch))], out, ("png", "pdf"))
    save_figures([("profile", lambda: plot_profile(profile))], out, ("png",))
    for k, v in stats.items():
        if isinstance(v, int | float):
            print(f"  {k:>24s} = {v:.6g}")
    print(f"-> {out}")
    return c.EXIT_OK


def _roughness_stats(ch, args):
    """Interface-unit (µm, degrees) statistics of a RoughnessCharacterisation."""
    from ..units import m_to_um, rad_to_deg

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
