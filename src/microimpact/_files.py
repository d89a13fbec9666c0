"""Reading and writing files: one place for the error messages and the atomic write.

Every reader opens its text file through :func:`read_lines`, so a missing file, a
folder, a binary file or an unreadable file gives the same one-line error, naming the
file, whichever reader is used. Every writer goes through :func:`atomic_write`, so no
output file is ever left half-written.
"""

from __future__ import annotations

import csv
import os
import tempfile
from pathlib import Path

from .errors import DataFormatError


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


def data_lines(lines) -> list[tuple[int, str]]:
    """``(1-based line number, line)`` of the lines that are neither blank nor a
    ``#`` comment."""
    out = []
    for lineno, line in enumerate(lines, start=1):
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            out.append((lineno, line))
    return out


def csv_cells(text: str, *, source, line: int) -> list[str]:
    """The cells of one comma-separated line (quotes allowed); a line the csv module
    cannot parse raises :class:`DataFormatError` naming the file and the line."""
    try:
        return next(csv.reader([text]))
    except csv.Error as exc:
        raise DataFormatError(
            f"cannot parse line: {exc}.", source=source, line=line
        ) from None


def is_number(cell: str) -> bool:
    """True if `cell` parses as a float."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


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
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
