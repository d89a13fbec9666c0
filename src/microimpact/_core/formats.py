"""Output format names shared by the scenario files, the pipeline and the plots.

A leaf module (no imports), so that reading a scenario file never loads plotting.
"""

#: Figure file formats: a scenario's ``[outputs] figures``, the CLI's ``--formats``
#: and :func:`microimpact.plotting.results.save_figure` accept these.
FIGURE_FORMATS = ("png", "pdf", "svg")
#: Figure formats when neither the scenario nor the caller names any.
DEFAULT_FIGURE_FORMATS = ("png", "pdf")
