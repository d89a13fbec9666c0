"""Choosing the samples of a size export holding several (a TSI AIM column or
row export, a wide time series) and turning number concentrations into counted
particles (``sampled_volume_cm3``); rules in ``docs/populations.md``."""

from __future__ import annotations

import re
from dataclasses import replace
from datetime import datetime

from ..errors import DataFormatError
from ..population.binned import BIN_VALUES
from ._size_common import _ask, _option

_RANGE = re.compile(r"^(?:(mean|sum)\s+)?(.+?)\s*\.\.\s*(.+)$", re.IGNORECASE)


def _iso_time(text):
    """A datetime of ISO 8601 `text` (``2022-02-15T21:20:30Z``), else None."""
    try:
        return datetime.fromisoformat(text.strip())
    except ValueError:
        return None


def _select(path, labels, sample, syntax, what, times=None):
    """(indices, how, text) of the samples `sample` chooses among `labels`.

    `sample` is a label (a Sample #, else the 1-based row number), ``"mean"`` or
    ``"sum"`` (of all), ``"A..B"`` (the mean of samples A to B, inclusive) or
    ``"sum A..B"``/``"mean A..B"``; with `times` (the ISO 8601 timestamps of the
    samples, else None) A and B may also be times: the samples from A to B
    inclusive, in any file order. `how` is ``"one"``, ``"mean"`` or ``"sum"``."""
    first = int(labels[0]) if labels[0].isdigit() else labels[0]
    if sample is None:
        if len(labels) == 1:
            return [0], "one", f"sample {labels[0]}"
        choices = [
            ("sample", first, "one sample: its Sample #, else its row number"),
            ("sample", "mean", "the mean of all samples"),
            ("sample", "sum", "the sum of all samples"),
            ("sample", f"{labels[0]}..{labels[-1]}", "the mean of a range"),
        ]
        if times is not None:
            span = f"{min(times).isoformat()}..{max(times).isoformat()}"
            choices.append(("sample", span, "the mean of a time range"))
        raise _ask(
            path,
            f"the {what} holds {len(labels)} samples ({labels[0]}..{labels[-1]})",
            choices,
            syntax,
            field="sample",
        )
    text = str(sample).strip()
    low = text.lower()
    allowed = (
        f"allowed: a Sample # ({labels[0]}..{labels[-1]}), 'mean', 'sum', 'A..B' or "
        "'sum A..B'" + (" (A, B Sample #s or ISO 8601 times)" if times else "")
    )
    if low in ("mean", "sum"):
        idx, how = list(range(len(labels))), low
    else:
        m = _RANGE.match(text)
        if m:
            how = (m.group(1) or "mean").lower()
            ends = [m.group(2), m.group(3)]
        else:
            how, ends = "one", [text, text]
        if m and times is not None and not all(e in labels for e in ends):
            return _select_times(path, times, ends, how, what, allowed)
        missing = [e for e in ends if e not in labels]
        if missing:
            raise DataFormatError(
                f"sample {missing[0]!r} is not in the {what}; {allowed}",
                source=path,
                field="sample",
            )
        a, b = (labels.index(e) for e in ends)
        if a > b:
            raise DataFormatError(
                f"sample range {text!r} runs backwards; allowed: A..B with A before "
                "B in the file",
                source=path,
                field="sample",
            )
        idx = list(range(a, b + 1))
    if len(idx) == 1:
        return idx, "one", f"sample {labels[idx[0]]}"
    span = f"samples {labels[idx[0]]}..{labels[idx[-1]]}"
    return idx, how, f"the {how} of {span} ({len(idx)} samples)"


def _select_times(path, times, ends, how, what, allowed):
    """:func:`_select` of the samples timed from ``ends[0]`` to ``ends[1]``."""
    lo, hi = (_iso_time(e) for e in ends)
    if lo is None or hi is None:
        bad = ends[0] if lo is None else ends[1]
        raise DataFormatError(
            f"sample range end {bad!r} is neither a Sample # nor an ISO 8601 time; "
            f"{allowed}",
            source=path,
            field="sample",
        )
    aware = {t.tzinfo is not None for t in (*times, lo, hi)}
    if len(aware) > 1:
        raise DataFormatError(
            f"the times {ends[0]!r}..{ends[1]!r} and the {what}'s timestamps do not "
            "both name a time zone; allowed: both with (e.g. Z, +02:00) or both "
            "without",
            source=path,
            field="sample",
        )
    if lo > hi:
        raise DataFormatError(
            f"sample range {ends[0]}..{ends[1]} runs backwards; allowed: A..B with "
            "A not after B",
            source=path,
            field="sample",
        )
    idx = [r for r, t in enumerate(times) if lo <= t <= hi]
    if not idx:
        raise DataFormatError(
            f"no sample of the {what} is timed from {ends[0]} to {ends[1]}; its "
            f"samples run from {min(times).isoformat()} to {max(times).isoformat()}",
            source=path,
            field="sample",
        )
    if len(idx) == 1:
        return idx, "one", f"the sample at {times[idx[0]].isoformat()}"
    return idx, how, (f"the {how} of the {len(idx)} samples timed {ends[0]}..{ends[1]}")


def _sample_key(labels, idx, how, sample):
    """The samples read, as the metadata's ``sample``: the Sample # of one, else
    ``"mean"``, ``"sum"`` or the range as given."""
    if how == "one":
        return labels[idx[0]]
    text = str(sample).strip()
    return text.lower() if text.lower() in ("mean", "sum") else text


def _aggregate(table, how):
    """The chosen samples' values (columns of `table`) combined by `how`."""
    return table.sum(axis=1) if how == "sum" else table.mean(axis=1)


_PER = (
    (re.compile(r"/\s*(cm3|cm³|cm\^3|cc)\b", re.IGNORECASE), 1.0, "cm^3"),
    (re.compile(r"/\s*(l|litre|liter)\b", re.IGNORECASE), 1e-3, "L"),
    (re.compile(r"/\s*(m3|m³|m\^3)\b", re.IGNORECASE), 1e-6, "m^3"),
)


def _per_cm3(name):
    """(factor to number per cm³, unit) of a value column's name, else None."""
    for pattern, factor, per in _PER:
        if pattern.search(name or ""):
            return factor, per
    return None


def _total_conc(names):
    """The name of an AIM export's ``Total Conc.(#/cm³)`` statistic, else None."""
    return next((h for h in names if h.lower().startswith("total conc")), None)


def _counted(path, bins, meta, volume_cm3, syntax):
    """`bins` of number concentrations as the particles counted in `volume_cm3`
    per sample (summed over the samples read): Poisson counts for the standard
    errors and the chi-squared test."""
    kind = bins.values
    weighting = BIN_VALUES[kind][0]
    option = _option("sampled_volume_cm3", volume_cm3, syntax)
    if kind == "count":
        raise DataFormatError(
            f"the values are counted particles already; {option} is for number "
            "concentrations (dN, dN/dlogDp, ...); leave it out",
            source=path,
            field="sampled_volume_cm3",
        )
    if weighting != "number":
        raise DataFormatError(
            f"the values are {kind} (a {weighting} weighting): no sampled volume "
            "turns them into counted particles; allowed with number concentrations "
            "(dN, dN/dlogDp, dN/dlnDp, dN/dDp)",
            source=path,
            field="sampled_volume_cm3",
        )
    named = meta.get("concentration_header") or meta.get("value_column")
    per = _per_cm3(str(named or ""))
    factor, unit = per if per is not None else (1.0, "cm^3")
    said = "" if per is not None else ", assumed: the file does not say"
    n_used = int(meta.get("n_samples_used", 1))
    samples = n_used if meta.get("aggregate") == "mean" else 1
    number = bins.number * factor * volume_cm3 * samples
    times = f" x {samples} samples" if samples > 1 else ""
    note = (
        f"number concentrations (per {unit}{said}) turned into counted particles: "
        f"x the sampled volume {volume_cm3:g} cm^3{times} = {float(number.sum()):.6g} "
        "particles; the standard errors and the chi-squared test assume Poisson "
        "counting of every particle in that volume (no coincidence, "
        "counting-efficiency, charging or inversion correction)"
    )
    return replace(bins, number=number, counted=True, notes=(*bins.notes, note))
