"""Matplotlib figures. Functions return figures; saving is the caller's business."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.signal.poincare import poincare_section, section_period
from analysis.signal.spectrum import Peak, amplitude_spectrum, find_peaks

MICRO = 1e6
AXIS_NAMES = {"x": ("x", "vx", "X direction"), "y": ("y", "vy", "Y direction")}


def display_label(label: str) -> str:
    """A peak label for print: unicode minus (VC−X)."""
    return label.replace("-", "\u2212")


def _title(ds: xr.Dataset) -> str:
    return (f"{ds.attrs.get('model', '?')}, $N_b$ = {ds.attrs.get('n_balls', '?')}, "
            f"{ds.attrs.get('speed_rpm', float('nan')):g} rpm "
            f"(X = {ds.attrs.get('shaft_hz', float('nan')):.2f} Hz, "
            f"VC = {ds.attrs.get('vc_hz', float('nan')):.2f} Hz)")


def plot_spectrum(ax, ds: xr.Dataset, var: str, peaks: list[Peak] | None = None,
                  f_max: float | None = None) -> None:
    """Amplitude spectrum of ``var`` (µm) on a log scale, labelled peaks marked."""
    spec = amplitude_spectrum(ds, var)
    peaks = find_peaks(ds, var) if peaks is None else peaks
    f_max = f_max or 2.5 * (ds.attrs["vc_hz"] + ds.attrs["shaft_hz"])
    sel = spec.sel(frequency=slice(0, f_max))
    ax.semilogy(sel.frequency, sel * MICRO, lw=0.8, color="C0")
    for peak in peaks:
        if peak.frequency_hz > f_max:
            continue
        if not peak.label:  # broadband or unnamed: marked, not labelled
            ax.plot(peak.frequency_hz, peak.amplitude * MICRO, "v", color="0.5", ms=3)
            continue
        ax.plot(peak.frequency_hz, peak.amplitude * MICRO, "v", color="C3", ms=4)
        ax.annotate(display_label(peak.label), (peak.frequency_hz, peak.amplitude * MICRO),
                    xytext=(0, 4), textcoords="offset points", ha="center", fontsize=7)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"amplitude of {var} (µm)")
    ax.set_xlim(0, f_max)
    ax.grid(True, which="both", alpha=0.3)


def plot_poincare(ax, ds: xr.Dataset, var: str, section: str = "shaft") -> None:
    """Stroboscopic Poincaré map: displacement (µm) against velocity (mm/s)."""
    pts = poincare_section(ds, section)
    pos, vel, _ = AXIS_NAMES[var]
    ax.plot(pts[pos] * MICRO, pts[vel] * 1e3, ".", ms=2.5, color="C2")
    period = section_period(ds, section)
    ax.set_xlabel(f"{pos} (µm)")
    ax.set_ylabel(f"{vel} (mm/s)")
    ax.set_title(f"Poincaré map, {section} section (every {period * 1e3:.3f} ms), "
                 f"{pts.sizes['k']} points", fontsize=8)
    ax.grid(True, alpha=0.3)


def paper_figure(ds: xr.Dataset, section: str = "shaft") -> Figure:
    """The paper's Figs. 2-6: spectrum and Poincaré map, X direction (a) and Y (b)."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), layout="constrained")
    for row, var in enumerate(("x", "y")):
        plot_spectrum(axes[row, 0], ds, var)
        axes[row, 0].set_title(f"({'ab'[row]}) {AXIS_NAMES[var][2]}: FFT", fontsize=9)
        plot_poincare(axes[row, 1], ds, var, section)
    fig.suptitle(_title(ds), fontsize=10)
    return fig


def spectrum_figure(ds: xr.Dataset) -> Figure:
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), layout="constrained")
    for ax, var in zip(axes, ("x", "y"), strict=True):
        plot_spectrum(ax, ds, var)
        ax.set_title(AXIS_NAMES[var][2], fontsize=9)
    fig.suptitle(_title(ds), fontsize=10)
    return fig


def poincare_figure(ds: xr.Dataset, section: str = "shaft") -> Figure:
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), layout="constrained")
    for ax, var in zip(axes, ("x", "y"), strict=True):
        plot_poincare(ax, ds, var, section)
    fig.suptitle(_title(ds), fontsize=10)
    return fig


def save_figure(fig: Figure, path) -> None:
    """Render ``fig`` to a file (PNG by suffix) and release it."""
    from analysis.io import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=130, format=str(path).rsplit(".", 1)[-1]))
    plt.close(fig)


NATURE_COLORS = {1: "#2a9d8f", 2: "#8ab17d", 3: "#e9c46a", 4: "#5e7fd6", 5: "#e76f51"}
NATURE_NAMES = {1: "periodic-1", 2: "periodic-2", 3: "periodic-n (n ≥ 3)",
                4: "quasi-periodic", 5: "chaotic"}


def diagram_figure(ds: xr.Dataset) -> Figure:
    """Orbit diagram: grid parameter against the Poincaré samples of x and y (µm); the up-
    and down-sweeps in different colours (hysteresis)."""
    param = ds.attrs["param"]
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True, layout="constrained")
    for ax, var in zip(axes, ("x", "y"), strict=True):
        for d, direction in enumerate(ds.direction.values):
            values = ds[var].isel(direction=d)
            grid = np.repeat(ds[param].values, values.sizes["k"])
            ax.plot(grid, values.values.ravel() * MICRO, ".", ms=2, color=f"C{d}", alpha=0.6)
            ax.plot([], [], "o", ms=3, color=f"C{d}", label=f"sweep {direction}")
        ax.set_ylabel(f"{var} on the {ds.attrs['section']} section (µm)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    unit = "rpm" if param == "speed_rpm" else ds.attrs.get(f"{param}_unit", "")
    axes[1].set_xlabel(f"{param}" + (f" ({unit})" if unit else ""))
    fig.suptitle(f"{ds.attrs['model']}, $N_b$ = {ds.attrs['n_balls']}: bifurcation diagram "
                 f"({ds.sizes['k']} section points per value)", fontsize=10)
    return fig


def chart_figure(ds: xr.Dataset) -> Figure:
    """Stability chart: the class of the motion on the grid (colours with a legend), and
    the largest Lyapunov exponent."""
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    xname, yname = ds.attrs["x"], ds.attrs["y"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    cmap = ListedColormap([NATURE_COLORS[k] for k in sorted(NATURE_COLORS)])
    norm = BoundaryNorm(np.arange(0.5, 6.5), cmap.N)
    axes[0].pcolormesh(ds[xname], ds[yname], ds.nature_code, cmap=cmap, norm=norm,
                       shading="nearest")
    present = sorted(set(np.unique(ds.nature_code.values).tolist()))
    axes[0].legend(handles=[Patch(color=NATURE_COLORS[k], label=NATURE_NAMES[k])
                            for k in present], fontsize=8, loc="upper right")
    axes[0].set_title("nature of the response", fontsize=9)
    mesh = axes[1].pcolormesh(ds[xname], ds[yname], ds.lyapunov, cmap="RdBu_r",
                              shading="nearest",
                              vmin=-np.nanmax(np.abs(ds.lyapunov.values)),
                              vmax=np.nanmax(np.abs(ds.lyapunov.values)))
    fig.colorbar(mesh, ax=axes[1], label="largest Lyapunov exponent (1/s)")
    axes[1].set_title("largest Lyapunov exponent", fontsize=9)
    from matplotlib.ticker import MaxNLocator

    for ax in axes:
        ax.set_xlabel(xname + (" (rpm)" if xname == "speed_rpm" else ""))
        ax.set_ylabel(yname)
        if yname == "n_balls":
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(f"{ds.attrs['model']}: stability chart", fontsize=10)
    return fig


def any_figure(ds: xr.Dataset) -> Figure:
    """The natural figure of any bearingdyn result file."""
    kind = ds.attrs.get("kind")
    if kind == "diagram":
        return diagram_figure(ds)
    if kind == "chart":
        return chart_figure(ds)
    if "special" in ds and "param" in ds.attrs:
        return branch_figure([ds])
    return paper_figure(ds)


SPECIAL_MARKERS = {"LP": "s", "PD": "D", "NS": "*", "BP": "^", "grazing?": "x"}


def branch_figure(branches: list[xr.Dataset]) -> Figure:
    """Continuation diagram: parameter vs orbit amplitude; stable solid, unstable dashed,
    special points (LP fold, PD period doubling, NS Neimark–Sacker, BP branch point)."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    for i, br in enumerate(branches):
        param = br.attrs["param"]
        lam, amp, stable = br[param].values, br.amplitude.values, br.stable.values
        color = f"C{i}"
        # one line per run of equal stability (short dashed pieces would look solid)
        cuts = np.nonzero(np.diff(stable))[0] + 1
        for run in np.split(np.arange(len(lam)), cuts):
            run = np.append(run, run[-1] + 1) if run[-1] + 1 < len(lam) else run
            ax.plot(lam[run], amp[run], color=color, ls="-" if stable[run[0]] else "--",
                    lw=1.4)
        ax.plot([], [], color=color, label=br.attrs.get("branch", f"branch {i + 1}"))
        for j, kind in enumerate(br.special.values):
            if kind:
                ax.plot(lam[j], amp[j], SPECIAL_MARKERS.get(str(kind), "o"), color="k", ms=6)
                ax.annotate(str(kind), (lam[j], amp[j]), xytext=(4, 4),
                            textcoords="offset points", fontsize=8)
    first = branches[0]
    unit = first[first.attrs["param"]].attrs.get("units", "")
    ax.set_xlabel(f"{first.attrs['param']} ({unit})")
    ax.set_ylabel("orbit amplitude, half peak-to-peak x (m)")
    ax.plot([], [], "k-", label="stable")
    ax.plot([], [], "k--", label="unstable")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(f"{first.attrs['model']}: periodic orbits ({first.attrs['period']}) "
                 "continued in " + first.attrs["param"], fontsize=9)
    return fig


def lyapunov_figure(result: xr.Dataset) -> Figure:
    """Running estimates of the Lyapunov exponents against time (convergence check)."""
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    for k in result.index.values:
        ax.plot(result.t, result.running.sel(index=k),
                label=f"λ{k} = {float(result.exponents.sel(index=k)):.4g} ± "
                      f"{float(result.ci95.sel(index=k)):.2g} 1/s")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("running estimate (1/s)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(_title(result) + f"; Σλ = {result.attrs['sum_of_exponents']:.5g}, "
                 f"mean divergence {result.attrs['mean_divergence']:.5g} 1/s", fontsize=8)
    return fig


__all__ = [
    "branch_figure",
    "display_label",
    "lyapunov_figure",
    "paper_figure",
    "plot_poincare",
    "plot_spectrum",
    "poincare_figure",
    "save_figure",
    "spectrum_figure",
]
