"""Scenarios: a complete, validated description of a Monte Carlo study.

A :class:`Scenario` holds model objects (a size distribution, the coefficient laws,
roughness-angle distributions) rather than raw numbers, so it can be built in Python
as easily as loaded from a TOML file with :meth:`Scenario.from_toml` (see
``docs/scenarios.md`` for every key). Validation happens in ``__post_init__`` and
raises :class:`~microimpact.errors.ScenarioError` naming the field, the value and what
is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .._core.validation import check_scalar
from ..errors import ScenarioError

SHADOWING_OPTIONS = ("reject", "weighted", "none")
SAMPLING_OPTIONS = ("mc", "qmc")
PRECISION_STATISTICS = ("capture_fraction", "e_mean", "e_rebound_mean", "mu_mean")


@dataclass(frozen=True)
class SurfaceVariant:
    """A named surface: a roughness-angle distribution, or None for molecularly
    smooth (phi = 0 exactly)."""

    name: str
    angles: Any = None

    @property
    def smooth(self) -> bool:
        """Molecularly smooth, by structure: no angle distribution, or one whose
        only value is exactly 0 (never by name)."""
        if self.angles is None:
            return True
        flag = getattr(self.angles, "is_smooth", None)
        if flag is not None:
            return bool(flag)
        try:
            return tuple(self.angles.support()) == (0.0, 0.0)
        except (AttributeError, TypeError, ValueError):
            return False

    def describe(self) -> dict:
        if self.angles is None:
            return {"name": self.name, "kind": "smooth"}
        d = dict(self.angles.describe())
        d["name"] = self.name
        return d


@dataclass(frozen=True)
class Precision:
    """Automatic sample size: stop a sweep point once the confidence-interval
    half-width of `statistic` is at most `half_width` (or `max_samples` is reached).
    """

    statistic: str = "capture_fraction"
    half_width: float = 0.01
    max_samples: int = 10_000_000
    min_samples: int = 1000

    def __post_init__(self):
        if self.statistic not in PRECISION_STATISTICS:
            raise ScenarioError(
                f"must be one of {', '.join(PRECISION_STATISTICS)}; "
                f"got {self.statistic!r}",
                field="precision.statistic",
            )
        hw = self.half_width
        if isinstance(hw, bool) or not (isinstance(hw, int | float) and hw > 0):
            raise ScenarioError(
                f"must be a number > 0; got {hw!r}", field="precision.half_width"
            )
        for name in ("max_samples", "min_samples"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ScenarioError(
                    f"must be an integer >= 1; got {v!r}", field=f"precision.{name}"
                )
        if self.min_samples > self.max_samples:
            default = Precision.__dataclass_fields__["min_samples"].default
            raise ScenarioError(
                f"must be <= max_samples ({self.max_samples}); got {self.min_samples}"
                + (" (the default)" if self.min_samples == default else ""),
                field="precision.min_samples",
            )


def _positive_tuple(values, name, *, lo=0.0, hi=math.inf, hi_inclusive=False):
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        raise ScenarioError(f"must be numbers; got {values!r}", field=name) from None
    if arr.ndim != 1 or arr.size == 0:
        raise ScenarioError(f"must be a non-empty list; got {values!r}", field=name)
    for v in arr:
        ok = np.isfinite(v) and v > lo and (v <= hi if hi_inclusive else v < hi)
        if not ok:
            rng = f"({lo}, {hi}{']' if hi_inclusive else ')'}"
            raise ScenarioError(f"value {float(v):g} is outside {rng}", field=name)
    return tuple(float(v) for v in arr)


def _choice(value, field, options):
    if value not in options:
        raise ScenarioError(
            f"must be one of {', '.join(repr(o) for o in options)}; got {value!r}",
            field=field,
        )
    return value


def _integer(value, field, low):
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ScenarioError(f"must be an integer >= {low}; got {value!r}", field=field)
    if value < low:
        raise ScenarioError(f"must be an integer >= {low}; got {value!r}", field=field)
    return int(value)


def _number(value, field, *, low, high, open_=False, open_low=False):
    """A real number in [low, high] ((low, high) if `open_`, (low, high] if
    `open_low`), else ScenarioError naming `field`."""
    try:
        x = check_scalar(value, field)
    except (TypeError, ValueError):
        raise ScenarioError(f"must be a number; got {value!r}", field=field) from None
    lo_ok = x > low if (open_ or open_low) else x >= low
    hi_ok = x < high if open_ else x <= high
    if not (lo_ok and hi_ok):
        left = "(" if (open_ or open_low) else "["
        right = ")" if open_ else "]"
        raise ScenarioError(
            f"must be in {left}{low:g}, {high:g}{right}; got {value!r}", field=field
        )
    return x


@dataclass(frozen=True)
class Scenario:
    """A Monte Carlo study.

    Parameters
    ----------
    name : str
        Short identifier (used in output folder and file names).
    particles : SizeDistribution
        Particle diameter distribution (anything with ``table()`` and
        ``describe()``).
    coefficients : ImpactCoefficients
        k1(d), k2(d), v_c(d) laws, the exponents p, q and the friction coefficient
        (anything with ``evaluate(diameter)``, ``p``, ``q``, ``friction``,
        ``describe()``).
    speeds_m_s : sequence of float
        Nominal incident speeds [m s-1].
    angles_deg : sequence of float
        Apparent incidence angles from the nominal plane [deg], in (0, 90].
    surfaces : sequence of SurfaceVariant
        Surfaces simulated side by side (default: one molecularly smooth surface).
    particle_roughness : AngleDistribution, optional
        The particle's own roughness angle; it adds to the surface's.
    speed_spread : float
        Relative standard deviation of the incident speed (normal, truncated to
        (0, 2) times the nominal speed); 0 for a constant speed.
    samples : int
        Impacts per sweep point (the paper used 4,000).
    precision : Precision, optional
        Automatic sample size instead of `samples`.
    shadowing : {"reject", "weighted", "none"}
    seed : int, optional
        Root seed; None draws fresh entropy (recorded in the results).
    sampling : {"mc", "qmc"}
        Plain Monte Carlo or randomised scrambled-Sobol quasi-Monte Carlo.
    qmc_replicates : int
        Independent scrambles for QMC error bars.
    confidence : float
        Confidence level of every reported interval.
    reference_angle_deg : float, optional
        Angle for the paper's relative coefficients ``e - e(ref)``.
    capture_quantiles : sequence of float
        Capture fractions at which the capture speed is reported.
    """

    name: str
    particles: Any
    coefficients: Any
    speeds_m_s: tuple = (1.0,)
    angles_deg: tuple = (90.0,)
    surfaces: tuple = (SurfaceVariant("smooth"),)
    particle_roughness: Any = None
    speed_spread: float = 0.0
    samples: int = 4000
    precision: Precision | None = None
    shadowing: str = "reject"
    seed: int | None = None
    sampling: str = "mc"
    qmc_replicates: int = 8
    confidence: float = 0.95
    reference_angle_deg: float | None = 85.0
    capture_quantiles: tuple = (0.5,)
    description: str = ""
    source: str | None = None

    def __post_init__(self):
        # Every check raises ScenarioError(field=...) without a file: the TOML layer
        # (microimpact.scenario.file) adds the file and the key path; an edit in Python
        # (with_options) is never blamed on the file the scenario came from.
        set_ = object.__setattr__
        if not isinstance(self.name, str) or not self.name.strip():
            raise ScenarioError(
                f"must be a non-empty string; got {self.name!r}", field="name"
            )
        if not isinstance(self.description, str):
            raise ScenarioError(
                f"must be a string; got {self.description!r}", field="description"
            )
        for obj, attr, needs in (
            (self.particles, "particles", ("table", "describe")),
            (self.coefficients, "coefficients", ("evaluate", "describe")),
        ):
            missing = [m for m in needs if not hasattr(obj, m)]
            if missing:
                raise ScenarioError(
                    f"{type(obj).__name__} lacks {', '.join(missing)}", field=attr
                )
        set_(self, "speeds_m_s", _positive_tuple(self.speeds_m_s, "sweep.speed_m_s"))
        set_(
            self,
            "angles_deg",
            _positive_tuple(
                self.angles_deg, "sweep.angle_deg", hi=90.0, hi_inclusive=True
            ),
        )
        surfaces = tuple(self.surfaces)
        if not surfaces or not all(isinstance(s, SurfaceVariant) for s in surfaces):
            raise ScenarioError(
                "must be a non-empty sequence of SurfaceVariant", field="surfaces"
            )
        names = [s.name for s in surfaces]
        if len(set(names)) != len(names):
            raise ScenarioError(
                f"surface names must be unique; got {names}", field="surfaces"
            )
        set_(self, "surfaces", surfaces)
        _choice(self.shadowing, "shadowing", SHADOWING_OPTIONS)
        _choice(self.sampling, "sampling", SAMPLING_OPTIONS)
        _integer(self.samples, "samples", 1)
        _integer(self.qmc_replicates, "qmc_replicates", 2)
        if self.seed is not None:
            _integer(self.seed, "seed", 0)
        set_(
            self,
            "speed_spread",
            _number(self.speed_spread, "sweep.speed_spread", low=0.0, high=0.5),
        )
        set_(
            self,
            "confidence",
            _number(self.confidence, "confidence", low=0.0, high=1.0, open_=True),
        )
        if self.reference_angle_deg is not None:
            set_(
                self,
                "reference_angle_deg",
                _number(
                    self.reference_angle_deg,
                    "reference_angle_deg",
                    low=0.0,
                    high=90.0,
                    open_low=True,
                ),
            )
        if self.precision is not None and not isinstance(self.precision, Precision):
            raise ScenarioError(
                f"must be a Precision or None; got {self.precision!r}",
                field="precision",
            )
        if self.precision is not None and self.sampling == "qmc":
            raise ScenarioError(
                "a precision target needs sampling = 'mc' (QMC error bars come from a "
                "fixed number of replicates)",
                field="precision",
            )
        qs = self.capture_quantiles
        qs = (qs,) if isinstance(qs, int | float) else qs
        try:
            qs = tuple(qs)
        except TypeError:
            raise ScenarioError(
                f"must be numbers in (0, 1); got {qs!r}", field="capture_quantiles"
            ) from None
        if not qs:
            raise ScenarioError("must not be empty", field="capture_quantiles")
        set_(
            self,
            "capture_quantiles",
            tuple(
                _number(q, "capture_quantiles", low=0.0, high=1.0, open_=True)
                for q in qs
            ),
        )

    @classmethod
    def from_toml(cls, path) -> Scenario:
        """Load and validate a scenario file (see ``docs/scenarios.md``)."""
        from .file import scenario_from_toml

        return scenario_from_toml(Path(path))

    @classmethod
    def from_preset(cls, name: str) -> Scenario:
        """A shipped preset reproducing the paper (see ``docs/presets.md``)."""
        from .file import load_preset

        return load_preset(name)

    def with_options(self, **changes) -> Scenario:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def describe(self) -> dict:
        """Plain-data description for provenance."""
        return {
            "name": self.name,
            "description": self.description,
            "particles": self.particles.describe(),
            "coefficients": self.coefficients.describe(),
            "surfaces": [s.describe() for s in self.surfaces],
            "particle_roughness": None
            if self.particle_roughness is None
            else self.particle_roughness.describe(),
            "speeds_m_s": list(self.speeds_m_s),
            "angles_deg": list(self.angles_deg),
            "speed_spread": self.speed_spread,
            "samples": self.samples,
            "precision": None if self.precision is None else vars(self.precision),
            "shadowing": self.shadowing,
            "seed": self.seed,
            "sampling": self.sampling,
            "qmc_replicates": self.qmc_replicates,
            "confidence": self.confidence,
            "reference_angle_deg": self.reference_angle_deg,
            "capture_quantiles": list(self.capture_quantiles),
            "source": self.source,
        }


def as_scenario(scenario) -> Scenario:
    """`scenario` as a :class:`Scenario`: a Scenario is returned as it is, a path to
    a ``.toml`` file is loaded, and any other string names a shipped preset.

    Raises
    ------
    ScenarioError
        For a missing or invalid file, or an unknown preset (with a did-you-mean
        hint).
    TypeError
        For anything else.
    """
    if isinstance(scenario, Scenario):
        return scenario
    return Scenario.from_toml(scenario_file(scenario))


def scenario_file(scenario) -> Path:
    """The scenario file that `scenario` names: a path to a ``.toml`` (or any
    existing) file as it is, else the file of the shipped preset of that name.

    Raises
    ------
    ScenarioError
        For a name that is neither a scenario file nor a preset (with a
        did-you-mean hint).
    TypeError
        For anything but a str or path.
    """
    import os

    if not isinstance(scenario, str | os.PathLike):
        raise TypeError(
            "`scenario` must be a Scenario, a path to a scenario file or a preset "
            f"name; got {type(scenario).__name__}."
        )
    from .file import PRESETS, preset_path

    text = os.fspath(scenario)
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return path
    if text in PRESETS:
        return preset_path(text)
    from .._core.validation import did_you_mean

    raise ScenarioError(
        "not a scenario file and not a preset name; presets: "
        f"{', '.join(sorted(PRESETS))}{did_you_mean(text, PRESETS)}",
        source=text,
    )
