"""Hypothesis strategies: valid scenario files of a user's own study.

:func:`studies` draws a complete scenario (TOML text plus any data files it names)
covering every key of ``docs/scenarios.md``: each particle distribution (normal,
lognormal, uniform, monodisperse, empirical inline and from a file, histogram), each
coefficient-law form (number, constant, power, polynomial, table, Thornton-Ning),
surfaces (smooth, normal, angles, scipy, synthetic), particle roughness, speed
spread, shadowing modes, MC and QMC, precision targets, a reference angle in the
sweep, outside it or none, capture quantiles and figure formats. Sweeps have 1-40
speeds (arrays, ranges, mixed, unsorted, repeated) and 1-20 angles. The speeds are
placed relative to ``v_c`` at the median diameter so that the capture fraction at
each end of the sweep is near 0, 50 % or 100 %. Samples per point go from 1 to a
few thousand, bounded by a total budget so that an example stays fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from hypothesis import strategies as st

__all__ = ["Study", "studies", "to_toml"]

#: Capture fraction aimed at, at an end of the sweep -> factor on v_c(median).
CAPTURE_ENDS = {"all": 1e-3, "half": 1.0, "none": 1e3}


@dataclass
class Study:
    """A drawn scenario: the TOML text and the files it refers to."""

    toml: str
    files: dict = field(default_factory=dict)
    data: dict = field(default_factory=dict, repr=False)

    def write(self, folder, name="study.toml"):
        """Write the scenario and its files into `folder`; the scenario path."""
        for fname, text in self.files.items():
            (folder / fname).write_text(text, encoding="utf-8")
        path = folder / name
        path.write_text(self.toml, encoding="utf-8")
        return path


# ------------------------------------------------------------------ TOML writer
def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(data: dict) -> str:
    """TOML text of `data`: scalars first, then tables, then arrays of tables
    (a list of dicts under a key ending the document, e.g. ``surfaces``)."""
    lines, tables, arrays = [], [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{k} = {_value(v)}")
    for k, v in tables:
        lines += ["", f"[{k}]"] + [f"{kk} = {_value(x)}" for kk, x in v.items()]
    for k, items in arrays:
        for v in items:
            lines += ["", f"[[{k}]]"] + [f"{kk} = {_value(x)}" for kk, x in v.items()]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ pieces
def _r(x, digits=6) -> float:
    """`x` rounded to `digits` significant digits (readable, exact in TOML)."""
    return float(f"{x:.{digits}g}")


@st.composite
def particles(draw):
    """``([particles] table, median diameter [um], files)``."""
    d50 = _r(draw(st.floats(1.0, 100.0)))
    kind = draw(
        st.sampled_from(
            [
                "normal",
                "lognormal",
                "uniform",
                "monodisperse",
                "empirical",
                "empirical_file",
                "histogram",
            ]
        )
    )
    files = {}
    if kind == "normal":
        t = {"distribution": "normal", "mean_um": d50}
        t["std_um"] = _r(d50 * draw(st.floats(0.02, 0.6)))
        if draw(st.booleans()):
            t["min_um"] = _r(d50 * draw(st.floats(0.0, 0.9)))
        if draw(st.booleans()):
            t["max_um"] = _r(d50 * draw(st.floats(1.1, 3.0)))
    elif kind == "lognormal":
        t = {"distribution": "lognormal", "median_um": d50}
        t["geometric_std"] = _r(draw(st.floats(1.02, 3.0)))
        if draw(st.booleans()):
            t["max_um"] = _r(d50 * draw(st.floats(1.5, 10.0)))
    elif kind == "uniform":
        w = draw(st.floats(0.01, 0.95))
        t = {"distribution": "uniform", "min_um": _r(d50 * (1 - w))}
        t["max_um"] = _r(d50 * (1 + w))
    elif kind == "monodisperse":
        t = {"distribution": "monodisperse", "diameter_um": d50}
    elif kind == "empirical":
        ds = draw(st.lists(st.floats(0.3, 3.0), min_size=1, max_size=30))
        t = {"distribution": "empirical", "diameters_um": [_r(d50 * x) for x in ds]}
        d50 = float(np.median(t["diameters_um"]))
    elif kind == "empirical_file":
        ds = draw(st.lists(st.floats(0.3, 3.0), min_size=2, max_size=40))
        values = [_r(d50 * x) for x in ds]
        files["diameters.csv"] = "diameter_um\n" + "\n".join(map(str, values)) + "\n"
        t = {"distribution": "empirical", "file": "diameters.csv"}
        d50 = float(np.median(values))
    else:  # histogram
        n = draw(st.integers(1, 8))
        widths = draw(st.lists(st.floats(0.05, 0.5), min_size=n, max_size=n))
        edges = np.cumsum([0.3, *widths]) * d50
        counts = draw(st.lists(st.integers(0, 500), min_size=n, max_size=n))
        if sum(counts) == 0:
            counts[draw(st.integers(0, n - 1))] = draw(st.integers(1, 50))
        t = {
            "distribution": "histogram",
            "edges_um": [_r(x, 8) for x in edges],
            "counts": counts,
        }
        d50 = float(np.median(edges))
    return t, d50, files


@st.composite
def law(draw, d50, *, kind=None, positive=True):
    """A coefficient-law value (a number or a law table) [m/s], near 'scale'."""
    kind = kind or draw(
        st.sampled_from(
            ["number", "constant", "power", "polynomial", "table", "thornton_ning"]
        )
    )
    scale = _r(10 ** draw(st.floats(-1.5, 0.7)))
    if kind == "number":
        return scale
    if kind == "constant":
        return {"law": "constant", "value_m_s": scale}
    if kind == "power":
        return {
            "law": "power",
            "a_m_s": scale,
            "b": _r(draw(st.floats(-3.0, 0.5))),
            "d_ref_um": _r(d50),
        }
    if kind == "polynomial":
        c1 = _r(scale * draw(st.floats(-0.5, 0.5)))
        return {"law": "polynomial", "coefficients_m_s": [scale, c1], "d_ref_um": d50}
    if kind == "table":
        n = draw(st.integers(2, 5))
        ds = sorted({_r(d50 * x) for x in np.geomspace(0.2, 5.0, n)})
        vs = [_r(scale * draw(st.floats(0.3, 3.0))) for _ in ds]
        return {
            "law": "table",
            "diameter_um": ds,
            "value_m_s": vs,
            "extrapolation": draw(st.sampled_from(["clamp", "loglinear"])),
        }
    from microimpact.physics.adhesion import MATERIALS

    mats = sorted(MATERIALS)
    return {
        "law": "thornton_ning",
        "particle": draw(st.sampled_from(mats)),
        "surface": draw(st.sampled_from(mats)),
        "work_of_adhesion_J_m2": _r(draw(st.floats(0.01, 1.0))),
    }


def _v_c_at(spec, d50_um) -> float:
    """v_c [m/s] of a law value at the median diameter."""
    from microimpact.physics.coefficients import law_from_dict
    from microimpact.units import um_to_m

    if not isinstance(spec, dict):
        return float(spec)
    return float(np.asarray(law_from_dict(spec)(um_to_m(d50_um))).ravel()[0])


@st.composite
def angle_law(draw, *, names=None):
    """A roughness-angle distribution: a surface table without ``name``."""
    kind = draw(st.sampled_from(["smooth", "normal", "angles", "scipy", "synthetic"]))
    if kind == "smooth":
        return {"kind": "smooth"}
    if kind == "normal":
        t = {"kind": "normal", "std_deg": _r(draw(st.floats(0.0, 25.0)))}
        if draw(st.booleans()):
            t["mean_deg"] = _r(draw(st.floats(-20.0, 20.0)))
        return t
    if kind == "angles":
        a = draw(st.lists(st.floats(-60.0, 60.0), min_size=1, max_size=20))
        return {"kind": "angles", "angles_deg": [_r(x, 4) for x in a]}
    if kind == "scipy":
        dist, shapes = draw(
            st.sampled_from(
                [("norm", []), ("laplace", []), ("t", [3.0]), ("uniform", [])]
            )
        )
        t = {"kind": "scipy", "distribution": dist}
        if shapes:
            t["shapes"] = shapes
        if dist == "uniform":
            t["loc_deg"] = -_r(draw(st.floats(1.0, 30.0)))
            t["scale_deg"] = -2 * t["loc_deg"]
        else:
            t["scale_deg"] = _r(draw(st.floats(0.5, 15.0)))
        return t
    length = _r(draw(st.floats(5.0, 40.0)))
    t = {"kind": "synthetic", "contact_length_um": length}
    if draw(st.booleans()):
        need = math.ceil(2.5 * length / 0.1)  # at least 2 contact lengths
        t.update(
            profile="gaussian",
            n_points=draw(st.integers(need, need + 1500)),
            dx_um=0.1,
            rms_height_um=_r(draw(st.floats(0.05, 1.0))),
            correlation_length_um=_r(draw(st.floats(1.0, 10.0))),
            seed=draw(st.integers(0, 1000)),
        )
    return t


_NAMES = st.sampled_from(["smooth", "rough", "a/b", "a_b", "x y", "Formica®", "s-1"])


@st.composite
def surfaces(draw):
    """The ``[[surfaces]]`` list (0-3 surfaces; 0: the default smooth one)."""
    n = draw(st.integers(0, 3))
    names = draw(st.lists(_NAMES, min_size=n, max_size=n, unique=True))
    out = []
    for name in names:
        t = draw(angle_law())
        out.append({"name": name, **t})
    return out


def _sweep_values(draw, values, *, digits=6):
    """`values` written as an array, a range table or a mix of them."""
    values = [_r(v, digits) for v in values]
    form = draw(st.sampled_from(["array", "range_num", "mixed", "unsorted"]))
    if len(values) >= 3 and form == "range_num":
        lo, hi = min(values), max(values)
        return {"start": lo, "stop": hi, "num": len(values)}, len(values)
    if len(values) >= 3 and form == "mixed":
        a, b = sorted(values[:2])
        return [{"start": a, "stop": b, "num": 2}, *values[2:]], len(values)
    if len(values) >= 2 and form == "unsorted":
        values = draw(st.permutations(values))
        if draw(st.booleans()):
            values = [*values, values[0]]  # a repeated value is accepted
        return list(values), len(values)
    return values if len(values) > 1 else values[0], len(values)


@st.composite
def studies(draw, *, max_speeds=40, max_angles=20, budget=60_000):
    """A valid scenario of a user's own study (see the module docstring).

    `budget` bounds samples x sweep points (a precision target may use up to
    ``max_samples`` per point, also bounded by it).
    """
    part, d50, files = draw(particles())
    v_c = draw(law(d50))
    coefficients = {
        "k1": draw(law(d50, kind=draw(st.sampled_from(["number", "constant"])))),
        "k2": draw(law(d50, kind=draw(st.sampled_from(["number", "power"])))),
        "v_c": v_c,
    }
    if draw(st.booleans()):
        coefficients["friction"] = draw(st.sampled_from([0.0, 0.15, 1.0, "inf"]))
    if draw(st.booleans()):
        coefficients["p"] = _r(draw(st.floats(0.5, 2.0)))
        coefficients["q"] = _r(draw(st.floats(0.5, 2.0)))
    vc50 = _v_c_at(v_c, d50)
    scale = vc50 if vc50 > 1e-4 else 0.1
    # capture near 100 %, 50 % or 0 % at each end of the sweep
    ends = sorted(
        draw(st.lists(st.sampled_from(list(CAPTURE_ENDS)), min_size=2, max_size=2)),
        key=lambda k: CAPTURE_ENDS[k],
    )
    lo, hi = (min(max(scale * CAPTURE_ENDS[k], 1e-4), 1e3) for k in ends)
    n_speeds = draw(st.integers(1, max_speeds))
    speeds = np.geomspace(lo, hi, n_speeds) if hi > lo else np.full(n_speeds, lo)
    speeds = list(dict.fromkeys(_r(v) for v in speeds)) or [_r(lo)]
    speed_value, n_speeds = _sweep_values(draw, speeds)
    n_angles = draw(st.integers(1, max_angles))
    angle_pool = st.floats(1.0, 90.0).map(lambda a: _r(a, 4))
    angles = draw(st.lists(angle_pool, min_size=n_angles, max_size=n_angles))
    if draw(st.booleans()):
        angles[-1] = 90.0  # normal impact: the capture figure
    if n_angles >= 2 and draw(st.booleans()):
        angles[0] = 85.0  # the default reference angle
    angle_value, n_angles = _sweep_values(draw, angles, digits=4)
    data = {"name": draw(st.sampled_from(["own-study", "my study", "Étude <1>"]))}
    if draw(st.booleans()):
        data["description"] = draw(st.sampled_from(["", "ten-line study & co"]))
    data["seed"] = draw(st.integers(0, 2**32))
    surf = draw(surfaces())
    n_points = max(len(surf), 1) * n_speeds * n_angles
    sampling = draw(st.sampled_from(["mc", "mc", "qmc"]))
    data["sampling"] = sampling
    if sampling == "qmc":
        data["qmc_replicates"] = draw(st.integers(2, 4))
    cap = max(1, budget // n_points)
    if sampling == "mc" and draw(st.integers(0, 4)) == 0:
        top = min(cap, 2000)
        mn = draw(st.integers(1, top))
        data["precision"] = {
            "statistic": draw(
                st.sampled_from(
                    ["capture_fraction", "e_mean", "e_rebound_mean", "mu_mean"]
                )
            ),
            "half_width": _r(draw(st.floats(0.02, 0.3))),
            "min_samples": mn,
            "max_samples": draw(st.integers(mn, top)),
        }
    else:
        tiny = draw(st.booleans())
        data["samples"] = (
            draw(st.integers(1, 5)) if tiny else draw(st.integers(1, min(cap, 4000)))
        )
    data["shadowing"] = draw(st.sampled_from(["reject", "weighted", "none"]))
    if draw(st.booleans()):
        data["confidence"] = _r(draw(st.floats(0.5, 0.999)))
    ref = draw(st.sampled_from(["default", "swept", "not swept", "none"]))
    if ref == "swept":
        data["reference_angle_deg"] = angles[-1]
    elif ref == "not swept":
        data["reference_angle_deg"] = 33.3
    elif ref == "none":
        data["reference_angle_deg"] = False
    if draw(st.booleans()):
        qs = draw(
            st.lists(
                st.floats(0.05, 0.95).map(lambda q: _r(q, 3)),
                min_size=1,
                max_size=3,
                unique=True,
            )
        )
        data["capture_quantiles"] = qs if len(qs) > 1 else qs[0]
    data["particles"] = part
    data["coefficients"] = coefficients
    if draw(st.integers(0, 3)) == 0:
        pr = draw(angle_law())
        if pr["kind"] == "synthetic":
            pr = {"kind": "normal", "std_deg": 3.0}
        data["particle_roughness"] = pr
    sweep = {"speed_m_s": speed_value, "angle_deg": angle_value}
    if draw(st.booleans()):
        sweep["speed_spread"] = _r(draw(st.floats(0.0, 0.5)))
    data["sweep"] = sweep
    data["outputs"] = {
        "figures": draw(st.sampled_from([["png"], ["png"], ["svg"], ["png", "pdf"]]))
    }
    if surf:
        data["surfaces"] = surf
    return Study(to_toml(data), files, data)
