"""Exception and warning types that callers may want to catch.

Every user mistake (a bad scenario key, a malformed data file, a bad CLI flag)
raises :class:`InputError`, a :class:`ValueError`. Its message names the file, the
field or line, the bad value and what is allowed. The CLI turns it into a one-line
message and exit code 2, never a traceback.
"""

from __future__ import annotations


def _one_line(text) -> str:
    """`text` with every run of whitespace (newlines included) as one space."""
    return " ".join(str(text).split())


class InputError(ValueError):
    """A user-supplied input is invalid.

    Parameters
    ----------
    message : str
        What is wrong and what is allowed.
    source : str or path-like, optional
        The file the input came from.
    field : str, optional
        The key path, column or argument name.
    line : int, optional
        1-based line number in `source`.
    """

    def __init__(self, message, *, source=None, field=None, line=None):
        self.message = message
        self.source = None if source is None else str(source)
        self.field = field
        self.line = line
        super().__init__(self._format())

    def _format(self) -> str:
        where = ""
        if self.source is not None:
            where = self.source
            if self.line is not None:
                where += f":{self.line}"
            where += ": "
        elif self.line is not None:
            where = f"line {self.line}: "
        if self.field:
            where += f"{self.field}: "
        return _one_line(where + str(self.message))


class ProfileFormatError(InputError):
    """A surface-profile file cannot be read."""


class DataFormatError(InputError):
    """A diameter, histogram or impact-data file cannot be read."""


class ScenarioError(InputError):
    """A scenario file or scenario object is invalid."""


class ScenarioErrors(ScenarioError):
    """Several problems of one scenario file, reported together in file order.

    ``errors`` holds each one (a :class:`ScenarioError`); the message is one line
    per problem, after a line that counts them.
    """

    def __init__(self, errors, *, source=None):
        self.errors = list(errors)
        lines = [str(e) for e in self.errors]
        head = f"{len(lines)} problems" + (f" in {source}" if source else "") + ":"
        self.message = "\n".join([head, *(f"  {line}" for line in lines)])
        self.source = None if source is None else str(source)
        self.field = None
        self.line = None
        ValueError.__init__(self, self.message)


class ConvergenceWarning(RuntimeWarning):
    """A Monte Carlo statistic did not reach its precision target."""
