"""The figure of ``bearingdyn diagnose``: the squared envelope spectrum with each family's
theoretical lines (dashed, named) and the lines found above the threshold marked, and the
fast kurtogram beside it with the band chosen. Functions return figures; saving is the
caller's."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from analysis.reports.plots import plt

COLOURS = {"outer-race": "C3", "inner-race": "C2", "ball": "C1", "cage": "C4"}
"""One colour per fault family."""


def _f_max(diagnosis) -> float:
    """The spectrum shown: up to 4.3 times the highest of BPFO, BPFI and 2xBSF."""
    table = diagnosis.frequencies
    top = 4.3 * max(table["BPFO"], table["BPFI"], table["2xBSF"])
    return float(min(top, diagnosis.envelope_hz[-1]))


def _spectrum_axis(ax, diagnosis) -> None:
    freq, amp = diagnosis.envelope_hz, diagnosis.envelope_amplitude
    f_max = _f_max(diagnosis)
    keep = (freq > 0) & (freq <= f_max)
    ax.plot(freq[keep], amp[keep], lw=0.7, color="0.25")
    top = float(amp[keep].max()) if keep.any() else 1.0
    for name, family in diagnosis.families.items():
        colour = COLOURS[name]
        for line in family.lines:
            if line.role != "harmonic" or line.theory_hz > f_max:
                continue
            ax.axvline(line.theory_hz, color=colour, ls="--", lw=0.7, alpha=0.7)
            ax.annotate(line.name, (line.theory_hz, 1.0), xycoords=("data", "axes fraction"),
                        rotation=90, va="top", ha="right", fontsize=6, color=colour)
        for line in family.lines:
            if line.above and line.found_hz is not None and line.found_hz <= f_max:
                i = round(line.found_hz / diagnosis.resolution_hz)
                y = float(amp[min(i, amp.size - 1)])
                marker = "v" if line.role == "harmonic" else "."
                ax.plot(line.found_hz, y + 0.03 * top, marker, color=colour, ms=5,
                        markerfacecolor=colour if family.clear else "none")
    ax.set_xlim(0, f_max)
    ax.set_ylim(0, 1.15 * top)
    ax.set_xlabel("frequency (Hz)")
    unit = diagnosis.units
    ax.set_ylabel(f"squared envelope amplitude ({unit}²)" if unit else
                  "squared envelope amplitude")
    handles = [Line2D([], [], color=c, ls="--", label=n) for n, c in COLOURS.items()]
    handles.append(Line2D([], [], color="0.3", marker="v", ls="", label="over the threshold"))
    handles.append(Line2D([], [], color="0.3", marker="v", ls="", markerfacecolor="none",
                          label="over it, family not clear"))
    ax.legend(handles=handles, fontsize=7, loc="upper right", framealpha=0.8)


def _kurtogram_axis(ax, fig, diagnosis) -> None:
    gram = diagnosis.kurtogram
    if gram is None or len(gram) == 0:
        ax.text(0.5, 0.5, "no band searched", ha="center", transform=ax.transAxes)
        return
    width = gram.high_hz - gram.low_hz
    shifted = np.abs(gram.low_hz / width - np.round(gram.low_hz / width)) > 1e-6
    y = gram.level + np.where(shifted, 0.25, 0.0)
    segments = [[(lo, yy), (hi, yy)] for lo, hi, yy in zip(gram.low_hz, gram.high_hz, y,
                                                               strict=True)]
    order = np.argsort(gram.kurtosis)
    lines = LineCollection([segments[i] for i in order], linewidths=5, cmap="viridis")
    lines.set_array(gram.kurtosis[order])
    ax.add_collection(lines)
    band = diagnosis.band
    chosen = np.flatnonzero(np.isclose(gram.low_hz, band.low_hz)
                            & np.isclose(gram.high_hz, band.high_hz))
    y_band = float(y[chosen[0]]) if chosen.size else band.level
    ax.add_patch(Rectangle((band.low_hz, y_band - 0.15), band.high_hz - band.low_hz, 0.3,
                           fill=False, edgecolor="C3", lw=1.5))
    ax.set_xlim(0, diagnosis.fs_hz / 2)
    ax.set_ylim(float(y.max()) + 0.7, float(y.min()) - 0.9)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("level log2(Nyquist / bandwidth)")
    ax.set_title(f"fast kurtogram: band {band.low_hz:.0f}–{band.high_hz:.0f} Hz (red), "
                 f"K = {band.kurtosis:.2f}", fontsize=9)
    fig.colorbar(lines, ax=ax, label="spectral kurtosis")


def diagnose_figure(diagnosis) -> Figure:
    """The squared envelope spectrum (theoretical lines dashed and named, lines found
    marked) and the kurtogram of an ``analysis.measured.diagnose.Diagnosis``."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.2), layout="constrained",
                                      width_ratios=(2.2, 1))
    _spectrum_axis(left, diagnosis)
    _kurtogram_axis(right, fig, diagnosis)
    speed = diagnosis.speed
    source = diagnosis.provenance.get("source_file", "")
    name = source.rsplit("/", 1)[-1] if source else "signal"
    channel = f" {diagnosis.channel}" if diagnosis.channel else ""
    left.set_title(f"{name}{channel}: {diagnosis.verdict} (confidence "
                   f"{diagnosis.confidence:.2f}); {speed.rpm:.1f} rpm, {diagnosis.bearing.name}, "
                   f"pre-whitening {diagnosis.prewhiten}", fontsize=9)
    return fig
