"""One progress convention for every long call: ``progress`` is ``True`` (a tqdm
bar on stderr), ``False`` (nothing), ``None`` (a bar only when stderr is a terminal)
or a callable, called as ``progress(done, total)`` after each step.

Work without a count of its own (the statistics of a run, writing one file) is a
:func:`stage`: silent unless it takes more than a second, then shown with its
elapsed time, within a :func:`stages` block that asks for it (the command line
opens one around each verb)."""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from contextvars import ContextVar

__all__ = ["Progress", "check_progress", "stage", "stages"]


def check_progress(progress, field="progress"):
    """`progress` if it is a bool, None or a callable, else TypeError naming it."""
    if progress is None or isinstance(progress, bool) or callable(progress):
        return progress
    raise TypeError(
        f"`{field}` must be True, False, None or a callable (done, total); "
        f"got {type(progress).__name__} {progress!r}."
    )


class Progress:
    """Progress of `total` steps (impacts, diameters, design rows...), shown as
    `progress` asks; :meth:`update` adds finished steps, :meth:`close` ends it."""

    def __init__(self, progress, *, total, unit, desc=None, initial=0):
        progress = check_progress(progress)
        self.total, self.done = total, initial
        self.callback = self.bar = None
        if callable(progress) and not isinstance(progress, bool):
            self.callback = progress
            return
        if progress is None:
            progress = sys.stderr.isatty()
        if progress:
            self.bar = _bar_class()(
                total=total,
                unit=unit,
                unit_scale=True,
                delay=1.0,
                desc=desc,
                leave=False,
            )
            self.bar.update(initial)

    @property
    def active(self) -> bool:
        """Whether anything shows or hears the progress (a bar or a callback)."""
        return self.bar is not None or self.callback is not None

    def update(self, n=1):
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.callback is not None:
            self.callback(self.done, self.total)

    def close(self):
        if self.bar is not None:
            self.bar.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _bar_class():
    """tqdm's bar without its monitor thread (``monitor_interval = 0``: it
    only retunes ``miniters`` of bars updated rarely): a thread of its own
    would keep this process from forking worker processes
    (:func:`~microimpact.engine.parallel.fork_pool`) while a bar shows."""
    global _BAR
    if _BAR is None:
        # deferred: tqdm (and its notebook detection) loads only for a bar
        from tqdm.auto import tqdm

        _BAR = type("MicroimpactBar", (tqdm,), {"monitor_interval": 0})
    return _BAR


_BAR = None


# ------------------------------------------------------------------ stages
#: A stage shows itself once it has taken this long [s]; quicker ones stay silent.
STAGE_DELAY_S = 1.0
#: While it shows, a stage's elapsed time is refreshed this often [s].
STAGE_REFRESH_S = 1.0

_STAGES: ContextVar = ContextVar("microimpact_stages", default=False)
_IN_STAGE: ContextVar = ContextVar("microimpact_in_stage", default=False)


@contextlib.contextmanager
def stages(progress):
    """Within this block, every :func:`stage` is shown as `progress` asks (the
    convention of this module; a callable is called as ``progress(desc, None)``
    when a stage starts and ``progress(desc, seconds)`` when it ends). Outside
    any such block stages are silent, so the library prints nothing of its own."""
    token = _STAGES.set(check_progress(progress))
    try:
        yield
    finally:
        _STAGES.reset(token)


@contextlib.contextmanager
def stage(desc):
    """One step of work without a count of its own (the statistics of a run, the
    writing of one file): once it has run :data:`STAGE_DELAY_S`, its name and
    elapsed time are shown on stderr (refreshed every :data:`STAGE_REFRESH_S`)
    until it ends, within a :func:`stages` block that asks for it."""
    progress = _STAGES.get()
    if progress is None:
        progress = sys.stderr.isatty()
    if progress is False or _IN_STAGE.get():  # a stage within a stage is its part
        yield
        return
    token = _IN_STAGE.set(True)
    try:
        with _shown(desc, progress):
            yield
    finally:
        _IN_STAGE.reset(token)


@contextlib.contextmanager
def _shown(desc, progress):
    t0 = time.perf_counter()
    if callable(progress) and not isinstance(progress, bool):
        progress(desc, None)
        try:
            yield
        finally:
            progress(desc, time.perf_counter() - t0)
        return
    ticker = _Ticker(desc, t0, tty=sys.stderr.isatty())
    ticker.start()
    ok = False
    try:
        yield
        ok = True
    finally:
        ticker.finish(ok)


class _Ticker(threading.Thread):
    """Shows a running stage on stderr: on a terminal one line rewritten with the
    elapsed time; elsewhere (a log) one line when it shows and one when it ends."""

    def __init__(self, desc, t0, *, tty):
        super().__init__(daemon=True)
        self.desc, self.t0, self.tty = desc, t0, tty
        self.done = threading.Event()
        self.shown = False
        self.lock = threading.Lock()

    def run(self):
        if self.done.wait(STAGE_DELAY_S):
            return
        while True:
            with self.lock:
                if self.done.is_set():
                    return
                self._show()
            if self.done.wait(STAGE_REFRESH_S):
                return

    def _show(self):
        elapsed = time.perf_counter() - self.t0
        if self.tty:
            sys.stderr.write(f"\r{self.desc}: {elapsed:.0f} s ")
        elif not self.shown:
            sys.stderr.write(f"{self.desc} ...\n")
        sys.stderr.flush()
        self.shown = True

    def finish(self, ok=True):
        with self.lock:
            self.done.set()
            if self.shown:
                elapsed = time.perf_counter() - self.t0
                end = "\r" if self.tty else ""
                how = "done in" if ok else "stopped after"
                sys.stderr.write(f"{end}{self.desc}: {how} {elapsed:.1f} s\n")
                sys.stderr.flush()
        self.join()
