"""Provenance of input files in output files: the file's name and the SHA-256 of
its bytes, never the absolute path of the machine that read it."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["file_provenance", "file_sha256"]


def file_sha256(path) -> str | None:
    """Hex SHA-256 of the bytes of `path`, or ``None`` if it cannot be read."""
    try:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None


def file_provenance(path) -> dict:
    """``{"file": name, "sha256": hash}`` of `path` (the name alone, no folder)."""
    path = os.fspath(path)
    return {"file": Path(path).name, "sha256": file_sha256(path)}
