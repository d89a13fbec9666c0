r"""The Formica surface family: what the paper tells us, and nothing chosen by outcome.

Li, Dunn & Brach (2000) did not publish their Formica scans. They tell us only:

* the layout: ten Surtronic 3+ scans of 4 mm, two points per micrometre (8,000
  points per scan);
* the height standard deviation of one scan, "approximately 45 µm" (Fig. 7);
* the instrument's "maximum amplitude at 150 µm, which was the highest possible
  value for this device": read as an amplitude, a scan's heights stay within
  ±150 µm of its mean line;
* the angles are slopes over the SST76 contact diameter, 20 µm;
* the angle distribution was asymmetric (Conclusions).

Published measurements of decorative laminate add one number: the roughness
average of melamine-overlaid laminate measured with a fine stylus, Ra = 2.30 µm
(15.6 % below its 2.73 µm HDF substrate; Kalaycioglu & Hiziroglu 2006 [1]_).

Everything else is unknown and is **sampled** from the ranges of
:data:`FORMICA_FAMILY` (each with its reason in ``docs/roughness.md``), so that a
statement of the paper can be judged over the unknown rather than at one tuned
point. A realization (:func:`formica_realization`) is made of three independent
parts, scan by scan:

* **waviness**: a stationary Gaussian random profile (Gaussian autocorrelation,
  correlation length :math:`\ell_w`), which carries most of the 45 µm;
* **roughness**: a Gaussian random profile with correlation length :math:`\ell_r`;
* **asymmetric texture**: a saw-tooth of random periods (mean :math:`P`) rising
  over a fraction :math:`w` of each period (:func:`~.synthetic.ripple_profile`),
  its steep faces turned toward (+1) or away from (-1) the particles at random.
  A Gaussian profile has symmetric slopes; this part is what makes the angle
  distribution asymmetric, as the paper says its distribution was.

The roughness and the texture form the *roughness band*: the texture carries a
share :math:`s` of its variance. The band is scaled so that the profile's
roughness average after the ISO 16610-21 Gaussian filter (cutoff 0.8 mm, ISO
4288's cutoff for Ra of 0.1–2 µm, near the published 2.3 µm) equals the drawn
Ra, and the waviness so that the pooled height standard deviation about each
scan's mean equals the drawn :math:`\sigma`. The paper's surface had asymmetric
angles: a realization whose angle skewness lies within :data:`ASYMMETRY_K`
standard errors of zero is not a Formica of the paper and is passed over
(:func:`formica_ensemble` keeps the candidates that qualify, each named by its
seed). A scan with a height more than 150 µm from its mean is measured again
(its waviness redrawn): the family is conditioned on the instrument's range.

References
----------
.. [1] H. Kalaycioglu and S. Hiziroglu, "Evaluation of surface characteristics of
   laminated flooring," *Building and Environment* 41:756–762, 2006.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ..io.profiles import Profile, ProfileSet
from ..units import deg_to_rad, m_to_um, rad_to_deg, um_to_m
from .roughness import gaussian_filter_profile, surface_angles
from .synthetic import gaussian_profile, ripple_profile

__all__ = [
    "FORMICA_FAMILY",
    "FormicaRealization",
    "draw_formica_parameters",
    "formica_ensemble",
    "formica_realization",
    "is_asymmetric",
    "pooled_angles_deg",
    "skewness_se",
]

#: Layout of the paper's scans (Surface Roughness Characterization).
N_SCANS = 10
N_POINTS = 8000
DX_UM = 0.5
#: The instrument's amplitude: heights stay within this of the scan's mean [µm].
AMPLITUDE_UM = 150.0
#: The SST76 contact diameter over which angles are taken [µm] (paper).
CONTACT_LENGTH_UM = 20.0
#: The ISO 4288 cutoff for the roughness average [µm].
RA_CUTOFF_UM = 800.0
#: Angles the paper drew from its angle distribution for each simulation.
N_ANGLES = 4000
#: Root seed of the shipped ensemble; realization k uses SeedSequence(ROOT, k).
ROOT_SEED = 20000376
#: Realizations in the shipped ensemble (the issue's minimum is 16).
N_REALIZATIONS = 16
#: Asymmetric angles: a skewness beyond this many standard errors (the paper's
#: Conclusions call its angle distribution asymmetric).
ASYMMETRY_K = 5.0

#: The family: for each parameter, how it is drawn, its range and where the range
#: comes from ("paper", "literature" or "assumed"). Fixed before any statement
#: was evaluated over the family (docs/roughness.md gives each reason).
FORMICA_FAMILY = {
    "height_std_um": {
        "draw": "uniform",
        "range": (40.0, 50.0),
        "source": "paper",
        "why": "Fig. 7: 'approximately 45 µm' for one scan, read as 45 ± 5 µm",
    },
    "ra_um": {
        "draw": "loguniform",
        "range": (1.15, 4.6),
        "source": "literature",
        "why": "Kalaycioglu & Hiziroglu (2006): Ra 2.30 µm of melamine-overlaid "
        "laminate, 2.73 µm of its substrate; a factor of 2 either way for finishes",
    },
    "waviness_length_um": {
        "draw": "loguniform",
        "range": (800.0, 3000.0),
        "source": "assumed",
        "why": "waviness is what lies beyond the 0.8 mm roughness cutoff (ISO "
        "16610-21); at most three quarters of the 4 mm scan",
    },
    "roughness_length_um": {
        "draw": "loguniform",
        "range": (10.0, 60.0),
        "source": "assumed",
        "why": "the texture of the overlay paper: from half to three times the "
        "20 µm contact length",
    },
    "texture_share": {
        "draw": "uniform",
        "range": (0.3, 0.9),
        "source": "assumed",
        "why": "the paper says only that the angles were asymmetric: the "
        "asymmetric texture carries from 30 % to 90 % of the band's variance",
    },
    "texture_period_um": {
        "draw": "loguniform",
        "range": (50.0, 400.0),
        "source": "assumed",
        "why": "a texture coarser than the contact length (so that it tilts "
        "facets) and finer than the waviness",
    },
    "texture_rise_fraction": {
        "draw": "uniform",
        "range": (0.05, 0.3),
        "source": "assumed",
        "why": "from a steep step to a mild saw-tooth (0.5 would be symmetric)",
    },
    "texture_orientation": {
        "draw": "sign",
        "range": (-1, 1),
        "source": "assumed",
        "why": "the paper does not say which way its asymmetry pointed",
    },
}


def draw_formica_parameters(rng=None) -> dict:
    """One draw of the parameters of :data:`FORMICA_FAMILY`, in its order.

    Parameters
    ----------
    rng : None, int or numpy.random.Generator

    Returns
    -------
    dict
        ``{name: value}`` (µm where the name says so).
    """
    rng = np.random.default_rng(rng)
    out = {}
    for name, spec in FORMICA_FAMILY.items():
        lo, hi = spec["range"]
        u = rng.random()
        if spec["draw"] == "uniform":
            out[name] = lo + (hi - lo) * u
        elif spec["draw"] == "loguniform":
            out[name] = math.exp(math.log(lo) + (math.log(hi) - math.log(lo)) * u)
        else:  # sign
            out[name] = 1 if u < 0.5 else -1
    return out


@dataclass(frozen=True)
class FormicaRealization:
    """One surface of the family.

    Attributes
    ----------
    index : int
        Its candidate number: its seed is ``SeedSequence(root, spawn_key=(index,))``.
    root : int
        The ensemble's root seed.
    parameters : dict
        The drawn :data:`FORMICA_FAMILY` parameters.
    profiles : ProfileSet
        Ten scans of 8,000 points at 0.5 µm [m].
    angles_deg : ndarray
        The slope angles over 20 µm segments of every scan [deg].
    measured : dict
        What the realization measures as a profilometer would: ``height_std_um``
        (pooled about each scan's mean), ``ra_um`` (ISO 0.8 mm filter),
        ``amplitude_um`` (largest height from a scan's mean), ``angle_std_deg``,
        ``angle_skewness``, ``redrawn_scans``.
    """

    index: int
    root: int
    parameters: dict
    profiles: ProfileSet
    angles_deg: np.ndarray
    measured: dict = field(default_factory=dict)

    @property
    def seed_text(self) -> str:
        """The seed as text: ``root/index``."""
        return f"{self.root}/{self.index}"


def _unit_std(z):
    z = z - z.mean(axis=1, keepdims=True)
    return z / np.sqrt(np.mean(z * z))


def _filtered_ra(z_um, x_m):
    out = []
    for row in z_um:
        r = gaussian_filter_profile(x_m, um_to_m(row), cutoff=um_to_m(RA_CUTOFF_UM))
        out.append(np.abs(r))
    return float(m_to_um(np.mean(out)))


def _waviness(rng, ell_um):
    """One scan of waviness: a window of a longer Gaussian record (so that scans
    are not periodic), less what the 0.8 mm filter passes (that is roughness)."""
    dx = float(um_to_m(DX_UM))
    p = gaussian_profile(
        4 * N_POINTS,
        dx,
        rms_height=1.0,
        correlation_length=float(um_to_m(ell_um)),
        rng=rng,
    )
    x = np.arange(N_POINTS) * dx
    z = p.z[:N_POINTS]
    return z - gaussian_filter_profile(x, z, cutoff=float(um_to_m(RA_CUTOFF_UM)))


def formica_heights(parameters, rng=None, *, max_redraws=200):
    """Heights [µm], shape (10, 8000), of the family at `parameters` (see the
    module docstring), and the number of scans redrawn for the ±150 µm range."""
    rng = np.random.default_rng(rng)
    prm = parameters
    dx = float(um_to_m(DX_UM))
    x = np.arange(N_POINTS) * dx
    rough = np.empty((N_SCANS, N_POINTS))
    tex = np.empty((N_SCANS, N_POINTS))
    wav = np.empty((N_SCANS, N_POINTS))
    for s in range(N_SCANS):
        wav[s] = _waviness(rng, prm["waviness_length_um"])
        rough[s] = gaussian_profile(
            4 * N_POINTS,
            dx,
            rms_height=1.0,
            correlation_length=float(um_to_m(prm["roughness_length_um"])),
            rng=rng,
        ).z[:N_POINTS]
        tex[s] = (
            prm["texture_orientation"]
            * ripple_profile(
                N_POINTS,
                dx,
                period=float(um_to_m(prm["texture_period_um"])),
                rise_fraction=prm["texture_rise_fraction"],
                rise_angle=float(deg_to_rad(30.0)),  # any: the band is scaled below
                rng=rng,
            ).z
        )
    share = prm["texture_share"]
    band = math.sqrt(1.0 - share) * _unit_std(rough) + math.sqrt(share) * _unit_std(tex)
    sigma = prm["height_std_um"]
    redrawn = 0
    a = prm["ra_um"]  # band scale [µm], refined below
    for _ in range(max_redraws):
        wav = wav - wav.mean(axis=1, keepdims=True)
        for _ in range(8):  # the band's scale for Ra, the waviness's for sigma
            c = _waviness_scale(wav, a * band, sigma)
            ra = _filtered_ra(c * wav + a * band, x)
            a *= prm["ra_um"] / ra
        c = _waviness_scale(wav, a * band, sigma)
        z = c * wav + a * band
        amp = np.abs(z - z.mean(axis=1, keepdims=True)).max(axis=1)
        bad = np.flatnonzero(amp > AMPLITUDE_UM)
        if bad.size == 0:
            return z - z.mean(axis=1, keepdims=True), redrawn
        for s in bad:  # measured again elsewhere: a new stretch of waviness
            wav[s] = _waviness(rng, prm["waviness_length_um"])
        redrawn += int(bad.size)
    raise RuntimeError(
        f"no scan set within the instrument's ±{AMPLITUDE_UM:g} µm after {max_redraws} "
        f"redraws (parameters {prm})"
    )


def _waviness_scale(wav, band, sigma):
    """c with pooled mean square of (c wav + band) = sigma^2 (a quadratic in c)."""
    a = np.mean(wav * wav)
    b = 2.0 * np.mean(wav * band)
    c0 = np.mean(band * band) - sigma**2
    if c0 >= 0:
        return 0.0
    return float((-b + math.sqrt(b * b - 4.0 * a * c0)) / (2.0 * a))


@functools.lru_cache(maxsize=64)  # deterministic, and ~0.3 s each to make
def formica_realization(index, *, root=ROOT_SEED) -> FormicaRealization:
    """Realization `index` of the family: parameters and heights from
    ``SeedSequence(root, spawn_key=(index,))``.

    Parameters
    ----------
    index : int
        Its place in the ensemble (0, 1, ...).
    root : int
        The ensemble's root seed.

    Returns
    -------
    FormicaRealization
    """
    # deferred: scipy.stats loads only for the skewness of a realization
    from scipy import stats

    index = int(index)
    if index < 0:
        raise ValueError(f"`index` must be >= 0; got {index}.")
    ss = np.random.SeedSequence(int(root), spawn_key=(index,))
    rng = np.random.default_rng(ss)
    prm = draw_formica_parameters(rng)
    z_um, redrawn = formica_heights(prm, rng)
    x = np.arange(N_POINTS) * float(um_to_m(DX_UM))
    meta = {
        "synthetic": "formica_realization",
        "root_seed": int(root),
        "index": index,
        **{k: float(v) for k, v in prm.items()},
    }
    profiles = ProfileSet(
        tuple(
            Profile(x, um_to_m(z_um[s]), {**meta, "scan": s}) for s in range(N_SCANS)
        ),
        {"source": f"Formica family realization {root}/{index} (SYNTHETIC)"},
    )
    ang = np.asarray(
        rad_to_deg(
            surface_angles(
                profiles,
                contact_length=float(um_to_m(CONTACT_LENGTH_UM)),
                method="slope",
            )
        )
    )
    zc = z_um - z_um.mean(axis=1, keepdims=True)
    measured = {
        "height_std_um": float(np.sqrt(np.mean(zc * zc))),
        "ra_um": _filtered_ra(z_um, x),
        "amplitude_um": float(np.abs(zc).max()),
        "angle_std_deg": float(np.std(ang, ddof=1)),
        "angle_skewness": float(stats.skew(ang)),
        "redrawn_scans": redrawn,
    }
    return FormicaRealization(index, int(root), prm, profiles, ang, measured)


def skewness_se(n) -> float:
    """Standard error of the sample skewness of `n` normal values,
    ``sqrt(6 n (n - 1) / ((n - 2)(n + 1)(n + 3)))`` (NaN below 4)."""
    n = float(n)
    if n < 4:
        return float("nan")
    return math.sqrt(6.0 * n * (n - 1.0) / ((n - 2.0) * (n + 1.0) * (n + 3.0)))


def is_asymmetric(realization) -> bool:
    """Whether the angles of `realization` are skewed beyond :data:`ASYMMETRY_K`
    standard errors (the paper's "asymmetry in the local surface roughness angle
    distribution")."""
    g = realization.measured["angle_skewness"]
    return bool(abs(g) > ASYMMETRY_K * skewness_se(realization.angles_deg.size))


def formica_ensemble(n=N_REALIZATIONS, *, root=ROOT_SEED, max_candidates=None):
    """The first `n` realizations of the family whose angles are asymmetric
    (:func:`is_asymmetric`), in the order of their seeds.

    Parameters
    ----------
    n : int
        Realizations wanted.
    root : int
        The ensemble's root seed; a realization's seed is ``root/index``.
    max_candidates : int, optional
        Candidates to try before giving up (default ``20 * n``).

    Returns
    -------
    list of FormicaRealization
        Their ``index`` fields are their seeds (candidates passed over leave gaps).
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"`n` must be >= 1; got {n}.")
    limit = 20 * n if max_candidates is None else int(max_candidates)
    out = []
    for k in range(limit):
        r = formica_realization(k, root=root)
        if is_asymmetric(r):
            out.append(r)
            if len(out) == n:
                return out
    raise RuntimeError(
        f"only {len(out)} of {limit} candidates of the Formica family have "
        f"asymmetric angles; {n} were wanted"
    )


def pooled_angles_deg(realizations, *, n=N_ANGLES, rng=None) -> np.ndarray:
    """`n` angles [deg] drawn with replacement, an equal share from each realization
    (the pooled surface of the preset)."""
    rng = np.random.default_rng(rng)
    k = len(realizations)
    counts = np.full(k, n // k)
    counts[: n - counts.sum()] += 1
    parts = [
        rng.choice(r.angles_deg, size=c, replace=True)
        for r, c in zip(realizations, counts, strict=True)
    ]
    return np.concatenate(parts)
