"""The figure of a model-against-measurement comparison (``analysis.measured.compare``): the
envelope order spectra above, the raw order spectra below, record and model overlaid on one
order axis, each in dB re its own largest line, the lines they share and those only one has
marked and named."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from analysis.measured.compare import SPECTRA, Comparison, OrderSpectrum
from analysis.reports import canvas as plt
from analysis.reports.plots import display_label

COLOURS = {"record": "C0", "model": "C3"}
FLOOR_DB = -60.0
"""Bottom of the dB axes."""
STATUS_MARKS = {"both": ("o", "k"), "record only": ("v", COLOURS["record"]),
                "model only": ("^", COLOURS["model"])}
TITLES = {"envelope": "squared envelope spectrum (band of largest kurtosis)",
          "raw": "raw spectrum"}


def _band(spectrum: OrderSpectrum) -> str:
    if spectrum.band_hz is None:
        return ""
    lo, hi = spectrum.band_hz
    return f", band {lo / 1e3:.3g}–{hi / 1e3:.3g} kHz"


def plot_kind(ax: Any, comparison: Comparison, kind: str) -> None:
    """Record and model spectra of ``kind`` on ``ax`` (dB re each one's largest line over
    order), each line marked by whether both have it, and named."""
    for source, spectrum in (("record", comparison.record[kind]),
                             ("model", comparison.model[kind])):
        ax.plot(spectrum.orders, np.maximum(spectrum.level_db, FLOOR_DB), lw=0.7,
                color=COLOURS[source], alpha=0.85,
                label=f"{source} ({comparison.units[source]}{_band(spectrum)})")
    labels = ax.get_xaxis_transform()
    for match in (m for m in comparison.matches if m.kind == kind):
        marker, colour = STATUS_MARKS[match.status]
        for line in (match.record, match.model):
            if line is not None:
                ax.plot(line.order, line.level_db, marker, ms=4, color=colour, mfc="none")
        first = match.record or match.model
        ax.annotate(display_label(match.name), (first.order, 1.0), xycoords=labels,
                    xytext=(0, 2), textcoords="offset points", rotation=90, fontsize=6.5,
                    color=colour, ha="center", va="bottom", annotation_clip=False)
    ax.set_xlim(0, comparison.max_order)
    ax.set_ylim(FLOOR_DB, 5)
    ax.set_ylabel("acceleration, dB re largest line"
                  if "m/s^2" in comparison.units.values() else "dB re largest line")
    ax.set_title(TITLES[kind], fontsize=9, pad=40)
    ax.legend(loc="lower right", fontsize=7)


def compare_figure(comparison: Comparison) -> Figure:
    """The envelope order spectra above the raw ones, sharing the order axis: record (blue)
    against model (red); lines both have ○ black, the record's only ▽ blue, the model's
    only △ red."""
    fig, axes = plt.subplots(len(SPECTRA), 1, figsize=(9, 7.5), layout="constrained",
                             sharex=True)
    for ax, kind in zip(axes, SPECTRA, strict=True):
        plot_kind(ax, comparison, kind)
    axes[-1].set_xlabel("order (cycles per shaft revolution)")
    prov = comparison.provenance
    fig.suptitle(f"{prov.get('record_signal', 'record')}\nagainst "
                 f"{prov.get('model_signal', 'model')}; ○ both, ▽ record only, △ model only",
                 fontsize=9)
    return plt.finish(fig, prov.get("model", {}))
