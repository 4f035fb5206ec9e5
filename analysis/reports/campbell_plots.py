"""Figures of the linear analyses of a finite-element rotor (``analysis.linear``): the
Campbell diagram (damped natural frequencies over speed, coloured by whirl, with the
excitation lines and the critical speeds marked; log decrements below) and the Bode plot of
the 1X unbalance response (amplitude and phase of x over speed)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from analysis.linear.campbell import Campbell
from analysis.linear.unbalance import UnbalanceResponse
from analysis.reports import canvas as plt

__all__ = ["WHIRL_COLOURS", "bode_figure", "campbell_figure"]

WHIRL_COLOURS = {"forward": "tab:blue", "backward": "tab:red", "mixed": "tab:gray"}
"""Colour of a mode's points by whirl (ROSS's colours)."""


def campbell_figure(result: Campbell, title: str = "",
                    source: Mapping[str, Any] | None = None) -> Figure:
    """Frequencies (Hz) over speed (rpm) by whirl, each excitation line (``order × speed``)
    dashed and named, the critical speeds circled and labelled; log decrements below."""
    fig, (ax, ax_ld) = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True, layout="constrained",
                                    gridspec_kw={"height_ratios": [3, 1.3]})
    speed = result.speed_rpm
    for mode in range(result.frequency_hz.shape[0]):
        ax.plot(speed, result.frequency_hz[mode], color="0.8", lw=0.8, zorder=1)
        ax_ld.plot(speed, result.log_dec[mode], color="0.8", lw=0.8, zorder=1)
        for whirl, colour in WHIRL_COLOURS.items():
            here = result.whirl[mode] == whirl
            ax.scatter(speed[here], result.frequency_hz[mode][here], s=12, color=colour,
                       zorder=2)
            ax_ld.scatter(speed[here], result.log_dec[mode][here], s=8, color=colour, zorder=2)
    top = np.nanmax(result.frequency_hz) * 1.22 if np.isfinite(result.frequency_hz).any() \
        else 1.0
    for (name, order), style in zip(result.lines.items(), ("--", "-.", ":", "--"),
                                    strict=False):
        ax.plot(speed, order * speed / 60.0, style, color="k", lw=1.0, label=f"{name} "
                f"({order:g} × speed)")
    for i, c in enumerate(result.critical):
        ax.plot(c.speed_rpm, c.frequency_hz, "o", ms=9, mfc="none", mec="darkorange", mew=1.6,
                zorder=3)
        named = f" ({c.line})" if len(result.lines) > 1 else ""
        left = (-52 - 6 * len(named), 6)  # alternate sides: close crossings stay legible
        ax.annotate(f"{c.speed_rpm:.0f} rpm{named}", (c.speed_rpm, c.frequency_hz),
                    textcoords="offset points", xytext=(7, -12) if i % 2 else left,
                    fontsize=7, color="darkorange", zorder=4,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                          "alpha": 0.85})
    for whirl, colour in WHIRL_COLOURS.items():
        ax.scatter([], [], s=12, color=colour, label=f"{whirl} whirl")
    ax.plot([], [], "o", ms=9, mfc="none", mec="darkorange", mew=1.6, label="critical speed")
    ax.set_ylim(0, top)
    ax.set_xlim(speed[0], speed[-1])
    ax.set_ylabel("damped natural frequency (Hz)")
    ax.legend(fontsize=7, loc="upper left", ncol=3)  # one band above the highest mode
    ax.grid(alpha=0.3)
    ax.set_title(title or "Campbell diagram")
    ax_ld.axhline(0.0, color="k", lw=0.6)
    if np.isfinite(result.log_dec).any() and np.nanmax(np.abs(result.log_dec)) < 1e-3:
        ax_ld.set_ylim(-0.01, 0.01)  # an undamped rotor: round-off, not a scale of 1e-12
    ax_ld.set_ylabel("log decrement")
    ax_ld.set_xlabel("shaft speed (rpm)")
    ax_ld.grid(alpha=0.3)
    return plt.finish(fig, dict(source or {}))


def bode_figure(result: UnbalanceResponse, title: str = "",
                source: Mapping[str, Any] | None = None,
                critical_rpm: tuple[float, ...] = ()) -> Figure:
    """Amplitude (m, log scale) and phase (deg) of x at the node over speed (rpm), the
    critical speeds dotted."""
    fig, (ax, ax_ph) = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True, layout="constrained",
                                    gridspec_kw={"height_ratios": [2, 1]})
    speed = result.speed_rpm
    moving = result.amplitude_m > 0
    ax.semilogy(speed[moving], result.amplitude_m[moving], color="tab:blue", lw=1.4)
    phase = result.phase_deg.astype(float).copy()
    jumps = np.flatnonzero(np.abs(np.diff(phase)) > 180.0)  # a wrap at ±180: no line across
    ax_ph.plot(np.insert(speed.astype(float), jumps + 1, np.nan), np.insert(phase, jumps + 1,
                                                                            np.nan),
               color="tab:blue", lw=1.2)
    for rpm in critical_rpm:
        for a in (ax, ax_ph):
            a.axvline(rpm, color="darkorange", ls=":", lw=1.0)
    ax.set_ylabel(f"x amplitude at node {result.node} (m)")
    ax.set_title(title or f"1X unbalance response at node {result.node}")
    ax.grid(alpha=0.3, which="both")
    ax_ph.set_ylabel("phase (deg)")
    ax_ph.set_ylim(-180, 180)
    ax_ph.set_yticks([-180, -90, 0, 90, 180])
    ax_ph.set_xlabel("shaft speed (rpm)")
    ax_ph.grid(alpha=0.3)
    ax_ph.set_xlim(speed[0], speed[-1])
    return plt.finish(fig, dict(source or {}))
