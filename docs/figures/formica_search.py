"""The documented search behind the shipped Formica roughness (docs/presets.md).

The synthetic Formica profile of
``src/microimpact/surface/data/make_formica_profile.py`` is Gaussian waviness
(correlation length ``ell``) plus an asymmetric saw-tooth ripple
(rise fraction ``w``, rise angle ``alpha``, orientation ``+1``: steep faces away
from the particles, ``-1``: toward them), always with a height std of 45 µm and
angles over the paper's 20 µm contact length. For each point of a grid over these
four numbers this script

1. makes the ten scans (``make_heights``, the shipped seed),
2. takes the 20 µm slope angles and draws 4,000 of them (as
   ``presets/make_preset_data.py`` does),
3. runs the ``sst76-formica-oblique`` preset on them (4,000 impacts per point,
   the preset's seed, one worker, the compiled kernel),
4. evaluates the paper's statements (:mod:`microimpact.analysis.statements`),

and writes ``formica_search.csv`` (one row per point: parameters, angle std and
skewness, the rough relative e at 10 deg, the parting angle, the e_m and mu_m
skewnesses, and each statement held or not, with by how much it misses) and
``formica_search.png`` (the trade-off). The candidates are the points that hold
"toward unity" and, among those, the most statements; each is run again at two
other engine seeds and at 40,000 impacts per point (``formica_search_confirm.csv``)
and the one holding the most in its worst run is chosen (ties: the smallest mean
total miss). It is printed, and it is what ``make_formica_profile.py`` ships. About
five minutes on one core (``--reuse-grid`` reads the grid's CSV back and only
confirms)::

    python docs/figures/formica_search.py            # the search (writes here)
    python src/microimpact/surface/data/make_formica_profile.py
    python src/microimpact/scenario/presets/make_preset_data.py
"""

from __future__ import annotations

import importlib.util
import itertools
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SRC = ROOT / "src" / "microimpact"

ELL_UM = (300.0, 450.0, 500.0, 550.0, 600.0, 800.0)
RISE_FRACTION = (0.06, 0.08, 0.09, 0.10, 0.11, 0.12)
RISE_ANGLE_DEG = (35.0, 37.5, 40.0, 42.5, 45.0)
ORIENTATION = (1, -1)
N_ANGLES = 4000
SAMPLES = 4000
#: The statements that depend on the roughness (the others do not move with it).
ROUGHNESS_STATEMENTS = (
    "angles-asymmetric",
    "rough-e-toward-unity",
    "rough-smooth-similar-above-45",
    "rough-mu-never-constant",
    "e_m-asymmetric-similar",
    "mu_m-85-symmetric",
    "mu_m-10-skewed",
)


def _load(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def angles_of(z_um, contact_length_um=20.0):
    """20 µm slope angles [deg] of scans `z_um` (rows) at the shipped spacing."""
    from microimpact.io.profiles import Profile, ProfileSet
    from microimpact.surface.roughness import surface_angles
    from microimpact.units import rad_to_deg

    mk = _load(HERE / "formica_search_recipe.py", "_mk")
    x = np.arange(z_um.shape[1]) * mk.DX_UM * 1e-6
    ps = ProfileSet(tuple(Profile(x, row * 1e-6, {}) for row in z_um))
    return rad_to_deg(
        surface_angles(ps, contact_length=contact_length_um * 1e-6, method="slope")
    )


def evaluate_point(ell, w, alpha, orientation, *, samples=SAMPLES, seed=None):
    """Statement verdicts and key numbers for one point of the grid."""
    from scipy import stats

    from microimpact.analysis.statements import Evidence, evaluate, parting_angle
    from microimpact.engine.montecarlo import run
    from microimpact.scenario import PRESET_DIR
    from microimpact.surface.roughness import write_angle_file

    mk = _load(HERE / "formica_search_recipe.py", "_mk")
    pd_ = _load(SRC / "scenario" / "presets" / "make_preset_data.py", "_pd")
    z = mk.make_heights(
        correlation_length_um=ell,
        rise_fraction=w,
        rise_angle_deg=alpha,
        orientation=orientation,
    )
    phi = angles_of(z)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        name = "sst76-formica-oblique"
        shutil.copy(PRESET_DIR / f"{name}.toml", tmp)
        shutil.copy(PRESET_DIR / "sst76_diameters.csv", tmp)
        sample = write_angle_file(
            tmp / "formica_angles_20um.csv", phi, n=N_ANGLES, rng=pd_.SEED
        )
        res = run(str(tmp / f"{name}.toml"), samples=samples, seed=seed, workers=1)
    zc = z - z.mean(axis=1, keepdims=True)
    ev = Evidence(
        summaries={name: res.summary},
        angles_deg=sample,
        height_std_um=float(np.sqrt(np.mean(zc * zc))),
        contact_length_um=20.0,
    )
    verdicts = evaluate(ev)
    r = ev.by_angle("formica")
    row = {
        "ell_um": ell,
        "rise_fraction": w,
        "rise_angle_deg": alpha,
        "orientation": orientation,
        "angle_std_deg": float(np.std(sample, ddof=1)),
        "angle_skewness": float(stats.skew(sample)),
        "e_rel_10": float(r.loc[10.0, "e_relative"]),
        "parting_angle_deg": parting_angle(ev),
        "e_skew_10": float(r.loc[10.0, "e_skewness"]),
        "e_skew_85": float(r.loc[85.0, "e_skewness"]),
        "mu_skew_10": float(r.loc[10.0, "mu_skewness"]),
        "mu_skew_85": float(r.loc[85.0, "mu_skewness"]),
    }
    held = 0
    miss = 0.0
    for sid in ROUGHNESS_STATEMENTS:
        v = verdicts[sid]
        row[sid] = bool(v.held)
        row[f"{sid}_miss"] = float(v.miss)
        held += bool(v.held)
        miss += float(v.miss)
    row["held"] = held
    row["total_miss"] = miss
    return row


#: The confirmation runs of the best points: (impacts per point, engine seed).
CONFIRM = ((4000, 12345), (4000, 777), (40000, None))


def candidates(table):
    """The points holding "toward unity" and, among those, the most statements."""
    ok = table[table["rough-e-toward-unity"]]
    if ok.empty:
        ok = table
    return ok[ok["held"] == ok["held"].max()]


def confirm(cands):
    """Each candidate again at other engine seeds and at 40,000 impacts per point
    (:data:`CONFIRM`): one row per candidate and run."""
    rows = []
    for _, c in cands.iterrows():
        for samples, seed in CONFIRM:
            r = evaluate_point(
                c["ell_um"],
                c["rise_fraction"],
                c["rise_angle_deg"],
                int(c["orientation"]),
                samples=samples,
                seed=seed,
            )
            r.update(samples=samples, seed=-1 if seed is None else seed)
            rows.append(r)
    return pd.DataFrame(rows)


def choose(table, confirmed=None):
    """The candidate (:func:`candidates`) that holds "toward unity" and the most
    statements in its worst confirmation run (ties: the smallest mean total miss);
    without confirmation runs, the candidate with the smallest total miss."""
    cands = candidates(table)
    keys = ["ell_um", "rise_fraction", "rise_angle_deg", "orientation"]
    if confirmed is None or confirmed.empty:
        return cands.sort_values("total_miss").iloc[0]
    score = (
        confirmed.assign(unity=confirmed["rough-e-toward-unity"].astype(int))
        .groupby(keys)
        .agg(unity=("unity", "min"), worst=("held", "min"), miss=("total_miss", "mean"))
    )
    best = score.sort_values(
        ["unity", "worst", "miss"], ascending=[False, False, True]
    ).index[0]
    pick = np.all([cands[k] == v for k, v in zip(keys, best, strict=True)], axis=0)
    return cands[pick].iloc[0]


def plot(table, chosen, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 2, figsize=(9.0, 3.8), constrained_layout=True)
    for o, mk in ((1, "o"), (-1, "s")):
        t = table[table["orientation"] == o]
        sc = axs[0].scatter(
            t["e_rel_10"],
            t["e_skew_10"],
            c=t["held"],
            cmap="viridis",
            vmin=0,
            vmax=len(ROUGHNESS_STATEMENTS),
            marker=mk,
            s=22,
            label="steep faces away (+1)" if o > 0 else "steep faces toward (−1)",
        )
        axs[1].scatter(
            t["angle_skewness"],
            t["mu_skew_85"],
            c=t["held"],
            cmap="viridis",
            vmin=0,
            vmax=len(ROUGHNESS_STATEMENTS),
            marker=mk,
            s=22,
        )
    for ax, (x, y) in zip(
        axs,
        (("e_rel_10", "e_skew_10"), ("angle_skewness", "mu_skew_85")),
        strict=True,
    ):
        ax.plot(chosen[x], chosen[y], "r*", ms=13, label="shipped")
    axs[0].axvspan(0.7, 1.3, color="0.9", zorder=0, label="toward unity (0.7–1.3)")
    axs[0].axhline(0, color="0.5", lw=0.6)
    axs[0].set_xlabel("rough relative e at 10°")
    axs[0].set_ylabel("e_m skewness at 10° (same sign as at 85°: < 0)")
    axs[0].legend(fontsize=7, loc="lower left")
    axs[1].axhline(0, color="0.5", lw=0.6)
    axs[1].set_xlabel("skewness of the roughness angles")
    axs[1].set_ylabel("μ_m skewness at 85°")
    fig.colorbar(sc, ax=axs, label="roughness statements held (of 7)")
    fig.suptitle("Formica search: the trade-off (4,000 impacts per point)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    grid_csv = HERE / "formica_search.csv"
    if "--reuse-grid" in argv and grid_csv.exists():  # the grid is deterministic
        table = pd.read_csv(grid_csv)
    else:
        rows = []
        grid = list(
            itertools.product(ELL_UM, RISE_FRACTION, RISE_ANGLE_DEG, ORIENTATION)
        )
        for k, (ell, w, a, o) in enumerate(grid):
            rows.append(evaluate_point(ell, w, a, o))
            print(f"{k + 1}/{len(grid)}", rows[-1]["held"], flush=True, file=sys.stderr)
        table = pd.DataFrame(rows)
        table.to_csv(grid_csv, index=False, float_format="%.4g")
    confirmed = confirm(candidates(table))
    confirmed.to_csv(
        HERE / "formica_search_confirm.csv", index=False, float_format="%.4g"
    )
    chosen = choose(table, confirmed)
    plot(table, chosen, HERE / "formica_search.png")
    print(chosen.to_string())
    return table, chosen


if __name__ == "__main__":
    main()
