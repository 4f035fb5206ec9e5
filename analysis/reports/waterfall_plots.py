"""Figures of run-ups: the waterfall (short-time spectra against speed) with its named
order lines, and the order spectrum (``analysis.signal.waterfall``, ``analysis.signal.orders``).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.reports import canvas as plt
from analysis.reports.plots import display_label, run_title, unit_scale
from analysis.signal.orders import order_lines

_SHAFT_COLOUR, _FAULT_COLOUR = "white", "#ffb000"
DYNAMIC_RANGE_DB = 60.0
"""Colours span this many dB below the largest amplitude of the waterfall."""


def _f_max(wf: xr.Dataset) -> float:
    """Top of the frequency axis (Hz): 1.1 × the highest named line at the highest speed,
    at most the spectra's top."""
    lines = wf["line_hz"].values
    top = float(np.max(lines)) * 1.1 if lines.size else float(wf["frequency"].values[-1])
    return min(top, float(wf["frequency"].values[-1]))


LABEL_GAP_PT = 9.0
"""Least distance (points) between two rotated line labels at the waterfall's top: a 7 pt
label is about 8 pt wide, so the labels of close lines (BSF and VC at top speed) were
printed over each other."""


def label_shifts(positions: list[float], gap: float, width: float) -> list[float]:
    """Offsets (points) that move labels at sorted ``positions`` (points along an axis of
    ``width``) apart to at least ``gap`` each, as little as possible: pushed right in
    order, then pulled back left from the axis end where they ran past it."""
    placed: list[float] = []
    for x in positions:
        placed.append(max(x, placed[-1] + gap) if placed else x)
    for i in range(len(placed) - 1, -1, -1):
        limit = width if i == len(placed) - 1 else placed[i + 1] - gap
        placed[i] = min(placed[i], limit)
    return [p - x for p, x in zip(placed, positions, strict=True)]


def plot_waterfall(ax, wf: xr.Dataset) -> None:
    """The waterfall on ``ax``: amplitude in dB (colour) over frequency (Hz) and speed
    (rpm; time (s) when the speed goes up and down, the speed on the ticks), each named
    line dashed and labelled at the top where the speed is highest."""
    amp = wf["amplitude"].values
    ref = float(amp.max()) if amp.max() > 0 else 1.0
    db = 20 * np.log10(np.maximum(amp / ref, 10 ** (-DYNAMIC_RANGE_DB / 20)))
    f = wf["frequency"].values
    speed = wf["speed_rpm"].values
    step = np.diff(speed)
    monotonic = bool(np.all(step > 0) or np.all(step < 0))
    if not monotonic:  # up and down (a table): along time, the speed on the tick labels
        speed = wf["time"].values
    f_max = _f_max(wf)
    keep = f <= f_max
    mesh = ax.pcolormesh(f[keep], speed, db[:, keep], shading="nearest", cmap="viridis",
                         vmin=-DYNAMIC_RANGE_DB, vmax=0.0, rasterized=True)
    cbar = ax.figure.colorbar(mesh, ax=ax, pad=0.01)
    scale, unit = unit_scale(str(wf.attrs.get("units", "")))
    cbar.set_label(f"amplitude, dB re {ref * scale:.3g} {unit}")
    fastest = int(np.argmax(wf["speed_rpm"].values))  # labels where the lines spread most
    labels = ax.get_xaxis_transform()  # x in Hz, y in axes fractions
    tops = []
    for name, kind, line in zip(wf["line"].values, wf["line_kind"].values,
                                wf["line_hz"].values, strict=True):
        if np.min(line) > f_max:
            continue
        colour = _FAULT_COLOUR if kind == "fault" else _SHAFT_COLOUR
        ax.plot(line, speed, ls="--", lw=0.7, color=colour, alpha=0.8)
        if line[fastest] <= f_max:
            tops.append((float(line[fastest]), display_label(str(name)), colour))
    tops.sort(key=lambda top: top[0])
    width = ax.get_position().width * ax.figure.get_figwidth() * 72.0  # points
    shifts = label_shifts([x / f_max * width for x, _, _ in tops], LABEL_GAP_PT, width)
    for (x, text, colour), shift in zip(tops, shifts, strict=True):
        ax.annotate(text, (x, 1.0), xycoords=labels, xytext=(shift, 3),
                    textcoords="offset points", rotation=90, fontsize=7,
                    color=colour, ha="center", va="bottom", annotation_clip=False,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "black", "alpha": 0.4,
                          "lw": 0},
                    arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.5}
                    if abs(shift) > 0.5 else None)
    ax.set_xlim(0, f_max)
    ax.set_xlabel("frequency (Hz)")
    if monotonic:
        ax.set_ylabel("speed (rpm)")
    else:
        ticks = np.linspace(speed[0], speed[-1], 7)
        rpm = np.interp(ticks, speed, wf["speed_rpm"].values)
        ax.set_yticks(ticks, [f"{t:.3g} s, {n:.0f} rpm" for t, n in zip(ticks, rpm,
                                                                          strict=True)])
        ax.set_ylabel("time (s) and speed (rpm)")
    ax.set_title(f"waterfall of {wf.attrs.get('variable', '')}: window "
                 f"{float(wf.attrs['window_s']) * 1e3:.3g} ms, bin "
                 f"{float(wf.attrs['bin_hz']):.3g} Hz; lines: orders (white), defect "
                 "orders (amber)", fontsize=9, pad=44)


def plot_orders(ax, spectrum: xr.DataArray, max_order: float | None = None) -> None:
    """An order spectrum on ``ax``: amplitude (µm for m) over order (cycles/rev), each
    named line a dotted vertical line, labelled."""
    scale, unit = unit_scale(str(spectrum.attrs.get("units", "")))
    order = spectrum["order"].values
    lines = order_lines(spectrum.attrs)
    top = max_order or max((line.order for line in lines), default=10.0) * 1.1
    keep = order <= top
    ax.plot(order[keep], spectrum.values[keep] * scale, lw=0.8, color="C0")
    peak = float(spectrum.values[keep][1:].max() * scale) if keep.sum() > 1 else 1.0
    for line in lines:
        if line.order > top:
            continue
        colour = "C3" if line.kind == "fault" else "0.4"
        ax.axvline(line.order, ls=":", lw=0.7, color=colour)
        ax.annotate(display_label(line.name), (line.order, peak), xytext=(2, 0),
                    textcoords="offset points", rotation=90, fontsize=7, color=colour,
                    va="top")
    ax.set_xlim(0, top)
    ax.set_ylim(0, peak * 1.25)
    ax.set_xlabel("order (cycles per shaft revolution)")
    ax.set_ylabel(f"{spectrum.attrs.get('variable', '')} amplitude ({unit})")
    ax.set_title(f"order spectrum: {int(spectrum.attrs['samples_per_rev'])} samples/rev, "
                 f"bin {float(spectrum.attrs['order_bin']):.3g} orders", fontsize=9)


def waterfall_figure(wf: xr.Dataset, orders: xr.DataArray | None = None) -> Figure:
    """The waterfall of ``wf`` and, with ``orders``, the order spectrum below it."""
    rows = 2 if orders is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(9, 5.5 + 3.2 * (rows - 1)), layout="constrained",
                             squeeze=False,
                             gridspec_kw={"height_ratios": [5, 3][:rows]})
    plot_waterfall(axes[0][0], wf)
    if orders is not None:
        plot_orders(axes[1][0], orders)
    fig.suptitle(run_title(wf), fontsize=10)
    return plt.finish(fig, wf)
