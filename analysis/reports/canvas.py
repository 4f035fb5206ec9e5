"""Figures without pyplot: ``subplots`` and ``close`` as pyplot has them, for a ``Figure`` on
its own Agg canvas.

A figure made here never joins pyplot's list of open figures, so making one needs no backend
(it renders headless, on any machine), changes no backend (a notebook's inline backend or a
script's choice stay as they were), and shows once where it is displayed (a notebook shows a
returned ``Figure`` itself; pyplot would show it a second time at the end of the cell)."""

from __future__ import annotations

import sys
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] | None = None,
             layout: str | None = None, **kwargs: Any) -> tuple[Figure, Any]:
    """A new figure (``figsize`` in inches, ``layout`` as matplotlib's) and its grid of axes:
    ``Figure.subplots(nrows, ncols, **kwargs)`` (``sharex``, ``squeeze``, …)."""
    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def close(fig: Figure) -> None:
    """Release ``fig``: nothing to do for a figure of ``subplots``; a figure pyplot made is
    closed there."""
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close(fig)
