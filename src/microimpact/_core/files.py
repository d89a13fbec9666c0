"""Reading and writing files: one place for the error messages and the atomic write.

Every reader opens its text file through :func:`read_lines`, so a missing file, a
folder, a binary file or an unreadable file gives the same one-line error, naming the
file, whichever reader is used. Every writer goes through :func:`atomic_write`, so no
output file is ever left half-written.

The delimited-text readers (profiles, diameters, histograms, impact data,
experiments) share the rest, so one file is read the same way by each:
:func:`data_lines` (blank lines, ``#`` comment lines and trailing ``# ...`` comments
outside quotes), :func:`sniff_delimiter` (``;``, else tab, else ``,``, else
whitespace, judged from the first data line outside quotes) and :func:`csv_cells`
(cells, quotes allowed), :func:`looks_like_header` (a first row without numbers),
:func:`read_table` (a table with a header row: duplicate, missing-column and
row-width checks), :func:`resolve_column` (a column chosen by name or index) and
:func:`parse_number` (one numeric cell, with the error naming the file, line, field,
value and what is allowed).
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import re
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from .progress import stage
from .validation import did_you_mean

#: Cells that mean "no value" (compared case-insensitively, after stripping).
MISSING = frozenset({"", "nan", "na", "n/a", "null", "none", "-", "?"})
#: Delimiters :func:`sniff_delimiter` looks for, in order of preference.
DELIMITERS = (";", "\t", ",")
#: Readers ask :func:`read_rows` / :func:`read_table` to sniff with this value.
SNIFF = "sniff"


def read_lines(path, *, error=DataFormatError, hint: str = "") -> list[str]:
    """The lines of a UTF-8 text file (a byte-order mark is ignored).

    Raises `error` (an :class:`~microimpact.errors.InputError` subclass) naming the
    file if it is missing, a folder, unreadable or not UTF-8 text; `hint` is added to
    the message for the last case.
    """
    try:
        with open(path, encoding="utf-8-sig") as fh:
            return fh.read().splitlines()
    except FileNotFoundError:
        raise error("cannot read file: file not found", source=path) from None
    except IsADirectoryError:
        raise error("cannot read file: it is a directory", source=path) from None
    except UnicodeDecodeError:
        raise error(f"not a UTF-8 text file{hint}", source=path) from None
    except OSError as exc:
        raise error(f"cannot read file: {exc.strerror}", source=path) from None


def strip_comment(text: str) -> str:
    """`text` without a trailing ``# ...`` comment; a ``#`` inside double quotes is
    kept (``"run #3"`` is one cell)."""
    inside = False
    for i, ch in enumerate(text):
        if ch == '"':
            inside = not inside
        elif ch == "#" and not inside:
            return text[:i]
    return text


def data_lines(lines, *, trailing_comments: bool = True) -> list[tuple[int, str]]:
    """``(1-based line number, line)`` of the lines that are neither blank nor a
    ``#`` comment.

    A ``# ...`` after the data on a line is cut off too (outside quotes), and the
    returned text stripped; ``trailing_comments=False`` keeps it.
    """
    return list(iter_data_lines(lines, trailing_comments=trailing_comments))


def iter_data_lines(lines, *, trailing_comments: bool = True):
    """:func:`data_lines`, one at a time (no list of them: a long file's rows are
    formed without a second copy of its lines)."""
    for lineno, line in enumerate(lines, start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        if trailing_comments:
            line = strip_comment(stripped).strip()
            if not line:
                continue
        yield lineno, line


#: A double-quoted part of a line (an unclosed one runs to the end).
_QUOTED = re.compile(r'("[^"]*(?:"|$))')


def _unquoted(text: str) -> str:
    """`text` with every double-quoted part replaced by ``x``."""
    return "".join("x" if k % 2 else part for k, part in enumerate(_QUOTED.split(text)))


def _unpad(text: str, delimiter: str) -> str:
    """`text` without the whitespace around each `delimiter` outside quotes, so a
    quoted cell after ``;<tab>`` is still read as quoted."""
    d = re.escape(delimiter)
    pad = re.compile(rf"[^\S{d}]*{d}[^\S{d}]*")  # whitespace other than `delimiter`
    return "".join(
        part if k % 2 else pad.sub(delimiter, part)
        for k, part in enumerate(_QUOTED.split(text))
    )


def sniff_delimiter(first_line: str) -> str | None:
    """The delimiter of a file from its first data line, or ``None`` (runs of
    whitespace).

    Quoted text is ignored, and so is whitespace next to a ``;`` or ``,`` (padding,
    as in ``1.0;<tab>2.0``). Then ``;`` wins over a tab, and a tab over ``,``: a
    file that holds both ``;`` and ``,`` is a semicolon file (the comma is its
    decimal separator, which the number parser then reports).
    """
    bare = re.sub(r"\s*([,;])\s*", r"\1", _unquoted(first_line).strip())
    return next((d for d in DELIMITERS if d in bare), None)


def check_delimiter(delimiter) -> str | None:
    """`delimiter` as :func:`split_rows` takes it (``None``: :data:`SNIFF`), or
    ``ValueError`` unless it is one character other than ``"`` and ``#``, ``""``
    (whitespace) or ``None`` (sniffed)."""
    if delimiter is None:
        return SNIFF
    if not (
        isinstance(delimiter, str) and len(delimiter) <= 1 and delimiter not in '"#'
    ):
        raise ValueError(
            "`delimiter` must be one character (not '\"' or '#'), '' "
            f"(whitespace) or None (sniffed); got {delimiter!r}."
        )
    return delimiter


def delimiter_name(delimiter: str | None) -> str:
    """``"whitespace"``, ``"tab"`` or the delimiter itself, for metadata."""
    return {None: "whitespace", "\t": "tab"}.get(delimiter, delimiter)


def csv_cells(
    text: str, *, source, line: int, delimiter: str | None = ",", error=DataFormatError
) -> list[str]:
    """The stripped cells of one delimited line; quotes allowed (``"5,2"`` is one
    cell). ``delimiter=None`` splits at runs of whitespace.

    A line the csv module cannot parse (e.g. an unclosed quote) raises `error` naming
    the file and the line.
    """
    if delimiter is None:
        text, delimiter = " ".join(text.split()), " "
    else:
        text = _unpad(text, delimiter)
    try:
        cells = next(
            csv.reader([text], delimiter=delimiter, skipinitialspace=True, strict=True),
            [],
        )
    except csv.Error as exc:
        raise error(f"cannot parse line: {exc}.", source=source, line=line) from None
    return [c.strip() for c in cells]


def is_number(cell: str) -> bool:
    """True if `cell` parses as a float."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _decimal_comma_hint(cell: str) -> str:
    if "," in cell and is_number(cell.replace(",", ".")):
        return "; the decimal separator must be '.'"
    return ""


def parse_number(
    cell: str,
    *,
    source,
    line=None,
    field=None,
    allowed: str,
    ok: Callable[[float], bool] | None = None,
    what: str = "value",
    error=DataFormatError,
) -> float:
    """One numeric cell as a float, or `error` naming the file, line, field, value
    and what is `allowed`.

    The messages are ``missing {what} '<cell>'`` (a :data:`MISSING` marker, NaN
    included), ``non-numeric {what} '<cell>'`` (with a hint for a decimal comma) and
    ``bad {what} '<cell>'`` (infinite, or ``ok(value)`` is false), each followed by
    ``; allowed: {allowed}``.
    """
    cell = cell.strip()
    where = {"source": source, "line": line, "field": field}
    if cell.lower() in MISSING:
        raise error(f"missing {what} {cell!r}; allowed: {allowed}", **where)
    try:
        value = float(cell)
    except ValueError:
        raise error(
            f"non-numeric {what} {cell!r}; allowed: {allowed}"
            f"{_decimal_comma_hint(cell)}",
            **where,
        ) from None
    if not math.isfinite(value) or (ok is not None and not ok(value)):
        raise error(f"bad {what} {cell!r}; allowed: {allowed}", **where)
    return value


def split_rows(
    lines,
    *,
    source,
    delimiter: str | None = SNIFF,
    error=DataFormatError,
    trailing_comments: bool = True,
) -> tuple[list[tuple[int, list[str]]], str | None]:
    """``([(line number, cells)], delimiter)`` of the data lines among `lines`.

    ``delimiter=SNIFF`` (the default) takes it from the first data line
    (:func:`sniff_delimiter`); ``None`` or ``""`` means runs of whitespace.
    """
    content = iter_data_lines(lines, trailing_comments=trailing_comments)
    first = next(content, None)
    if delimiter == SNIFF:
        delimiter = sniff_delimiter(first[1]) if first is not None else None
    delimiter = delimiter or None
    if first is None:
        return [], delimiter
    rows = [
        (n, csv_cells(t, source=source, line=n, delimiter=delimiter, error=error))
        for n, t in itertools.chain((first,), content)
    ]
    return rows, delimiter


def read_rows(
    path,
    *,
    delimiter: str | None = SNIFF,
    error=DataFormatError,
    hint: str = "",
    trailing_comments: bool = True,
) -> tuple[list[tuple[int, list[str]]], str | None]:
    """:func:`split_rows` of the lines of the file `path` (see :func:`read_lines`)."""
    return split_rows(
        read_lines(path, error=error, hint=hint),
        source=path,
        delimiter=delimiter,
        error=error,
        trailing_comments=trailing_comments,
    )


def check_row_width(
    rows, width: int, *, source, delimiter, error=DataFormatError, reference="header"
) -> None:
    """Raise `error` for the first row with a non-empty cell beyond column `width`.

    Such a row is never silently cut: its most common cause is a decimal comma
    (``52,8``) or an unquoted delimiter inside a cell. Shorter rows are left to the
    caller (their absent cells are missing values).
    """
    for lineno, cells in rows:
        if len(cells) > width and any(cells[width:]):
            hint = "; the decimal separator must be '.'"
            if delimiter is not None:
                hint += (
                    f" and a cell holding {delimiter_name(delimiter)!r} must be quoted"
                )
            raise error(
                f"row has {len(cells)} cells, {reference} has {width}{hint}",
                source=source,
                line=lineno,
            )


def find_column(name: str, header) -> list[int]:
    """Indices of the header cells equal to `name`: the exact match if there is
    exactly one, else every case-insensitive match."""
    exact = [j for j, h in enumerate(header) if h == name]
    if len(exact) == 1:
        return exact
    folded = name.strip().lower()
    return [j for j, h in enumerate(header) if h.strip().lower() == folded]


def resolve_column(
    column,
    header,
    n_columns: int,
    *,
    name: str,
    source,
    line=None,
    error=DataFormatError,
) -> int | None:
    """The 0-based index of `column` (a header name or a 0-based index, negative
    counting from the end), or ``None`` for ``None``.

    Header names match exactly, else case-insensitively. Raises `error` (field
    `name`) for an unknown, ambiguous or out-of-range column, or a name when the
    file has no header; ``TypeError`` for another type.
    """
    if column is None:
        return None
    span = f"0..{n_columns - 1}"
    if isinstance(column, str):
        if header is None:
            raise error(
                f"column {column!r} requested by name but the file has no header "
                f"row; give a 0-based column number ({span})",
                source=source,
                field=name,
            )
        hits = find_column(column, header)
        if len(hits) == 1:
            return hits[0]
        listing = ", ".join(repr(h) for h in header)
        if hits:
            raise error(
                f"column name {column!r} is ambiguous: it matches columns "
                f"{', '.join(str(j) for j in hits)}; give a 0-based column number",
                source=source,
                line=line,
                field=name,
            )
        raise error(
            f"no column named {column!r}; allowed: {listing}"
            f"{did_you_mean(column, header)}",
            source=source,
            line=line,
            field=name,
        )
    if isinstance(column, int | np.integer) and not isinstance(column, bool):
        if -n_columns <= column < n_columns:
            return int(column) % n_columns
        also = " or a header name" if header else ""
        raise error(
            f"column index {column!r} out of range; allowed: {span}{also}",
            source=source,
            field=name,
        )
    raise TypeError(
        f"`{name}` must be a column name (str), a 0-based index (int) or None; "
        f"got {column!r}."
    )


@dataclass(frozen=True)
class Table:
    """A delimited table read by :func:`read_table`.

    Attributes
    ----------
    source : str
        The file.
    header_line : int or None
        1-based line number of the header row (``None`` if the file has none).
    header : list of str or None
        The header cells (stripped), or ``None``.
    index : dict
        0-based column of each requested name that the header holds (the keys are
        the requested spellings, whatever the header's case).
    rows : list of (int, list of str)
        The data rows: line number and stripped cells. A row may be shorter than
        the header (its absent cells are ``""``), never longer.
    delimiter : str or None
        The delimiter (``None``: whitespace).
    """

    source: str
    header_line: int | None
    header: list | None
    index: dict
    rows: list
    delimiter: str | None

    @property
    def width(self) -> int:
        """Number of columns (of the header, or of the first row without one)."""
        if self.header is not None:
            return len(self.header)
        return len(self.rows[0][1]) if self.rows else 0

    @staticmethod
    def cell(cells, j) -> str:
        """Cell `j` of a row (``""`` if `j` is ``None`` or beyond the row)."""
        return cells[j] if j is not None and j < len(cells) else ""

    def missing_column(self, name: str, allowed: str, *, error=DataFormatError):
        """The error for a required column `name` the header lacks."""
        header = self.header or []
        other = [d for d in DELIMITERS if d != self.delimiter and d in "".join(header)]
        if len(header) == 1 and self.delimiter is not None and other:
            want, got = delimiter_name(self.delimiter), delimiter_name(other[0])
            hint = (
                f" (the columns must be separated by {want!r}; this header holds "
                f"{got!r})"
            )
        else:
            hint = did_you_mean(name, header)
        return error(
            f"required column missing; header has {self.header}, {allowed}{hint}.",
            source=self.source,
            line=self.header_line,
            field=name,
        )


def looks_like_header(cells) -> bool:
    """True if no cell is a number and some cell is text other than a missing-value
    marker: the rule every reader uses to tell a header row from a data row."""
    return not any(is_number(c) for c in cells) and any(
        c.lower() not in MISSING for c in cells
    )


def read_table(
    path,
    required=(),
    *,
    optional=(),
    header: bool | None = True,
    delimiter: str | None = SNIFF,
    error=DataFormatError,
    hint: str = "",
    expected: str | None = None,
    empty: str | None = None,
) -> Table:
    """Read a delimited table: header row, column index and data rows.

    Parameters
    ----------
    path : str or path-like
    required, optional : sequence of str
        Column names to look up in the header (exactly, else case-insensitively).
        A missing `required` one raises `error` (with a did-you-mean hint).
    header : bool or None
        ``True``: the first data line is the header. ``None``: it is a header if
        any of its cells is neither a number nor a missing-value marker.
    delimiter : str or None
        The delimiter, ``None`` for whitespace, or :data:`SNIFF` (the default: the
        rules of :func:`sniff_delimiter`, as every reader).
    error : type
        The :class:`~microimpact.errors.InputError` subclass to raise.
    hint : str
        Added to the not-UTF-8 message.
    expected : str, optional
        What the header should hold, for the "no header found" message (default:
        the `required` names).
    empty : str, optional
        Message when there are no data rows (default: "no header found" for an empty
        file, "no data rows after the header" for a header alone).

    Raises
    ------
    error
        No header; duplicate column names (compared case-insensitively); a required
        column missing; no data rows; a row with more (non-empty) cells than the
        header; a line the csv module cannot parse.
    """
    source = os.fspath(path)
    rows, delimiter = read_rows(source, delimiter=delimiter, error=error, hint=hint)
    if not rows:
        if empty is not None:
            raise error(empty, source=source)
        want = expected if expected is not None else ", ".join(required)
        raise error(
            f"no header found; expected a header with columns {want}.", source=source
        )
    header_line = names = None
    if header or (header is None and looks_like_header(rows[0][1])):
        (header_line, names), rows = rows[0], rows[1:]
        folded = [h.lower() for h in names]
        dup = sorted({h for h in folded if h and folded.count(h) > 1})
        if dup:
            raise error(
                f"duplicate column(s) {dup}; each column may appear once (names "
                "are compared case-insensitively).",
                source=source,
                line=header_line,
            )
    table = Table(source, header_line, names, {}, rows, delimiter)
    for name in (*required, *optional):
        hits = find_column(name, names or [])
        if hits:
            table.index[name] = hits[0]
        elif name in required:
            raise table.missing_column(name, f"required {list(required)}", error=error)
    if not rows:
        if empty is not None:
            raise error(empty, source=source)
        raise error("no data rows after the header.", source=source, line=header_line)
    check_row_width(
        rows,
        table.width,
        source=source,
        delimiter=delimiter,
        error=error,
        reference="header" if names is not None else "the first row",
    )
    return table


def atomic_write(path, write) -> Path:
    """Call ``write(tmp_path)`` then rename the temporary file onto `path`.

    The temporary file sits in the same folder, so the rename is atomic: at any
    moment `path` is either the old complete file or the new complete one. It gets
    the permissions a plain ``open(path, "w")`` would give.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        with stage(f"writing {path.name}"):  # shown when it takes over a second
            write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
