"""OpenFOAM dictionaries of a wall law (microimpact.wall_law.openfoam).

The dictionaries are parsed back with a small FoamFile reader and compared with
values computed here from the raw rebound samples of a synthetic table; where
OpenFOAM is installed, a one-parcel icoUncoupledKinematicParcelFoam case checks
that OpenFOAM rebounds with the tabulated mean e_n and e_t.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from foam_box import FACES, box_case

xr = pytest.importorskip("xarray")

from microimpact.wall_law.openfoam import (  # noqa: E402
    DEMO_CASE,
    LOCAL_INTERACTION_FILE,
    LOCAL_PATCHES_FILE,
    STOCHASTIC_FILE,
    fallback_condition,
    write_openfoam,
)

DIAMETERS = (1.0, 3.0, 10.0)
SPEEDS = (1.0, 5.0)
ANGLES = (15.0, 30.0, 60.0)
N = 400  # rebounds per node; the reservoir holds them all


# --------------------------------------------------------------------------- #
# A tiny FoamFile reader: dictionaries, lists, strings, comments.
# --------------------------------------------------------------------------- #

_TOKEN = re.compile(
    r'\s+|//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\])*"|[{}();]|[^\s{}();"]+', re.S
)


def _tokens(text):
    out = []
    for m in _TOKEN.finditer(text):
        t = m.group()
        if t.isspace() or t.startswith("//") or t.startswith("/*"):
            continue
        out.append(t)
    return out


def _atom(t):
    if t.startswith('"'):
        return ("string", re.sub(r"\\(.)", r"\1", t[1:-1]))
    try:
        return float(t)
    except ValueError:
        return t


class _Parser:
    def __init__(self, text):
        self.toks = _tokens(text)
        self.i = 0

    def peek(self):
        return self.toks[self.i] if self.i < len(self.toks) else None

    def next(self):
        t = self.toks[self.i]
        self.i += 1
        return t

    def dictionary(self, end=None):
        d = {}
        while self.peek() != end:
            key = self.next()
            assert key not in "{}();", f"unexpected {key!r}"
            key = _atom(key)
            key = key[1] if isinstance(key, tuple) else key
            if self.peek() == "{":
                self.next()
                d[key] = self.dictionary("}")
                self.next()
            else:
                values = []
                while self.peek() != ";":
                    values.append(self.value())
                self.next()
                d[key] = values[0] if len(values) == 1 else values
        return d

    def value(self):
        t = self.next()
        if t == "(":
            return self.list_body(")")
        return _atom(t)

    def list_body(self, end):
        """Items of a list; ``name { ... }`` pairs become (name, dict)."""
        items = []
        while self.peek() != end:
            t = self.next()
            if self.peek() == "{":
                self.next()
                name = _atom(t)
                items.append((name, self.dictionary("}")))
                self.next()
            elif t == "(":
                items.append(self.list_body(")"))
            else:
                items.append(_atom(t))
        if end is not None:
            self.next()
        return items


def parse_foam(text):
    return _Parser(text).dictionary()


def parse_list_fragment(text):
    return _Parser(text).list_body(None)


# --------------------------------------------------------------------------- #
# A synthetic wall-law table with the schema of docs/wall-law.md, and the raw
# rebound samples it was made from (kept for independent expectations).
# --------------------------------------------------------------------------- #


def _samples(si, di, vi, ai, angle):
    rng = np.random.default_rng([si, di, vi, ai])
    # e_n and mu correlated (a tilted facet raises one and lowers the other), so
    # mean(e_t) differs from 1 - mean(mu) (1 + mean(e_n)) tan(theta)
    z = rng.standard_normal(N)
    e_n = 0.45 + 0.05 * di - 0.02 * vi + 0.1 * si + 0.12 * z
    mu = 0.12 + 0.01 * ai + 0.08 * z + 0.02 * rng.standard_normal(N)
    e_t = 1.0 - mu * (1.0 + e_n) * math.tan(math.radians(angle))
    return e_n, mu, e_t


def make_dataset(
    surfaces=("steel", "glass"), angles=ANGLES, capture=None, no_impact=None, seed=7
):
    shape = (len(surfaces), len(DIAMETERS), len(SPEEDS), len(angles))
    dims = ("surface", "diameter_um", "speed_m_s", "angle_deg")
    data = {k: np.full(shape, np.nan) for k in ("e_n", "mu", "e_t")}
    stats = {f"{k}_{s}": np.full(shape, np.nan) for k in data for s in ("mean", "std")}
    res = {k: np.full((*shape, N), np.nan) for k in ("e_n", "mu", "e_t")}
    count = np.zeros(shape, np.int32)
    n_impacts = np.full(shape, 1000, np.int64)
    p = np.full(shape, 0.0)
    raw = {}
    for idx in np.ndindex(shape):
        si, di, vi, ai = idx
        p[idx] = 0.05 * (si + 1) + 0.01 * di
        if capture is not None and surfaces[si] == capture:
            p[idx] = 1.0
            continue
        if no_impact is not None and surfaces[si] == no_impact:
            p[idx] = np.nan
            n_impacts[idx] = 0
            continue
        e_n, mu, e_t = _samples(si, di, vi, ai, angles[ai])
        if angles[ai] == 90.0:
            e_t = np.full(N, np.nan)
        raw[idx] = (e_n, mu, e_t)
        for k, x in zip(("e_n", "mu", "e_t"), (e_n, mu, e_t), strict=True):
            stats[f"{k}_mean"][idx] = np.mean(x)
            stats[f"{k}_std"][idx] = np.std(x, ddof=1)
            res[k][idx] = x
        count[idx] = N
    n_captured = np.where(n_impacts > 0, np.round(np.nan_to_num(p) * 1000), 0)
    ds = xr.Dataset(
        {
            "n_samples": (dims, np.full(shape, 1000, np.int64)),
            "n_impacts": (dims, n_impacts),
            "n_captured": (dims, n_captured.astype(np.int64)),
            "n_rebounds": (dims, count.astype(np.int64)),
            "capture_probability": (dims, p),
            "capture_ci_low": (dims, p * 0.9),
            "capture_ci_high": (dims, np.minimum(p * 1.1, 1.0)),
            "reimpact_probability": (dims, np.zeros(shape)),
            **{k: (dims, v) for k, v in stats.items()},
            "reservoir_count": (dims, count),
            "reservoir_e_n": ((*dims, "sample"), res["e_n"]),
            "reservoir_mu": ((*dims, "sample"), res["mu"]),
            "reservoir_e_t": ((*dims, "sample"), res["e_t"]),
            "reservoir_lateral_angle_deg": ((*dims, "sample"), 0.0 * res["e_n"]),
        },
        coords={
            "surface": np.array(surfaces, dtype=object),
            "diameter_um": np.array(DIAMETERS),
            "speed_m_s": np.array(SPEEDS),
            "angle_deg": np.array(angles),
            "sample": np.arange(N, dtype=np.int32),
        },
        attrs={
            "title": "microimpact wall law: synthetic",
            "scenario": 'name = "synthetic"\n',
            "seed": str(seed),
            "samples_per_node": 1000,
            "shadowing": "strict",
            "microimpact_version": "test",
        },
    )
    return ds, raw


class _Law:
    """Duck-typed wall law: only ``.dataset`` is used."""

    def __init__(self, dataset):
        self.dataset = dataset


def _law(ds):
    """A synthetic table as a wall law: write_openfoam reads only ``.dataset``
    (microimpact.WallLaw checks the full, evolving schema; the real one is tested
    through ``real_law`` below)."""
    return _Law(ds)


@pytest.fixture(scope="module")
def real_law():
    """A small table built by microimpact itself (reservoir >= samples, so the
    reservoir holds every rebound of a node)."""
    import microimpact as mi

    spec = mi.WallLawSpec(
        diameters_um=(40, 80),
        speeds_m_s=(10, 40),
        angles_deg=(20, 45, 70),
        reservoir=400,
        samples=400,
    )
    return mi.build_wall_law("sst76-formica-oblique", spec, seed=3)


def _expected(raw, si, node):
    """e = mean e_n and OpenFOAM's mu = 1 - mean e_t, with e_t recomputed from each
    rebound's e_n and impulse ratio (not read from the table's e_t variables)."""
    di, vi, ai = node
    e_n, mu, _ = raw[(si, di, vi, ai)]
    e_t = 1.0 - mu * (1.0 + e_n) * math.tan(math.radians(ANGLES[ai]))
    return float(np.mean(e_n)), 1.0 - float(np.mean(e_t))


def _patches(path):
    text = Path(path).read_text()
    if Path(path).name == LOCAL_PATCHES_FILE:
        return dict(parse_list_fragment(text))
    d = parse_foam(text)
    assert set(d) == {"FoamFile", "localInteractionCoeffs"}
    return dict(d["localInteractionCoeffs"]["patches"])


# --------------------------------------------------------------------------- #
# The fallback dictionaries
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize("name", [LOCAL_INTERACTION_FILE, LOCAL_PATCHES_FILE])
def test_default_condition_e_and_mu_match_the_rebounds(tmp_path, name):
    ds, raw = make_dataset()
    files = write_openfoam(_law(ds), tmp_path)
    top = [p for p in files if p.parent == tmp_path / "openfoam"]
    assert sorted(p.name for p in top) == sorted(
        [LOCAL_INTERACTION_FILE, LOCAL_PATCHES_FILE, STOCHASTIC_FILE, "build.sh"]
    )
    assert all(p.is_relative_to(tmp_path / "openfoam") for p in files)
    # middle of each axis: log d -> 3 um (nearer sqrt(10) than 10), log v -> a tie
    # between 1 and 5 at sqrt(5), the lower node; angle 37.5 -> 30 deg
    node = (1, 0, 1)
    patches = _patches(tmp_path / "openfoam" / name)
    assert list(patches) == ["steel", "glass"]
    for si, s in enumerate(("steel", "glass")):
        e, mu = _expected(raw, si, node)
        assert patches[s]["type"] == "rebound"
        assert patches[s]["e"] == pytest.approx(e, rel=1e-9)
        assert patches[s]["mu"] == pytest.approx(mu, rel=1e-9)
        # OpenFOAM's mu is 1 - e_t, not the impulse ratio nor 1 - e_t built from
        # the mean e_n and mean impulse ratio
        e_n, mu_m, _ = raw[(si, *node)]
        naive = np.mean(mu_m) * (1 + np.mean(e_n)) * math.tan(math.radians(30))
        assert abs(patches[s]["mu"] - naive) > 1e-4
        assert abs(patches[s]["mu"] - np.mean(mu_m)) > 1e-3


def test_header_records_seed_condition_and_statistics(tmp_path):
    ds, raw = make_dataset(seed=12345)
    write_openfoam(_law(ds), tmp_path, angle_deg=60)
    text = (tmp_path / "openfoam" / LOCAL_INTERACTION_FILE).read_text()
    assert "Generated by microimpact" in text
    assert "seed: 12345" in text
    assert "synthetic" in text
    assert "diameter 3 um, speed 1 m/s, angle 60 deg" in text
    assert "angle_deg given 60" in text and "diameter_um middle" in text
    e_n, _, e_t = raw[(0, 1, 0, 2)]
    line = next(x for x in text.splitlines() if x.startswith("//   steel:"))
    nums = [float(v) for v in re.findall(r"[-+]?\d+\.\d+(?:e[-+]?\d+)?", line)]
    assert nums[0] == pytest.approx(np.mean(e_n), rel=1e-9)
    assert nums[1] == pytest.approx(np.std(e_n, ddof=1), rel=1e-9)
    assert nums[2] == pytest.approx(np.mean(e_t), rel=1e-9)
    assert nums[3] == pytest.approx(np.std(e_t, ddof=1), rel=1e-9)
    assert nums[4] == pytest.approx(ds.capture_probability.values[0, 1, 0, 2])
    assert "mu = 1 - mean e_t" in text
    assert "NOT applied" in text


@pytest.mark.parametrize(
    ("kwargs", "node"),
    [
        ({"angle_deg": 60}, (1, 0, 2)),
        ({"angle_deg": 50}, (1, 0, 2)),  # 10 deg from 60, 20 from 30
        ({"angle_deg": 22.5}, (1, 0, 0)),  # a tie: the lower node
        ({"diameter_um": 2.0}, (1, 0, 1)),  # nearer 3 than 1 in log d
        ({"diameter_um": 1.0, "speed_m_s": 5.0}, (0, 1, 1)),
        ({"speed_m_s": 2.0}, (1, 0, 1)),  # nearer 1 than 5 in log v
        ({"speed_m_s": 2.5}, (1, 1, 1)),
    ],
)
def test_given_condition_takes_nearest_node(tmp_path, kwargs, node):
    ds, raw = make_dataset()
    cond = fallback_condition(ds, **kwargs)
    assert tuple(cond[a][0] for a in ("diameter_um", "speed_m_s", "angle_deg")) == node
    write_openfoam(_law(ds), tmp_path, **kwargs)
    patches = _patches(tmp_path / "openfoam" / LOCAL_INTERACTION_FILE)
    for si, s in enumerate(("steel", "glass")):
        e, mu = _expected(raw, si, node)
        assert patches[s]["e"] == pytest.approx(e, rel=1e-9)
        assert patches[s]["mu"] == pytest.approx(mu, rel=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"angle_deg": 10}, "angle_deg"),
        ({"angle_deg": 61}, "angle_deg"),
        ({"diameter_um": 0.5}, "diameter_um"),
        ({"diameter_um": 11}, "diameter_um"),
        ({"speed_m_s": 0}, "speed_m_s"),
        ({"speed_m_s": 6}, "speed_m_s"),
        ({"speed_m_s": float("nan")}, "speed_m_s"),
        ({"diameter_um": "big"}, "diameter_um"),
    ],
)
def test_condition_outside_the_table_names_the_argument(tmp_path, kwargs, name):
    ds, _ = make_dataset()
    with pytest.raises(ValueError, match=f"`{name}`"):
        write_openfoam(_law(ds), tmp_path, **kwargs)
    assert not (tmp_path / "openfoam").exists()


def test_node_values_at_the_ends_of_the_range_are_accepted(tmp_path):
    ds, _ = make_dataset()
    cond = fallback_condition(ds, diameter_um=10, speed_m_s=1, angle_deg=15)
    assert cond == {
        "diameter_um": (2, 10.0),
        "speed_m_s": (0, 1.0),
        "angle_deg": (0, 15.0),
    }


def test_normal_incidence_is_refused(tmp_path):
    ds, _ = make_dataset(angles=(30.0, 90.0))
    with pytest.raises(ValueError, match=r"`angle_deg`.*normal incidence"):
        write_openfoam(_law(ds), tmp_path, angle_deg=90)


def test_surface_captured_everywhere_is_written_stick(tmp_path):
    ds, raw = make_dataset(capture="glass")
    with pytest.warns(UserWarning, match="'glass' has no rebound anywhere"):
        write_openfoam(_law(ds), tmp_path)
    for name in (LOCAL_INTERACTION_FILE, LOCAL_PATCHES_FILE):
        patches = _patches(tmp_path / "openfoam" / name)
        assert patches["glass"] == {"type": "stick"}
        assert patches["steel"]["e"] == pytest.approx(_expected(raw, 0, (1, 0, 1))[0])


def test_surface_without_impacts_is_an_error(tmp_path):
    ds, _ = make_dataset(no_impact="glass")
    with pytest.raises(ValueError, match="'glass' has no impact"):
        write_openfoam(_law(ds), tmp_path)


def test_patch_names_default_mapped_and_regex(tmp_path):
    ds, _ = make_dataset(surfaces=("Ra 0.5 µm", "glass", "steel"))
    write_openfoam(
        _law(ds), tmp_path, patches={"glass": "window", "steel": "(top|bottom)Wall"}
    )
    text = (tmp_path / "openfoam" / LOCAL_PATCHES_FILE).read_text()
    keys = [k for k, _ in parse_list_fragment(text)]
    assert keys == ["Ra_0.5__m", "window", ("string", "(top|bottom)Wall")]
    stoch = parse_foam((tmp_path / "openfoam" / STOCHASTIC_FILE).read_text())
    entries = stoch["stochasticWallLawCoeffs"]["patches"]
    assert [k for k, _ in entries] == keys
    assert [v["surface"] for _, v in entries] == [
        ("string", "Ra 0.5 µm"),
        ("string", "glass"),
        ("string", "steel"),
    ]


@pytest.mark.parametrize(
    ("patches", "match"),
    [
        ({"glas": "w"}, "did you mean 'glass'"),
        ({"glass": ""}, "non-empty"),
        ({"glass": 'a"b'}, "without quotes"),
        ({"glass": "steel"}, "both be written as patch steel"),
    ],
)
def test_bad_patch_mapping(tmp_path, patches, match):
    ds, _ = make_dataset()
    with pytest.raises(ValueError, match=match):
        write_openfoam(_law(ds), tmp_path, patches=patches)


def _with_stay(ds):
    """`ds` with a ``stay_probability`` column and the flow it was computed for
    (a ramp of two friction velocities, 60 s each), as build_wall_law writes it."""
    ds = ds.copy()
    p = ds["capture_probability"]
    ds["stay_probability"] = (p.dims, np.full(p.shape, 0.6))
    ds["stay_probability"].attrs.update(
        friction_velocity_m_s=np.array([0.5, 1.25]), exposure_s=np.array([60.0, 60.0])
    )
    return ds


@pytest.mark.parametrize("stay", [False, True])
def test_resuspension_switch_follows_the_stay_column(tmp_path, stay):
    """``resuspension yes;`` exactly where the table carries stay_probability,
    in the exported coefficients and in the demo case's copy, with the flow the
    column assumes said in the comment above it."""
    ds, _ = make_dataset()
    write_openfoam(_law(_with_stay(ds) if stay else ds), tmp_path)
    folder = tmp_path / "openfoam"
    for path in (folder, folder / DEMO_CASE / "constant"):
        text = (path / STOCHASTIC_FILE).read_text()
        d = parse_foam(text)["stochasticWallLawCoeffs"]
        assert d["resuspension"] == ("yes" if stay else "no")
        said = " ".join(
            line.strip().removeprefix("//").strip()
            for line in text.split("strictClamp     no;")[1].splitlines()
            if line.strip().startswith("//")
        )
        if stay:
            assert "quasi-steady flow" in said and "independent particles" in said
            assert "friction velocity 0.5, 1.25 m/s for 60, 60 s" in said
        else:
            assert "no stay_probability" in said


def test_stochastic_dictionary_keys(tmp_path):
    ds, _ = make_dataset()
    write_openfoam(_law(ds), tmp_path / "law")
    text = (tmp_path / "law" / "openfoam" / STOCHASTIC_FILE).read_text()
    d = parse_foam(text)["stochasticWallLawCoeffs"]
    assert set(d) == {
        "table",
        "patches",
        "maxReimpacts",
        "warnClamped",
        "strictClamp",
        "resuspension",
    }
    # the case's copy of the table, not a path of the machine that built it
    assert d["table"] == ("string", "$FOAM_CASE/constant/wall_law.swl")
    assert str(tmp_path) not in text
    assert dict(d["patches"]) == {
        "steel": {"surface": ("string", "steel"), "captured": "stick"},
        "glass": {"surface": ("string", "glass"), "captured": "stick"},
    }
    assert d["maxReimpacts"] == 10.0 and d["warnClamped"] == "yes"
    assert d["strictClamp"] == "no" and d["resuspension"] == "no"
    for key in (
        "table",
        "patches",
        "surface",
        "captured",
        "maxReimpacts",
        "warnClamped",
        "strictClamp",
        "resuspension",
    ):
        assert f"  {key}" in text  # every key is described in the file


def test_rewrite_is_atomic_and_leaves_no_temporary_files(tmp_path):
    ds, _ = make_dataset()
    write_openfoam(_law(ds), tmp_path, angle_deg=15)
    write_openfoam(_law(ds), tmp_path, angle_deg=60)
    names = sorted(p.name for p in (tmp_path / "openfoam").iterdir())
    assert names == sorted(
        [
            LOCAL_INTERACTION_FILE,
            LOCAL_PATCHES_FILE,
            STOCHASTIC_FILE,
            "build.sh",
            "demoCase",
            "stochasticWallLaw",
        ]
    )
    model = tmp_path / "openfoam" / "stochasticWallLaw"
    assert not [p for p in model.rglob("*") if p.name.endswith(".tmp")]
    assert "angle 60 deg" in (tmp_path / "openfoam" / LOCAL_PATCHES_FILE).read_text()


def test_built_law_e_and_mu_from_its_reservoirs(tmp_path, real_law):
    """A table microimpact built: e and mu against the rebounds held in its
    reservoirs (every rebound, as reservoir >= samples), e_t recomputed from each
    rebound's e_n and impulse ratio."""
    ds = real_law.dataset
    write_openfoam(real_law, tmp_path)
    patches = _patches(tmp_path / "openfoam" / LOCAL_INTERACTION_FILE)
    # the middle: 40 um (a tie in log d), 10 m/s (a tie in log v), 45 deg
    at = {"diameter_um": 40.0, "speed_m_s": 10.0, "angle_deg": 45.0}
    for s in ("formica", "smooth"):
        node = ds.sel(surface=s, **at)
        k = int(node.reservoir_count)
        assert k == int(node.n_rebounds) > 100
        e_n = node.reservoir_e_n.values[:k]
        mu = node.reservoir_mu.values[:k]
        e_t = 1.0 - mu * (1.0 + e_n) * math.tan(math.radians(45.0))
        assert patches[s]["type"] == "rebound"
        assert patches[s]["e"] == pytest.approx(np.mean(e_n), rel=1e-9)
        assert patches[s]["mu"] == pytest.approx(1.0 - np.mean(e_t), rel=1e-9)


# --------------------------------------------------------------------------- #
# A real OpenFOAM: one parcel bouncing off a wall with the generated dictionary.
# --------------------------------------------------------------------------- #

_SOLVER = "icoUncoupledKinematicParcelFoam"


def _foam_env():
    env = dict(os.environ)
    if "FOAM_ETC" not in env:
        for etc in ("/usr/share/openfoam/etc", "/usr/lib/openfoam/openfoam1912/etc"):
            if Path(etc, "controlDict").is_file():
                env["FOAM_ETC"] = etc
                env.setdefault("WM_PROJECT_DIR", str(Path(etc).parent))
                break
    return env


def _case(case: Path, boundary: dict, include: str, speed, angle, steps=60):
    h = 0.02  # the parcel starts 2 cm above the floor
    theta = math.radians(angle)
    u_n, u_t = speed * math.sin(theta), speed * math.cos(theta)
    t_hit = h / u_n
    dt = t_hit / 40.0  # the parcel strikes at step 40, is read at step 60
    put = box_case(case, boundary=boundary, solver=_SOLVER, dt=dt, steps=steps)
    put("constant/kinematicCloudPositions", "vectorField", "( (0.02 0.02 0.05) )\n")
    put(
        "constant/kinematicCloudProperties",
        "dictionary",
        "solution\n{\n    active true; coupled false; transient yes;\n"
        "    cellValueSourceCorrection off; maxCo 0.3;\n"
        "    interpolationSchemes { rho cell; U cellPoint; mu cell; }\n"
        "    integrationSchemes { U Euler; }\n    sourceTerms { schemes { } }\n}\n"
        "constantProperties { rho0 2500; youngsModulus 1e8; poissonsRatio 0.35; }\n"
        "subModels\n{\n"
        "    particleForces { }\n"  # no drag, no gravity: a ballistic parcel
        "    injectionModels\n    {\n        model1\n        {\n"
        "            type manualInjection; massTotal 0; parcelBasisType fixed;\n"
        '            nParticle 1; SOI 0; positionsFile "kinematicCloudPositions";\n'
        f"            U0 ({u_t!r} {-u_n!r} 0);\n"
        "            sizeDistribution { type fixedValue; "
        "fixedValueDistribution { value 1e-5; } }\n        }\n    }\n"
        "    dispersionModel none;\n"
        "    patchInteractionModel localInteraction;\n"
        f"{include}"
        "    heatTransferModel none; surfaceFilmModel none;\n"
        "    stochasticCollisionModel none; collisionModel none; radiation off;\n"
        "}\ncloudFunctions { }\n",
    )
    return u_n, u_t


def _run_case(case: Path):
    env = _foam_env()
    for app in ("blockMesh", _SOLVER):
        proc = subprocess.run(
            [app, "-case", str(case)],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        (case / f"log.{app}").write_text(proc.stdout + proc.stderr)
        assert proc.returncode == 0, (
            f"{app} failed:\n{proc.stdout[-3000:]}\n{proc.stderr}"
        )
    times = [p for p in case.iterdir() if re.fullmatch(r"[0-9.eE+-]+", p.name)]
    last = max(times, key=lambda p: float(p.name))
    assert float(last.name) > 0, "the solver wrote no time step"
    text = (last / "lagrangian" / "kinematicCloud" / "U").read_text()
    body = text.split("}", 1)[1]
    m = re.search(r"1\s*\(\s*\(([^()]*)\)\s*\)", body)
    assert m, f"expected one parcel in {last}/lagrangian/kinematicCloud/U:\n{body}"
    return [float(v) for v in m.group(1).split()], (case / f"log.{_SOLVER}").read_text()


needs_openfoam = pytest.mark.skipif(
    shutil.which(_SOLVER) is None or shutil.which("blockMesh") is None,
    reason="OpenFOAM (Debian package openfoam) is not installed",
)


def _bounce(tmp_path, law, surface, layout, speed, angle):
    """Export `law` at (speed, angle), let one parcel strike the floor of a box in
    OpenFOAM, and return the parcel's velocity after the bounce, u_n, u_t and the
    solver's log.

    ``whole-file``: the floor is named after the surface and is the only patch,
    and the whole ``localInteractionCoeffs`` file is included. ``fragment``: the
    floor and the other faces are two patches, and ``localInteractionPatches`` is
    included in a list that also makes the other faces ``escape``; the surface is
    mapped to the regular expression ``(floor|ground)``, which OpenFOAM matches.
    """
    law_dir = tmp_path / "law"
    if layout == "whole-file":
        write_openfoam(law, law_dir, speed_m_s=speed, angle_deg=angle)
        inc = (law_dir / "openfoam" / LOCAL_INTERACTION_FILE).as_posix()
        boundary = {surface: ("wall", FACES["floor"] + " " + FACES["outer"])}
        include = f'    #include "{inc}"\n'
    else:
        write_openfoam(
            law,
            law_dir,
            speed_m_s=speed,
            angle_deg=angle,
            patches={surface: "(floor|ground)"},
        )
        inc = (law_dir / "openfoam" / LOCAL_PATCHES_FILE).as_posix()
        boundary = {
            "floor": ("wall", FACES["floor"]),
            "outer": ("patch", FACES["outer"]),
        }
        include = (
            "    localInteractionCoeffs\n    {\n        patches\n        (\n"
            f'            #include "{inc}"\n'
            "            outer { type escape; }\n        );\n    }\n"
        )
    case = tmp_path / "case"
    u_n, u_t = _case(case, boundary, include, speed, angle)
    velocity, log = _run_case(case)
    return velocity, u_n, u_t, log


def _check_bounce(velocity, u_n, u_t, log, e_n, e_t):
    # U_n' = e u_n off the floor, U_t' = e_t u_t along it (10 significant digits
    # written; the tracker's arithmetic adds nothing visible at this tolerance)
    assert velocity[1] == pytest.approx(e_n * u_n, rel=1e-8)
    assert velocity[0] == pytest.approx(e_t * u_t, rel=1e-8)
    assert velocity[2] == pytest.approx(0.0, abs=1e-12)
    assert re.search(r"escape\s*=\s*0,", log)  # the parcel stayed in the box


@needs_openfoam
@pytest.mark.parametrize("layout", ["whole-file", "fragment"])
def test_openfoam_parcel_rebounds_with_tabulated_means(tmp_path, layout):
    """One parcel strikes the floor at the table's speed and angle: its velocity
    after the bounce is (e_t u_t, e_n u_n) with the tabulated means."""
    ds, _ = make_dataset(surfaces=("steel",))
    velocity, u_n, u_t, log = _bounce(tmp_path, _law(ds), "steel", layout, 5.0, 30.0)
    node = {"diameter_um": 1, "speed_m_s": 1, "angle_deg": 1}  # 3 um, 5 m/s, 30 deg
    e_n = float(ds.e_n_mean.isel(surface=0, **node))
    e_t = float(ds.e_t_mean.isel(surface=0, **node))
    assert 0.3 < e_n < 0.9 and 0.5 < e_t < 0.95  # a real bounce, not a trivial one
    _check_bounce(velocity, u_n, u_t, log, e_n, e_t)


@needs_openfoam
def test_openfoam_parcel_rebounds_with_a_built_laws_means(tmp_path, real_law):
    """The same with a table microimpact built (SST 76 on formica, 10 m/s, 45 deg)."""
    velocity, u_n, u_t, log = _bounce(
        tmp_path, real_law, "formica", "fragment", 10.0, 45.0
    )
    node = real_law.dataset.sel(
        surface="formica", diameter_um=40.0, speed_m_s=10.0, angle_deg=45.0
    )
    e_n, e_t = float(node.e_n_mean), float(node.e_t_mean)
    assert 0.05 < e_n < 0.9 and 0.3 < e_t < 0.95
    _check_bounce(velocity, u_n, u_t, log, e_n, e_t)


@needs_openfoam
@pytest.mark.skipif(shutil.which("foamDictionary") is None, reason="no foamDictionary")
@pytest.mark.parametrize("stay", [False, True])
def test_openfoam_reads_the_stochastic_dictionary(tmp_path, stay):
    ds, _ = make_dataset()
    ds = _with_stay(ds) if stay else ds
    write_openfoam(_law(ds), tmp_path, patches={"glass": "(window|pane)"})
    path = tmp_path / "openfoam" / STOCHASTIC_FILE

    def entry(name):
        proc = subprocess.run(
            ["foamDictionary", str(path), "-entry", name, "-value"],
            capture_output=True,
            text=True,
            env=_foam_env(),
            timeout=60,
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        return proc.stdout.strip()

    assert entry("stochasticWallLawCoeffs/table") == (
        '"$FOAM_CASE/constant/wall_law.swl"'
    )
    patches = entry("stochasticWallLawCoeffs/patches")
    assert re.fullmatch(
        r'\(\s*steel\s*\{\s*surface\s*"steel"\s*;\s*captured\s*stick\s*;\s*\}'
        r'\s*"\(window\|pane\)"\s*\{\s*surface\s*"glass"\s*;\s*captured\s*stick'
        r"\s*;\s*\}\s*\)",
        patches,
    ), patches
    assert entry("stochasticWallLawCoeffs/maxReimpacts") == "10"
    # the model reads it as a switch, default no (StochasticWallLaw.C)
    assert entry("stochasticWallLawCoeffs/resuspension") == ("yes" if stay else "no")


@pytest.mark.parametrize("angle", [5.0, 10.0, 45.0, 80.0])
def test_demo_parcels_strike_the_floor_inside_the_box(tmp_path, angle):
    """Every demo parcel's straight flight (no drag, no gravity) reaches the floor
    inside the box, and before the run ends. At a shallow node (10 deg: the demo
    of a reduced-axis table of docs/wall-law.md) half of them left through the
    side first, so the demo reported 504 first strikes of its 1,000 parcels."""
    ds, _ = make_dataset(angles=(angle, 90.0))
    write_openfoam(_law(ds), tmp_path)
    case = tmp_path / "openfoam" / DEMO_CASE
    props = (case / "constant" / "kinematicCloudProperties").read_text()
    u = [float(x) for x in re.search(r"U0\s+\(([^)]*)\)", props).group(1).split()]
    assert math.degrees(math.atan2(-u[1], u[0])) == pytest.approx(angle)
    pos = (case / "constant" / "kinematicCloudPositions").read_text()
    pts = np.array(re.findall(r"^\(([-\d.e+]+) ([-\d.e+]+) ([-\d.e+]+)\)$", pos, re.M))
    x, y, z = pts.astype(float).T
    assert len(x) == 1000
    t_strike = y / -u[1]
    control = (case / "system" / "controlDict").read_text()
    end = float(re.search(r"endTime\s+(\S+);", control)[1])
    x_strike = x + u[0] * t_strike
    assert np.all((0 < x_strike) & (x_strike < 0.1)), x_strike.max()
    assert np.all((0 < z) & (z < 0.1) & (0 < y) & (y < 0.1))
    assert np.all(t_strike < end)
