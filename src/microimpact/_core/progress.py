"""One progress convention for every long call: ``progress`` is ``True`` (a tqdm
bar on stderr), ``False`` (nothing), ``None`` (a bar only when stderr is a terminal)
or a callable, called as ``progress(done, total)`` after each step."""

from __future__ import annotations

import sys

__all__ = ["Progress", "check_progress"]


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
            # deferred: tqdm (and its notebook detection) loads only for a bar
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=total,
                unit=unit,
                unit_scale=True,
                delay=1.0,
                desc=desc,
                leave=False,
            )
            self.bar.update(initial)

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
