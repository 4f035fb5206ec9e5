"""Figures without pyplot: ``subplots`` and ``close`` as pyplot has them, for a ``Figure`` on
its own Agg canvas; and the provenance a figure carries into its file.

A figure made here never joins pyplot's list of open figures, so making one needs no backend
(it renders headless, on any machine), changes no backend (a notebook's inline backend or a
script's choice stay as they were), and shows once where it is displayed (a notebook shows a
returned ``Figure`` itself; pyplot would show it a second time at the end of the cell).

Provenance: a figure function calls ``stamp(fig, result)`` with the result it draws; every
figure file is written by ``analysis.reports.plots.save_figure``, which passes
``file_metadata(fig, format)`` to ``savefig``: a PNG carries the model, the spec path, its
SHA-256 and the versions as text chunks (``model``, ``spec_file``, ``spec_sha256``,
``bearingdyn_version``, ``Software``) and every other value the result's attributes hold
(each parameter, the balls, the step: what the .nc carries), a PDF or SVG the same in its
``Subject`` or ``Description``."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

PROVENANCE_KEYS = ("model", "spec_file", "spec_sha256", "bearingdyn_version")
"""The attributes of a result that its figure's file carries."""


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


def stamp(fig: Figure, source: Any) -> Figure:
    """Record on ``fig`` the provenance of the result it draws (``source``: a Dataset or
    DataArray, or a mapping of attrs): model, spec path, SHA-256 and the version that
    computed it (``PROVENANCE_KEYS``) first, then every other attribute the result file
    holds as one value (each parameter in SI units, the balls, the step, the frequencies, …;
    an array of up to ``MAX_ARRAY_VALUES`` values as its list, a longer one left out), so a
    figure's file carries what its .nc carries. Returns ``fig``."""
    attrs = getattr(source, "attrs", source)
    if isinstance(attrs, Mapping):
        found = {key: str(attrs[key]) for key in PROVENANCE_KEYS if key in attrs}
        for key, value in attrs.items():
            text = _attribute_text(value)
            if str(key) not in found and text is not None and _latin1(str(key)):
                found[str(key)] = text
        fig.bearingdyn_provenance = found
    return fig


MAX_ARRAY_VALUES = 64
"""Longest array attribute a figure's file carries (a speed table's points)."""


def _attribute_text(value: Any) -> str | None:
    """An attribute as the text a file's metadata holds: numbers with every digit (``repr``
    of a float), strings as they are, short arrays as lists; None for anything else."""
    import numpy as np

    if isinstance(value, (str, bool, int, float, np.integer, np.floating, np.bool_)):
        return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        flat = np.asarray(value).ravel()
        if flat.size <= MAX_ARRAY_VALUES and flat.dtype.kind in "biuf":
            return "[" + ", ".join(repr(float(v)) for v in flat) + "]"
    return None


def _latin1(key: str) -> bool:
    """A PNG text key: 1 to 79 Latin-1 characters."""
    try:
        key.encode("latin-1")
    except UnicodeEncodeError:
        return False
    return 0 < len(key) < 80


def figure_provenance(fig: Figure) -> dict[str, str]:
    """What ``stamp`` recorded on ``fig`` ({} for a figure never stamped)."""
    return dict(getattr(fig, "bearingdyn_provenance", {}))


def file_metadata(fig: Figure, fmt: str) -> dict[str, str] | None:
    """The ``metadata`` argument of ``fig.savefig`` for a file of format ``fmt`` (``png``,
    ``pdf``, ``svg``; None for others): the figure's provenance (``stamp``) and the version
    of bearingdyn that drew it (``Software``)."""
    from analysis.provenance import package_version

    drawn = f"bearingdyn {package_version()}"
    found = figure_provenance(fig)
    words = "; ".join(f"{key}={value}" for key, value in found.items())
    fmt = fmt.lower()
    if fmt == "png":
        return {"Software": drawn, **found}
    if fmt == "pdf":
        return {"Creator": drawn, **({"Subject": words} if words else {})}
    if fmt == "svg":
        return {"Creator": drawn, **({"Description": words} if words else {})}
    return None


def footnote(fig: Figure, text: str, fontsize: float = 6.5) -> None:
    """``text`` as a footnote under everything else of ``fig`` (a constrained-layout
    figure): wrapped to the figure's width and set as the figure's bottom label, for which
    the layout makes room, so it never covers an axis label or the tick labels however
    many lines it takes."""
    label = fig.supxlabel(text, fontsize=fontsize, color="0.3", x=0.01, ha="left",
                          va="bottom")
    fit_text(label, 0.97 * fig.bbox.width)  # lines measured with the figure's renderer


def _wrapped(text: str, width_px: float, measure) -> str:
    """``text`` with line breaks after ", " or "; " (else spaces) so that each line measures
    at most ``width_px`` (``measure(line)`` in pixels); a word longer than the width keeps
    its line."""
    lines: list[str] = []
    for paragraph in text.split("\n"):
        pieces = [p for p in _pieces(paragraph)]
        line = ""
        for piece in pieces:
            trial = line + piece
            if line and measure(trial.rstrip()) > width_px:
                lines.append(line.rstrip())
                line = piece.lstrip()
            else:
                line = trial
        lines.append(line.rstrip())
    return "\n".join(lines)


def _pieces(text: str) -> list[str]:
    """``text`` cut after each ", ", "; " or ": " (or after each space when it has none)."""
    import re

    parts = [p for p in re.split(r"(?<=[,;:] )", text) if p]
    if len(parts) <= 1:
        parts = [p for p in re.split(r"(?<= )", text) if p]
    return parts


def fit_text(artist, width_px: float) -> None:
    """Break the text of ``artist`` (a title, suptitle or label) into lines no wider than
    ``width_px`` display pixels, measured with the figure's renderer."""
    from matplotlib.text import Text

    fig = artist.get_figure(root=True) if hasattr(artist, "get_figure") else artist.figure
    renderer = fig.canvas.get_renderer()
    probe = Text(0, 0, "", fontproperties=artist.get_fontproperties(), figure=fig)

    def measure(line: str) -> float:
        probe.set_text(line)
        return probe.get_window_extent(renderer).width

    artist.set_text(_wrapped(artist.get_text(), width_px, measure))


def fit_titles(fig: Figure, margin_px: float = 8.0) -> Figure:
    """Make every title of ``fig`` fit: the suptitle within the figure's width, each axes
    title within its axes (and the figure), each x label within the figure, broken into
    lines at commas where too wide. Call once the axes are drawn; returns ``fig``."""
    fig.canvas.draw()
    width = fig.bbox.width - 2 * margin_px
    if fig._suptitle is not None and fig._suptitle.get_text():
        fit_text(fig._suptitle, width)
    for ax in fig.axes:
        for title in (ax.title, ax._left_title, ax._right_title):
            if title.get_text():
                fit_text(title, min(max(ax.bbox.width, 0.3 * width), width))
        label = ax.xaxis.label  # centred under its axes: as wide as the figure lets it
        if label.get_text():
            centre = 0.5 * (ax.bbox.x0 + ax.bbox.x1) - fig.bbox.x0
            fit_text(label, max(2 * min(centre - margin_px,
                                        fig.bbox.width - margin_px - centre), 0.2 * width))
    return fig


def no_offsets(fig: Figure) -> Figure:
    """Turn off the offset ("+1.002e3") of every linear axis of ``fig``: an axis shows its
    values in the unit its label names, never as an offset or a multiplier of them."""
    from matplotlib.ticker import ScalarFormatter

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            formatter = axis.get_major_formatter()
            if isinstance(formatter, ScalarFormatter):
                formatter.set_useOffset(False)
    return fig


def finish(fig: Figure, source: Any) -> Figure:
    """The last step of every figure function: titles that fit (``fit_titles``), axes
    without offsets (``no_offsets``), the provenance of ``source`` recorded (``stamp``)."""
    no_offsets(fig)
    fit_titles(fig)
    return stamp(fig, source)
