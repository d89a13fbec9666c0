"""The engine at parameter values: one model shared by sensitivity and calibration.

A :class:`ScenarioModel` reads a scenario file once and turns parameter values
(numbers of the file named by dotted keys, :mod:`microimpact.scenario.parameters`)
into engine results. Each table of the file (the size distribution, the coefficient
laws, every surface's roughness angles) is built once and kept: at new parameter
values only the tables whose numbers changed are built again, so a design row costs
its engine time, not the parsing of the file and the building of its surfaces (an
areal surface's synthetic height map, for instance). Every evaluation runs with the
same seed unless told otherwise (common random numbers), one worker each: the
callers spread evaluations, not impacts, over workers.

    model = ScenarioModel("sst76-formica-areal", ["surfaces.formica-areal.rms_um"])
    result = model.run({"surfaces.formica-areal.rms_um": 12.0}, samples=1000)
"""

from __future__ import annotations

import contextlib
import threading
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._core.validation import check_int
from ..engine.montecarlo import run
from ..engine.plan import build_plan
from ..scenario.parameters import check_parameter_key, with_values
from ..scenario.scenario import (
    ScenarioFile,
    read_scenario,
    scenario_file_from_dict,
)

__all__ = ["ScenarioModel"]


@contextlib.contextmanager
def _quiet():
    """The scenario's warnings off (a model shows them once, when it reads the
    file). warnings.catch_warnings swaps process-wide filters: only the main
    thread may (on worker threads, each warning shows once per place, as by
    default)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


class ScenarioModel:
    """A scenario at parameter values: values -> scenario -> engine result.

    Parameters
    ----------
    scenario : ScenarioFile, path, preset name or dict
        The scenario, read once. A dict is parsed TOML data (then `source` names
        it in messages and `base_dir` resolves its relative file names).
    keys : sequence of str
        Dotted keys of the parameters, in the order of the rows given to
        :meth:`values`; each is checked to be a number that may vary.
    samples : int, optional
        Impacts per sweep point of every evaluation (default: the scenario's
        ``samples``); a ``[precision]`` target is not used, so every evaluation
        draws the same impacts.
    seed : int, optional
        The engine seed of every evaluation (default: the scenario's).
    source, base_dir :
        For a dict `scenario` only.

    Attributes
    ----------
    file : ScenarioFile
        The file as read, at its own values.
    data : dict
        Its parsed data without the ``[sensitivity]`` table.
    """

    def __init__(
        self, scenario, keys=(), *, samples=None, seed=None, source=None, base_dir=None
    ):
        self.cache: dict = {}
        if isinstance(scenario, Mapping):
            if base_dir is None and source is not None:
                base_dir = Path(source).resolve().parent
            file = scenario_file_from_dict(
                dict(scenario), source=source, base_dir=base_dir, cache=self.cache
            )
        else:
            file = read_scenario(scenario, cache=self.cache)
        self.file: ScenarioFile = file
        self.source = file.source
        self.base_dir = file.base_dir
        self.data = {k: v for k, v in file.data.items() if k != "sensitivity"}
        self.set_keys(keys)
        base = file.scenario
        self.samples = (
            base.samples if samples is None else check_int(samples, "samples")
        )
        self.seed = base.seed if seed is None else seed
        self._base = self.scenario({})  # fills the cache with the file's tables

    def set_keys(self, keys):
        """Name the parameters (dotted keys, the column order of rows), each
        checked to be a number of the file that may vary."""
        keys = tuple(keys)
        for key in keys:
            check_parameter_key(self.data, key, source=self.source)
        self.keys = keys

    @property
    def base(self):
        """The scenario at the file's own values."""
        return self._base

    def values(self, row) -> dict:
        """`row` (values in the order of :attr:`keys`, or a mapping) as a mapping of
        dotted key -> float."""
        if isinstance(row, Mapping):
            return {str(k): float(v) for k, v in row.items()}
        row = np.atleast_1d(np.asarray(row, dtype=float))
        return dict(zip(self.keys, (float(v) for v in row), strict=True))

    def scenario(self, row):
        """The validated scenario at `row` (values, or a mapping key -> value): the
        file's data with those numbers, each unchanged table taken as built."""
        values = self.values(row)
        data = (
            with_values(self.data, values, source=self.source) if values else self.data
        )
        return scenario_file_from_dict(
            data, source=self.source, base_dir=self.base_dir, cache=self.cache
        ).scenario

    def plan(self, row, *, seed=None):
        """The engine's tables at `row` (``build_plan`` with `seed`, default
        :attr:`seed`): what :meth:`run` at `row` simulates, for a caller that also
        draws per-impact outputs from the same impacts (pass it to :meth:`run`)."""
        with _quiet():
            return build_plan(
                self.scenario(row), seed=self.seed if seed is None else seed
            )

    def run(self, row, *, samples=None, seed=None, plan=None):
        """The engine result at `row`: ``microimpact.run`` with one worker, no
        progress bar, `samples` impacts per point (default :attr:`samples`) and
        `seed` (default :attr:`seed`); `plan`: :meth:`plan` at `row` and that seed,
        not built again. The scenario's warnings were shown once, when the model
        read the file; they are not repeated for every row."""
        with _quiet():
            return run(
                self.scenario(row),
                samples=self.samples if samples is None else samples,
                seed=self.seed if seed is None else seed,
                workers=1,
                progress=False,
                plan=plan,
            )

    def summary(self, row, *, samples=None, seed=None):
        """The summary table of :meth:`run` (the result itself is dropped, so
        memory stays bounded over many evaluations)."""
        return self.run(row, samples=samples, seed=seed).summary
