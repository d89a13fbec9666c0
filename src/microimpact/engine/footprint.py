"""The cost of a run, from its scenario: kept in :mod:`microimpact._core.footprint`
(the lowest layer, so that a command can refuse a sweep too big for the machine
before the engine and SciPy load); this module is its public name."""

from .._core.footprint import *  # noqa: F403
from .._core.footprint import __all__  # noqa: F401
