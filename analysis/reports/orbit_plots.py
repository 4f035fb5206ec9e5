"""Figures of a run's orbits (``analysis.signal.orbit``) and of its full spectrum
(``analysis.signal.full_spectrum``): what a vibration engineer reads first about how a
shaft whirls."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.reports import canvas as plt
from analysis.reports.plots import display_label, run_title, scale_of, unit_scale
from analysis.signal.full_spectrum import (
    WhirlPeak,
    full_spectrum,
    full_spectrum_peaks,
    orbit_pair,
)
from analysis.signal.orbit import Orbit, orbits


def plot_orbit(ax, orbit: Orbit, speed_rpm: np.ndarray | None = None):
    """One orbit on ``ax`` in µm (for m): the path, the clearance circle (dashed, when the
    orbit is a bearing's), the once-per-revolution marks (black dots) and the first and
    last marks named; equal scales on both axes. ``speed_rpm`` (one per path sample: a
    run-up) colours the path by the shaft speed (``SPEED_CMAP``) instead of one colour, so
    the orbit of each speed can be told from the others; returns that line collection (for
    its colour bar), else None."""
    factor, unit = unit_scale(orbit.unit)
    coloured = None
    if speed_rpm is not None and len(speed_rpm) == len(orbit.x) > 1:
        from matplotlib.collections import LineCollection

        points = np.column_stack([orbit.x * factor, orbit.y * factor])
        segments = np.stack([points[:-1], points[1:]], axis=1)
        coloured = LineCollection(segments, cmap=SPEED_CMAP, linewidths=0.6,
                                  label="orbit, coloured by shaft speed")
        coloured.set_array(0.5 * (speed_rpm[:-1] + speed_rpm[1:]))
        ax.add_collection(coloured)
        ax.autoscale_view()
    else:
        ax.plot(orbit.x * factor, orbit.y * factor, lw=0.6, color="C0", label="orbit")
    if orbit.mark_x.size:
        step = mark_step(orbit.mark_x.size, run_up=coloured is not None)
        xs, ys = orbit.mark_x[::step] * factor, orbit.mark_y[::step] * factor
        every = f": every {step}th of {orbit.mark_x.size}" if step > 1 else ""
        ax.plot(xs, ys, "o", ms=3 if step == 1 else 2, color="k",
                label=f"once per revolution ({xs.size} marks{every})")
        ax.plot(orbit.mark_x[0] * factor, orbit.mark_y[0] * factor, "o", ms=6, mfc="none",
                color="C3", label="first mark")
    if orbit.clearance:
        angle = np.linspace(0, 2 * math.pi, 361)
        r = orbit.clearance * factor
        ax.plot(r * np.cos(angle), r * np.sin(angle), "--", lw=0.9, color="0.45",
                label=f"radial clearance γ0 = {r:.3g} {unit}")
    ax.plot(0, 0, "+", color="0.45", ms=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"X ({unit})")
    ax.set_ylabel(f"Y ({unit})")
    ax.set_title(f"{orbit.name}: {orbit.what}", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2,
              frameon=False)  # below the axes: never over the orbit
    return coloured


MAX_RUN_UP_MARKS = 40
"""Once-per-revolution marks drawn at most on a run-up's orbit: every revolution of a
run-up was drawn (367 marks buried its orbit), so every k-th is, and the legend says so."""


def mark_step(count: int, run_up: bool) -> int:
    """Every how many of ``count`` once-per-revolution marks one is drawn: all at constant
    speed (they pile onto the section's points), every k-th on a run-up so that at most
    ``MAX_RUN_UP_MARKS`` are drawn."""
    if not run_up or count <= MAX_RUN_UP_MARKS:
        return 1
    return math.ceil(count / MAX_RUN_UP_MARKS)


SPEED_CMAP = "viridis"
"""Colours of a run-up's orbit by shaft speed (perceptually uniform, colour-blind safe)."""


def run_speeds(ds: xr.Dataset) -> np.ndarray | None:
    """The shaft speed (rpm) at each sample of a run whose speed follows a profile (a
    run-up or coast-down), None at constant speed."""
    from analysis.integrate.speed_profile import profile_of

    profile = profile_of(ds.attrs)
    if profile is None:
        return None
    t = np.asarray(ds["t"].values, dtype=float)
    return profile.speed(t, float(ds.attrs.get("duration", t[-1])))


def orbit_figure(ds: xr.Dataset, x: str | None = None, y: str | None = None,
                 node: int | None = None) -> Figure:
    """The orbits of a run (``analysis.signal.orbit.orbits``; ``x``, ``y``: one pair of
    state variables only; ``node``: a flexible model's shaft node only), one panel each, in
    µm, with the bearings' clearance circles and a mark once per shaft revolution."""
    found = orbits(ds, x, y, node)
    columns = min(len(found), 3)
    rows = math.ceil(len(found) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(max(6.4, 4.6 * columns), 4.4 * rows + 1.0),
                             layout="constrained", squeeze=False)
    speeds = run_speeds(ds)
    for ax, orbit in zip(axes.ravel(), found, strict=False):
        coloured = plot_orbit(ax, orbit, speeds)
        if coloured is not None:
            fig.colorbar(coloured, ax=ax, label="shaft speed (rpm)", shrink=0.8)
    for ax in axes.ravel()[len(found):]:
        ax.set_visible(False)
    t = ds["t"].values
    over = (f"speeds {float(speeds[0]):.0f}…{float(speeds[-1]):.0f} rpm, "
            if speeds is not None else "")
    fig.suptitle(f"{run_title(ds)}; orbit over {over}t = {float(t[0]):.4g}…"
                 f"{float(t[-1]):.4g} s", fontsize=10)
    return plt.finish(fig, ds)


def full_spectrum_figure(ds: xr.Dataset, x: str | None = None, y: str | None = None,
                         peaks: list[WhirlPeak] | None = None,
                         f_max: float | None = None) -> Figure:
    """The full spectrum of x + i·y (default: the first body's displacements) on a log
    scale in µm, backward whirl on the left (negative frequencies), forward on the right;
    its lines named (``-X``: backward 1X). The range covers every line of ``peaks``
    (default: ``full_spectrum_peaks``) and the run's characteristic frequencies."""
    from analysis.reports.plots import f_max_of

    x, y = orbit_pair(ds, x, y)
    spectrum = full_spectrum(ds, x, y)
    peaks = full_spectrum_peaks(ds, x, y) if peaks is None else peaks
    top = max([abs(p.signed_frequency_hz) for p in peaks], default=0.0)
    nyquist = float(spectrum.frequency.max())
    f_max = min(max(f_max or f_max_of(ds.attrs) or nyquist, 1.08 * top), nyquist)
    factor, unit = scale_of(ds, x)
    sel = spectrum.sel(frequency=slice(-f_max, f_max))
    fig, ax = plt.subplots(figsize=(10, 4.6), layout="constrained")
    floor = float(sel.max()) * 1e-7
    ax.semilogy(sel.frequency, np.maximum(sel.values, floor) * factor, lw=0.7, color="C0")
    ax.axvline(0, color="0.5", lw=0.8)
    for peak in peaks:
        f = peak.signed_frequency_hz
        if abs(f) > f_max:
            continue
        colour = "C3" if peak.whirl == "forward" else "C2"
        ax.plot(f, peak.amplitude * factor, "v", color=colour, ms=4)
        note = ax.annotate(display_label(peak.name), (f, peak.amplitude * factor),
                           xytext=(0, 4), textcoords="offset points", ha="center",
                           va="bottom", fontsize=7,
                           arrowprops=dict(arrowstyle="-", color="0.6", lw=0.5, shrinkA=0,
                                           shrinkB=2))
        note.peak_label = True
    ax.plot([], [], "v", color="C3", ls="none", label="forward whirl line (+f)")
    ax.plot([], [], "v", color="C2", ls="none", label="backward whirl line (−f, named −…)")
    ax.legend(fontsize=7, loc="lower right", framealpha=0.85)
    ax.set_xlim(-f_max, f_max)
    ax.set_xlabel("frequency (Hz): < 0 backward whirl, > 0 forward whirl")
    ax.set_ylabel(f"full spectrum of {x} + i·{y} ({unit})")
    ax.text(0.01, 0.98, "backward", transform=ax.transAxes, ha="left", va="top", fontsize=8,
            color="C2")
    ax.text(0.99, 0.98, "forward", transform=ax.transAxes, ha="right", va="top", fontsize=8,
            color="C3")
    ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(run_title(ds) + f"; full spectrum of {x} + i·{y}", fontsize=10)
    plt.finish(fig, ds)
    from analysis.reports.plots import separate_peak_labels

    separate_peak_labels(fig)
    return fig


__all__ = ["full_spectrum_figure", "orbit_figure", "plot_orbit"]
