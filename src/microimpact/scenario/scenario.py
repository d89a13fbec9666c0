"""Scenarios: a complete, validated description of a Monte Carlo study.

A :class:`Scenario` holds model objects (a size distribution, the coefficient laws,
roughness-angle distributions) rather than raw numbers, so it can be built in Python
as easily as loaded from a TOML file with :meth:`Scenario.from_toml` (see
``docs/scenarios.md`` for every key). Validation happens in ``__post_init__`` and
raises :class:`~microimpact.errors.ScenarioError` naming the field, the value and what
is allowed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from .._core.reprs import html_table, value_text
from .._core.validation import did_you_mean
from ..errors import ScenarioError, ScenarioErrors
from .file import (
    PRESETS,
    file_order,
    parse_scenario,
    preset_path,
    read_toml,
    read_toml_text,
)
from .outputs import Outputs
from .parts import (
    SAMPLING_OPTIONS,
    SHADOWING_OPTIONS,
    Precision,
    SurfaceVariant,
    _choice,
    _integer,
    _number,
    _plausible_speeds,
    _positive_tuple,
)
from .sensitivity import SensitivitySettings
from .wall_law import WallLawSpec

__all__ = [
    "Scenario",
    "ScenarioFile",
    "as_scenario",
    "load_preset",
    "read_scenario",
    "scenario_file",
    "scenario_file_from_dict",
    "scenario_from_dict",
    "scenario_from_toml",
]


@dataclass(frozen=True, repr=False)
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
    #: SHA-256 of the scenario file's text (UTF-8), recorded with the file's name
    #: instead of its path in every output (set by :func:`read_scenario`).
    source_sha256: str | None = None

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
        _plausible_speeds(self.speeds_m_s, "sweep.speed_m_s")
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
        return scenario_from_toml(Path(path))

    @classmethod
    def from_preset(cls, name: str) -> Scenario:
        """A shipped preset reproducing the paper (see ``docs/presets.md``)."""
        return load_preset(name)

    def _parts_text(self) -> list[tuple[str, str]]:
        """(label, text) of each part, in the user's units (um, deg, m/s)."""

        def law(spec):
            if not isinstance(spec, dict):
                return value_text(spec)
            kind = spec.get("law", "")
            args = ", ".join(
                f"{k}={value_text(v)}" for k, v in spec.items() if k != "law"
            )
            return f"{kind}({args})"

        p = self.particles.describe()
        params = ", ".join(
            f"{k}={value_text(v)}"
            for k, v in (p.get("params") or {}).items()
            if v is not None and not isinstance(v, list | tuple)
        )
        c = self.coefficients.describe()
        coeffs = "; ".join(
            f"{k} {law(c[k])}" for k in ("k1", "k2", "v_c") if k in c
        ) + "".join(
            f"; {k} {value_text(c[k])}" for k in ("p", "q", "friction") if k in c
        )
        surfaces = ", ".join(
            f"{s.name} ({s.describe().get('kind', '?')})" for s in self.surfaces
        )

        def axis(values, unit):
            lo, hi = min(values), max(values)
            span = f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"
            return f"{span} {unit} ({len(values)})"

        sampling = f"{self.samples} impacts per point, {self.sampling}"
        if self.precision is not None:
            sampling += f", precision target on {self.precision.statistic}"
        return [
            ("particles", f"{p.get('kind', '?')}({params})"),
            ("coefficients", coeffs),
            ("surfaces", surfaces),
            ("speeds", axis(self.speeds_m_s, "m/s")),
            ("angles", axis(self.angles_deg, "deg")),
            ("sampling", f"{sampling}, shadowing {self.shadowing!r}, seed {self.seed}"),
        ]

    def __repr__(self) -> str:
        parts = "; ".join(f"{k} {v}" for k, v in self._parts_text())
        return f"<Scenario {self.name!r}: {parts}>"

    def _repr_html_(self) -> str:
        rows = self._parts_text()
        if self.description:
            rows.insert(0, ("description", self.description))
        return html_table(f"Scenario {self.name!r}", rows)

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
            # the file's name and hash, never the folders of the machine that ran it
            "source": None if self.source is None else Path(str(self.source)).name,
            "source_sha256": self.source_sha256,
        }


@dataclass(frozen=True)
class ScenarioFile:
    """A scenario file read and validated once: the physics (:attr:`scenario`) and
    the tables the other verbs use, so that no command reads the file twice.

    Attributes
    ----------
    scenario : Scenario
        The physics of the study.
    outputs : Outputs
        The ``[outputs]`` table (figure formats, report, experiment files).
    wall_law : WallLawSpec or None
        The ``[wall_law]`` table, if any.
    sensitivity : SensitivitySettings or None
        The ``[sensitivity]`` table, if any.
    data : dict
        The parsed TOML (what parameters are substituted into).
    source : str or None
        The file, as named in messages.
    base_dir : Path
        The folder relative file names resolve from.
    text : str or None
        The file's text as read (None for data that came as a dict).
    """

    scenario: Scenario
    outputs: Outputs
    wall_law: WallLawSpec | None
    sensitivity: SensitivitySettings | None
    data: dict
    source: str | None
    base_dir: Path
    text: str | None = None


def scenario_file_from_dict(
    data: dict, *, source=None, base_dir=None, cache=None, text=None
) -> ScenarioFile:
    """A :class:`ScenarioFile` from parsed TOML data (see
    :func:`~microimpact.scenario.file.parse_scenario` for the arguments); the
    Scenario's own errors are mapped onto the file's key paths."""
    parsed = parse_scenario(data, source=source, base_dir=base_dir, cache=cache)
    digest = None if text is None else hashlib.sha256(text.encode()).hexdigest()
    scenario, problems = _checked_scenario(parsed, source_sha256=digest)
    problems = file_order(data, [*parsed.problems, *problems])
    if len(problems) == 1:
        raise problems[0]
    if problems:
        raise ScenarioErrors(problems, source=parsed.source)
    return ScenarioFile(
        scenario=scenario,
        outputs=parsed.outputs,
        wall_law=parsed.wall_law,
        sensitivity=parsed.sensitivity,
        data=parsed.data,
        source=parsed.source,
        base_dir=parsed.base_dir,
        text=text,
    )


def _checked_scenario(parsed, **extra):
    """``(Scenario or None, its problems)``: each value the Scenario refuses is
    recorded and replaced by its default, and the Scenario checked again, so that
    every wrong value is reported, not only the first."""
    args = dict(parsed.arguments)
    defaults = {
        f.name: f.default
        for f in dataclasses.fields(Scenario)
        if f.default is not dataclasses.MISSING
    }
    problems = []
    for _ in range(len(args) + 1):
        try:
            return Scenario(**args, **extra), problems
        except ScenarioError as exc:
            problems.append(parsed.error(exc.field, exc.message))
            name = (exc.field or "").split(".")[0]
            if name not in defaults or args.get(name) == defaults[name]:
                return None, problems
            args[name] = defaults[name]
    return None, problems


def read_scenario(scenario, *, cache=None) -> ScenarioFile:
    """Read a scenario file (a path, or the name of a shipped preset) once into a
    :class:`ScenarioFile` (`cache`: see
    :func:`~microimpact.scenario.file.parse_scenario`).

    Raises
    ------
    ScenarioError
        File not found or unreadable, TOML syntax errors (with line and column), and
        every invalid key or value (naming the key path).
    """
    if isinstance(scenario, ScenarioFile):
        return scenario
    path = scenario_file(scenario)
    text, data = read_toml_text(path)
    return scenario_file_from_dict(
        data, source=path, base_dir=path.resolve().parent, text=text, cache=cache
    )


def scenario_from_dict(data: dict, *, source=None, base_dir=None) -> Scenario:
    """Build a :class:`Scenario` from parsed TOML data (see ``docs/scenarios.md``).

    Parameters
    ----------
    data : dict
        The scenario, as :func:`tomllib.load` returns it.
    source : str or path-like, optional
        The file `data` came from; named in every error message and recorded as
        ``Scenario.source``.
    base_dir : path-like, optional
        Folder that relative file names resolve from (default: the folder of
        `source`, else the current directory).

    Returns
    -------
    Scenario
        The physics of the study. The ``[outputs]``, ``[wall_law]`` and
        ``[sensitivity]`` tables are validated too (:func:`read_scenario` keeps
        them).

    Raises
    ------
    ScenarioError
        One line naming the file, the key path, the bad value and what is allowed.
    """
    return scenario_file_from_dict(data, source=source, base_dir=base_dir).scenario


def scenario_from_toml(path) -> Scenario:
    """Load and validate a TOML scenario file (see ``docs/scenarios.md``).

    Relative paths inside the file resolve from the file's own folder.
    """
    path = Path(path)
    return scenario_file_from_dict(
        read_toml(path), source=path, base_dir=path.resolve().parent
    ).scenario


def load_preset(name: str) -> Scenario:
    """Load a shipped preset reproducing the paper by name (see ``docs/presets.md``).

    >>> load_preset("sst65-silicon-normal").samples
    4000
    """
    return scenario_from_toml(preset_path(name))


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
    if not isinstance(scenario, str | os.PathLike):
        raise TypeError(
            "`scenario` must be a Scenario, a path to a scenario file or a preset "
            f"name; got {type(scenario).__name__}."
        )
    text = os.fspath(scenario)
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return path
    if text in PRESETS:
        return preset_path(text)
    raise ScenarioError(
        "not a scenario file and not a preset name; presets: "
        f"{', '.join(sorted(PRESETS))}{did_you_mean(text, PRESETS)}",
        source=text,
    )
