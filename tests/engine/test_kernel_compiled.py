"""The compiled kernel and the NumPy kernel compute the same bits.

The compiled single-pass kernel (``engine/_ckernel.c``) exists only for speed; the
NumPy kernel is the readable form (and the fallback where no C compiler was there at
install time). With p = q = 1
they perform the same IEEE operations in the same order, so every count, histogram
and moment must agree exactly; with general p, q they may differ by the last bit of
``pow`` and agree to round-off.
"""

import dataclasses
import time

import numpy as np
import pytest
from engine_helpers import PowerCoefficients, rough, scenario
from numpy.testing import assert_allclose, assert_array_equal

from microimpact import SurfaceVariant
from microimpact._core.tables import CellTable
from microimpact.engine import kernel
from microimpact.engine.plan import Sampler, build_plan, resolve_kernel
from microimpact.errors import InputError
from microimpact.population.distributions import (
    empirical_diameters,
    histogram_diameters,
)
from microimpact.surface.angles import angles_from_sample

pytestmark = pytest.mark.skipif(
    kernel.KERNEL != "compiled", reason="the compiled kernel is not built"
)


@pytest.fixture(params=[True, False], ids=["simd", "scalar"])
def simd(request):
    """Run with the AVX-512 lookups of the compiled kernel, then with its scalar
    ones (the same bits; the first is skipped on a CPU without AVX-512)."""
    ck = kernel._ckernel()
    if not ck.simd(True) and request.param:
        pytest.skip("no AVX-512 lookups on this CPU")
    ck.simd(request.param)
    yield request.param
    ck.simd(True)


def _both(plan, point, block=3, n=30_000):
    fused = kernel.simulate_block(plan, point, 0, block, n)
    plain = kernel.simulate_block(
        dataclasses.replace(plan, kernel="numpy"), point, 0, block, n
    )
    return fused.to_arrays(), plain.to_arrays()


def _assert_same_bits(plan, points=None, block=3, n=30_000):
    """Every array of the compiled kernel's accumulator equals the NumPy kernel's,
    at each of `points` (default: every sweep point)."""
    for point in range(len(plan.points)) if points is None else points:
        a, b = _both(plan, point, block=block, n=n)
        for key in a:
            assert_array_equal(a[key], b[key], err_msg=f"{key} at point {point}")


@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
@pytest.mark.parametrize("friction", [0.15, np.inf])
def test_bit_identical_for_p_q_one(shadowing, friction, simd):
    sc = scenario(
        coefficients=PowerCoefficients(friction=friction),
        surfaces=(rough(15.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.3,),
        angles_deg=(20.0, 90.0),
        shadowing=shadowing,
        speed_spread=0.1,
    )
    _assert_same_bits(build_plan(sc))


def test_general_exponents_agree_to_round_off():
    sc = scenario(
        coefficients=PowerCoefficients(p=1.3, q=0.7, friction=0.2),
        surfaces=(rough(12.0),),
        speeds_m_s=(0.4,),
        angles_deg=(35.0,),
    )
    a, b = _both(build_plan(sc), 0)
    assert_array_equal(a["counts"], b["counts"])
    assert_allclose(a["e"], b["e"], rtol=1e-12)
    assert_allclose(a["mu"], b["mu"], rtol=1e-12)
    assert np.abs(a["e_hist"] - b["e_hist"]).sum() <= 2


def test_bit_identical_for_every_kind_of_table(simd):
    # discrete (equal cells), histogram (guide search), the refined grid, discrete
    # angles with every shadowing, continuous angles 'weighted' (a guide search)
    rng = np.random.default_rng(3)
    emp = SurfaceVariant("emp", angles_from_sample(rng.normal(2.0, 12.0, 3000)))
    for particles in (
        empirical_diameters(rng.lognormal(3.9, 0.3, 4000)),
        histogram_diameters([10.0, 30.0, 50.0, 80.0, 120.0], [1, 5, 3, 1]),
    ):
        for shadowing in ("reject", "weighted", "none"):
            sc = scenario(
                particles=particles,
                surfaces=(emp, rough(9.0)),
                speeds_m_s=(0.25,),
                angles_deg=(15.0, 60.0),
                shadowing=shadowing,
                speed_spread=0.05,
            )
            _assert_same_bits(build_plan(sc), n=5000)


@pytest.mark.parametrize("n", [0, 1, 255, 256, 257, 1000])
def test_bit_identical_at_chunk_edges(n, simd):
    # a block shorter than, equal to and just past one inner chunk (256 impacts)
    sc = scenario(surfaces=(rough(15.0),), speeds_m_s=(0.3,), angles_deg=(30.0,))
    _assert_same_bits(build_plan(sc), [0], block=0, n=n)


def test_qmc_bit_identical(simd):
    # QMC indices arrive unshifted (shift 0), so the kernel checks their range
    sc = scenario(
        surfaces=(rough(15.0),), speeds_m_s=(0.3,), angles_deg=(30.0,), sampling="qmc"
    )
    _assert_same_bits(build_plan(sc), [0], block=0, n=4096)


def _sampler(values, columns=3):
    one = (np.asarray(values, float), np.asarray(values, float))
    sampler = Sampler.of(CellTable.from_atoms(values), one, *([one] * columns))
    return kernel._sampler_args(sampler)


def _block_args(**over):
    """Arguments of a valid 4-impact call of ``_ckernel.block`` (smooth surface)."""
    n = 4
    one = kernel._sampler_args(None)
    d = Sampler.of(
        CellTable.from_atoms([1.0, 2.0, 3.0, 4.0]),
        ([1.0, 2, 3, 4], [1.0, 2, 3, 4]),
        ([1.0] * 4, [1.0] * 4),  # 1/k1
        ([1.0] * 4, [1.0] * 4),  # 1/k2
        ([0.1] * 4, [0.1] * 4),  # v_c
    )
    args = dict(
        i_d=(np.arange(n, dtype=np.uint64) << np.uint64(62)),
        i_a=np.zeros(1, np.uint64),
        i_s=np.zeros(1, np.uint64),
        i_p=np.zeros(1, np.uint64),
        n=n,
        angle_random=False,
        speed_random=False,
        dsamp=kernel._sampler_args(d),
        asamp=one,
        cut=0,
        psamp=one,
        pair_total=0,
        pair_shift=0,
        ssamp=one,
        sin_theta=1.0,
        cos_theta=0.0,
        speed=1.0,
        p=1.0,
        q=1.0,
        friction=0.2,
        shadow_none=False,
        hist=kernel._HIST,
        e_hist=np.zeros(kernel.E_EDGES.size + 1 + kernel._SPILL, np.int64),
        mu_hist=np.zeros(kernel.MU_EDGES.size + 1 + kernel._SPILL, np.int64),
        areal=False,
        lat_hist=np.zeros(1, np.int64),
    )
    args.update(over)
    return list(args.values())


def test_direct_call_normal_impact():
    # normal impact at 1 m/s on a smooth surface: u = 1, k1 = k2 = 1, v_c = 0.1,
    # so R = 1/2, rho = 1/1.9, e = R (1 - rho) (Eqs. 4-6) for all 4 impacts
    args = _block_args()
    counts, sums = kernel._ckernel().block(*args)
    # (shadowed, captured, reimpact, rolling, rebounds): mu = 0 rolls (Eq. 3)
    assert counts == (0, 0, 0, 4, 4)
    e_hist = args[-4]
    assert e_hist.sum() == 4
    assert e_hist[np.searchsorted(kernel.E_EDGES, 0.5 * (1 - 1 / 1.9))] == 4
    e = 0.5 * (1.0 - 1.0 / 1.9)
    assert sums[0] == pytest.approx(e, rel=1e-15)  # shift K = first rebound
    assert sums[1:4] == (0.0, 0.0, 0.0)  # all equal to K
    assert sums[8:] == (0.0, 0.0, 0.0, 0.0)  # no lateral sums off areal surfaces


def test_spill_constant_matches():
    assert kernel._ckernel().SPILL == kernel._SPILL
    assert kernel._ckernel().CHUNK == 256


def _bad_kind(kind):
    rows, stride, guide, shift, _, levels, cbits = _sampler([1.0, 2.0])[:7]
    return (rows, stride, guide, shift, kind, levels, cbits)


@pytest.mark.parametrize(
    ("over", "error"),
    [
        ({"i_d": np.arange(3, dtype=np.uint64)}, ValueError),  # shorter than n
        ({"i_d": np.arange(8, dtype=np.uint64)[::2]}, ValueError),  # strided
        ({"e_hist": np.zeros(3, np.int64)}, ValueError),  # no room for the bins
        ({"n": -1}, ValueError),
        ({"dsamp": _sampler([1.0], columns=1)}, ValueError),  # too few columns
        ({"dsamp": _bad_kind(2)}, ValueError),  # not a refined grid
        ({"dsamp": _bad_kind(7)}, ValueError),
        ({"pair_total": 2**30, "pair_shift": 40}, ValueError),  # ranks overflow
        ({"pair_shift": -1}, ValueError),  # a pair search without its columns
        ({"pair_shift": -2}, ValueError),
        ({"dsamp": (np.zeros(3), 8, np.zeros(17, np.uint32), 60, 0, 0, 0)}, ValueError),
    ],
)
def test_direct_call_rejects_bad_buffers(over, error):
    with pytest.raises(error):
        kernel._ckernel().block(*_block_args(**over))


def test_constant_columns_are_read_once():
    # k1 and k2 constant (PowerCoefficients), v_c not: the compiled kernel is told
    # which columns it may read once instead of per impact
    plan = build_plan(scenario(surfaces=(rough(15.0),)))
    assert kernel.constant_columns(plan.diameters) == 0b011
    sp = plan.points[0]
    assert kernel.constant_columns(plan.angle_tables(sp.surface, 90.0).sampler) == 0


def test_samplers_check_their_rows():
    t = CellTable.from_atoms([1.0, 2.0])
    with pytest.raises(ValueError, match="sentinel"):
        Sampler(t, np.zeros((2, 4)), np.zeros((2, 2)))


@pytest.mark.parametrize(
    ("value", "expect"),
    [
        ("numpy", "numpy"),
        ("", "compiled"),
        ("auto", "compiled"),
        ("COMPILED", "compiled"),
    ],
)
def test_kernel_choice_from_environment(value, expect, monkeypatch):
    monkeypatch.setenv(kernel.KERNEL_ENV, value)
    assert resolve_kernel() == expect
    assert build_plan(scenario()).kernel == expect
    assert build_plan(scenario(), kernel="numpy").kernel == "numpy"


def test_bad_kernel_choice_is_an_input_error(monkeypatch):
    monkeypatch.setenv(kernel.KERNEL_ENV, "fortran")
    with pytest.raises(InputError, match="MICROIMPACT_KERNEL='fortran'"):
        resolve_kernel()
    with pytest.raises(InputError, match="argument `kernel`"):
        resolve_kernel("fortran")


def _runnable_isas():
    """The x86-64 levels this CPU runs (from /proc/cpuinfo; baseline elsewhere)."""
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((ln for ln in f if ln.startswith("flags")), "").split()
    except OSError:
        flags = []
    levels = {
        "x86-64-v4": {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"},
        "x86-64-v3": {"avx2", "fma", "bmi2", "f16c", "movbe"},
    }
    return [isa for isa, need in levels.items() if need <= set(flags)] + ["x86-64"]


def _build_for(isa, tmp_path):
    """The kernel compiled for one instruction set only (no clones), or None."""
    import importlib.util
    import shutil
    import subprocess
    import sysconfig
    from pathlib import Path

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    src = Path(kernel.__file__).with_name("_ckernel.c")
    out = tmp_path / f"{isa}" / "_ckernel.so"
    out.parent.mkdir()
    cmd = [cc, "-shared", "-fPIC", "-O3", "-ffp-contract=off", "-std=c11"]
    cmd += [f"-march={isa}", "-DMICROIMPACT_NO_CLONES"]
    cmd += [f"-I{sysconfig.get_paths()['include']}", str(src), "-o", str(out)]
    if subprocess.run(cmd, capture_output=True, check=False).returncode:
        return None
    spec = importlib.util.spec_from_file_location("_ckernel", out)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("p", [1.0, 1.3])
def test_instruction_set_clones_give_the_same_bits(p, tmp_path, monkeypatch, simd):
    # the installed module picks an AVX-512, AVX2 or baseline clone at load time;
    # each, built alone, must give the installed module's results bit for bit
    # (which the tests above compare with the NumPy kernel)
    import platform

    if platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("x86-64 clones only")
    sc = scenario(
        coefficients=PowerCoefficients(p=p, q=p, friction=0.2),
        surfaces=(rough(15.0),),
        speeds_m_s=(0.4,),
        angles_deg=(35.0,),
        shadowing="none",
        speed_spread=0.1,
    )
    plan = build_plan(sc)
    ref = kernel.simulate_block(plan, 0, 0, 1, 20_000).to_arrays()
    for isa in _runnable_isas():
        module = _build_for(isa, tmp_path)
        if module is None:
            pytest.skip("no C compiler for the test builds")
        monkeypatch.setattr(kernel, "_ckernel", lambda module=module: module)
        got = kernel.simulate_block(plan, 0, 0, 1, 20_000).to_arrays()
        for key in ref:
            assert_array_equal(got[key], ref[key], err_msg=f"{key} ({isa})")


@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
def test_bit_identical_with_a_rough_particle(shadowing, simd):
    # both discrete: exact pairs ('reject', 'none'); 'weighted': a pair search
    # (540,000 pairs: its rejection and its fallback)
    rng = np.random.default_rng(4)
    sc = scenario(
        surfaces=(SurfaceVariant("s", angles_from_sample(rng.normal(0, 12, 900))),),
        particle_roughness=angles_from_sample(rng.normal(0, 8, 600)),
        speeds_m_s=(0.3,),
        angles_deg=(15.0, 80.0),
        shadowing=shadowing,
        speed_spread=0.05,
    )
    _assert_same_bits(build_plan(sc), n=5000)


@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
def test_specs_in_one_call_equal_blocks_one_by_one(shadowing, simd):
    # kernel.simulate_specs is one C call for plain Monte Carlo (the kernel draws
    # each block's keyed streams itself); every accumulator equals the NumPy
    # kernel's for the same spec, whatever the order and sizes of the specs
    sc = scenario(
        surfaces=(rough(15.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.3, 1.0),
        angles_deg=(20.0, 90.0),
        shadowing=shadowing,
        speed_spread=0.1,
    )
    plan = build_plan(sc)
    plain = dataclasses.replace(plan, kernel="numpy")
    npts = len(plan.points)
    sizes = [(0, 4000), (1, 257), (2, 0)]
    specs = [(p, 0, b, n) for b, n in sizes for p in range(npts)]
    specs += [(npts - 1 - p, 0, 64, 1000) for p in range(npts)]
    got = kernel.simulate_specs(plan, specs)
    for spec, acc in zip(specs, got, strict=True):
        ref = kernel.simulate_block(plain, *spec).to_arrays()
        for key, a in acc.to_arrays().items():
            assert_array_equal(a, ref[key], err_msg=f"{key} {spec}")


# ------------------------------------------------------ areal surfaces (issue 24)
def _areal_surfaces():
    """Three areal angle sets: correlated normal pairs, a synthetic Gaussian
    surface's facets (anisotropic), and pairs with phi_perp = +-0 and steep
    facets (mirrored signs of zero, near-vertical phi_par)."""
    from engine_helpers import correlated_areal_angles

    from microimpact.surface.areal_angles import (
        areal_angles_from_sample,
        gaussian_areal_angles,
    )

    rng = np.random.default_rng(9)
    par = np.r_[rng.normal(0.0, 25.0, 300), [-89.0, 88.5, 60.0]]
    perp = np.r_[np.where(rng.random(300) < 0.5, 0.0, -0.0), [0.0, 30.0, -75.0]]
    return (
        SurfaceVariant("corr", correlated_areal_angles(700, 5, 18.0, 14.0, 0.3)),
        SurfaceVariant(
            "gauss",
            gaussian_areal_angles(
                nx=64,
                ny=64,
                dx_um=1.0,
                rms_um=1.0,
                corr_x_um=6.0,
                corr_y_um=12.0,
                seed=2,
                contact_diameter_um=3.0,
            ),
        ),
        SurfaceVariant("flat-steep", areal_angles_from_sample(par, perp)),
    )


@pytest.mark.parametrize("sampling", ["mc", "qmc"])
@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
def test_areal_bit_identical(shadowing, sampling, simd):
    """Areal surfaces on the compiled kernel: every count, moment (the lateral
    angle's too) and histogram equals the NumPy kernel's, beside a profile
    surface and a smooth one in the same plan."""
    sc = scenario(
        coefficients=PowerCoefficients(friction=0.2),
        surfaces=(*_areal_surfaces(), rough(12.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.3, 1.0),
        angles_deg=(8.0, 45.0, 89.0),
        shadowing=shadowing,
        speed_spread=0.1,
        sampling=sampling,
    )
    plan = build_plan(sc)
    assert plan.kernel == "compiled"
    _assert_same_bits(plan, n=3000 if sampling == "mc" else 1024)


def test_areal_bit_identical_with_general_exponents_and_no_friction_limit():
    # p = q = 1 has its own loop; the general one (pow) may differ in pow's last
    # bit only, and with friction = inf every impact rolls
    for coeffs in (
        PowerCoefficients(friction=np.inf),
        PowerCoefficients(p=1.3, q=0.7, friction=0.1),
    ):
        sc = scenario(
            coefficients=coeffs,
            surfaces=_areal_surfaces()[:1],
            speeds_m_s=(0.4,),
            angles_deg=(30.0,),
        )
        a, b = _both(build_plan(sc), 0, n=20_000)
        assert_array_equal(a["counts"], b["counts"])
        for key in ("e", "mu", "lateral"):
            assert_allclose(a[key], b[key], rtol=1e-12)
        if np.isinf(coeffs.friction):
            for key in a:
                assert_array_equal(a[key], b[key], err_msg=key)


@pytest.mark.parametrize("n", [0, 1, 255, 257])
def test_areal_bit_identical_at_chunk_edges(n):
    sc = scenario(surfaces=_areal_surfaces()[:1], speeds_m_s=(0.3,), angles_deg=(30.0,))
    _assert_same_bits(build_plan(sc), [0], block=0, n=n)


def test_areal_specs_and_stacked_rows_equal_blocks_one_by_one():
    """One ``_ckernel.specs`` call over areal and profile points (keyed streams in
    C; lateral spans in its buffer) gives each block's NumPy accumulator, and the
    stacked rows are exactly ``Stacked.of`` of them."""
    from microimpact.engine.summary import Stacked

    sc = scenario(
        surfaces=(*_areal_surfaces()[:2], rough(12.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.3, 1.0),
        angles_deg=(20.0, 70.0),
        shadowing="weighted",
        speed_spread=0.1,
    )
    plan = build_plan(sc)
    plain = dataclasses.replace(plan, kernel="numpy")
    npts = len(plan.points)
    specs = [
        (p, 0, b, n) for b, n in [(0, 3000), (1, 257), (2, 0)] for p in range(npts)
    ]
    specs += [(npts - 1 - p, 0, 64, 700) for p in range(npts)]
    got = kernel.simulate_specs(plan, specs)
    ref = [kernel.simulate_block(plain, *spec) for spec in specs]
    for spec, a, b in zip(specs, got, ref, strict=True):
        assert a == b, spec
    stacked, want = kernel.simulate_specs_stacked(plan, specs), Stacked.of(ref)
    for name in ("counts", "e", "mu", "lateral"):
        assert_array_equal(getattr(stacked, name), getattr(want, name), err_msg=name)
    for i in range(len(specs)):
        assert stacked.accumulator(i) == want.accumulator(i)


@pytest.mark.parametrize("sampling", ["mc", "qmc"])
def test_grouped_specs_are_the_python_fold_bit_for_bit(sampling):
    """``simulate_specs_stacked(plan, specs, groups)``: the kernel merges each
    group's blocks itself. Oracle: every block's accumulator from the NumPy
    kernel, folded left to right by ``PointAccumulator.merge`` (the driver's
    order), stacked: every array equal bit for bit (-0.0 and NaN included), over
    areal, profile and smooth points, spread speeds, blocks of 0, 1 and 3,000
    impacts, points that capture everything, and groups of 1 to 4 blocks."""
    from microimpact.engine.summary import Stacked

    sc = scenario(
        surfaces=(*_areal_surfaces()[:1], rough(12.0), SurfaceVariant("smooth")),
        speeds_m_s=(0.01, 1.0),
        angles_deg=(20.0, 70.0),
        shadowing="weighted",
        speed_spread=0.1,
        sampling=sampling,
    )
    plan = build_plan(sc)
    plain = dataclasses.replace(plan, kernel="numpy")
    sizes = [(3000, 1, 0, 2000), (257,), (0, 1000), (1, 1, 1)]
    specs, groups = [], []
    for p in range(len(plan.points)):
        for g in sizes[p % len(sizes)], sizes[(p + 1) % len(sizes)]:
            first = specs[-1][2] + 1 if specs and specs[-1][0] == p else 0
            specs += [(p, 0, first + b, n) for b, n in enumerate(g)]
            groups.append(len(g))
    want = []
    at = 0
    for g in groups:
        accs = [kernel.simulate_block(plain, *spec) for spec in specs[at : at + g]]
        acc = accs[0]
        for other in accs[1:]:
            acc = acc.merge(other)
        want.append(acc)
        at += g
    want = Stacked.of(want)
    got = kernel.simulate_specs_stacked(plan, specs, groups)
    for name in ("counts", "e", "mu", "lateral"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype, name
        assert_array_equal(a.view(np.int64), b.view(np.int64), err_msg=name)
    for name in ("e_spans", "mu_spans", "lateral_spans"):
        a, b = getattr(got, name), getattr(want, name)
        for f in ("offset", "length", "counts"):
            assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f"{name}.{f}")
    assert np.any(want.counts[:, 2] == want.counts[:, 0] - want.counts[:, 1])
    with pytest.raises(ValueError, match="group lengths"):
        kernel.simulate_specs_stacked(plan, specs, [*groups[:-1], groups[-1] + 1])
    with pytest.raises(ValueError, match="group lengths"):
        kernel.simulate_specs_stacked(plan, specs, [0, *groups])


def test_areal_runs_give_the_same_bits_on_any_worker_count(monkeypatch):
    """microimpact.run of an areal scenario: the compiled kernel on one worker and
    on two worker threads, and the NumPy kernel on two worker processes, give the
    same result."""
    from microimpact.engine.montecarlo import run

    sc = scenario(
        surfaces=_areal_surfaces()[:2],
        speeds_m_s=(0.3, 1.0),
        angles_deg=(20.0, 60.0),
        samples=70_000,
        shadowing="weighted",
    )
    one = run(sc, seed=3)
    two = run(sc, seed=3, workers=2)
    monkeypatch.setenv("MICROIMPACT_KERNEL", "numpy")
    ref = run(sc, seed=3, workers=2)
    assert one.provenance["kernel"] == "compiled"
    assert two.provenance["local_workers"] == "threads"
    assert ref.provenance["kernel"] == "numpy"
    cols = [c for c in one.summary.columns if c != "surface"]
    for other in (two, ref):
        assert_array_equal(one.summary[cols].to_numpy(), other.summary[cols].to_numpy())
        for k in one.accumulators:
            assert one.accumulators[k] == other.accumulators[k]


# ---------------------------------------------------------- QMC in C (issue 24)
@pytest.mark.parametrize("shadowing", ["reject", "weighted"])
def test_qmc_specs_bit_identical_to_scipys_points(shadowing, simd):
    """The compiled kernel generates each replicate's scrambled Sobol' points
    itself (from SciPy's direction numbers and shift, in SciPy's Gray-code
    order); the NumPy kernel takes them from ``scipy.stats.qmc.Sobol.random``
    after ``fast_forward``. Every block agrees bit for bit: 1 to 4 dimensions
    (smooth; rough; areal with the speed factor; a pair search), blocks past the
    first (fast-forwarded), several replicates, sizes across chunk edges."""
    rng = np.random.default_rng(4)
    surfaces = (
        SurfaceVariant("smooth"),
        rough(10.0),
        *_areal_surfaces()[:1],
        SurfaceVariant("s", angles_from_sample(rng.normal(0, 12, 900))),
    )
    for particle in (None, angles_from_sample(rng.normal(0, 8, 600))):
        sc = scenario(
            surfaces=surfaces[3:] if particle is not None else surfaces[:3],
            particle_roughness=particle,
            speeds_m_s=(0.3,),
            angles_deg=(15.0, 80.0),
            shadowing=shadowing,
            speed_spread=0.05,
            sampling="qmc",
        )
        plan = build_plan(sc)
        plain = dataclasses.replace(plan, kernel="numpy")
        sizes = [(0, 3000), (1, 257), (5, 1000), (2, 0)]
        specs = [
            (p, r, b, n)
            for p in range(len(plan.points))
            for r in (0, 5)
            for b, n in sizes
        ]
        got = kernel.simulate_specs(plan, specs)
        for spec, acc in zip(specs, got, strict=True):
            assert acc == kernel.simulate_block(plain, *spec), spec


def test_qmc_runs_give_the_same_bits_on_any_worker_count(monkeypatch):
    """QMC through microimpact.run: compiled, 1 worker and 2 worker threads, and
    the NumPy kernel on 2 worker processes, give the same result (and the same
    replicate error bars)."""
    from microimpact.engine.montecarlo import run

    sc = scenario(
        surfaces=(rough(12.0), *_areal_surfaces()[:1]),
        speeds_m_s=(0.3, 1.0),
        angles_deg=(20.0, 60.0),
        samples=3 * 2**14,
        sampling="qmc",
        qmc_replicates=4,
    )
    one = run(sc, seed=5)
    two = run(sc, seed=5, workers=2)
    monkeypatch.setenv("MICROIMPACT_KERNEL", "numpy")
    ref = run(sc, seed=5, workers=2)
    assert (
        one.provenance["kernel"] == "compiled" and ref.provenance["kernel"] == "numpy"
    )
    assert two.provenance["local_workers"] == "threads"
    cols = [c for c in one.summary.columns if c != "surface"]
    for other in (two, ref):
        assert_array_equal(one.summary[cols].to_numpy(), other.summary[cols].to_numpy())


def test_qmc_past_the_end_of_the_sequence_is_refused():
    sc = scenario(surfaces=(rough(12.0),), sampling="qmc")
    plan = build_plan(sc)
    last = 2**30 // plan.block_size - 1
    kernel.simulate_specs(plan, [(0, 0, last, plan.block_size)])  # the last block
    with pytest.raises(ValueError, match="2\\*\\*30"):
        kernel.simulate_specs(plan, [(0, 0, last + 1, 1)])
    with pytest.raises(ValueError):  # SciPy refuses it on the NumPy kernel too
        kernel.simulate_block(
            dataclasses.replace(plan, kernel="numpy"), 0, 0, last + 1, 1
        )


@pytest.mark.parametrize("sampling", ["mc", "qmc"])
@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
def test_per_impact_outputs_equal_the_numpy_kernels(shadowing, sampling):
    """``kernel.simulate_specs_impacts`` (what the wall law is built from): each
    impact's outcome, and e_m, mu_m (and psi on an areal surface) of each
    rebound, bit for bit those of ``simulate_block(..., store=True)``."""
    sc = scenario(
        surfaces=(*_areal_surfaces()[:1], rough(10.0), SurfaceVariant("smooth")),
        angles_deg=(12.0, 85.0),
        speeds_m_s=(0.3,),
        shadowing=shadowing,
        speed_spread=0.1,
        sampling=sampling,
        coefficients=PowerCoefficients(friction=0.2),
    )
    plan = build_plan(sc)
    specs = [
        (p, 0, b, n) for p in range(len(plan.points)) for b, n in ((0, 3000), (1, 300))
    ]
    got = kernel.simulate_specs_impacts(plan, specs)
    at = 0
    for spec in specs:
        ref = kernel.simulate_block(plan, *spec, store=True)
        sl = slice(at, at + spec[3])
        at = sl.stop
        code = got["outcome"][sl]
        assert_array_equal(code == 2, ref["shadowed"])
        assert_array_equal(code == 1, ref["captured"] & ~ref["shadowed"])
        reb = code == 0
        keys = ["e_m", "mu_m"]
        if plan.points[spec[0]].surface == 0:  # the areal surface
            keys.append("lateral_angle_deg")
        for key in keys:
            assert_array_equal(
                got[key][sl][reb], ref[key][reb], err_msg=f"{key} {spec}"
            )


def test_released_ns_counts_the_kernel_time_without_the_gil():
    """``_ckernel.released_ns`` (benchmarks/gil_share.py's second reading) grows
    by the time a call ran with the GIL released: more than half of a call that
    fills 32 MB of random words, and never more than the call's wall time."""
    ck = kernel._ckernel()
    out = np.empty(2**22, dtype=np.uint64)
    words = kernel.entropy_words(12345)
    r0, t0 = ck.released_ns(), time.perf_counter_ns()
    ck.stream(words, (0, 1), out)
    t1, r1 = time.perf_counter_ns(), ck.released_ns()
    assert 0.5 * (t1 - t0) < r1 - r0 <= t1 - t0
    assert ck.released_ns() == r1  # nothing runs in between: a count, not a clock
