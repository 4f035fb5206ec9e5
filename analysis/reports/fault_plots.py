"""Figures of bearing faults: the time signal with the ball-passing times of a defect marked,
and the labelled envelope spectrum. Functions return figures; saving is the caller's."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.provenance import displacement_names
from analysis.reports.plots import display_label, plt, run_title, scale_of
from analysis.signal.envelope import Band
from analysis.signal.spectrum import Peak, fault_frequencies


def fault_words(attrs) -> str:
    """``FTF = 33.22 Hz, BPFO = 299.01 Hz, …`` of each bearing ('' without them)."""
    words = []
    for bearing, table in fault_frequencies(attrs).items():
        tag = f"[{bearing}]" if bearing else ""
        words += [f"{name}{tag} = {value:.2f} Hz" for name, value in table.items()]
    return ", ".join(words)


def peak_text(peak: Peak) -> str:
    """The label of a peak as drawn: every name within one bin, joined by ' | '."""
    names = [peak.label, *peak.also] if peak.label else []
    return " | ".join(display_label(n) for n in names)


def envelope_figure(spectrum: xr.DataArray, peaks: list[Peak], band: Band,
                    f_max: float | None = None) -> Figure:
    """The envelope spectrum (amplitude in the unit of the enveloped variable, scaled like
    its run: µm for m) with its labelled peaks, up to ``f_max`` (Hz; default: 3.2 times the
    highest defect frequency, or further to show every peak in ``peaks``); the band, the
    noise and the defect frequencies in the title, the band's note below. Two names in one
    bin are drawn together ('BPFO | VC') and the figure says so."""
    attrs = spectrum.attrs
    var = str(attrs.get("envelope_of", "x"))
    factor, unit = scale_of(xr.Dataset({var: ((), 0.0, {"units": attrs.get("units", "")})}),
                            var)
    table = fault_frequencies(attrs)
    top = max((max(t["BPFO"], t["BPFI"], 2 * t["BSF"]) for t in table.values()), default=0.0)
    highest = max((p.frequency_hz for p in peaks), default=0.0)  # every peak listed shows
    f_max = f_max or min(max(3.2 * top if top > 0 else 0.0, 1.05 * highest)
                         or float(spectrum.frequency[-1]), float(spectrum.frequency[-1]))
    sel = spectrum.sel(frequency=slice(0, f_max))
    fig, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    ax.plot(sel.frequency, sel * factor, lw=0.8, color="C0")
    shared = False
    for peak in peaks:
        if peak.frequency_hz > f_max:
            continue
        y = peak.amplitude * factor
        if not peak.label:
            ax.plot(peak.frequency_hz, y, "v", color="0.5", ms=3)
            continue
        shared = shared or bool(peak.also)
        ax.plot(peak.frequency_hz, y, "v", color="C3", ms=4)
        ax.annotate(peak_text(peak), (peak.frequency_hz, y), xytext=(0, 5),
                    textcoords="offset points", ha="center", va="bottom", fontsize=7,
                    rotation=90)
    ax.set_xlim(0, f_max)
    ax.set_ylim(0, 1.45 * float(sel.max()) * factor)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"envelope amplitude of {var}" + (f" ({unit})" if unit else ""))
    ax.grid(True, alpha=0.3)
    how = {"kurtosis": "chosen by spectral kurtosis", "user": "given",
           "resonance": "by kurtosis, holding a resonance"}.get(band.chosen, band.chosen)
    note = ("; names joined by '|' fall within one bin" if shared else "")
    noise = (f"; white noise at {float(attrs['noise_snr_db']):g} dB SNR, seed "
             f"{int(attrs['noise_seed'])}" if "noise_seed" in attrs else "")
    ax.set_title(f"envelope spectrum, band {band.low_hz:.0f}–{band.high_hz:.0f} Hz ({how}, "
                 f"K = {band.kurtosis:.3g}){note}{noise}\n{fault_words(attrs)}", fontsize=8)
    if band.note:
        plt.footnote(fig, band.note)
    fig.suptitle(run_title(xr.Dataset(attrs=attrs)), fontsize=10)
    return plt.finish(fig, attrs)  # titles that fit, no offsets, the run's provenance


def impulse_figure(ds: xr.Dataset, passes: np.ndarray, window_s: float, what: str,
                   variables: tuple[str, ...] | None = None) -> Figure:
    """``variables`` of the run over its first ``window_s`` seconds (default: the first
    body's x and its velocity, ``x_housing`` and ``vx_housing`` for the 6205 defect models),
    and the acceleration d(v)/dt of the last one (m/s², where the impacts show as spikes),
    with the times ``passes`` (s) at which a ball meets the defect drawn as dashed lines
    (labelled ``what``)."""
    if variables is None:
        x = displacement_names(ds)[0]
        variables = (x, f"v{x}")
    t = ds["t"].values
    shown = t <= t[0] + window_s
    ms = (t[shown] - t[0]) * 1e3
    velocity = variables[-1]
    acceleration = np.gradient(ds[velocity].values, t)[shown]
    fig, axes = plt.subplots(len(variables) + 1, 1, figsize=(9, 2.2 * (len(variables) + 1)),
                             layout="constrained", sharex=True)
    marks = passes[(passes >= t[0]) & (passes <= t[0] + window_s)]
    rows = [(ds[v].values[shown], *scale_of(ds, v), v) for v in variables]
    rows.append((acceleration, 1.0, "m/s²", f"d({velocity})/dt"))
    for ax, (values, factor, unit, name) in zip(axes, rows, strict=True):
        ax.plot(ms, values * factor, lw=0.7, color="C0")
        for k, tp in enumerate(marks):
            ax.axvline((tp - t[0]) * 1e3, color="C3", lw=0.6, ls="--",
                       label=what if k == 0 else None)
        ax.set_ylabel(name + (f" ({unit})" if unit else ""))
        ax.grid(True, alpha=0.3)
    if len(marks):
        axes[0].legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel(f"t − {t[0]:g} s (ms)")
    axes[0].set_title(fault_words(ds.attrs), fontsize=8)
    fig.suptitle(run_title(ds), fontsize=10)
    return fig
