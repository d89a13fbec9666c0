"""Scenario files: shared constants and the validation context.

Part of :mod:`microimpact.scenario.file`, split out to keep modules small.
"""

from __future__ import annotations

import math
import numbers
import re
from pathlib import Path

from .._core.validation import as_field_error, check_choice, check_int, did_you_mean
from ..errors import InputError, ScenarioError, _one_line
from ..units import LENGTH_UNITS

#: Folder of the shipped preset scenario files.
PRESET_DIR = Path(__file__).resolve().parent / "presets"
#: Preset name -> scenario file in :data:`PRESET_DIR` (see ``docs/presets.md``).
PRESETS: dict[str, str] = {
    "sst65-silicon-normal": "sst65-silicon-normal.toml",
    "sst125-silicon-normal": "sst125-silicon-normal.toml",
    "sst76-formica-oblique": "sst76-formica-oblique.toml",
    "lycopodium-formica-oblique": "lycopodium-formica-oblique.toml",
    "sst76-formica-areal": "sst76-formica-areal.toml",
}
#: The presets that reproduce the paper (what `microimpact reproduce` runs); the
#: others carry its cases beyond it.
PAPER_PRESETS = (
    "sst65-silicon-normal",
    "sst125-silicon-normal",
    "sst76-formica-oblique",
    "lycopodium-formica-oblique",
)

TOP_KEYS = (
    "name",
    "description",
    "seed",
    "samples",
    "precision",
    "shadowing",
    "sampling",
    "qmc_replicates",
    "confidence",
    "reference_angle_deg",
    "capture_quantiles",
    "particles",
    "coefficients",
    "surfaces",
    "surface",
    "particle_roughness",
    "sweep",
    "outputs",
    "wall_law",
    "sensitivity",
    "resuspension",
    "calibration",  # read by `calibrate --method bayes` (its priors); others skip it
)
PARTICLE_KEYS = {
    "normal": ({"mean_um", "std_um"}, {"min_um", "max_um"}),
    # one median of MEDIAN_KEYS (checked in file._particles); density and shape
    # factor only with an MMAD
    "lognormal": (
        {"geometric_std"},
        {
            "median_um",
            "mass_median_um",
            "mmad_um",
            "density_kg_m3",
            "shape_factor",
            "min_um",
            "max_um",
        },
    ),
    "uniform": ({"min_um", "max_um"}, set()),
    "monodisperse": ({"diameter_um"}, set()),
    "empirical": (
        set(),
        {"file", "diameters_um", "column", "unit", "min_um", "max_um"},
    ),
    "histogram": (
        set(),
        {"file", "edges_um", "counts", "unit", "layout", "values", "column", "sample"},
    ),
}
#: Keys of kind = "areal" (see _config_surfaces._areal).
AREAL_SYNTHETIC_KEYS = (
    ("rms_um", "corr_x_um", "nx", "ny", "dx_um", "seed"),
    ("corr_y_um", "dy_um"),
)
AREAL_FILE_KEYS = ("dx_um", "dy_um", "z_unit", "delimiter", "format")
AREAL_PATCHES = ("disc", "square")
AREAL_LEVEL = ("plane", "none")
SURFACE_KEYS = {
    "smooth": (set(), set()),
    "angles": (set(), {"file", "angles_deg"}),
    "normal": ({"std_deg"}, {"mean_deg"}),
    "scipy": ({"distribution"}, {"shapes", "loc_deg", "scale_deg"}),
    "profile": (
        {"file", "contact_length_um"},
        {
            "method",
            "detrend",
            "cutoff_um",
            "x_column",
            "z_column",
            "scan_column",
            "unit",
            "x_unit",
            "z_unit",
            "dx_um",
        },
    ),
    "synthetic": (
        {"contact_length_um"},
        {
            "profile",
            "method",
            "detrend",
            "cutoff_um",
            "n_points",
            "dx_um",
            "rms_height_um",
            "correlation_length_um",
            "seed",
        },
    ),
    # areal: a height map (file) or a seeded Gaussian areal surface (synthetic);
    # exactly one of file/synthetic and one of the contact keys is checked there
    "areal": (
        set(),
        {
            "file",
            "synthetic",
            "contact_diameter_um",
            "contact_length_um",
            "azimuth_deg",
            "azimuth",
            "azimuth_seed",
            "patch",
            "step_um",
            "level",
            "min_coverage",
            *AREAL_FILE_KEYS,
        },
    ),
}
COEFFICIENT_KEYS = ("set", "k1", "k2", "v_c", "p", "q", "friction")
SWEEP_KEYS = ("speed_m_s", "angle_deg", "speed_spread")
PRECISION_KEYS = ("statistic", "half_width", "max_samples", "min_samples")
OUTPUT_KEYS = ("figures", "report", "experiments", "distribution_speed_m_s")
WALL_LAW_KEYS = (
    "diameter_um",
    "speed_m_s",
    "angle_deg",
    "reservoir",
    "samples",
    "speed_axis",
    "reduced_speed",
    "fallback_at",
)
#: Keys of ``[wall_law] fallback_at``: the condition whose mean coefficients a
#: compiler-less OpenFOAM fallback applies.
FALLBACK_KEYS = ("diameter_um", "speed_m_s", "angle_deg")
SPACINGS = ("linear", "log")
ANGLE_METHODS = ("slope", "paper")
DETREND = ("line", "mean", "none")
SYNTHETIC_PROFILES = ("formica", "gaussian")
#: Largest number of sweep values a range table may generate.
MAX_SWEEP_POINTS = 100_000

_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_TOML_EOF = re.compile(r"\s*\(at end of document\)\s*$")
_BACKTICKED = re.compile(r"`([A-Za-z_][A-Za-z0-9_]*)`")


# ---------------------------------------------------------------------- helpers
def _show(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _type_name(value) -> str:
    return {
        bool: "a boolean",
        int: "an integer",
        float: "a number",
        str: "a string",
        list: "an array",
        dict: "a table",
    }.get(type(value), type(value).__name__)


class _Ctx:
    """Where the data came from: the file for messages, the folder for paths."""

    def __init__(self, source, base_dir, cache=None):
        self.source = None if source is None else str(source)
        self.base_dir = Path(base_dir) if base_dir is not None else Path.cwd()
        self.cache = cache
        #: The problems found so far, where the file is read table by table
        #: (:meth:`attempt`): all of them are reported together.
        self.problems: list[ScenarioError] = []

    def attempt(self, build, *args, fallback=None, **kwargs):
        """``build(*args, **kwargs)``, or `fallback` after recording its
        ScenarioError in :attr:`problems`, so that the rest of the file is still
        checked."""
        try:
            return build(*args, **kwargs)
        except ScenarioError as exc:
            self.problems.append(exc)
            return fallback

    def cached(self, where, table, build, *args):
        """``build(self, *args)``, the model object of the table `table` at key
        path `where`; with a cache, built once per content of the table (and
        folder its file names resolve from) and given back unchanged after."""
        if self.cache is None:
            return build(self, *args)
        try:
            key = (where, _frozen(table), str(self.base_dir))
        except TypeError:  # not plain TOML data: build it, the checks name it
            return build(self, *args)
        if key not in self.cache:
            self.cache[key] = build(self, *args)
        return self.cache[key]

    def error(self, key, message) -> ScenarioError:
        return ScenarioError(_one_line(message), source=self.source, field=key)

    # -- structure ----------------------------------------------------------
    def table(self, value, key) -> dict:
        if not isinstance(value, dict):
            raise self.error(key, f"must be a table; got {_type_name(value)}")
        return value

    def keys(self, table, where, allowed, required=()):
        allowed = tuple(allowed)
        for key in table:
            if key not in allowed:
                raise self.error(
                    _join(where, key),
                    f"unknown key {key!r}{did_you_mean(key, allowed)}; "
                    f"allowed: {', '.join(sorted(allowed))}",
                )
        for key in sorted(required):
            if key not in table:
                raise self.error(_join(where, key), "missing required key")

    def kind(self, table, where, key, kinds, also=()):
        """The value of `key` in `table`, one of the keys of `kinds` (kind ->
        ``(required keys, optional keys)``), after checking the table's keys against
        that kind (`also`: further keys every kind allows)."""
        if key not in table:
            # a misspelt key is reported as unknown (with did-you-mean) before the
            # missing key it probably is
            known = {key, *also}.union(*(r | o for r, o in kinds.values()))
            self.keys(table, where, known)
            raise self.error(
                _join(where, key),
                f"missing required key (one of: {', '.join(kinds)})",
            )
        kind = self.choice(table[key], _join(where, key), tuple(kinds))
        required, optional = kinds[kind]
        self.keys(table, where, {key, *also} | required | optional, required)
        return kind

    # -- scalars ------------------------------------------------------------
    def number(self, value, key, *, low=None, strict=False, high=None, inf=False):
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if not ok:
            raise self.error(
                key, f"must be a number; got {_type_name(value)} {_show(value)}"
            )
        x = float(value)
        if math.isnan(x) or (math.isinf(x) and not inf):
            raise self.error(key, f"must be a finite number; got {_show(value)}")
        if low is not None and (x <= low if strict else x < low):
            raise self.error(
                key, f"must be {'>' if strict else '>='} {low:g}; got {_show(value)}"
            )
        if high is not None and x > high:
            raise self.error(key, f"must be <= {high:g}; got {_show(value)}")
        return x

    def get_number(self, table, where, key, **kw):
        """:meth:`number` of ``table[key]`` (key path ``where.key``); None if absent."""
        if key not in table:
            return None
        return self.number(table[key], _join(where, key), **kw)

    def integer(self, value, key, *, low=0):
        with as_field_error(key, ScenarioError, source=self.source):
            return check_int(value, key, minimum=low)

    def string(self, value, key):
        if not isinstance(value, str) or not value.strip():
            raise self.error(
                key,
                f"must be a non-empty string; got {_type_name(value)} {_show(value)}",
            )
        return value

    def choice(self, value, key, options):
        with as_field_error(key, ScenarioError, source=self.source):
            return check_choice(value, key, options)

    def numbers(self, value, key, *, low=None, strict=False, minimum=1):
        if not isinstance(value, list):
            raise self.error(
                key, f"must be an array of numbers; got {_type_name(value)}"
            )
        if len(value) < minimum:
            raise self.error(
                key, f"must hold at least {minimum} value(s); got {len(value)}"
            )
        return [
            self.number(v, f"{key}[{i}]", low=low, strict=strict)
            for i, v in enumerate(value)
        ]

    def column(self, value, key):
        """A column of a data file: its name or its 0-based index."""
        if isinstance(value, bool) or not isinstance(value, str | int):
            raise self.error(
                key, f"must be a column name or a 0-based index; got {_show(value)}"
            )
        return value

    def unit(self, value, key):
        return self.choice(value, key, tuple(LENGTH_UNITS))

    def path(self, value, key) -> Path:
        text = self.string(value, key)
        p = Path(text).expanduser()
        if not p.is_absolute():
            p = self.base_dir / p
        if not p.is_file():
            where = "" if Path(text).is_absolute() else f" (resolved to {p})"
            if p.is_dir():
                raise self.error(key, f"{text!r} is a directory, not a file{where}")
            raise self.error(key, f"file not found: {text!r}{where}")
        return p

    # -- factories ----------------------------------------------------------
    def build(self, where, table, func, *args, **kwargs):
        """Call a model factory; turn its errors into a ScenarioError that names
        the scenario file and the key path (the key named in the message if any)."""
        try:
            return func(*args, **kwargs)
        except InputError as exc:  # a data file: keep its own file/line in the text
            raise self.error(where, str(exc)) from None
        except (ValueError, TypeError, KeyError, OSError) as exc:
            msg = str(exc).strip("'\"")
            key = where
            for name in _BACKTICKED.findall(msg):
                if name in table:
                    key = _join(where, name)
                    break
            raise self.error(key, msg) from None


def _frozen(value):
    """Plain TOML data as a hashable value (tables and arrays as tuples)."""
    if isinstance(value, dict):
        return ("{", tuple((k, _frozen(v)) for k, v in value.items()))
    if isinstance(value, list | tuple):
        return ("[", tuple(_frozen(v) for v in value))
    hash(value)
    return (type(value).__name__, value)


def _join(where, key) -> str:
    return f"{where}.{key}" if where else key
