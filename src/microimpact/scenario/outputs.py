"""Output settings of a study: what is written besides the results themselves.

They are not physics, so they are not part of
:class:`~microimpact.scenario.scenario.Scenario`;
:class:`~microimpact.pipeline.study.Study` owns them. A scenario file's ``[outputs]``
table is read into this object by :func:`microimpact.scenario.file.outputs_from_toml`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from .._core.formats import DEFAULT_FIGURE_FORMATS, FIGURE_FORMATS
from .._core.validation import check_scalar

__all__ = ["Outputs"]


@dataclass(frozen=True)
class Outputs:
    """What a study writes, besides the results themselves.

    Parameters
    ----------
    figures : sequence of {"png", "pdf", "svg"}
        Figure formats; empty for no figures.
    report : bool
        Write ``report.html``.
    experiments : sequence of path
        Experiment CSV files (``microimpact.io.experiments.read_experiments``
        format) to draw in the figures and compare with in the report.
    distribution_speed_m_s : float, optional
        The swept speed [m/s] of the distribution figures (paper Figs. 9, 10);
        default: the slowest swept speed at which particles rebound.
    """

    figures: tuple = DEFAULT_FIGURE_FORMATS
    report: bool = True
    experiments: tuple = ()
    distribution_speed_m_s: float | None = None

    def __post_init__(self):
        figures = self.figures
        if isinstance(figures, str):
            figures = (figures,)
        try:
            figures = tuple(dict.fromkeys(figures))
        except TypeError:
            raise ValueError(
                f"`figures` must be a sequence of {FIGURE_FORMATS}; got {figures!r}."
            ) from None
        bad = [f for f in figures if f not in FIGURE_FORMATS]
        if bad:
            raise ValueError(
                f"`figures` must be a subset of {FIGURE_FORMATS}; got {bad[0]!r}."
            )
        if not isinstance(self.report, bool):
            raise TypeError(f"`report` must be True or False; got {self.report!r}.")
        exps = self.experiments
        if isinstance(exps, str | os.PathLike):
            exps = (exps,)
        v = self.distribution_speed_m_s
        if v is not None:
            v = check_scalar(v, "distribution_speed_m_s", minimum=0, strict=True)
            object.__setattr__(self, "distribution_speed_m_s", v)
        object.__setattr__(self, "figures", figures)
        object.__setattr__(self, "experiments", tuple(Path(e) for e in exps))
