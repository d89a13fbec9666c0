"""An output folder owned by one study at a time.

* **Lock.** ``.microimpact.lock`` is locked with ``flock`` (POSIX) while a study runs
  or writes: a second study into the same folder is refused with an
  :class:`OutputFolderBusy` error naming the folder and the process holding it. The
  operating system releases the lock when the process ends in any way (SIGKILL
  included), so a lock is never stale.
* **Manifest.** ``.microimpact-manifest.json`` lists the files the last study wrote
  there, by part (tables, figures, report). When a study writes a part again, the
  files of that part that the previous study wrote and this one does not are
  removed (e.g. ``distributions_10deg.png`` after the angle sweep changed). Files
  the user put in the folder are in no manifest and are never touched.
* **Temporary files.** The atomic writes leave ``.<name>.<random>.tmp`` files behind
  only if the process is killed; those of outputs named in the manifest (or of this
  study's outputs) are removed when the folder is next taken.
"""

from __future__ import annotations

import json
import os

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no lock
    fcntl = None
import re
from pathlib import Path

from .._core.files import atomic_write
from .._core.formats import FIGURE_FORMATS
from ..errors import InputError

__all__ = [
    "CHECKPOINT_NAME",
    "LOCK_NAME",
    "MANIFEST_NAME",
    "OutputFolder",
    "OutputFolderBusy",
]

#: The lock file that keeps a second study out of a folder while one writes.
LOCK_NAME = ".microimpact.lock"
#: The list of files the last study wrote (removed again by the next one).
MANIFEST_NAME = ".microimpact-manifest.json"
#: The checkpoint file a study keeps in its output folder while it runs.
CHECKPOINT_NAME = ".microimpact-checkpoint.npz"
#: File suffixes of figures (the part "figures" of the manifest).
_FIGURE_SUFFIXES = tuple(f".{f}" for f in FIGURE_FORMATS)
_TMP = re.compile(r"^\.(?P<name>.+)\.[A-Za-z0-9_]{8}\.tmp$")
#: Outputs a study may write (their stale temporary files are always removed).
KNOWN = (
    "summary.csv",
    "results.nc",
    "capture_speed.csv",
    "experiments.csv",
    "report.html",
)


class OutputFolderBusy(InputError):
    """Another study is writing to the output folder."""


class OutputFolder:
    """Context manager: lock `path` (created if needed) for one study.

    Use :meth:`write` to write a file atomically and :meth:`record` to update the
    manifest (removing the previous study's files of the same parts that were not
    written again).
    """

    def __init__(self, path):
        self.path = Path(path)
        self._fd = None

    def __enter__(self) -> OutputFolder:
        if self.path.exists() and not self.path.is_dir():
            raise InputError(
                "is a file, not a folder; give a new or existing folder",
                source=self.path,
            )
        self.path.mkdir(parents=True, exist_ok=True)
        lock = self.path / LOCK_NAME
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise OutputFolderBusy(
                    f"another microimpact run (process {holder}) is writing to this "
                    "folder; wait for it to finish or choose another --out",
                    source=self.path,
                ) from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self._fd = fd
        self._clean_temporaries()
        return self

    def __exit__(self, *exc):
        if self._fd is not None:
            os.close(self._fd)  # releases the flock
            self._fd = None
        return False

    # ------------------------------------------------------------------ files
    def write(self, name, write) -> Path:
        """``write(tmp_path)`` then rename onto ``path / name`` (atomic)."""
        return atomic_write(self.path / name, write)

    def manifest(self) -> dict:
        """The previous study's manifest: ``{part: [file names]}`` (empty if none or
        unreadable)."""
        try:
            data = json.loads((self.path / MANIFEST_NAME).read_text())
        except (OSError, ValueError):
            return {}
        parts = data.get("parts", {}) if isinstance(data, dict) else {}
        return {
            str(k): [str(f) for f in v if isinstance(f, str)]
            for k, v in parts.items()
            if isinstance(v, list)
        }

    def settings(self) -> dict:
        """The output settings the last study recorded (:meth:`record`), or {}."""
        try:
            data = json.loads((self.path / MANIFEST_NAME).read_text())
        except (OSError, ValueError):
            return {}
        got = data.get("outputs", {}) if isinstance(data, dict) else {}
        return got if isinstance(got, dict) else {}

    def record(self, written, parts, *, settings=None) -> None:
        """Record `written` (paths in this folder) as the files of `parts`; remove
        the files of those parts that the previous manifest lists and `written`
        does not. `settings` (plain data: the study's output settings) replaces
        the recorded ones; None keeps them."""
        kept = self.settings() if settings is None else settings
        old = self.manifest()
        names = {Path(p).name for p in written}
        new = {k: v for k, v in old.items() if k not in parts}
        for part in parts:
            for name in old.get(part, []):
                target = self.path / name
                if name not in names and Path(name).name == name and target.is_file():
                    target.unlink()
            new[part] = sorted(
                Path(p).name for p in written if _part_of(Path(p).name) == part
            )
        atomic_write(
            self.path / MANIFEST_NAME,
            lambda t: Path(t).write_text(
                json.dumps(
                    {"generator": "microimpact", "parts": new, "outputs": kept},
                    indent=1,
                )
            ),
        )

    def _clean_temporaries(self) -> None:
        listed = {n for files in self.manifest().values() for n in files}
        listed |= set(KNOWN) | {MANIFEST_NAME, CHECKPOINT_NAME}
        for entry in self.path.iterdir():
            m = _TMP.match(entry.name)
            if m and entry.is_file() and _owned(m.group("name"), listed):
                entry.unlink(missing_ok=True)


def _owned(name: str, listed) -> bool:
    return name in listed or name.endswith(_FIGURE_SUFFIXES)


def _part_of(name: str) -> str:
    if name == "report.html":
        return "report"
    if name.endswith(_FIGURE_SUFFIXES):
        return "figures"
    return "tables"
