"""The compiled kernel's keyed streams are NumPy's, bit for bit.

Block ``b`` of sweep point ``p`` draws variable ``v`` from
``PCG64(SeedSequence(entropy, spawn_key=(p, b, v)))``. The compiled kernel derives
these streams itself (``_ckernel.c``: SeedSequence's pool mixing and
``generate_state``, PCG64's seeding and XSL-RR output); NumPy is the oracle here.
"""

import dataclasses

import numpy as np
import pytest
from engine_helpers import rough, scenario
from numpy.testing import assert_array_equal

from microimpact import SurfaceVariant
from microimpact.engine import kernel
from microimpact.engine.plan import build_plan
from microimpact.surface.angles import angles_from_sample

pytestmark = pytest.mark.skipif(
    kernel.KERNEL != "compiled", reason="the compiled kernel is not built"
)

ENTROPIES = [
    0,
    1,
    7,
    2**31,
    2**32 - 1,  # one full word
    2**32,  # two words, the first 0
    2**63 + 5,
    2**64 - 1,
    2**64,  # three words
    2**64 + 12345,
    2**96 - 1,
    2**127 + 99,  # a 128-bit entropy, as SeedSequence() draws
    0x8F2A_1C3B_9D4E_5F60_7182_93A4_B5C6_D7E8,
    2**128,  # five words: some mixed in after the pool
    2**160 + 2**33 + 1,
    3**200,  # many words
]
KEYS = [
    (0, 0, 0),
    (0, 0, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (9_999, 63, 2),
    (123_456, 7_000, 1),
    (2**32 - 1, 2**32 - 1, 2),  # the largest one-word elements
    (2**32, 0, 1),  # a two-word element
    (5, 2**40 + 3, 0),
    (2**64 - 1, 2**63, 2**33),  # the largest elements
    (0,),
    (3, 4),
    (0, 0xFFFF_FFFF, 2),  # the QMC tag
    (1, 2, 3, 4, 5, 6),
    (),  # no spawn key: no zero padding of a short entropy
]


def _numpy(entropy, key, n):
    ss = np.random.SeedSequence(entropy, spawn_key=key)
    return np.random.PCG64(ss).random_raw(n)


@pytest.mark.parametrize("entropy", ENTROPIES, ids=lambda e: f"{e.bit_length()}b")
def test_streams_equal_numpy(entropy):
    for key in KEYS:
        got = kernel.compiled_stream_raw(entropy, key, 3000)
        assert_array_equal(got, _numpy(entropy, key, 3000), err_msg=f"key {key}")


def test_many_random_keys():
    rng = np.random.default_rng(20261123)
    for _ in range(300):
        entropy = int(rng.integers(0, 2**63)) << int(rng.integers(0, 100))
        key = tuple(int(k) for k in rng.integers(0, 2**20, size=3))
        n = int(rng.integers(1, 600))
        got = kernel.compiled_stream_raw(entropy, key, n)
        assert_array_equal(got, _numpy(entropy, key, n), err_msg=f"{entropy} {key}")


def test_stream_raw_is_the_compiled_stream():
    entropy = 0x1234_5678_9ABC_DEF0_1122_3344_5566_7788
    for point, block, var in [(0, 0, 0), (17, 3, 1), (4_999, 64, 2)]:
        assert_array_equal(
            kernel.compiled_stream_raw(entropy, (point, block, var), 5000),
            kernel.stream_raw(entropy, point, block, var, 5000),
        )


def test_entropy_words():
    assert kernel.entropy_words(0) == bytes(4)
    assert kernel.entropy_words(1) == b"\x01\x00\x00\x00"
    assert len(kernel.entropy_words(2**32)) == 8
    assert len(kernel.entropy_words(2**128 - 1)) == 16
    with pytest.raises(ValueError):
        kernel.entropy_words(-1)


def test_stream_rejects_bad_input():
    ck = kernel._ckernel()
    out = np.empty(4, np.uint64)
    with pytest.raises(ValueError):
        ck.stream(b"", (0,), out)  # no entropy word
    with pytest.raises(OverflowError):
        ck.stream(kernel.entropy_words(1), (2**64,), out)
    with pytest.raises(OverflowError):
        ck.stream(kernel.entropy_words(1), (-1,), out)
    with pytest.raises(ValueError):
        ck.stream(kernel.entropy_words(1), (0,) * 17, out)


def test_portable_128_bit_path_gives_the_same_bits(tmp_path):
    # the fallback for compilers without unsigned __int128, built and checked here
    import importlib.util
    import shutil
    import subprocess
    import sysconfig
    from pathlib import Path

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    src = Path(kernel.__file__).with_name("_ckernel.c")
    out = tmp_path / "_ckernel.so"
    cmd = [cc, "-shared", "-fPIC", "-O2", "-ffp-contract=off", "-std=c11"]
    cmd += ["-DMICROIMPACT_NO_INT128", "-DMICROIMPACT_NO_CLONES"]
    cmd += [f"-I{sysconfig.get_paths()['include']}", str(src), "-o", str(out)]
    if subprocess.run(cmd, capture_output=True, check=False).returncode:
        pytest.skip("the test build failed")
    spec = importlib.util.spec_from_file_location("_ckernel", out)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    for entropy in (0, 2**64 + 1, 2**127 + 99, 3**200):
        for key in [(0, 0, 0), (2**64 - 1, 2**63, 2), (12, 34, 1)]:
            got = np.empty(2000, np.uint64)
            module.stream(kernel.entropy_words(entropy), key, got)
            assert_array_equal(got, _numpy(entropy, key, 2000))


# ---------------------------------------------------- blocks from keyed streams
def _plan(**over):
    rng = np.random.default_rng(5)
    emp = SurfaceVariant("emp", angles_from_sample(rng.normal(2.0, 12.0, 2000)))
    kw = dict(
        surfaces=(rough(12.0), emp, SurfaceVariant("smooth")),
        speeds_m_s=(0.2, 0.5),
        angles_deg=(10.0, 45.0, 85.0),
        speed_spread=0.1,
    )
    kw.update(over)
    return build_plan(scenario(**kw))


@pytest.mark.parametrize("shadowing", ["reject", "none", "weighted"])
@pytest.mark.parametrize("spread", [0.0, 0.1])
def test_specs_equal_blocks_from_numpy_draws(shadowing, spread):
    # one C call for many specs (the compiled kernel draws its own variables) gives
    # what the NumPy kernel gives block by block on NumPy's draws, and what the
    # compiled kernel gives on NumPy's draws (its draw-array entry)
    plan = _plan(shadowing=shadowing, speed_spread=spread)
    plain = dataclasses.replace(plan, kernel="numpy")
    npts = len(plan.points)
    specs = [(p, 0, b, n) for p in range(npts) for b, n in [(0, 1), (1, 700), (64, 0)]]
    specs += [(p, 0, 5, 3000) for p in range(npts)]
    specs += [(npts - 1, 0, 2**31, 257), (0, 0, 0, 1)]  # a large block index
    got = kernel.simulate_specs(plan, specs)
    assert len(got) == len(specs)
    for spec, acc in zip(specs, got, strict=True):
        ref = kernel.simulate_block(plain, *spec)
        assert acc == ref, spec
        for key, a in acc.to_arrays().items():
            assert_array_equal(a, ref.to_arrays()[key], err_msg=f"{key} {spec}")
        # the draw-array entry of the compiled kernel, on NumPy's streams
        point, _rep, block, n = spec
        sp = plan.points[point]
        tables = plan.angle_tables(sp.surface, sp.angle_deg)
        variables = kernel._variables(plan, tables)
        raw = {
            v: kernel.stream_raw(plan.entropy, point, block, v, n) for v in variables
        }
        old = kernel._simulate_compiled(plan, sp, tables, raw, n)
        assert old == acc, spec


def test_specs_with_a_rough_particle_and_large_entropy():
    rng = np.random.default_rng(4)
    sc = scenario(
        surfaces=(SurfaceVariant("s", angles_from_sample(rng.normal(0, 12, 900))),),
        particle_roughness=angles_from_sample(rng.normal(0, 8, 600)),
        speeds_m_s=(0.3,),
        angles_deg=(15.0, 80.0),
        speed_spread=0.05,
    )
    for seed in (0, 2**64 + 3, 2**130 + 17):
        plan = build_plan(sc, seed=seed)
        plain = dataclasses.replace(plan, kernel="numpy")
        specs = [(p, 0, b, 2500) for p in range(len(plan.points)) for b in (0, 1)]
        for spec, acc in zip(specs, kernel.simulate_specs(plan, specs), strict=True):
            assert acc == kernel.simulate_block(plain, *spec), (seed, spec)


def test_specs_spans_are_the_dense_histograms():
    plan = _plan()
    specs = [(p, 0, 0, 4000) for p in range(len(plan.points))]
    for acc in kernel.simulate_specs(plan, specs):
        for name, dense in (("e", acc.e_hist), ("mu", acc.mu_hist)):
            lo, counts = acc.span_of(name)
            nz = np.flatnonzero(dense)
            if nz.size:
                assert lo == nz[0] and lo + counts.size == nz[-1] + 1
                assert counts[0] and counts[-1]
            else:
                assert counts.size == 0
        assert acc.e_hist.sum() == acc.rebounds == acc.e.n


def test_specs_reject_bad_input():
    plan = _plan()
    ck = kernel._ckernel()
    sp = plan.points[0]
    pt = kernel._point_args(plan.angle_tables(sp.surface, sp.angle_deg), sp.speed)
    words = kernel.entropy_words(plan.entropy)
    common = kernel._common_args(plan)

    def run(specs, k=None, entropy=words):
        k = len(specs) if k is None else k
        return ck.specs(
            entropy,
            common,
            specs,
            np.empty((k, 5), np.int64),
            np.empty((k, 12)),
            np.empty((k, 6), np.int64),
        )

    assert run([]) == b""
    with pytest.raises(ValueError):
        run([(0, 0, 10, pt)], k=0)  # output arrays too short
    with pytest.raises(ValueError):
        run([(0, 0, -1, pt)])
    with pytest.raises(ValueError):
        run([(0, 0, 10, pt)], entropy=b"")
    with pytest.raises(TypeError):
        run([(0, 0, 10, list(pt))])
    with pytest.raises(TypeError):
        run([[0, 0, 10, pt]])
    with pytest.raises(OverflowError):
        run([(-1, 0, 10, pt)])
    with pytest.raises(OverflowError):
        run([(0, 2**64, 10, pt)])
