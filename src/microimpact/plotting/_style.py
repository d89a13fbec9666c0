"""The house style of every figure: palette and local rcParams (a leaf module)."""

import contextlib
import sys

#: Okabe-Ito colours (distinguishable with colour-vision deficiency).
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
#: Local rcParams of every figure made here.
STYLE = {
    "font.size": 9.0,
    "axes.labelsize": 9.0,
    "axes.titlesize": 9.5,
    "legend.fontsize": 8.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.5,
    "lines.linewidth": 1.5,
    "legend.frameon": False,
    "errorbar.capsize": 2.5,
    "savefig.dpi": 200,
    "pdf.fonttype": 42,
}


def colour(k: int) -> str:
    """The `k`-th colour of the palette (cycled)."""
    return PALETTE[k % len(PALETTE)]


def use_agg():
    """Draw without a display (files only), unless a backend is already in use:
    pyplot imported means the caller chose one, which is left as it is."""

    if "matplotlib.pyplot" not in sys.modules:
        # deferred: matplotlib loads only when a figure is drawn
        import matplotlib

        matplotlib.use("Agg")


@contextlib.contextmanager
def styled(extra=None):
    """Apply :data:`STYLE` (and the rcParams in `extra`) for the figure drawn in
    this block, then put back the values of those keys only.

    Not ``matplotlib.rc_context``: that restores *every* rcParam on exit, among
    them ``interactive``, which a notebook's inline backend sets to True when the
    first figure of a session resolves the backend inside the block. Restored to
    False, no later figure is drawn inline: only the first figure of a kernel
    session showed (matplotlib#25041, #24351; issue 33)."""
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib as mpl

    rc = {**STYLE, **(extra or {})}
    saved = {key: mpl.rcParams[key] for key in rc}
    mpl.rcParams.update(rc)
    try:
        yield
    finally:
        mpl.rcParams.update(saved)
