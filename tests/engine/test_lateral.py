"""The lateral statistics (issue 14, part 2b): the folded lateral angle
psi_f = atan2(V_b, |V_t|) over rebounds, accumulated, summarised and stored.

Oracles, each independent of the accumulating code:

* the per-impact arrays of ``simulate_block(store=True)`` (the lateral angle psi of
  :func:`microimpact.apparent_rebound`, tested there), folded by hand and reduced
  with NumPy (``np.mean``, ``np.std``, ``np.histogram``);
* profile and smooth surfaces: exactly 0, on both kernels, bit for bit alike;
* mirror symmetry of the isotropic areal preset surface: mean within k SE of 0;
* the scalar per-point oracle :func:`microimpact.engine.statistics.point_row`.
"""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, correlated_areal_angles, rough, scenario
from numpy.testing import assert_allclose, assert_array_equal

import microimpact as mi
from microimpact.engine import checkpoint as ckpt
from microimpact.engine import kernel
from microimpact.engine.accumulators import (
    LATERAL_BINS,
    LATERAL_EDGES,
    LATERAL_ZERO_BIN,
    Moments,
    PointAccumulator,
    folded_lateral_deg,
    lateral_histogram_counts,
)
from microimpact.engine.dataset import LATERAL_VARIABLES
from microimpact.engine.kernel import simulate_block
from microimpact.engine.montecarlo import build_plan, run
from microimpact.engine.statistics import point_row
from microimpact.scenario.scenario import SurfaceVariant

K = 4.0


def _areal(n=600, seed=5, std_par=18.0, std_perp=14.0, rho=0.3):
    return correlated_areal_angles(n, seed, std_par, std_perp, rho)


def _areal_scenario(**kw):
    base = dict(
        surfaces=(SurfaceVariant("areal", _areal()),),
        speeds_m_s=(0.3, 1.0),
        angles_deg=(25.0, 60.0),
        coefficients=PowerCoefficients(friction=0.2, vc_ref=0.05),
        speed_spread=0.1,
    )
    base.update(kw)
    return scenario(**base)


def _oracle(s):
    """psi_f of the rebounds of per-impact arrays `s` (folded by hand)."""
    psi = s["lateral_angle_deg"][~s["captured"] & ~s["shadowed"]]
    assert not np.isnan(psi).any()
    back = np.abs(psi) > 90.0
    return np.where(back, np.sign(psi) * 180.0 - psi, psi)


# ----------------------------------------------------------------- definition
def test_folding():
    psi = np.array([0.0, 180.0, 10.0, -10.0, 170.0, -170.0, 90.0, -90.0, 95.0])
    assert_array_equal(folded_lateral_deg(psi), [0, 0, 10, -10, 10, -10, 90, -90, 85])
    assert not np.signbit(folded_lateral_deg(np.array([180.0, -0.0]))).any()
    h = lateral_histogram_counts(np.array([90.0, -90.0, 0.0, 89.75]))
    assert h.size == LATERAL_BINS and h[0] == h[-1] == 0  # the last edge inclusive
    assert h[-2] == 2 and h[1] == 1 and h[LATERAL_ZERO_BIN] == 1


# ------------------------------------------------------- against the impacts
@pytest.mark.parametrize("shadowing", ["reject", "weighted", "none"])
@pytest.mark.parametrize("point", [0, 1, 3])
def test_accumulator_equals_the_per_impact_oracle(shadowing, point):
    plan = build_plan(_areal_scenario(shadowing=shadowing), kernel="numpy")
    n = 20_000
    acc = simulate_block(plan, point, 0, 0, n)
    s = simulate_block(plan, point, 0, 0, n, store=True)
    psi = _oracle(s)
    assert acc.lateral.n == psi.size == acc.rebounds == acc.e.n
    assert 0 < acc.captured < acc.impacts  # captures are excluded, not zeros
    assert np.std(psi) > 2.0 and np.any(np.abs(s["lateral_angle_deg"]) > 90)
    assert_allclose(acc.lateral.mean, psi.mean(), rtol=1e-9, atol=1e-12)
    assert_allclose(acc.lateral.std, np.std(psi, ddof=1), rtol=1e-9)
    assert_allclose(
        acc.lateral.m3, np.sum((psi - psi.mean()) ** 3), rtol=1e-6, atol=1e-6
    )
    h = acc.lateral_hist
    assert h[0] == h[-1] == 0
    assert_array_equal(h[1:-1], np.histogram(psi, LATERAL_EDGES)[0])


def test_profile_and_smooth_surfaces_are_exactly_zero_on_both_kernels():
    sc = scenario(
        surfaces=(rough(15.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.2, 1.0),
        angles_deg=(30.0, 75.0),
        coefficients=PowerCoefficients(friction=0.2, vc_ref=0.05),
    )
    kernels = ["numpy"] + (["compiled"] if kernel.KERNEL == "compiled" else [])
    accs = {}
    for k in kernels:
        plan = build_plan(sc, kernel=k)
        accs[k] = [
            kernel.simulate_specs(plan, [(p, 0, 0, 5000)])[0]
            for p in range(len(plan.points))
        ]
        for acc in accs[k]:
            assert acc.rebounds > 0
            assert acc.lateral == Moments(acc.rebounds, 0.0, 0.0, 0.0)
            assert np.flatnonzero(acc.lateral_hist).tolist() == [LATERAL_ZERO_BIN]
    if len(kernels) == 2:
        assert accs["numpy"] == accs["compiled"]
    res = run(sc, samples=3000)
    s = res.summary
    for col in LATERAL_VARIABLES:
        if col in ("lateral_se_deg", "lateral_ci_low_deg", "lateral_ci_high_deg"):
            assert (s[col] == 0.0).all(), col
        else:
            assert (s[col] == 0.0).all(), col
    assert res.dataset["surface_is_areal"].values.tolist() == [0, 0]


# ------------------------------------------------------------------ merging
def test_merge_is_associative_and_equals_one_pass():
    plan = build_plan(_areal_scenario(), kernel="numpy")
    blocks = [simulate_block(plan, 2, 0, b, 3000) for b in range(3)]
    a, b, c = blocks
    left, right = a.merge(b).merge(c), a.merge(b.merge(c))
    assert left.lateral.n == right.lateral.n
    assert_array_equal(left.lateral_hist, right.lateral_hist)
    for x, y in (
        (left.lateral.mean, right.lateral.mean),
        (left.lateral.m2, right.lateral.m2),
    ):
        assert_allclose(x, y, rtol=1e-12)
    psi = np.concatenate(
        [_oracle(simulate_block(plan, 2, 0, b, 3000, store=True)) for b in range(3)]
    )
    assert left.lateral.n == psi.size
    assert_allclose(left.lateral.mean, psi.mean(), rtol=1e-9, atol=1e-12)
    assert_allclose(left.lateral.m2, np.sum((psi - psi.mean()) ** 2), rtol=1e-9)
    assert_array_equal(left.lateral_hist[1:-1], np.histogram(psi, LATERAL_EDGES)[0])


# ------------------------------------------------------------ the summary
@pytest.fixture(scope="module")
def areal_result():
    sc = _areal_scenario(
        surfaces=(SurfaceVariant("areal", _areal()), rough(15.0)),
    )
    return run(sc, samples=6000)


def test_summary_equals_the_point_row_oracle(areal_result):
    s = areal_result.summary
    conf = areal_result.confidence
    for i, acc in areal_result.accumulators.items():
        row = point_row(acc, conf)
        for key in LATERAL_VARIABLES:
            assert np.array_equal(
                np.float64(row[key]), np.float64(s.loc[i, key]), equal_nan=True
            ), key
    # the lateral columns, then the heavy-tail columns added after them (issue 25)
    from microimpact.engine.dataset import TAIL_VARIABLES

    lat = list(s.columns[-len(LATERAL_VARIABLES) - len(TAIL_VARIABLES) :])
    assert lat == list(LATERAL_VARIABLES) + list(TAIL_VARIABLES)
    areal = s[s["surface"] == "areal"]
    assert (areal["lateral_std_deg"] > 1.0).all()
    assert (areal["lateral_p05_deg"] < 0).all() and (areal["lateral_p95_deg"] > 0).all()
    ds = areal_result.dataset
    assert ds["surface_is_areal"].values.tolist() == [1, 0]
    assert ds["lateral_mean_deg"].attrs["units"] == "degree"
    assert ds["lateral_hist"].dims[-1] == "lateral_bin"
    assert ds["lateral_bin"].attrs["bounds"] == "lateral_bin_bounds"
    for p in range(len(areal_result.accumulators)):
        counts, edges = areal_result.histogram(p, "lateral")
        assert_array_equal(counts, areal_result.accumulators[p].lateral_hist[1:-1])
        assert edges is LATERAL_EDGES


def test_ragged_layout_reads_back(monkeypatch, areal_result):
    from microimpact.engine import dataset

    monkeypatch.setattr(dataset, "DENSE_HISTOGRAM_CELLS", 1)
    res = run(
        _areal_scenario(surfaces=(SurfaceVariant("areal", _areal()), rough(15.0))),
        samples=6000,
    )
    assert res.dataset.attrs["histograms"] == "ragged"
    assert "lateral_hist_counts" in res.dataset
    for p in range(len(res.accumulators)):
        assert_array_equal(
            res.histogram(p, "lateral")[0], areal_result.histogram(p, "lateral")[0]
        )


def test_mirror_symmetry_of_the_isotropic_preset_surface():
    from microimpact.scenario.scenario import load_preset

    sc = load_preset("sst76-formica-areal")
    import dataclasses

    sc = dataclasses.replace(
        sc,
        surfaces=tuple(s for s in sc.surfaces if s.name == "formica-areal"),
        angles_deg=(20.0, 45.0, 70.0),
    )
    res = run(sc, samples=20_000)
    s = res.summary
    assert (s["lateral_std_deg"] > 3.0).all()
    assert (s["lateral_mean_deg"].abs() < K * s["lateral_se_deg"]).all()
    # and the median within a bin or two of 0
    assert (s["lateral_p50_deg"].abs() < 1.0).all()


# ------------------------------------------------------- files and checkpoints
def test_old_results_file_loads_with_nan_lateral_columns(tmp_path, areal_result):
    ds = areal_result.dataset
    drop = [
        v
        for v in ds.variables
        if str(v).startswith("lateral") or v == "surface_is_areal"
    ]
    old = ds.drop_vars(drop)
    old.attrs.pop("lateral_edges")
    assert not any("lateral" in str(v) for v in old.variables)
    path = tmp_path / "results.nc"
    old.to_netcdf(path, engine="netcdf4")
    back = mi.open_result(tmp_path)
    s = back.summary
    for col in LATERAL_VARIABLES:
        assert s[col].isna().all(), col
    keep = [c for c in s.columns if c not in LATERAL_VARIABLES and c != "surface"]
    new = areal_result.summary
    assert_array_equal(s[keep].to_numpy(), new[keep].to_numpy())
    assert [x.areal for x in back.scenario.surfaces] == [False, False]
    with pytest.raises(ValueError, match="no lateral histogram"):
        back.histogram(0, "lateral")
    # and a fresh file round-trips the lateral columns
    areal_result.to_files(tmp_path / "new")
    again = mi.open_result(tmp_path / "new")
    assert_array_equal(
        again.summary[list(LATERAL_VARIABLES)].to_numpy(),
        new[list(LATERAL_VARIABLES)].to_numpy(),
    )
    assert [x.areal for x in again.scenario.surfaces] == [True, False]


def test_checkpoint_round_trip_keeps_the_lateral_state(tmp_path):
    plan = build_plan(_areal_scenario(), kernel="numpy")
    state = {
        (p, 0): (
            2,
            simulate_block(plan, p, 0, 0, 4000).merge(
                simulate_block(plan, p, 0, 1, 4000)
            ),
        )
        for p in range(4)
    }
    state[(4, 0)] = (1, PointAccumulator(n=3, captured=3))
    fp = {"seed": "1", "samples": "s", "scenario": "x"}
    ckpt.save(tmp_path / "c.npz", fp, state)
    back = ckpt.load(tmp_path / "c.npz", fp)
    for k, (nxt, acc) in state.items():
        assert back[k][0] == nxt and back[k][1] == acc
        assert back[k][1].lateral == acc.lateral
        assert_array_equal(back[k][1].lateral_hist, acc.lateral_hist)


def test_format_2_checkpoint_is_reported_not_misread(tmp_path):
    """A checkpoint written before the lateral state (format 2) is stale."""
    fp = {"seed": "1", "samples": "s", "scenario": "x"}
    path = tmp_path / "c.npz"
    ckpt.save(path, fp, {(0, 0): (1, PointAccumulator(n=5))})
    with zipfile.ZipFile(path) as z:
        members = {i.filename: z.read(i) for i in z.infolist()}
    with zipfile.ZipFile(path, "w") as z:
        for name, data in members.items():
            if name == "format_version.npy":
                import io

                buf = io.BytesIO()
                np.lib.format.write_array(buf, np.array(2))
                data = buf.getvalue()
            z.writestr(name, data)
    with pytest.raises(ckpt.CheckpointMismatch) as info:
        ckpt.load(path, fp)
    assert info.value.reason == "format" and "format 2" in str(info.value)


# ------------------------------------------------------------ figure and report
def test_profile_vs_areal_figure_and_report(tmp_path, areal_result):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from microimpact.pipeline.figures import figures_for_result, result_figures
    from microimpact.pipeline.report import write_report
    from microimpact.plotting.areal import plot_profile_vs_areal

    paths = figures_for_result(areal_result, tmp_path, formats=("png",))
    assert tmp_path / "profile_vs_areal.png" in paths
    axs = plot_profile_vs_areal(areal_result)
    assert len(axs) == 4
    lateral = axs[3].get_lines()
    assert len(lateral) == 2 and np.all(lateral[1].get_ydata() == 0.0)  # profile
    plt.close("all")
    # a result read back from its file knows its areal surface structurally
    areal_result.to_files(tmp_path / "run")
    back = mi.open_result(tmp_path / "run")
    stems = [stem for stem, _, f in result_figures(back)]
    plt.close("all")
    assert "profile_vs_areal" in stems
    report = write_report(back, tmp_path / "report.html")
    html = report.read_text()
    assert "Profile versus areal roughness" in html and "not in the paper" in html


def test_no_profile_vs_areal_figure_without_an_areal_surface():
    import matplotlib.pyplot as plt

    from microimpact.pipeline.figures import result_figures
    from microimpact.plotting.areal import plot_profile_vs_areal

    res = run(scenario(surfaces=(rough(10.0),), angles_deg=(30.0, 60.0)), samples=500)
    assert "profile_vs_areal" not in [s for s, _, _ in result_figures(res)]
    plt.close("all")
    with pytest.raises(ValueError, match="no areal surface"):
        plot_profile_vs_areal(res)
