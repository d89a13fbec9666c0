"""Scenario parameters addressed by dotted keys, for sensitivity and calibration.

A *parameter* is one number of a scenario file, named by its dotted path in the
parsed TOML data::

    particles.median_um            [particles] median_um = 10
    coefficients.friction          [coefficients] friction = 0.15
    coefficients.k1                [coefficients] k1 = 4.0 (a plain number)
    coefficients.v_c.a_m_s         [coefficients] v_c = {law = "power", a_m_s = 0.2}
    surfaces.formica.std_deg       the [[surfaces]] entry whose name is "formica"
    particle_roughness.std_deg     [particle_roughness] std_deg = 3
    sweep.speed_spread             [sweep] speed_spread = 0.05
    confidence                     a top-level key

Entries of the ``[[surfaces]]`` array are addressed by their ``name`` (which
defaults to their ``kind``, as in the scenario). The key must exist in the data and
hold a number (an integer or a float, not a boolean, string, array or table);
anything else is a :class:`~microimpact.errors.ScenarioError` naming the key, with a
"did you mean" among the numeric keys of the data.

:func:`with_values` only replaces numbers: the scenario built from its result by
:func:`~microimpact.scenario.file.scenario_from_dict` validates the new values, so a
value out of range gets the scenario's own one-line message naming the key::

    scenario = scenario_from_dict(with_values(data, {"particles.median_um": 12}),
                                  source=path)

(This module imports no other layer, so the scenario configuration may use it.)
"""

from __future__ import annotations

import copy
import numbers
from collections.abc import Iterator, Mapping

from .._core.validation import did_you_mean
from ..errors import ScenarioError

__all__ = [
    "NOT_PARAMETERS",
    "check_parameter_key",
    "get_value",
    "numeric_keys",
    "with_values",
]

#: Keys (and tables, with everything under them) that cannot be parameters: they
#: fix the sweep points, the sampling or the reporting, which must be the same at
#: every parameter value. ``sweep.speed_spread`` is physics and may vary.
NOT_PARAMETERS = (
    "seed",
    "samples",
    "qmc_replicates",
    "confidence",
    "reference_angle_deg",
    "capture_quantiles",
    "precision",
    "outputs",
    "wall_law",
    "sensitivity",
    "sweep.speed_m_s",
    "sweep.angle_deg",
)


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _entry_name(entry) -> str | None:
    """The name a ``[[surfaces]]`` entry is addressed by (its ``name``, default its
    ``kind``, as the scenario names it)."""
    if not isinstance(entry, dict):
        return None
    name = entry.get("name", entry.get("kind"))
    return name if isinstance(name, str) else None


def _walk(value, prefix: str) -> Iterator[tuple[str, object]]:
    """``(dotted key, value)`` of every leaf below `value` (tables, and arrays of
    named tables; other arrays are leaves)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _walk(v, f"{prefix}.{k}" if prefix else str(k))
    elif (
        isinstance(value, list)
        and value
        and all(_entry_name(e) is not None for e in value)
    ):
        for entry in value:
            yield from _walk(entry, f"{prefix}.{_entry_name(entry)}")
    else:
        yield prefix, value


def numeric_keys(data: Mapping) -> list[str]:
    """Every dotted key of `data` that holds a number (the keys a parameter may
    name), in file order."""
    return [k for k, v in _walk(data, "") if _is_number(v)]


def _error(key, message, source) -> ScenarioError:
    return ScenarioError(message, source=source, field=key)


def _locate(data, key: str, source=None):
    """``(container, slot)`` holding `key` in `data`: ``container[slot]`` is its
    value. Raises ScenarioError (with did-you-mean) if there is no such key."""
    if not isinstance(key, str) or not key.strip():
        raise _error(
            str(key), f"a parameter must be a dotted scenario key; got {key!r}", source
        )
    parts = key.split(".")
    node, i = data, 0
    while True:
        part = parts[i]
        if isinstance(node, dict):
            if part not in node:
                raise _missing(data, key, source)
            if i == len(parts) - 1:
                return node, part
            node, i = node[part], i + 1
        elif isinstance(node, list):  # [[surfaces]]: entries by name (dots allowed)
            names = [_entry_name(e) for e in node]
            for j in range(len(parts), i, -1):
                if ".".join(parts[i:j]) in names:
                    break
            else:
                raise _missing(data, key, source)
            entry = node[names.index(".".join(parts[i:j]))]
            if j == len(parts):
                raise _not_number(key, entry, source)
            node, i = entry, j
        else:  # below a number or a string
            raise _missing(data, key, source)


def _missing(data, key, source) -> ScenarioError:
    keys = numeric_keys(data)
    return _error(
        key,
        f"no such number in the scenario{did_you_mean(key, keys)}; "
        "a parameter names a number of the file by its dotted key, e.g. "
        "'particles.median_um' or 'surfaces.<name>.std_deg'",
        source,
    )


def _not_number(key, value, source) -> ScenarioError:
    if isinstance(value, dict | list):
        what = "a table" if isinstance(value, dict) else "an array"
        inner = [k for k, v in _walk(value, key) if _is_number(v)]
        hint = f"; name one of its numbers: {', '.join(inner[:6])}" if inner else ""
        return _error(key, f"is {what}, not a number{hint}", source)
    return _error(key, f"is not a number (it holds {value!r})", source)


def get_value(data: Mapping, key: str, *, source=None) -> float:
    """The number at dotted `key` of the parsed scenario `data`.

    Raises
    ------
    ScenarioError
        The key does not exist (with a "did you mean" among the numeric keys), or
        it does not hold a number (a table gets the list of its numbers).
    """
    container, slot = _locate(data, key, source)
    value = container[slot]
    if not _is_number(value):
        raise _not_number(key, value, source)
    return value


def with_values(data: Mapping, values: Mapping[str, float], *, source=None) -> dict:
    """A deep copy of the parsed scenario `data` with the numbers at the dotted
    keys of `values` replaced (`data` is not changed).

    A whole-number value replacing an integer stays an integer (so integer keys
    keep their type); other values are stored as floats. The values are not
    validated here: build the scenario
    (:func:`~microimpact.scenario.file.scenario_from_dict`) for that.

    Raises
    ------
    ScenarioError
        A key that does not exist or does not hold a number, or a value that is not
        a real number, naming the key.
    """
    out = copy.deepcopy(dict(data))
    for key, value in values.items():
        container, slot = _locate(out, key, source)
        old = container[slot]
        if not _is_number(old):
            raise _not_number(key, old, source)
        if not _is_number(value):
            raise _error(key, f"the new value must be a number; got {value!r}", source)
        if isinstance(old, int) and float(value).is_integer():
            container[slot] = int(value)
        else:
            container[slot] = float(value)
    return out


def check_parameter_key(data: Mapping, key: str, *, source=None, where=None) -> float:
    """The file value of the parameter at dotted `key` of the parsed scenario
    `data`, after checking that it may vary (it is a number, and neither it nor its
    table is one of :data:`NOT_PARAMETERS`); `where` is the key path named in the
    message (default: the key).

    Raises
    ------
    ScenarioError
        Naming `where`, the reason and what may vary instead.
    """
    where = key if where is None else where
    for bad in NOT_PARAMETERS:
        if key == bad or str(key).startswith(bad + "."):
            raise ScenarioError(
                "cannot be a parameter: it fixes the sweep points, the sampling or "
                "the reporting, which must be the same at every parameter value; "
                "vary physics numbers such as surfaces.<name>.std_deg or "
                "coefficients.v_c.a_m_s",
                source=source,
                field=where,
            )
    try:
        return float(get_value(data, key, source=source))
    except ScenarioError as exc:
        raise ScenarioError(exc.message, source=source, field=where) from None
