"""The performance benchmark ``benchmarks/run.py``: it runs end to end (``--smoke``),
writes every documented key, and its plain-NumPy baseline computes the same physics
as the engine (both checked against an independent quadrature of the exact
expectation). No timing is asserted."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, stats

import microimpact as mi

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "run.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("microimpact_bench_run", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def angles(bench):
    return bench.formica_angles()


def test_smoke_writes_every_key(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--smoke", "--json", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    data = json.loads(out.read_text())
    dask_missing = importlib.util.find_spec("dask") is None
    for key in (
        "rng_floor_per_s",
        "numpy_baseline_per_s",
        "engine_per_s",
        "engine_all_cores_per_s",
        "dask_per_s",
        "peak_rss_mb",
        "qmc_error_ratio",
        "rng_floor_classic_per_s",
        "grid_per_s",
        "grid_all_cores_per_s",
        "grid_ratio",
        "wall_law_build_s",
        "wall_law_per_s",
    ):
        assert key in data, key
        if key == "dask_per_s" and dask_missing:
            assert data[key] is None
            continue
        value = data[key]
        assert isinstance(value, int | float) and math.isfinite(value), (key, value)
        assert value > 0, (key, value)
    assert data["peak_rss_mb_by_n"]
    assert all(v > 0 for v in data["peak_rss_mb_by_n"].values())
    assert data["peak_rss_mb"] == max(data["peak_rss_mb_by_n"].values())
    # no temporary file left beside the JSON (atomic write)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench.json"]
    assert "variant" in proc.stdout and "M/s" in proc.stdout


def test_reference_capture_fraction_is_the_closed_form(bench, angles):
    """The quadrature's capture fraction against scipy's truncated normal CDF."""
    _, raw = angles
    theta = np.deg2rad(bench.ANGLE_DEG)
    phi = raw[raw < theta]
    u = bench.SPEED * np.sin(theta - phi)
    d_star = bench.D_REF_UM * 1e-6 * (u / bench.VC_A) ** (1.0 / bench.EXPONENT)
    mean, std = bench.MEAN_UM * 1e-6, bench.STD_UM * 1e-6
    dist = stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std)
    expected = dist.cdf(d_star).mean()
    ref = bench.reference_values(raw, nodes=256)
    assert_allclose(ref["capture_fraction"], expected, rtol=1e-12)


def test_reference_e_mean_matches_adaptive_quadrature(bench):
    """Midpoint quadrature of E[e_m] against scipy.integrate.quad of the reference
    physics (microimpact.apparent_rebound) over diameter, for a few angles."""
    mean, std = bench.MEAN_UM * 1e-6, bench.STD_UM * 1e-6
    dist = stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std)
    d_ref = bench.D_REF_UM * 1e-6
    phis = np.array([-0.4, -0.1, 0.0, 0.2, 0.45])  # [rad], all < 30 deg
    expected = []
    for phi in phis:

        def integrand(d, phi=phi):
            r = mi.apparent_rebound(
                bench.SPEED,
                bench.ANGLE_DEG,
                np.rad2deg(phi),
                k1=bench.K1,
                k2=bench.K2_A * (d / d_ref) ** bench.EXPONENT,
                v_c=bench.VC_A * (d / d_ref) ** bench.EXPONENT,
                friction=bench.FRICTION,
            )
            return float(r.e_m) * dist.pdf(d)

        u = bench.SPEED * np.sin(np.deg2rad(bench.ANGLE_DEG) - phi)
        d_star = d_ref * (u / bench.VC_A) ** (1.0 / bench.EXPONENT)
        val, _ = integrate.quad(integrand, d_star, mean + 12 * std, limit=200)
        expected.append(val)
    got = [bench.reference_values(np.array([p]))["e_mean"] for p in phis]
    assert_allclose(got, expected, rtol=0, atol=2e-7)


def test_numpy_baseline_agrees_with_engine(bench, angles):
    """Same physics: NumPy baseline and engine agree within 5 standard errors, and
    each agrees with the quadrature of the exact expectation."""
    dist, raw = angles
    n = 1 << 17
    base = bench.numpy_baseline(n, raw, rng=np.random.default_rng(7))
    result = mi.run(bench.make_scenario(dist), samples=n, seed=11, progress=False)
    eng = bench._summary_stats(result)
    z = bench.agreement(base, eng)
    assert abs(z["z_e_mean"]) < 5, z
    assert abs(z["z_capture_fraction"]) < 5, z
    ref = bench.reference_values(raw)
    for est in (base, eng):
        p = ref["capture_fraction"]
        assert abs(est["e_mean"] - ref["e_mean"]) < 5 * est["e_se"]
        assert abs(est["capture_fraction"] - p) < 5 * math.sqrt(p * (1 - p) / n)
    # the histogram of rebounds counts every rebound (all fall in [-1, 3] here)
    rebounds = round(n * (1 - base["capture_fraction"]))
    assert base["e_hist"].sum() == rebounds
    # check_agreement raises on a real disagreement
    shifted = dict(eng, e_mean=eng["e_mean"] + 10 * eng["e_se"])
    with pytest.raises(RuntimeError, match="standard errors"):
        bench.check_agreement(base, shifted, "test")


def _gil_share_module():
    path = ROOT / "benchmarks" / "gil_share.py"
    spec = importlib.util.spec_from_file_location("microimpact_bench_gil", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_gil_share_pools_recordings_by_their_samples():
    """Recordings of one path pool their samples; the standard error is the
    spread between recordings over sqrt(R), written out here by hand; the
    kernel bound pools the seconds."""
    pooled = _gil_share_module().pooled

    def rec(n, held, frames, wall, released):
        return {
            "samples": n,
            "gil_samples": held,
            "gil_share": held / n,
            "gil_frames": frames,
            "wall_s": wall,
            "released_s": released,
            "kernel_bound": 1 - released / wall,
        }

    recs = [
        rec(1000, 20, [["a", 3]], 2.0, 1.96),
        rec(500, 20, [["a", 1]], 1.0, 0.97),
        rec(1500, 45, [["b", 9]], 3.0, 2.97),
    ]
    row = pooled(recs)
    assert row["samples"] == 3000 and row["gil_samples"] == 85
    assert row["gil_share"] == pytest.approx(85 / 3000)
    # shares 0.02, 0.04, 0.03: mean 0.03, sample std 0.01, over sqrt(3)
    assert row["gil_share_se"] == pytest.approx(0.01 / math.sqrt(3))
    assert row["recordings"] == pytest.approx([0.02, 0.04, 0.03])
    assert row["gil_frames"] == [("b", 9), ("a", 4)]
    g = 85 / 3000
    assert row["amdahl_16"] == pytest.approx(1 / (g + (1 - g) / 16))
    # 6 s of wall time, 5.9 s of it in the kernel without the GIL
    assert row["kernel_bound"] == pytest.approx(0.1 / 6.0)
    assert row["kernel_bounds"] == pytest.approx([0.02, 0.03, 0.01])
    assert pooled(recs[:1]) is recs[0]


def test_gil_share_child_timing_line_is_read_back():
    """The timing the children print (TIMED) runs and is parsed back: the wall
    time of the calls and the kernel's GIL-free time within it."""
    gil = _gil_share_module()
    out = io.StringIO()
    code = "REPEAT = 2\ndef path():\n    sum(range(1000))\n" + gil.TIMED
    with contextlib.redirect_stdout(out):
        exec(code, {})
    wall, released = gil._released(out.getvalue())
    assert wall > 0
    assert released == 0.0 or math.isnan(released)  # no kernel call in the path
    with pytest.raises(RuntimeError, match="timing line"):
        gil._released("nothing\n")
