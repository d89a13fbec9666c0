"""The paper's statements, each with the test that decides whether we hold it.

One table, three readers: ``docs/presets.md`` (its statement table, written by
``docs/figures/paper_statements.py``), the tests (``tests/pipeline/test_presets.py``,
``tests/analysis/test_statements.py``) and
the reproduction report (``microimpact reproduce``, :func:`statement_table_html`).
Each :class:`Statement` carries the paper's own words (Li, Dunn & Brach 2000), our
reading of them as a numerical test (``reading``), the figure of the reproduction
that shows it, and a checker that turns the evidence (:class:`Evidence`: the
presets' results, the Formica angle sample and profile) into a :class:`Verdict`:
held or not, our number, and by how much it misses.

Each statement is of one of two kinds (:attr:`Statement.kind`):

* ``"evidence"``: our model could contradict it; judged over the Formica family
  (:mod:`microimpact.analysis.robustness`);
* ``"input"``: it holds by construction (a calibrated input, algebra, a scaled
  quantity, a property the surface family is conditioned on), so it is shown
  apart and never counted as evidence (:attr:`Statement.input_because`).

A statement whose evidence cannot be evaluated (a NaN, a missing angle) is not
held, never held (:func:`evaluate`).

The thresholds of the readings are module constants, written down (with their
reasons in ``docs/presets.md``) before the statements were judged over the
Formica family, and used unchanged by every reader:

* a skewness is *significant* ("asymmetric", "skewed") if ``|g| > K_SKEW`` times its
  standard error ``sqrt(6 n (n - 1) / ((n - 2)(n + 1)(n + 3)))``;
* a distribution is *relatively symmetric* if ``|g| <= SYMMETRIC_SKEW`` (Bulmer's
  rule of thumb: below 0.5 in size, approximately symmetric);
* a transition is *sudden* ("reached suddenly", "relatively narrow") if the speed
  of 10 % capture is at most :data:`SUDDEN_RATIO` times the speed of 90 % capture;
* the e_m asymmetry *comes from the smaller spheres* if one diameter (the sample's
  median) leaves at most :data:`FROM_SIZES_SHARE` of its skewness;
* two relative restitution curves are *similar* where they differ by at most
  :data:`SIMILAR_TOL` (5 % of the unity the rough curve tends to);
* "toward unity": the rough relative e at 10° within :data:`UNITY_BAND` and never
  falling (by more than two standard errors) from 45° down to 10°.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..physics.impact import apparent_rebound
from ..scenario import PRESET_DIR
from ..surface.formica import skewness_se
from ..surface.roughness import read_angle_file
from ..surface.synthetic import formica_profile

__all__ = [
    "STATEMENTS",
    "Evidence",
    "Statement",
    "Verdict",
    "evaluate",
    "skewness_se",
    "statement_table_html",
    "statement_table_markdown",
]

#: A skewness is significant beyond this many standard errors.
K_SKEW = 5.0
#: Largest difference of relative e at which rough and smooth are "similar".
SIMILAR_TOL = 0.05
#: The rough relative e at 10 deg "toward unity" (the issue's acceptance band).
UNITY_BAND = (0.7, 1.3)
#: "Relatively symmetric": a skewness at most this in size (Bulmer 1979).
SYMMETRIC_SKEW = 0.5
#: "Reached suddenly": v(10 % capture) / v(90 % capture) at most this.
SUDDEN_RATIO = 2.0
#: "Comes from the smaller spheres": one diameter keeps at most this share of the
#: e_m skewness.
FROM_SIZES_SHARE = 0.5
#: Surfaces of the sst76 preset.
ROUGH, SMOOTH = "formica", "smooth"
OBLIQUE = "sst76-formica-oblique"
#: The summary key of the oblique preset run with one diameter (the mechanism).
ONE_DIAMETER = f"{OBLIQUE}:one-diameter"


@dataclass(frozen=True)
class Verdict:
    """The outcome of one statement: `held`, our number(s) as text, and `miss`, by
    how much the reading fails (0 when held; in the reading's own unit)."""

    id: str
    held: bool
    ours: str
    miss: float = 0.0


@dataclass
class Evidence:
    """What the checkers read. Every field is optional; a statement whose evidence
    is missing is not evaluated.

    Attributes
    ----------
    summaries : dict
        ``{preset name: summary DataFrame}`` (``SimulationResult.summary``).
    capture_speeds : dict
        ``{preset name: 50 % capture speed [m/s]}`` at 90 deg.
    capture_fractions : dict
        ``{preset name: (speeds [m/s], capture fractions)}`` at 90 deg.
    angles_deg : ndarray
        The Formica roughness-angle sample [deg].
    height_std_um : float
        Height standard deviation of the Formica profile [µm].
    contact_length_um : float
        Contact length of the angle sample [µm].
    """

    summaries: dict = field(default_factory=dict)
    capture_speeds: dict = field(default_factory=dict)
    capture_fractions: dict = field(default_factory=dict)
    angles_deg: np.ndarray | None = None
    height_std_um: float | None = None
    contact_length_um: float | None = None

    @classmethod
    def from_results(cls, results, *, surface_data=True) -> Evidence:
        """Evidence from ``{name: SimulationResult}`` (or a list of results), plus
        (``surface_data``) the shipped Formica angle file and profile."""
        if not isinstance(results, dict):
            results = {r.scenario.name: r for r in results}
        ev = cls(summaries={k: r.summary for k, r in results.items()})
        for name, r in results.items():
            s = r.summary
            if (s["angle_deg"] == 90).all() and s["speed_m_s"].nunique() > 1:
                c = s.sort_values("speed_m_s")
                ev.capture_fractions[name] = (
                    c["speed_m_s"].to_numpy(float),
                    c["capture_fraction"].to_numpy(float),
                )
                try:
                    cs = r.capture_speed()
                    ev.capture_speeds[name] = float(cs["speed_m_s"].iloc[0])
                except (KeyError, ValueError, IndexError):
                    pass
        if surface_data:
            ev.add_shipped_surface()
        return ev

    def add_realization(self, realization) -> Evidence:
        """The angles and measured height std of a Formica family realization
        (:class:`~microimpact.surface.formica.FormicaRealization`)."""
        self.angles_deg = np.asarray(realization.angles_deg, dtype=float)
        self.height_std_um = float(realization.measured["height_std_um"])
        self.contact_length_um = 20.0
        return self

    def add_shipped_surface(self) -> Evidence:
        """The shipped Formica angle sample and profile (``presets/``, ``data/``)."""
        path = PRESET_DIR / "formica_angles_20um.csv"
        self.angles_deg = read_angle_file(path)
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("# contact length:"):
                self.contact_length_um = float(line.split(":")[1].split()[0])
        z = np.concatenate([p.z - p.z.mean() for p in formica_profile()])
        self.height_std_um = float(np.sqrt(np.mean(z * z)) * 1e6)
        return self

    def by_angle(self, surface, preset=OBLIQUE):
        s = self.summaries.get(preset)
        if s is None:
            return None
        return s[s["surface"] == surface].set_index("angle_deg").sort_index()


@dataclass(frozen=True)
class Statement:
    """One statement of the paper (see the module docstring)."""

    id: str
    where: str  # the paper's section or figure
    words: str  # the paper's words, quoted
    reading: str  # our numerical test of them
    figure: str  # the reproduction's figure: "<preset>/<stem>"
    check: Callable[[Evidence], Verdict | None]
    #: "evidence" (the model could contradict it) or "input" (holds by
    #: construction; shown apart, never counted)
    kind: str = "evidence"
    #: for an input: what makes it hold by construction
    input_because: str = ""
    #: where the paper says it: its claim number in docs/paper-comparison.md
    claim: str = ""


# ------------------------------------------------------------------ checkers


def _capture(name, target, half):
    def check(ev):
        v = ev.capture_speeds.get(name)
        if v is None:
            return None
        miss = max(0.0, abs(v - target) - half)
        return Verdict("", miss == 0.0, f"{v:.4f} m/s", miss)

    return check


def _capture_order(ev):
    a = ev.capture_speeds.get("sst65-silicon-normal")
    b = ev.capture_speeds.get("sst125-silicon-normal")
    if a is None or b is None:
        return None
    return Verdict("", b < a, f"SST125 {b:.3f} < SST65 {a:.3f} m/s", max(0.0, b - a))


def _eq9(_ev):
    # an impact that slides with friction 0.3 on a facet of -20 deg (apparent
    # angle 5 deg, true angle 25 deg: mu_0 > 0.3), through the engine's physics
    res = apparent_rebound(1.0, 5.0, -20.0, k1=1.0, k2=0.0, v_c=0.0, friction=0.3)
    mu_m = float(res.mu_m)
    miss = max(0.0, abs(mu_m - 0.7) - 0.05)
    return Verdict("", miss == 0.0, f"{mu_m:.3f}", miss)


def _height_std(ev):
    if ev.height_std_um is None:
        return None
    miss = max(0.0, abs(ev.height_std_um - 45.0) - 5.0)
    if ev.contact_length_um is not None:
        miss += abs(ev.contact_length_um - 20.0)
    cl = "?" if ev.contact_length_um is None else f"{ev.contact_length_um:g}"
    return Verdict(
        "", miss == 0.0, f"{ev.height_std_um:.1f} µm; angles over {cl} µm", miss
    )


def _angles_asymmetric(ev):
    if ev.angles_deg is None:
        return None
    # deferred: scipy loads only when a statement is checked
    from scipy import stats

    a = np.asarray(ev.angles_deg, dtype=float)
    g = float(stats.skew(a))
    lim = K_SKEW * skewness_se(a.size)
    return Verdict(
        "",
        abs(g) > lim,
        f"skewness {g:+.2f} (std {a.std(ddof=1):.1f}°, n {a.size})",
        max(0.0, lim - abs(g)),
    )


def _toward_unity(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    e = r["e_relative"]
    se = r["e_relative_se"]
    e10 = float(e.loc[10.0])
    lo, hi = UNITY_BAND
    miss = max(0.0, lo - e10, e10 - hi)
    seq = e.loc[10.0:45.0].to_numpy()[::-1]  # 45 deg down to 10 deg
    sse = se.loc[10.0:45.0].to_numpy()[::-1]
    drops = seq[:-1] - seq[1:] - 2.0 * np.hypot(sse[:-1], sse[1:])
    miss += float(max(0.0, drops.max()))
    return Verdict(
        "",
        miss == 0.0,
        f"{float(e.loc[45.0]):.2f} (45°), {float(e.loc[30.0]):.2f} (30°), "
        f"{float(e.loc[20.0]):.2f} (20°), {e10:.2f} (10°)",
        miss,
    )


def parting_angle(ev) -> float:
    """The highest swept angle at and below which rough and smooth relative e
    differ by more than :data:`SIMILAR_TOL` at every angle (NaN if none)."""
    r, s = ev.by_angle(ROUGH), ev.by_angle(SMOOTH)
    d = (r["e_relative"] - s["e_relative"]).abs().dropna()
    part = float("nan")
    for t in d.index:
        if (d.loc[:t] > SIMILAR_TOL).all():
            part = float(t)
    return part


def _similar_then_differ(ev):
    r, s = ev.by_angle(ROUGH), ev.by_angle(SMOOTH)
    if r is None or s is None:
        return None
    d = (r["e_relative"] - s["e_relative"]).abs()
    above = d.loc[50.0:90.0].dropna()
    below = d.loc[10.0:40.0].dropna()
    miss = max(0.0, float(above.max()) - SIMILAR_TOL) + max(
        0.0, SIMILAR_TOL - float(below.min())
    )
    return Verdict(
        "",
        miss == 0.0,
        f"parting angle {parting_angle(ev):g}°; |Δ| ≤ {float(above.max()):.3f} "
        f"at 50–90°, ≥ {float(below.min()):.3f} at 10–40°",
        miss,
    )


def _smooth_mu_flat(ev):
    s = ev.by_angle(SMOOTH)
    if s is None:
        return None
    mu = s["mu_mean"].loc[10.0:45.0]
    dev = float(np.abs(mu - 0.15).max())
    return Verdict(
        "",
        dev <= 0.005,
        f"{float(mu.min()):.3f}–{float(mu.max()):.3f} at 10–45°",
        max(0.0, dev - 0.005),
    )


def _smooth_e_falls(ev):
    s = ev.by_angle(SMOOTH)
    if s is None:
        return None
    # from 45 deg down to 10 deg e must fall: e(10) < e(20) < e(30) < e(45) + tol
    e10, e20, e30, e45 = (float(s["e_relative"].loc[a]) for a in (10, 20, 30, 45))
    ok = e10 < e20 < e30 < e45 + 0.01 and e10 < 0
    rises = max(0.0, e10 - e20, e20 - e30, e30 - e45 - 0.01, e10)
    return Verdict(
        "", ok, f"{e45:+.3f} (45°), {e30:+.3f} (30°), {e10:+.3f} (10°)", rises
    )


def _rough_mu_never_constant(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    mu = r["mu_mean"].loc[10.0:45.0].to_numpy()[::-1]
    se = r["mu_se"].loc[10.0:45.0].to_numpy()[::-1]
    rise = np.diff(mu) - 2.0 * np.hypot(se[:-1], se[1:])
    return Verdict(
        "",
        bool(np.all(rise > 0)),
        f"{mu[0]:.2f} (45°) → {mu[-1]:.2f} (10°), smallest 5° step "
        f"{float(np.diff(mu).min()):+.3f}",
        float(max(0.0, -rise.min())),
    )


def _e_m_asymmetric_similar(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    g10, g85 = float(r.loc[10.0, "e_skewness"]), float(r.loc[85.0, "e_skewness"])
    n10 = float(r.loc[10.0, "n_rebounds"])
    n85 = float(r.loc[85.0, "n_rebounds"])
    l10, l85 = K_SKEW * skewness_se(n10), K_SKEW * skewness_se(n85)
    same = np.sign(g10) == np.sign(g85)
    ok = bool(same and abs(g10) > l10 and abs(g85) > l85)
    # how far g10 is from the nearest value that would hold: g85's side, beyond
    # its significance limit
    miss = 0.0 if ok else abs(g10 - math.copysign(l10, g85))
    return Verdict("", ok, f"skewness {g10:+.2f} (10°), {g85:+.2f} (85°)", miss)


def _mu_m_85_symmetric(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    m85, med85 = float(r.loc[85.0, "mu_mean"]), float(r.loc[85.0, "mu_p50"])
    g85, g10 = float(r.loc[85.0, "mu_skewness"]), float(r.loc[10.0, "mu_skewness"])
    centred = max(abs(m85), abs(med85))
    # a NaN anywhere fails: max() would drop it (max(0.0, nan) is 0.0)
    miss = (
        max(0.0, centred - 0.05)
        + max(0.0, abs(g85) - SYMMETRIC_SKEW)
        + max(0.0, abs(g85) - abs(g10))
    )
    finite = all(map(math.isfinite, (m85, med85, g85, g10)))
    return Verdict(
        "",
        finite and miss == 0.0,
        f"mean {m85:+.3f}, median {med85:+.3f}, skewness {g85:+.2f} (85°) "
        f"against {g10:+.2f} (10°)",
        miss if finite else math.inf,
    )


def _speed_at_capture(speeds, fractions, level):
    """The speed [m/s] at which the capture fraction crosses `level`, by linear
    interpolation of the (falling) capture curve; NaN if it never crosses."""
    v, f = np.asarray(speeds, float), np.asarray(fractions, float)
    for i in range(len(v) - 1):
        a, b = f[i], f[i + 1]
        if (a - level) * (b - level) <= 0 and a != b:
            return float(v[i] + (level - a) * (v[i + 1] - v[i]) / (b - a))
    return float("nan")


def _capture_sudden(ev):
    c = ev.capture_fractions.get("sst65-silicon-normal")
    if c is None:
        return None
    v10 = _speed_at_capture(*c, 0.1)
    v90 = _speed_at_capture(*c, 0.9)
    ratio = v10 / v90 if v90 > 0 else float("nan")
    ok = math.isfinite(ratio) and ratio <= SUDDEN_RATIO
    miss = max(0.0, ratio - SUDDEN_RATIO) if math.isfinite(ratio) else math.inf
    return Verdict(
        "",
        ok,
        f"10 % capture at {v10:.3f} m/s, 90 % at {v90:.3f} m/s (ratio {ratio:.2f})",
        miss,
    )


def _e_m_skew_from_sizes(ev):
    r = ev.by_angle(ROUGH)
    one = ev.by_angle(ROUGH, preset=ONE_DIAMETER)
    if r is None or one is None:
        return None
    g = [float(r.loc[a, "e_skewness"]) for a in (10.0, 85.0)]
    g1 = [float(one.loc[a, "e_skewness"]) for a in (10.0, 85.0)]
    kept = [abs(b) / abs(a) if a != 0 else math.inf for a, b in zip(g, g1, strict=True)]
    ok = all(math.isfinite(k) and k <= FROM_SIZES_SHARE for k in kept)
    miss = max(k - FROM_SIZES_SHARE for k in kept)
    return Verdict(
        "",
        ok,
        f"skewness {g[0]:+.2f} → {g1[0]:+.2f} (10°), {g[1]:+.2f} → {g1[1]:+.2f} "
        "(85°) with one diameter",
        max(0.0, miss) if math.isfinite(miss) else math.inf,
    )


def _e_m_skew_all_angles(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    r = r.loc[10.0:85.0]
    g = r["e_skewness"].to_numpy(float)
    lim = np.array([K_SKEW * skewness_se(n) for n in r["n_rebounds"]])
    sign = np.sign(g[-1]) if g.size else 0.0
    ok_each = np.isfinite(g) & (np.sign(g) == sign) & (np.abs(g) > lim)
    ok = bool(g.size and ok_each.all())
    short = np.where(np.sign(g) == sign, np.maximum(0.0, lim - np.abs(g)), np.abs(g))
    miss = float(np.nanmax(short)) if g.size else math.inf
    fails = [f"{a:g}°" for a, o in zip(r.index, ok_each, strict=True) if not o]
    return Verdict(
        "",
        ok,
        f"skewness {float(np.nanmin(g)):+.2f} to {float(np.nanmax(g)):+.2f} over "
        f"10–85°; not significant with the 85° sign at "
        f"{', '.join(fails) if fails else 'no angle'}",
        0.0 if ok else miss,
    )


def _mu_m_10_skewed(ev):
    r = ev.by_angle(ROUGH)
    if r is None:
        return None
    g10 = float(r.loc[10.0, "mu_skewness"])
    lim = K_SKEW * skewness_se(float(r.loc[10.0, "n_rebounds"]))
    return Verdict("", g10 > lim, f"skewness {g10:+.2f} (10°)", max(0.0, lim - g10))


_F4 = f"{OBLIQUE}/angle_pdf_formica"
_F8 = f"{OBLIQUE}/coefficients_relative"
_F8ABS = f"{OBLIQUE}/coefficients"
_F9 = f"{OBLIQUE}/distributions_10deg"
_F10 = f"{OBLIQUE}/distributions_85deg"

#: The paper's statements, in the order of the paper.
STATEMENTS: tuple[Statement, ...] = (
    Statement(
        "capture-sst65",
        "Fig. 5",
        "at 50% of capture, the corresponding normal velocity is approximately "
        "0.20 m/s",
        "SST65 50 % capture speed in 0.18–0.22 m/s",
        "sst65-silicon-normal/capture",
        _capture("sst65-silicon-normal", 0.20, 0.02),
        kind="input",
        input_because="v_c(52.8 µm) = 0.20 m/s is calibrated to this sentence",
        claim="C48",
    ),
    Statement(
        "capture-sst125",
        "Fig. 6",
        "At 50% of capture, the critical velocity is approximately 0.13 m/s",
        "SST125 50 % capture speed in 0.11–0.15 m/s",
        "sst125-silicon-normal/capture",
        _capture("sst125-silicon-normal", 0.13, 0.02),
        kind="input",
        input_because="the v_c exponent −1.58 is calibrated to this sentence",
        claim="C52",
    ),
    Statement(
        "capture-larger-slower",
        "Fig. 6",
        "larger-diameter microparticles having smaller capture velocities",
        "SST125's capture speed below SST65's",
        "sst125-silicon-normal/capture",
        _capture_order,
        kind="input",
        input_because="follows from the two calibrated capture speeds",
        claim="C53, C83",
    ),
    Statement(
        "capture-sudden",
        "Fig. 5, Conclusions",
        "It is seen that capture is reached suddenly as the normal velocity "
        "decreases ... transition to capture occurs over a relatively narrow normal "
        "impact velocity range",
        f"SST65: the speed of 10 % capture at most {SUDDEN_RATIO:g} times the speed "
        "of 90 % capture",
        "sst65-silicon-normal/capture",
        _capture_sudden,
        claim="C50, C82",
    ),
    Statement(
        "height-std",
        "Fig. 7",
        "the standard deviation of surface height was approximately 45 µm, which "
        "was larger than the contact diameter of a SST76 microsphere "
        "(approximately 20 µm)",
        "Formica profile height std in 40–50 µm ('approximately 45 µm'); angles "
        "over 20 µm segments",
        _F4,
        _height_std,
        kind="input",
        input_because="the Formica family is drawn with a height std of 45 ± 5 µm "
        "and angles over 20 µm",
        claim="C56",
    ),
    Statement(
        "angles-asymmetric",
        "Conclusions",
        "asymmetry in the local surface roughness angle distribution led to "
        "asymmetries in the distributions of the apparent coefficient of "
        "restitution and the apparent impulse ratio",
        f"skewness of the Formica angle sample beyond {K_SKEW:g} standard errors",
        _F4,
        _angles_asymmetric,
        kind="input",
        input_because="the Formica family keeps only realizations with asymmetric "
        "angles (the paper says its angles were)",
        claim="C86",
    ),
    Statement(
        "rough-e-toward-unity",
        "Fig. 8",
        "As the incident angle is decreased, the relative coefficient of "
        "restitution for the rough surface increases toward unity",
        f"rough relative e at 10° in {UNITY_BAND[0]:g}–{UNITY_BAND[1]:g}, and no "
        "5° step from 45° down to 10° falls by more than 2 standard errors",
        _F8,
        _toward_unity,
        claim="C62",
    ),
    Statement(
        "rough-smooth-similar-above-45",
        "Fig. 8",
        "From approximately 90° down to 45°, the molecularly-smooth and rough "
        "surface cases are similar. Below 45°, they differ.",
        f"|rough − smooth relative e| ≤ {SIMILAR_TOL:g} at every angle 50–90° and "
        f"> {SIMILAR_TOL:g} at every angle 10–40°",
        _F8,
        _similar_then_differ,
        claim="C61",
    ),
    Statement(
        "smooth-e-falls",
        "Fig. 8",
        "whereas for the molecularly-smooth surface [the relative coefficient of "
        "restitution] decreases due to the effects of adhesion",
        "smooth relative e falls from 45° to 10° and is negative at 10°",
        _F8,
        _smooth_e_falls,
        kind="input",
        input_because="k1 = 4 m/s and the 1 m/s incident speed were chosen so that "
        "the smooth relative e falls below 45°",
        claim="C63",
    ),
    Statement(
        "smooth-mu-constant",
        "Fig. 8",
        "for the molecularly-smooth surface case, they become constant and equal "
        "to 0.15",
        "smooth μ within 0.005 of 0.15 at every angle 10–45°",
        _F8ABS,
        _smooth_mu_flat,
        kind="input",
        input_because="friction 0.15 is set from this sentence",
        claim="C65",
    ),
    Statement(
        "rough-mu-never-constant",
        "Fig. 8",
        "Impulse ratio values for the rough surface case never become constant "
        "with decreasing incident angle",
        "rough μ rises by more than 2 standard errors at every 5° step from 45° "
        "down to 10°",
        _F8ABS,
        _rough_mu_never_constant,
        claim="C64",
    ),
    Statement(
        "e_m-asymmetric-similar",
        "Figs. 9, 10",
        "the shapes of the frequency distributions of e_m for both angles are "
        "asymmetric and similar",
        f"e_m skewness at 10° and at 85° beyond {K_SKEW:g} standard errors, with "
        "the same sign",
        _F9,
        _e_m_asymmetric_similar,
        claim="C66",
    ),
    Statement(
        "e_m-asymmetry-from-small-spheres",
        "Figs. 9, 10",
        "This asymmetry comes from the smaller diameter microspheres travelling at "
        "slightly lower incident velocities, where the effects of adhesion are more "
        "significant",
        f"rough e_m skewness at 10° and 85° with one diameter (the sample's median) "
        f"at most {FROM_SIZES_SHARE:g} of its size with the SST76 sample",
        _F9,
        _e_m_skew_from_sizes,
        claim="C67",
    ),
    Statement(
        "e_m-asymmetry-all-angles",
        "Figs. 9, 10",
        "This asymmetry remains throughout all incident angles for the same reason",
        f"rough e_m skewness beyond {K_SKEW:g} standard errors, with the sign it has "
        "at 85°, at every swept angle 10–85°",
        _F9,
        _e_m_skew_all_angles,
        claim="C68",
    ),
    Statement(
        "mu_m-85-symmetric",
        "Fig. 10",
        "The shape of the frequency distribution of μ_m at 85° is relatively "
        "symmetric about zero, as expected",
        f"μ_m at 85°: mean and median within 0.05 of 0, skewness at most "
        f"{SYMMETRIC_SKEW:g} in size (approximately symmetric) and smaller in size "
        "than at 10°",
        _F10,
        _mu_m_85_symmetric,
        claim="C69",
    ),
    Statement(
        "mu_m-10-skewed",
        "Fig. 9",
        "as the incident angle is lowered, the μ_m distribution becomes "
        "asymmetric. This asymmetry results from the 'shadow' effect of the "
        "positive local surface angles",
        f"μ_m skewness at 10° positive (toward large μ_m) beyond {K_SKEW:g} "
        "standard errors",
        _F9,
        _mu_m_10_skewed,
        claim="C70, C71",
    ),
    Statement(
        "eq9-example",
        "Eq. 9",
        "microspheres having an actual impulse ratio value equal to 0.3 that "
        "encounter a surface with a local angle of -20° will have an apparent "
        "impulse ratio value of 0.7",
        "Eq. 9 at μ = 0.3, φ = −20° within 0.05 of 0.7",
        "",
        _eq9,
        kind="input",
        input_because="Eq. 9 is algebra",
        claim="C73",
    ),
)


def evaluate(evidence: Evidence, statements=STATEMENTS) -> dict[str, Verdict | None]:
    """``{statement id: Verdict}`` (None where the evidence is missing).

    A verdict that cannot be evaluated (its shortfall is NaN) is not held."""
    out = {}
    for s in statements:
        v = s.check(evidence)
        if v is None:
            out[s.id] = None
            continue
        miss = float(v.miss)
        held = bool(v.held) and math.isfinite(miss)
        out[s.id] = Verdict(
            s.id, held, v.ours, miss if math.isfinite(miss) else math.inf
        )
    return out


def _mark(v):
    if v is None:
        return "not evaluated"
    return "held" if v.held else f"NOT held (misses by {v.miss:.3g})"


def _md(text) -> str:
    """`text` safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|")


def statement_table_markdown(verdicts, statements=STATEMENTS) -> str:
    """The statement table as Markdown (``docs/presets.md``)."""
    rows = [
        "| id | paper | the paper's words | our reading | ours | held |",
        "|---|---|---|---|---|---|",
    ]
    for s in statements:
        v = verdicts.get(s.id)
        ours = "–" if v is None else v.ours
        rows.append(
            f"| `{s.id}` | {s.where} | “{_md(s.words)}” | {_md(s.reading)} | "
            f"{_md(ours)} | {_mark(v)} |"
        )
    return "\n".join(rows)


def statement_table_html(verdicts, statements=STATEMENTS, *, anchors=None) -> str:
    """The statement table as HTML (the reproduction report); `anchors` maps a
    statement's ``figure`` (``"<preset>/<stem>"``) to an in-page link."""
    e = html.escape
    anchors = anchors or {}
    out = [
        '<table class="statements"><thead><tr><th>paper</th><th>the paper\'s '
        "words</th><th>our reading</th><th>ours</th><th>held</th><th>figure</th>"
        "</tr></thead><tbody>"
    ]
    for s in statements:
        v = verdicts.get(s.id)
        ours = "–" if v is None else v.ours
        cls = "na" if v is None else ("held" if v.held else "failed")
        link = anchors.get(s.figure)
        fig = (
            f'<a href="{e(link)}">{e(s.figure.split("/")[-1])}</a>'
            if link
            else e(s.figure.split("/")[-1] if s.figure else "–")
        )
        out.append(
            f'<tr class="{cls}"><td>{e(s.where)}</td><td>“{e(s.words)}”</td>'
            f"<td>{e(s.reading)}</td><td>{e(ours)}</td><td>{e(_mark(v))}</td>"
            f"<td>{fig}</td></tr>"
        )
    out.append("</tbody></table>")
    return "\n".join(out)
