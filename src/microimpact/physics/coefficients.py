r"""Impact coefficients :math:`k_1, k_2, v_c` as laws of particle diameter.

[1]_ models the restitution of a microsphere by (Eqs. 4-6)

.. math:: R = \frac{k_1^p}{k_1^p + |v_n|^p},\quad
          \rho = \frac{k_2^q}{k_2^q + ||v_n| - v_c|^q},\quad e = R(1-\rho),

with capture (:math:`e = 0`) for :math:`|v_n| \le v_c`. The speeds :math:`k_1, k_2,
v_c` depend on the diameter; [1]_ obtains them by least-squares regression at
each diameter, then regresses each against diameter. This module provides

* law forms (callable as ``law(diameter)`` with diameter in metres, returning
  m s⁻¹): :class:`PowerLaw`, :class:`PolynomialLaw`, :class:`TableLaw`,
  :class:`ConstantLaw`, :class:`CallableLaw`, :class:`ThorntonNingLaw`;
* :class:`ImpactCoefficients`, the set of three laws plus :math:`p, q` and the
  Coulomb friction coefficient;
* :func:`law_from_dict` (scenario files), the registry :data:`LAWS` and the
  documented parameter sets :data:`COEFFICIENT_SETS`;
The least-squares fits that produce these laws from impact data live in
:mod:`microimpact.physics.fitting`.

References
----------
.. [1] X. Li, P. F. Dunn, R. M. Brach, "Monte Carlo analysis of polydisperse
   microparticle impacts with surfaces," *Aerosol Sci. Technol.* 33:376-386, 2000.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from .._core.validation import (
    as_float_array,
    check_choice,
    check_scalar,
    did_you_mean,
)
from ..errors import ScenarioError
from ..units import m_to_um, um_to_m
from . import adhesion

__all__ = [
    "COEFFICIENT_SETS",
    "LAWS",
    "CallableLaw",
    "CoefficientValues",
    "ConstantLaw",
    "ImpactCoefficients",
    "PolynomialLaw",
    "PowerLaw",
    "TableLaw",
    "ThorntonNingLaw",
    "law_from_dict",
]


# --------------------------------------------------------------------------- laws
def _um(x) -> float:
    """Metres to micrometres for describe(), without binary noise (50e-6 -> 50.0)."""
    return float(f"{float(m_to_um(x)):.12g}")


class _Law:
    """Shared evaluation: NaN where diameter <= 0, nan or inf; 0-d for scalars."""

    def __call__(self, diameter):
        d = as_float_array(diameter, "diameter")
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(d) & (d > 0)
        out = np.full(d.shape, np.nan)
        if np.any(ok):
            out[ok] = self._evaluate(d[ok])
        return out[()]

    def _evaluate(self, d: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class PowerLaw(_Law):
    r"""Power law :math:`a\,(d/d_{ref})^b`.

    Parameters
    ----------
    a : float
        Value at ``d_ref`` [m s⁻¹], >= 0.
    b : float
        Exponent [-].
    d_ref : float
        Reference diameter [m], > 0.
    """

    a: float
    b: float
    d_ref: float = 1e-6

    def __post_init__(self):
        object.__setattr__(self, "a", check_scalar(self.a, "a", minimum=0))
        object.__setattr__(self, "b", check_scalar(self.b, "b"))
        object.__setattr__(
            self,
            "d_ref",
            check_scalar(self.d_ref, "d_ref", minimum=0, strict=True),
        )

    def _evaluate(self, d):
        return self.a * (d / self.d_ref) ** self.b

    def describe(self) -> dict:
        return {
            "law": "power",
            "a_m_s": self.a,
            "b": self.b,
            "d_ref_um": _um(self.d_ref),
        }


@dataclass(frozen=True)
class PolynomialLaw(_Law):
    r"""Polynomial :math:`\sum_i c_i (d/d_{ref})^i` [m s⁻¹].

    Where the polynomial is negative (outside the range it was fitted on) the
    value is impossible for a speed and ``nan`` is returned.

    Parameters
    ----------
    coefficients : sequence of float
        :math:`c_0, c_1, \dots` [m s⁻¹], lowest order first.
    d_ref : float
        Reference diameter [m], > 0.
    """

    coefficients: tuple[float, ...]
    d_ref: float = 1e-6

    def __post_init__(self):
        try:
            coefs = tuple(self.coefficients)
        except TypeError:
            raise TypeError(
                "`coefficients` must be a sequence of numbers; "
                f"got {self.coefficients!r}."
            ) from None
        if not coefs:
            raise ValueError("`coefficients` must hold at least one number; got ().")
        coefs = tuple(
            check_scalar(c, f"coefficients[{i}]") for i, c in enumerate(coefs)
        )
        object.__setattr__(self, "coefficients", coefs)
        object.__setattr__(
            self,
            "d_ref",
            check_scalar(self.d_ref, "d_ref", minimum=0, strict=True),
        )

    def _evaluate(self, d):
        v = np.polynomial.polynomial.polyval(d / self.d_ref, self.coefficients)
        return np.where(v >= 0, v, np.nan)

    def describe(self) -> dict:
        return {
            "law": "polynomial",
            "coefficients_m_s": list(self.coefficients),
            "d_ref_um": _um(self.d_ref),
        }


_EXTRAPOLATION = ("clamp", "loglinear")


@dataclass(frozen=True)
class TableLaw(_Law):
    """Tabulated values, interpolated linearly in log(diameter)-log(value).

    Parameters
    ----------
    diameters : sequence of float
        Strictly increasing diameters [m], > 0; at least 2.
    values : sequence of float
        Values at those diameters [m s⁻¹], > 0 (the interpolation is in log).
    extrapolation : {'clamp', 'loglinear'}
        Outside the table, ``'clamp'`` holds the end value; ``'loglinear'``
        continues the end segment's power law.
    """

    diameters: tuple[float, ...]
    values: tuple[float, ...]
    extrapolation: str = "clamp"

    def __post_init__(self):
        d = as_float_array(self.diameters, "diameters").ravel()
        v = as_float_array(self.values, "values").ravel()
        if d.size < 2 or d.size != v.size:
            raise ValueError(
                "`diameters` and `values` must have the same length >= 2; "
                f"got {d.size} and {v.size}."
            )
        if not (np.all(np.isfinite(d)) and np.all(d > 0) and np.all(np.diff(d) > 0)):
            raise ValueError(
                "`diameters` must be finite, > 0 and strictly increasing; "
                f"got {d.tolist()}."
            )
        if not (np.all(np.isfinite(v)) and np.all(v > 0)):
            raise ValueError(
                "`values` must be finite and > 0 (log interpolation); "
                f"got {v.tolist()}."
            )
        check_choice(self.extrapolation, "extrapolation", _EXTRAPOLATION)
        object.__setattr__(self, "diameters", tuple(d.tolist()))
        object.__setattr__(self, "values", tuple(v.tolist()))

    def _evaluate(self, d):
        x, y = np.log(self.diameters), np.log(self.values)
        ld = np.log(d)
        out = np.interp(ld, x, y)
        if self.extrapolation == "loglinear":
            lo, hi = ld < x[0], ld > x[-1]
            out[lo] = y[0] + (ld[lo] - x[0]) * (y[1] - y[0]) / (x[1] - x[0])
            out[hi] = y[-1] + (ld[hi] - x[-1]) * (y[-1] - y[-2]) / (x[-1] - x[-2])
        return np.exp(out)

    def describe(self) -> dict:
        return {
            "law": "table",
            "diameter_um": [_um(x) for x in self.diameters],
            "value_m_s": list(self.values),
            "extrapolation": self.extrapolation,
        }


@dataclass(frozen=True)
class ConstantLaw(_Law):
    """The same value at every diameter.

    Parameters
    ----------
    value : float
        [m s⁻¹], >= 0; ``inf`` is allowed (e.g. :math:`k_1 = \\infty` gives R = 1).
    """

    value: float

    def __post_init__(self):
        object.__setattr__(
            self,
            "value",
            check_scalar(self.value, "value", minimum=0, allow_inf=True),
        )

    def _evaluate(self, d):
        return np.full(d.shape, self.value)

    def describe(self) -> dict:
        return {"law": "constant", "value_m_s": self.value}


@dataclass(frozen=True)
class CallableLaw(_Law):
    """Wrap a user function ``func(diameter [m]) -> value [m s⁻¹]``.

    The function receives a 1-d array of valid diameters and must return an
    array of the same shape (or a scalar) of finite values >= 0; anything else
    raises ``ValueError`` naming the function.
    """

    func: Callable[[np.ndarray], Any]
    name: str | None = None

    def __post_init__(self):
        if not callable(self.func):
            raise TypeError(f"`func` must be callable; got {self.func!r}.")

    def _label(self) -> str:
        return self.name or getattr(self.func, "__qualname__", repr(self.func))

    def _evaluate(self, d):
        try:
            v = np.asarray(self.func(d), dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"coefficient function {self._label()} returned a non-numeric "
                f"value: {exc}"
            ) from None
        if v.shape not in ((), d.shape):
            raise ValueError(
                f"coefficient function {self._label()} returned shape {v.shape} "
                f"for {d.shape} diameters."
            )
        if not (np.all(np.isfinite(v)) and np.all(v >= 0)):
            raise ValueError(
                f"coefficient function {self._label()} returned values that are "
                "not finite and >= 0."
            )
        return np.broadcast_to(v, d.shape)

    def describe(self) -> dict:
        return {"law": "callable", "func": self._label()}


@dataclass(frozen=True)
class ThorntonNingLaw(_Law):
    """Capture velocity from the JKR sticking velocity of Thornton & Ning (1998).

    See :func:`microimpact.physics.adhesion.thornton_ning_sticking_velocity`.

    Parameters
    ----------
    density : float
        Particle density [kg m⁻³].
    contact_modulus : float
        :math:`E^*` [Pa].
    work_of_adhesion : float
        Dupré work of adhesion [J m⁻²] (pull-off force 3/2 π w R).
    particle, surface : str, optional
        Material names, kept for provenance only.
    """

    density: float
    contact_modulus: float
    work_of_adhesion: float
    particle: str | None = None
    surface: str | None = None

    def __post_init__(self):
        object.__setattr__(
            self,
            "density",
            check_scalar(self.density, "density", minimum=0, strict=True),
        )
        object.__setattr__(
            self,
            "contact_modulus",
            check_scalar(
                self.contact_modulus, "contact_modulus", minimum=0, strict=True
            ),
        )
        object.__setattr__(
            self,
            "work_of_adhesion",
            check_scalar(self.work_of_adhesion, "work_of_adhesion", minimum=0),
        )

    def _evaluate(self, d):
        return adhesion.thornton_ning_sticking_velocity(
            d, self.density, self.contact_modulus, self.work_of_adhesion
        )

    def describe(self) -> dict:
        out = {
            "law": "thornton_ning",
            "density_kg_m3": self.density,
            "contact_modulus_Pa": self.contact_modulus,
            "work_of_adhesion_J_m2": self.work_of_adhesion,
        }
        out.update(
            {
                k: v
                for k, v in (("particle", self.particle), ("surface", self.surface))
                if v
            }
        )
        return out


def _coerce_law(x, name):
    if isinstance(x, numbers.Real) and not isinstance(x, bool):
        return ConstantLaw(float(x))
    if callable(x):
        return x if hasattr(x, "describe") else CallableLaw(x)
    raise TypeError(
        f"`{name}` must be a number or a law (callable of diameter); got {x!r}."
    )


class CoefficientValues(NamedTuple):
    """Coefficient values at given diameters [m s⁻¹]."""

    k1: np.ndarray
    k2: np.ndarray
    v_c: np.ndarray


@dataclass(frozen=True)
class ImpactCoefficients:
    """The diameter laws of the impact model of [1]_ and its exponents.

    Parameters
    ----------
    k1, k2, v_c : law or float
        Laws of diameter [m] -> [m s⁻¹]; plain numbers become :class:`ConstantLaw`.
    p, q : float
        Exponents of Eqs. 4-5 of [1]_ (the paper uses 1), > 0.
    friction : float
        Coulomb friction coefficient for sliding at the end of contact, >= 0;
        ``inf`` means the sphere always leaves rolling (μ = μ₀, Eq. 3 of [1]_).
    """

    k1: Any
    k2: Any
    v_c: Any
    p: float = 1.0
    q: float = 1.0
    friction: float = math.inf

    def __post_init__(self):
        for name in ("k1", "k2", "v_c"):
            object.__setattr__(self, name, _coerce_law(getattr(self, name), name))
        object.__setattr__(self, "p", check_scalar(self.p, "p", minimum=0, strict=True))
        object.__setattr__(self, "q", check_scalar(self.q, "q", minimum=0, strict=True))
        object.__setattr__(
            self,
            "friction",
            check_scalar(self.friction, "friction", minimum=0, allow_inf=True),
        )

    def evaluate(self, diameter) -> CoefficientValues:
        """``(k1, k2, v_c)`` at `diameter` [m], ndarrays [m s⁻¹], NaN where d <= 0."""
        return CoefficientValues(
            self.k1(diameter), self.k2(diameter), self.v_c(diameter)
        )

    def describe(self) -> dict:
        # __post_init__ coerces every law to one with describe() (_coerce_law)
        return {
            "k1": self.k1.describe(),
            "k2": self.k2.describe(),
            "v_c": self.v_c.describe(),
            "p": self.p,
            "q": self.q,
            "friction": self.friction,
        }

    @classmethod
    def from_dict(
        cls, spec: dict, *, source=None, field: str | None = None
    ) -> ImpactCoefficients:
        """Build from a scenario table.

        Either ``{k1 = {...}, k2 = {...}, v_c = {...}, p, q, friction}`` (law tables
        as for :func:`law_from_dict`, or plain numbers [m/s]) or ``{set = "<name of
        COEFFICIENT_SETS>"}``, in which case the other keys override the set.
        """
        where = field or "coefficients"
        if not isinstance(spec, dict):
            raise ScenarioError(
                f"must be a table; got {spec!r}.", source=source, field=where
            )
        spec = dict(spec)
        if "set" in spec:
            name = spec.pop("set")
            if name not in COEFFICIENT_SETS:
                raise ScenarioError(
                    f"unknown coefficient set {name!r}; allowed: "
                    f"{', '.join(sorted(COEFFICIENT_SETS))}"
                    + did_you_mean(name, COEFFICIENT_SETS),
                    source=source,
                    field=f"{where}.set",
                )
            base = {k: v for k, v in COEFFICIENT_SETS[name].items() if k != "source"}
            spec = {**base, **spec}
        _check_keys(spec, {"k1", "k2", "v_c"}, {"p", "q", "friction"}, source, where)
        kwargs = {}
        for key in ("k1", "k2", "v_c"):
            value = spec[key]
            if isinstance(value, dict):
                kwargs[key] = law_from_dict(
                    value, source=source, field=f"{where}.{key}"
                )
            elif (
                isinstance(value, numbers.Real)
                and not isinstance(value, bool)
                and value >= 0
            ):
                kwargs[key] = float(value)
            else:
                raise ScenarioError(
                    f"must be a law table or a number >= 0 [m/s]; got {value!r}.",
                    source=source,
                    field=f"{where}.{key}",
                )
        for key in ("p", "q", "friction"):
            if key in spec:
                kwargs[key] = spec[key]
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise ScenarioError(str(exc), source=source, field=where) from None

    @classmethod
    def from_set(cls, name: str) -> ImpactCoefficients:
        """Build one of the documented :data:`COEFFICIENT_SETS`."""
        if name not in COEFFICIENT_SETS:
            raise ValueError(
                f"`name` must be one of {sorted(COEFFICIENT_SETS)}; got {name!r}."
                + did_you_mean(name, COEFFICIENT_SETS)
            )
        return cls.from_dict({"set": name}, field=f"COEFFICIENT_SETS[{name!r}]")


# ------------------------------------------------------------------ law_from_dict
class _SpecError(Exception):
    def __init__(self, key, message):
        super().__init__(message)
        self.key, self.message = key, message


def _check_keys(params, required, optional, source=None, where=None):
    allowed = set(required) | set(optional)
    for key in params:
        if key not in allowed:
            msg = (
                f"unknown key {key!r}; allowed: {', '.join(sorted(allowed))}"
                + did_you_mean(key, allowed)
            )
            if where is None:
                raise _SpecError(key, msg)
            raise ScenarioError(msg, source=source, field=f"{where}.{key}")
    for key in sorted(required):
        if key not in params:
            need = ", ".join(sorted(required))
            msg = f"missing required key {key!r} (required: {need})"
            if where is None:
                raise _SpecError(key, msg)
            raise ScenarioError(msg, source=source, field=f"{where}.{key}")


def _num(params, key, *, low=None, strict=False, default=None):
    """``params[key]`` checked by :func:`check_scalar` (`default` if absent); an
    error names the key (:class:`_SpecError`)."""
    if key not in params:
        return default
    try:
        return check_scalar(params[key], key, minimum=low, strict=strict)
    except (TypeError, ValueError) as exc:
        raise _SpecError(key, str(exc)) from None


def _num_list(params, key, *, low=None, strict=False):
    x = params[key]
    if not isinstance(x, (list, tuple)) or not x:
        raise _SpecError(key, f"must be a non-empty list of numbers; got {x!r}")
    return [_num({key: v}, key, low=low, strict=strict) for v in x]


def _build_power(params):
    _check_keys(params, {"a_m_s", "b"}, {"d_ref_um"})
    return PowerLaw(
        _num(params, "a_m_s", low=0),
        _num(params, "b"),
        float(um_to_m(_num(params, "d_ref_um", low=0, strict=True, default=1.0))),
    )


def _build_constant(params):
    _check_keys(params, {"value_m_s"}, set())
    return ConstantLaw(_num(params, "value_m_s", low=0))


def _build_polynomial(params):
    _check_keys(params, {"coefficients_m_s"}, {"d_ref_um"})
    d_ref = float(um_to_m(_num(params, "d_ref_um", low=0, strict=True, default=1.0)))
    return PolynomialLaw(tuple(_num_list(params, "coefficients_m_s")), d_ref)


def _build_table(params):
    _check_keys(params, {"diameter_um", "value_m_s"}, {"extrapolation"})
    d = _num_list(params, "diameter_um", low=0, strict=True)
    v = _num_list(params, "value_m_s", low=0, strict=True)
    extrapolation = params.get("extrapolation", "clamp")
    if extrapolation not in _EXTRAPOLATION:
        raise _SpecError(
            "extrapolation",
            f"must be one of {', '.join(_EXTRAPOLATION)}; got {extrapolation!r}",
        )
    if len(d) != len(v) or len(d) < 2:
        raise _SpecError(
            "value_m_s",
            "must have the same length (>= 2) as diameter_um; "
            f"got {len(v)} and {len(d)}",
        )
    if any(b <= a for a, b in itertools.pairwise(d)):
        raise _SpecError("diameter_um", f"must be strictly increasing; got {d}")
    return TableLaw(tuple(um_to_m(np.array(d)).tolist()), tuple(v), extrapolation)


def _build_thornton_ning(params):
    _check_keys(
        params,
        set(),
        {
            "particle",
            "surface",
            "work_of_adhesion_J_m2",
            "density_kg_m3",
            "contact_modulus_Pa",
        },
    )
    mats = {}
    for key in ("particle", "surface"):
        if key in params:
            try:
                mats[key] = adhesion.material(params[key])
            except (TypeError, ValueError) as exc:
                raise _SpecError(key, str(exc)) from None
    density = _num(params, "density_kg_m3", low=0, strict=True)
    if density is None:
        if "particle" not in mats:
            raise _SpecError(
                "particle", "give 'particle' (a material name) or 'density_kg_m3'"
            )
        density = mats["particle"].density
    e_star = _num(params, "contact_modulus_Pa", low=0, strict=True)
    if e_star is None:
        for key in ("particle", "surface"):
            if key not in mats:
                raise _SpecError(
                    key, f"give '{key}' (a material name) or 'contact_modulus_Pa'"
                )
        a, b = mats["particle"], mats["surface"]
        e_star = float(
            adhesion.contact_modulus(
                a.youngs_modulus, a.poisson_ratio, b.youngs_modulus, b.poisson_ratio
            )
        )
    w = _num(params, "work_of_adhesion_J_m2", low=0)
    if w is None:
        gammas = [
            getattr(mats.get(k), "surface_energy", None)
            for k in ("particle", "surface")
        ]
        if None in gammas:
            raise _SpecError(
                "work_of_adhesion_J_m2",
                "required: the surface energy of the particle or surface material "
                "is not known "
                "(Dupré work of adhesion, J/m^2; JKR pull-off force = 1.5*pi*w*R)",
            )
        w = float(adhesion.geometric_mean_work_of_adhesion(*gammas))
    return ThorntonNingLaw(
        density,
        e_star,
        w,
        particle=getattr(mats.get("particle"), "name", None),
        surface=getattr(mats.get("surface"), "name", None),
    )


#: Law name -> builder. A builder takes the law's parameter dict (the spec
#: without its ``"law"`` key, unit-suffixed keys) and returns a callable law;
#: it may raise ``ValueError``/``TypeError``, reported as :class:`ScenarioError`.
#: Register your own with ``LAWS["mine"] = lambda params: MyLaw(**params)``.
LAWS: dict[str, Callable[[dict], Any]] = {
    "power": _build_power,
    "constant": _build_constant,
    "polynomial": _build_polynomial,
    "table": _build_table,
    "thornton_ning": _build_thornton_ning,
}


def law_from_dict(spec: dict, *, source=None, field: str | None = None):
    """Build a coefficient law from a plain dict such as a TOML scenario table.

    Examples of `spec`::

        {"law": "power", "a_m_s": 0.05, "b": -1.2, "d_ref_um": 50}
        {"law": "constant", "value_m_s": 0.2}
        {"law": "polynomial", "coefficients_m_s": [0.3, -0.1], "d_ref_um": 50}
        {"law": "table", "diameter_um": [20, 50, 80], "value_m_s": [0.4, 0.2, 0.1],
         "extrapolation": "clamp"}
        {"law": "thornton_ning", "particle": "stainless_steel", "surface": "silicon",
         "work_of_adhesion_J_m2": 0.4}

    Parameters
    ----------
    spec : dict
        ``"law"`` names a builder of :data:`LAWS`; the other keys are its parameters.
    source : str or path-like, optional
        The file `spec` came from (for messages).
    field : str, optional
        The key path of `spec` in that file, e.g. ``"coefficients.k1"``.

    Raises
    ------
    ScenarioError
        Naming ``field.<key>``, the bad value and what is allowed.
    """
    where = field or "law"
    if not isinstance(spec, dict):
        raise ScenarioError(
            f"must be a table with a 'law' key; got {spec!r}.",
            source=source,
            field=where,
        )
    name = spec.get("law")
    if name not in LAWS:
        msg = (
            f"unknown law {name!r}; allowed: {', '.join(sorted(LAWS))}"
            if "law" in spec
            else "missing key 'law'"
        )
        if "law" not in spec:
            msg += f" (one of: {', '.join(sorted(LAWS))})"
        raise ScenarioError(
            msg + did_you_mean(name, LAWS), source=source, field=f"{where}.law"
        )
    params = {k: v for k, v in spec.items() if k != "law"}
    try:
        return LAWS[name](params)
    except _SpecError as exc:
        raise ScenarioError(
            exc.message, source=source, field=f"{where}.{exc.key}"
        ) from None
    except (TypeError, ValueError, KeyError) as exc:
        raise ScenarioError(str(exc), source=source, field=where) from None


# ---------------------------------------------------------------- parameter sets
#: Documented parameter sets, each usable as ``ImpactCoefficients.from_set(name)``.
#: The paper [1] does not print its regressions of k1, k2, v_c; the sets below
#: are labelled illustrative or derived, with every number's origin stated.
COEFFICIENT_SETS: dict[str, dict] = {
    "li2000_sst_silicon_illustrative": {
        # k1: ASSUMPTION (illustrative), R = 0.91 at 1 m/s; not given in [1].
        "k1": {"law": "constant", "value_m_s": 10.0},
        # k2: ASSUMPTION (illustrative); sets how sharply e drops as v_n -> v_c,
        # which [1] describes as a narrow transition. Not given in [1].
        "k2": {"law": "constant", "value_m_s": 0.02},
        # v_c: power law through the two 50 %-capture speeds quoted in [1]'s text:
        # 0.20 m/s for SST65 (mean diameter 52.8 um, Gaussian fit) and 0.13 m/s for
        # SST125 (nominal 64-76 um, ASSUMED 70 um). Identifying the population's
        # 50 %-capture speed with v_c at the mean diameter is an ASSUMPTION.
        # b = ln(0.13/0.20) / ln(70/52.8) = -1.5277.
        "v_c": {"law": "power", "a_m_s": 0.20, "b": -1.5277, "d_ref_um": 52.8},
        "p": 1.0,  # [1], "it is assumed that q = p = 1"
        "q": 1.0,  # [1], idem
        # friction: [1], Fig. 8 text: on the smooth surface the impulse ratio
        # becomes constant, 0.15, at low incidence angles, i.e. sliding at mu.
        "friction": 0.15,
        "source": "Illustrative set anchored on numbers quoted in the text of Li, Dunn "
        "& Brach (2000): v_c through the 50%-capture speeds 0.20 m/s (52.8 um) and "
        "0.13 m/s (~70 um); friction 0.15 from the Fig. 8 discussion. k1 and k2 are "
        "assumptions, not the paper's regressions (which it does not print).",
    },
    "thornton_ning_ss304_silicon": {
        "k1": {"law": "constant", "value_m_s": 10.0},  # ASSUMPTION, as above
        "k2": {"law": "constant", "value_m_s": 0.02},  # ASSUMPTION, as above
        # v_c: Thornton & Ning (1998) Eq. 54 with SS304 on silicon properties from
        # adhesion.MATERIALS; work of adhesion 0.4 J/m^2 is an ASSUMPTION at the
        # upper value used in their worked examples (Figs. 9-10: 0.2 and 0.4 J/m^2).
        # It gives v_c ~ 0.014 m/s at 50 um, about 14x below [1]'s ~0.2 m/s: the
        # elastic JKR estimate underpredicts capture (cf. Wall et al. 1990 in [1]).
        "v_c": {
            "law": "thornton_ning",
            "particle": "stainless_steel_304",
            "surface": "silicon",
            "work_of_adhesion_J_m2": 0.4,
        },
        "p": 1.0,  # [1]
        "q": 1.0,  # [1]
        "friction": 0.15,  # [1], Fig. 8 text (see above)
        "source": "Physically based v_c from Thornton & Ning (1998), Powder Technol. "
        "99:154, with handbook properties and an ASSUMED work of adhesion 0.4 J/m^2; "
        "k1, k2 illustrative assumptions.",
    },
    "no_adhesion_illustrative": {
        "k1": {"law": "constant", "value_m_s": 10.0},  # ASSUMPTION
        "k2": {"law": "constant", "value_m_s": 0.0},  # no adhesion: rho = 0
        "v_c": {"law": "constant", "value_m_s": 0.0},  # no capture
        "p": 1.0,
        "q": 1.0,
        "friction": math.inf,  # always rolling at the end of contact
        "source": "Illustrative adhesion-free set (e = R only); useful for checks.",
    },
}
