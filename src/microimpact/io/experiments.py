"""Read experimental mean values with confidence intervals from CSV.

File format: UTF-8 CSV with one header row. Blank lines and lines whose first
non-blank character is ``#`` are skipped. Columns (any order; others are ignored):

``speed_m_s`` and/or ``angle_deg``
    Where the point was measured: nominal incident speed [m s⁻¹] (> 0) and/or
    apparent incidence angle from the nominal plane [deg] (in (0, 90]). At least one
    of the two columns must be present; a cell may be left empty in a file that has
    both.
``surface`` (optional)
    Name of the simulated surface the point belongs to (e.g. ``rough``).
``statistic``
    What was measured, one of :data:`STATISTICS`: ``e`` (mean coefficient of
    restitution of rebounding particles), ``mu`` (mean impulse ratio),
    ``e_relative`` and ``mu_relative`` (the paper's relative coefficients,
    ``e - e(85°)``), ``capture_fraction`` (fraction captured, in [0, 1]).
``mean``
    The measured mean.
The interval, per row, one of:
    * ``ci_low`` and ``ci_high`` (the confidence limits);
    * ``half_width`` (symmetric: ``mean ± half_width``);
    * ``std`` and ``n`` (sample standard deviation and sample size; the interval is
      the Student-t interval ``mean ± t_{n-1} std / sqrt(n)``).
``confidence`` (optional)
    Confidence level of the interval, default 0.95 (the paper's error bars).
``n`` (optional with the first two forms)
    Sample size; when given, the standard error is the half-width over ``t_{n-1}``
    instead of over the normal quantile.

Example (paper Fig. 5 style)::

    # SST65 on silicon, Li et al. (1999); 95 % error bars
    speed_m_s,statistic,mean,ci_low,ci_high
    0.35,e,0.42,0.36,0.48
    1.20,e,0.78,0.75,0.81
"""

from __future__ import annotations

import math
import os

from .._core.files import Table, parse_number, read_table
from .._core.validation import did_you_mean
from ..errors import DataFormatError

__all__ = [
    "COORDINATES",
    "STATISTICS",
    "STATISTIC_LABELS",
    "combine_experiments",
    "read_experiments",
    "scenario_experiments",
    "write_experiments",
]

#: Statistics an experimental point may report.
STATISTICS = ("e", "mu", "e_relative", "mu_relative", "capture_fraction")
#: How figures and reports name each statistic.
STATISTIC_LABELS = {
    "e": "e (rebounds)",
    "mu": "μ",
    "e_relative": "e relative",
    "mu_relative": "μ relative",
    "capture_fraction": "capture fraction",
}
#: Columns that locate a point in the sweep.
COORDINATES = ("speed_m_s", "angle_deg")

_NUMERIC = ("mean", "ci_low", "ci_high", "half_width", "std", "n", "confidence")
_OUT_COLUMNS = (
    "surface",
    "speed_m_s",
    "angle_deg",
    "statistic",
    "mean",
    "ci_low",
    "ci_high",
    "se",
    "n",
    "confidence",
    "line",
)


def _read_table(source):
    """The file's table, with the columns and the interval form checked."""
    table = read_table(
        source,
        ("statistic", "mean"),
        optional=(*COORDINATES, "surface", *_NUMERIC),
        expected="speed_m_s or angle_deg, statistic, mean and an interval "
        "(ci_low, ci_high | half_width | std, n)",
    )
    have = table.index
    if not any(c in have for c in COORDINATES):
        raise table.missing_column("speed_m_s", "need speed_m_s and/or angle_deg")
    if not (
        {"ci_low", "ci_high"} <= have.keys()
        or "half_width" in have
        or {"std", "n"} <= have.keys()
    ):
        raise table.missing_column(
            "ci_low",
            "an interval needs ci_low and ci_high, or half_width, or std and n",
        )
    return table


_RULES = {
    "speed_m_s": ("a finite speed > 0 [m/s]", lambda v: v > 0),
    "angle_deg": ("an angle in (0, 90] [deg]", lambda v: 0 < v <= 90),
    "mean": ("a finite number", lambda v: True),
    "ci_low": ("a finite number", lambda v: True),
    "ci_high": ("a finite number", lambda v: True),
    "half_width": ("a finite number >= 0", lambda v: v >= 0),
    "std": ("a finite number >= 0", lambda v: v >= 0),
    "n": ("an integer >= 2", lambda v: v >= 2 and v == int(v)),
    "confidence": ("a number in (0, 1)", lambda v: 0 < v < 1),
}


def _parse_row(cells, index, *, source, line):
    def cell(col):
        return Table.cell(cells, index.get(col))

    row = {"line": line}
    for col in (*COORDINATES, *_NUMERIC):
        text = cell(col)
        if text == "":
            row[col] = math.nan
            continue
        allowed, ok = _RULES[col]
        row[col] = parse_number(
            text, source=source, line=line, field=col, allowed=allowed, ok=ok
        )
    if all(math.isnan(row[c]) for c in COORDINATES):
        raise DataFormatError(
            "missing value; each row needs speed_m_s or angle_deg.",
            source=source,
            line=line,
            field="/".join(c for c in COORDINATES if c in index),
        )
    stat = cell("statistic")
    if stat not in STATISTICS:
        raise DataFormatError(
            f"unknown statistic {stat!r}; allowed: {', '.join(STATISTICS)}"
            f"{did_you_mean(stat, STATISTICS)}.",
            source=source,
            line=line,
            field="statistic",
        )
    row["statistic"] = stat
    row["surface"] = cell("surface") or None
    if math.isnan(row["mean"]):
        raise DataFormatError(
            "missing value; a number is required.",
            source=source,
            line=line,
            field="mean",
        )
    if stat == "capture_fraction" and not 0 <= row["mean"] <= 1:
        raise DataFormatError(
            f"bad value {row['mean']!r}; a capture fraction must lie in [0, 1] "
            "(give a fraction, not a percentage).",
            source=source,
            line=line,
            field="mean",
        )
    if math.isnan(row["confidence"]):
        row["confidence"] = 0.95
    _interval(row, source=source)
    return row


def _interval(row, *, source):
    """Fill ``ci_low``, ``ci_high`` and ``se`` from whichever form the row uses."""
    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.special import ndtri

    # deferred: this SciPy submodule loads only when it is used (import time)
    from scipy.stats import t as student_t

    line, mean, n, conf = row["line"], row["mean"], row["n"], row["confidence"]
    q = 0.5 + conf / 2.0
    crit = float(ndtri(q)) if math.isnan(n) else float(student_t.ppf(q, n - 1))
    lo, hi = row["ci_low"], row["ci_high"]
    if not (math.isnan(lo) and math.isnan(hi)):
        for col, v in (("ci_low", lo), ("ci_high", hi)):
            if math.isnan(v):
                raise DataFormatError(
                    "missing value; ci_low and ci_high must be given together.",
                    source=source,
                    line=line,
                    field=col,
                )
        if not lo <= mean <= hi:
            raise DataFormatError(
                f"interval [{lo!r}, {hi!r}] does not contain the mean {mean!r}; "
                "ci_low <= mean <= ci_high is required.",
                source=source,
                line=line,
                field="ci_low",
            )
        row["se"] = (hi - lo) / (2.0 * crit)
    elif not math.isnan(row["half_width"]):
        h = row["half_width"]
        row["ci_low"], row["ci_high"], row["se"] = mean - h, mean + h, h / crit
    elif not (math.isnan(row["std"]) or math.isnan(n)):
        se = row["std"] / math.sqrt(n)
        row["ci_low"], row["ci_high"], row["se"] = (
            mean - crit * se,
            mean + crit * se,
            se,
        )
    else:
        raise DataFormatError(
            "no interval on this row; give ci_low and ci_high, or half_width, "
            "or std and n.",
            source=source,
            line=line,
            field="ci_low",
        )


def read_experiments(path):
    """Read experimental means with confidence intervals (format: module docstring).

    Parameters
    ----------
    path : str or path-like
        The CSV file.

    Returns
    -------
    pandas.DataFrame
        One row per data line, in file order, with columns ``surface`` (str or
        None), ``speed_m_s`` [m s⁻¹] and ``angle_deg`` [deg] (NaN where not given),
        ``statistic``, ``mean``, ``ci_low``, ``ci_high``, ``se`` (standard error of
        the mean: the half-width over the normal quantile, or over ``t_{n-1}`` when
        ``n`` is given), ``n`` (NaN if not given), ``confidence`` and ``line`` (the
        1-based line number in the file). ``attrs["source"]`` is the path.

    Raises
    ------
    DataFormatError
        Naming file, line, column and value, if the file is missing or empty, a
        required column is missing or duplicated, a statistic is unknown, a number
        is malformed or out of range, a row has no interval, or an interval does not
        contain its mean.
    """
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    source = os.fspath(path)
    table = _read_table(source)
    rows = [
        _parse_row(cells, table.index, source=source, line=lineno)
        for lineno, cells in table.rows
    ]
    table = pd.DataFrame(rows, columns=list(_OUT_COLUMNS))
    for col in ("speed_m_s", "angle_deg", "mean", "ci_low", "ci_high", "se", "n"):
        table[col] = table[col].astype(float)
    table["surface"] = table["surface"].astype(object)
    table.attrs["source"] = source
    return table


def combine_experiments(experiments):
    """One table from experiments given as tables and/or CSV paths.

    Parameters
    ----------
    experiments : None, DataFrame, path-like or sequence of them
        Tables as returned by :func:`read_experiments`, or paths to such files.

    Returns
    -------
    pandas.DataFrame or None
        The rows of all of them (None for None or an empty sequence).
    """
    if experiments is None:
        return None
    # deferred: pandas loads only where a table is made (import time)
    import pandas as pd

    items = (
        [experiments]
        if isinstance(experiments, str | os.PathLike | pd.DataFrame)
        else list(experiments)
    )
    tables = [
        read_experiments(x) if isinstance(x, str | os.PathLike) else x for x in items
    ]
    tables = [  # each row keeps the file it came from, for messages
        t.assign(source=t.attrs["source"])
        if isinstance(t, pd.DataFrame) and "source" in t.attrs and "source" not in t
        else t
        for t in tables
    ]
    for t in tables:
        if not isinstance(t, pd.DataFrame) or not {
            "statistic",
            "mean",
            "ci_low",
            "ci_high",
        } <= set(t.columns):
            raise TypeError(
                "`experiments` must be read_experiments() tables or paths; "
                f"got {type(t).__name__}."
            )
    if not tables:
        return None
    out = pd.concat(tables, ignore_index=True)
    for c in ("speed_m_s", "angle_deg", "surface"):
        if c not in out:
            out[c] = math.nan if c != "surface" else None
    return out


def scenario_experiments(scenario, experiments=None):
    """The experiments for `scenario` as one table: exactly `experiments`.

    Experiments are passed explicitly (they are output settings, not part of the
    simulated scenario): ``None`` means no experiments, and the scenario is never
    consulted for files of its own. `scenario` is kept so that callers can name
    the study the experiments belong to; it is not read.

    Parameters
    ----------
    scenario : object
        The study (not read).
    experiments : None, DataFrame, path-like or sequence of them, optional
        As for :func:`combine_experiments`.

    Returns
    -------
    pandas.DataFrame or None
        :func:`combine_experiments` of them; None when there are none.

    Raises
    ------
    DataFormatError
        If a file cannot be read (naming file, line and column).
    """
    del scenario  # not read: experiments are explicit
    return combine_experiments(experiments)


def write_experiments(table, path, *, comment=None):
    """Write a :func:`read_experiments` table back in the format it reads: the
    same means, intervals, sample sizes and confidence levels, so that reading
    the file gives the same table (its standard errors included).

    Parameters
    ----------
    table : pandas.DataFrame
        As returned by :func:`read_experiments` or :func:`combine_experiments`.
    path : str or path-like
        The CSV file (written as given; wrap in an atomic write for outputs).
    comment : str, optional
        A first line, written after ``# ``.
    """
    cols = [c for c in _OUT_COLUMNS if c in table and c not in ("se", "line")]
    with open(path, "w", encoding="utf-8", newline="") as fh:
        if comment:
            fh.write(f"# {comment}\n")
        table[cols].to_csv(fh, index=False)
