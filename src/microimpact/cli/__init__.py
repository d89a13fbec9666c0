"""The ``microimpact`` command line: a thin dispatcher over the library.

Each verb is a module of this package with ``HELP``, ``cli_parse(parser)`` (its
arguments) and ``cli_action(args)`` (a few lines around one library call), in the
way SALib's command line is built. This module only builds the parser, dispatches,
and turns exceptions into one-line messages and exit codes (see
:mod:`microimpact.cli._common` and ``docs/cli.md``):

* :class:`~microimpact.errors.InputError` (a bad flag, file, key or value): exit 2;
* an environment failure (an output that cannot be written, a full disk, a closed
  pipe, out of memory): exit 3, naming the path and the cause;
* anything else is a bug of ours: exit 1, with the traceback saved to a file
  (``MICROIMPACT_DEBUG=1`` re-raises it instead);
* Ctrl-C exits 130 and SIGTERM 143, each after the checkpoint is saved; the
  message names the checkpoint only where one exists.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

from .. import __version__
from .._core.progress import stages
from ..errors import InputError, ScenarioErrors, _one_line
from ._common import (
    EXIT_ENVIRONMENT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USER,
)

#: Verb -> module of this package.
VERBS = {
    "run": "run",
    "reproduce": "reproduce",
    "report": "report",
    "roughness": "roughness",
    "sizes": "sizes",
    "fit": "fit",
    "convergence": "convergence",
    "compare": "compare",
    "presets": "presets",
    "wall-law": "wall_law",
    "sensitivity": "sensitivity",
    "calibrate": "calibrate",
    "resuspend": "resuspend",
}

#: A library argument named in an :class:`InputError` -> the flag that sets it.
_FLAG_OF_ARGUMENT = {"address": "--scheduler"}


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse's own convention)
        self.exit(EXIT_USER, f"{self.prog}: error: {message}\n")


def _verb(name):
    return importlib.import_module(f".{VERBS[name]}", __name__)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every verb."""
    p = _Parser(
        prog="microimpact",
        description="Monte Carlo analysis of polydisperse microparticle impacts "
        "with rough surfaces (Li, Dunn & Brach 2000).",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in VERBS:
        module = _verb(name)
        module.cli_parse(sub.add_parser(name, help=module.HELP))
    return p


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so that the checkpoint is saved."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _warning_printer(command):
    """A ``warnings.showwarning`` that prints one line, without the source line."""

    def show(message, category, filename, lineno, file=None, line=None):
        print(f"microimpact {command}: warning: {_one_line(message)}", file=sys.stderr)

    return show


def _environment_message(err) -> str | None:
    """The one-line message of an environment failure, or None if `err` is not
    one (then it is a bug of ours)."""
    if isinstance(err, MemoryError):
        return "out of memory; use fewer sweep points, samples per task or workers"
    if isinstance(err, BrokenPipeError):
        return "the output pipe was closed"
    if isinstance(err, OSError):
        causes = {
            errno.ENOSPC: "no space left on the device",
            errno.EDQUOT: "disk quota exceeded",
            errno.EACCES: "permission denied",
            errno.EPERM: "operation not permitted",
            errno.EROFS: "read-only file system",
            errno.EIO: "input/output error",
            errno.EMFILE: "too many open files",
        }
        cause = causes.get(err.errno, err.strerror or type(err).__name__)
        where = err.filename if err.filename is not None else "(output)"
        return f"cannot write {where}: {cause}"
    return None


def _save_traceback(command) -> str:
    """Write the current exception's traceback to a file; return its path."""
    fd, path = tempfile.mkstemp(prefix=f"microimpact-{command}-", suffix=".txt")
    with os.fdopen(fd, "w") as fh:
        fh.write(f"microimpact {__version__}, command: {' '.join(sys.argv)}\n\n")
        traceback.print_exc(file=fh)
    return path


def _checkpoints(command, args) -> list[Path]:
    """The checkpoints that `command` keeps and that exist now."""
    # deferred: only an interrupted run needs the name
    from ..pipeline.folder import CHECKPOINT_NAME

    out = getattr(args, "out", None)
    if out is None:
        return []
    out = Path(out)
    if command == "run":
        found = [out / CHECKPOINT_NAME]
    elif command == "reproduce":
        found = sorted(out.glob(f"*/{CHECKPOINT_NAME}"))
    elif command == "wall-law":
        folder = out / _verb(command).CHECKPOINT_DIR
        found = [folder] if folder.is_dir() and any(folder.iterdir()) else []
    else:
        return []
    return [p for p in found if p.exists()]


def _kept(command, args) -> str:
    """What an interrupted `command` kept: only a checkpoint that exists, by path."""
    if command not in ("run", "reproduce", "wall-law"):
        return "nothing was kept (this command keeps no checkpoint)"
    found = _checkpoints(command, args)
    if not found:
        return "no work had finished, so no checkpoint was kept; nothing to resume"
    where = ", ".join(str(p) for p in found)
    return f"finished work is kept in {where}; the same command resumes it"


def main(argv=None) -> int:
    """Entry point of the ``microimpact`` command; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error
        return int(exc.code or 0)
    command = args.command
    previous = None
    if hasattr(signal, "SIGTERM"):
        try:
            previous = signal.signal(signal.SIGTERM, _on_sigterm)
        except ValueError:  # not the main thread
            previous = None
    try:
        with warnings.catch_warnings():  # restores the default printer after
            warnings.showwarning = _warning_printer(command)
            with stages(False if getattr(args, "quiet", False) else None):
                return _verb(command).cli_action(args)
    except ScenarioErrors as err:  # every problem of the file, one per line
        print(f"microimpact {command}: error: {err}", file=sys.stderr)
        return EXIT_USER
    except InputError as err:
        if err.field in _FLAG_OF_ARGUMENT:  # the library's argument, named as a flag
            err = type(err)(
                err.message,
                source=err.source,
                field=_FLAG_OF_ARGUMENT[err.field],
                line=err.line,
            )
        print(f"microimpact {command}: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt as err:
        what = "terminated" if isinstance(err, Terminated) else "interrupted"
        print(f"{what}; {_kept(command, args)}", file=sys.stderr)
        return EXIT_TERMINATED if isinstance(err, Terminated) else EXIT_INTERRUPTED
    except (OSError, MemoryError) as err:
        message = _environment_message(err)
        if isinstance(err, BrokenPipeError):  # nothing more can be printed there
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        if os.environ.get("MICROIMPACT_DEBUG"):
            raise
        print(f"microimpact {command}: error: {message}", file=sys.stderr)
        return EXIT_ENVIRONMENT
    except Exception as err:  # a bug of ours: say so, keep the traceback
        if os.environ.get("MICROIMPACT_DEBUG"):
            raise
        path = _save_traceback(command)
        print(
            f"microimpact {command}: internal error: {type(err).__name__}: "
            f"{_one_line(err)} (a bug in microimpact; the traceback is in {path}; "
            "please report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


__all__ = ["VERBS", "build_parser", "main"]
