"""The pipeline: run -> files -> figures -> report, as one library object.

In the spirit of pvlib's ``ModelChain``, :class:`Study` sequences the steps that
``microimpact run`` performs and owns the output settings (:class:`Outputs`), which
are not part of the physics (:class:`~microimpact.scenario.scenario.Scenario`). Each
step is a method that returns the study, so they chain::

    import microimpact as mi

    study = mi.Study("my-study.toml", outputs=mi.Outputs(figures=("png",)))
    study.run(workers=2).write("out/")          # summary.csv, results.nc, figures,
                                                # capture_speed.csv, report.html
    mi.Study.from_result(mi.open_result("out/")).write("out/", parts=("figures",
                                                 "report"))  # no simulation

:meth:`Study.execute` is the whole of ``microimpact run``: it owns the output folder
for the duration (a lock refuses a second run into it), keeps a checkpoint there so
an interrupted run resumes, writes every output atomically, and removes the files an
earlier run wrote there that this one does not (a manifest); files the user put in
the folder are never touched.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from .._core.files import atomic_write
from .._core.validation import check_subset
from ..analysis.compare import check_experiments
from ..analysis.robustness import SAMPLES, robustness_study
from ..engine.checkpoint import Checkpoint
from ..engine.montecarlo import run
from ..engine.result import open_result
from ..io.experiments import combine_experiments, write_experiments
from ..plotting._style import use_agg
from ..plotting.results import save_figures
from ..scenario.file import PAPER_PRESETS
from ..scenario.outputs import Outputs
from ..scenario.scenario import Scenario, read_scenario
from .figures import figures_for_result, swept_speed
from .folder import CHECKPOINT_NAME, OutputFolder
from .report import input_figures, write_report

__all__ = ["CHECKPOINT_NAME", "Outputs", "Study", "reproduce"]

#: The parts :meth:`Study.write` can write.
PARTS = ("tables", "figures", "report")


class Study:
    """One study: a scenario, its output settings, and (after :meth:`run`) its
    result.

    Parameters
    ----------
    scenario : Scenario, path or str
        A :class:`~microimpact.scenario.scenario.Scenario`, a scenario TOML file (its
        ``[outputs]`` table gives the default `outputs`), or a preset name.
    outputs : Outputs, optional
        Output settings; default: the file's ``[outputs]`` table, else
        :class:`Outputs()`.

    Attributes
    ----------
    scenario : Scenario or ScenarioRecord
    outputs : Outputs
    result : SimulationResult or None
        Set by :meth:`run` (or given to :meth:`from_result`).
    files : list of pathlib.Path
        Every file the last :meth:`write` wrote.
    """

    def __init__(self, scenario, *, outputs: Outputs | None = None):
        _outputs_iv(outputs)
        if not isinstance(scenario, Scenario):
            file = read_scenario(scenario)  # the file is opened once, here
            if outputs is None:
                outputs = file.outputs
            scenario = file.scenario
        self._setup(scenario, outputs)

    @classmethod
    def from_result(cls, result, *, outputs: Outputs | None = None) -> Study:
        """A study around an existing result (e.g. :func:`open_result`), to write its
        files, figures and report without running anything."""
        _outputs_iv(outputs)
        study = cls.__new__(cls)  # the result's scenario may be a ScenarioRecord
        study._setup(result.scenario, outputs)
        study.result = result
        return study

    @classmethod
    def from_folder(cls, folder, *, outputs: Outputs | None = None) -> Study:
        """The study a run folder holds: its ``results.nc``, the output settings the
        run recorded and the experiments it compared with (``experiments.csv``,
        the copy the run kept), so that :meth:`write` rebuilds what the run wrote.
        `outputs` overrides the recorded settings; its experiments, where given,
        replace the run's."""
        folder = Path(folder)
        result = open_result(folder)
        if folder.is_file():
            folder = folder.parent
        saved = OutputFolder(folder).settings()
        copy = folder / EXPERIMENTS_NAME
        recorded = Outputs(
            figures=tuple(saved.get("figures", Outputs().figures)),
            report=bool(saved.get("report", True)),
            experiments=(copy,) if copy.is_file() else (),
            distribution_speed_m_s=saved.get("distribution_speed_m_s"),
        )
        if outputs is not None:
            recorded = replace(
                outputs, experiments=outputs.experiments or recorded.experiments
            )
        return cls.from_result(result, outputs=recorded)

    def _setup(self, scenario, outputs):
        self.scenario = scenario
        self.outputs = Outputs() if outputs is None else outputs
        self.result = None
        self.files: list[Path] = []
        self._experiments = None

    def __repr__(self) -> str:
        state = "not run" if self.result is None else repr(self.result)
        return f"<Study {self.scenario.name!r}: {state}>"

    # ------------------------------------------------------------ steps
    def experiments(self):
        """The experiments table (read once, before any output), or None."""
        if self._experiments is None and self.outputs.experiments:
            self._experiments = combine_experiments(list(self.outputs.experiments))
        return self._experiments

    def run(self, **options) -> Study:
        """Run the simulation (:func:`microimpact.run` with `options`: samples,
        seed, workers, backend, executor, address, checkpoint, progress)."""

        exp = self.experiments()  # a bad experiments file fails before the run
        if exp is not None:  # and so does one the sweep cannot serve
            check_experiments(self.scenario, exp)
        wanted = self.outputs.distribution_speed_m_s
        if wanted is not None:  # a figure setting the sweep cannot serve, too
            swept_speed(self.scenario.speeds_m_s, wanted)
        self.result = run(self.scenario, **options)
        return self

    def write(self, out_dir, *, parts=PARTS) -> Study:
        """Write the outputs of :attr:`result` into `out_dir`.

        Parameters
        ----------
        out_dir : path
            Folder (created if needed). While writing, the folder is locked
            against other studies; files that an earlier study wrote there and
            this one does not are removed (see the module notes).
        parts : sequence of {"tables", "figures", "report"}
            ``tables``: ``summary.csv``, ``results.nc``, ``capture_speed.csv``;
            ``figures``: the figures in :attr:`Outputs.figures`;
            ``report``: ``report.html`` (if :attr:`Outputs.report`).
        """
        self._need_result()
        parts = _parts_iv(parts)
        with OutputFolder(out_dir) as folder:
            self._write(folder, parts)
        return self

    def report(self, path=None) -> Path:
        """Write ``report.html`` (default: in the folder of the last :meth:`write`)
        and return its path."""
        self._need_result()
        if path is None:
            if not self.files:
                raise ValueError("give `path`: nothing has been written yet.")
            path = self.files[0].parent / "report.html"
        return self._report(Path(path), figures=None)

    def execute(self, out_dir, **options) -> Study:
        """Run and write everything into `out_dir`: the whole of ``microimpact run``.

        The folder is locked for the whole run; a checkpoint kept there
        (:data:`CHECKPOINT_NAME`) lets an interrupted run resume with the same
        command; it is removed once every output is written. ``checkpoint=`` may
        be a function of the :class:`~microimpact.engine.checkpoint.Checkpoint`,
        called once it is loaded (before any block runs), e.g. to say how much
        was restored.
        """

        self.experiments()
        with OutputFolder(out_dir) as folder:
            checkpoint = options.pop("checkpoint", None)
            if checkpoint is None or callable(checkpoint):
                # a callable is told how much was restored before any block runs
                checkpoint = Checkpoint(
                    folder.path / CHECKPOINT_NAME, on_load=checkpoint
                )
            self.run(checkpoint=checkpoint, **options)
            self._write(folder, PARTS)
            Path(getattr(checkpoint, "path", checkpoint)).unlink(missing_ok=True)
        return self

    # ------------------------------------------------------------ internals
    def _need_result(self):
        if self.result is None:
            raise ValueError("the study has no result yet: call run() first.")

    def _write(self, folder, parts):
        written = []
        result = self.result
        if "tables" in parts:
            written += [
                folder.write("summary.csv", result.write_summary),
                folder.write("results.nc", result.to_netcdf),
                folder.write(
                    "capture_speed.csv",
                    lambda t: result.capture_speed().to_csv(t, index=False),
                ),
            ]
        exp = self.experiments()
        if "tables" in parts and exp is not None:
            # a copy of what was compared, so that `microimpact report` rebuilds
            # the comparison without the original files
            written.append(
                folder.write(EXPERIMENTS_NAME, lambda t: _write_experiments(exp, t))
            )
        figures = []
        if "figures" in parts and self.outputs.figures:
            figures = self._figures(folder)
            written += figures
        if "report" in parts and self.outputs.report:
            written.append(
                self._report(
                    folder.path / "report.html",
                    figures=figures if "figures" in parts else None,
                    folder=folder,
                )
            )
        o = self.outputs
        folder.record(
            written,
            parts,
            settings={
                "figures": list(o.figures),
                "report": o.report,
                "distribution_speed_m_s": o.distribution_speed_m_s,
                "experiments": [Path(p).name for p in o.experiments],
            },
        )
        self.files = written

    def _figures(self, folder):

        use_agg()
        exp = self.experiments()
        paths = figures_for_result(
            self.result,
            folder.path,
            formats=self.outputs.figures,
            experiments=exp,
            distribution_speed_m_s=self.outputs.distribution_speed_m_s,
        )
        paths += save_figures(
            [(name, fig) for name, _caption, fig in input_figures(self.result)],
            folder.path,
            self.outputs.figures,
        )
        return [Path(p) for p in paths]

    def _report(self, path, *, figures, folder=None):

        use_agg()
        name = self.result.scenario.name
        csv = path.parent / "summary.csv"
        return Path(
            write_report(
                [self.result],
                path,
                extra_figures={name: figures} if figures is not None else None,
                experiments={name: self.experiments()},
                csv_paths=[csv] if csv.exists() else None,
                distribution_speeds={name: self.outputs.distribution_speed_m_s},
            )
        )


#: The copy of the experiments a run compared with, kept in its folder.
EXPERIMENTS_NAME = "experiments.csv"


def _write_experiments(exp, path):
    """The run's copy of its experiments, named after the files they came from."""
    sources = sorted({Path(str(s)).name for s in exp.get("source", []) if s})
    note = "the experiments this run compared with"
    if sources:
        note += " (from " + ", ".join(sources) + ")"
    write_experiments(exp, path, comment=note)


def _outputs_iv(outputs):
    if outputs is not None and not isinstance(outputs, Outputs):
        raise TypeError(f"`outputs` must be an Outputs; got {outputs!r}.")


def _parts_iv(parts):

    return check_subset(parts, "parts", PARTS)


def reproduce(out_dir="out", *, samples=None, figures=None, **options) -> list[Study]:
    """Reproduce the paper: run its four presets into ``out_dir/<preset>/`` and
    write one report of them all to ``out_dir/report.html``.

    Parameters
    ----------
    out_dir : path
    samples : int, optional
        Impacts per sweep point (default: each preset's, 4,000).
    figures : sequence of {"png", "pdf", "svg"}, optional
        Figure formats (default: each preset's ``[outputs] figures``, png).
    **options
        As for :meth:`Study.run` (seed, workers, backend, ...).
    """

    out = Path(out_dir)
    studies = [Study(name) for name in PAPER_PRESETS]
    if figures is not None:
        for study in studies:
            study.outputs = replace(study.outputs, figures=figures)
    for study in studies:  # every experiments file is read before any output
        study.experiments()
    for study in studies:
        study.execute(out / study.scenario.name, samples=samples, **options)
    # the statements judged over the Formica family, at full size (about 20 s);
    # --quick / --samples shrink it with the presets
    n = SAMPLES if samples is None else max(int(samples), 1000)
    robust = robustness_study(samples=n, workers=options.get("workers", 1) or 1)
    with OutputFolder(out) as folder:
        path = write_report(
            [s.result for s in studies],
            folder.path / "report.html",
            extra_figures={
                s.scenario.name: [f for f in s.files if f.suffix != ".html"]
                for s in studies
            },
            experiments={s.scenario.name: s.experiments() for s in studies},
            csv_paths=[out / s.scenario.name / "summary.csv" for s in studies],
            title="microimpact: reproducing Li, Dunn & Brach (2000)",
            statements=robust,
        )
        files = [Path(path)]
        for stem, frame in (
            ("robustness", robust.table),
            ("robustness_conditions", robust.conditions.reset_index()),
            ("robustness_surfaces", robust.realizations),
        ):
            p = folder.path / f"{stem}.csv"
            atomic_write(p, lambda t, f=frame: f.to_csv(t, index=False))
            files.append(p)
        folder.record(files, ("report", "tables"))
    return studies
