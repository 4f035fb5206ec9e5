"""Brute-force bifurcation diagrams of the balanced rotor against continuation and shooting.

    python docs/scripts/sweep_vs_continuation.py diagram.nc cold.nc fold.nc branch.nc \\
        [-o docs/figures/sweep-diagram-balanced-rotor.png]

Reads the results of the commands in docs/sweeps.md (balanced rotor, N_b = 8, 50 N, VC
section): ``diagram.nc`` (followed, up and down), ``cold.nc`` (``--no-follow``: every value
from the spec's initial state), ``fold.nc`` (followed, fine grid across the fold pair) and
``branch.nc`` (``bearingdyn continue``: the period-1 branch with its LP and PD points). It
adds orbits found by shooting (``analysis.stability.periodic.shoot``), stepped in speed
from one orbit to the next until Newton fails or falls back onto a shorter period:

- period 2, from the middle of the PD interval (the period-1 orbit kicked along the
  eigenvector of its multiplier below −1 and settled);
- period 3, from a point of ``cold.nc`` that shows period 3.

It prints the stable ranges found and draws y on the VC section (µm) against the speed:
the whole range, the fold pair and the period-doubling interval. About 15 s.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from analysis.integrate.simulate import simulate
from analysis.io import open_result
from analysis.model import System
from analysis.signal.poincare import poincare_section
from analysis.stability.periodic import PeriodicOrbit, shoot

MODEL, N_BALLS, LOAD = "balanced-rotor", 8, {"radial_load": 50.0}
"""The case of docs/sweeps.md (load in N)."""
VAR = "y"
"""The state variable drawn (m; shown in µm)."""
STEP = 10.0
"""Speed step (rpm) of the shooting families."""
TOL = 1e-3
"""Points equal to this fraction of the orbit's size are one point."""


@dataclass(frozen=True)
class Orbit:
    """A periodic orbit at ``speed`` (rpm): its ``period`` (in VC periods), its section
    points (rows, the model's state order) and whether it is stable."""

    speed: float
    period: int
    points: np.ndarray
    stable: bool


def orbit_run(orbit: PeriodicOrbit) -> xr.Dataset:
    """One period of ``orbit`` simulated from z0 at t0 = 0 with its own RK4 step."""
    return simulate(orbit.system, duration=orbit.period_s, transient=0.0,
                    dt=orbit.period_s / orbit.n_steps, initial_state=orbit.z0)


def section_points(orbit: PeriodicOrbit, n: int) -> np.ndarray:
    """The ``n`` VC-section states (rows) of an orbit of n VC periods."""
    section = poincare_section(orbit_run(orbit), "vc")
    return np.stack([section[v].values[:n] for v in orbit.state_names], axis=1)


def orbit_size(orbit: PeriodicOrbit) -> np.ndarray:
    """Peak-to-peak of every state variable over the orbit (m, m/s)."""
    run = orbit_run(orbit)
    return np.array([np.ptp(run[v].values) for v in orbit.state_names])


def solve(speed: float, n: int, guess: np.ndarray | None = None,
          settle_from: np.ndarray | None = None) -> Orbit | None:
    """The orbit of ``n`` VC periods at ``speed`` from ``guess`` (or after settling 0.3 s
    from ``settle_from``); None when Newton fails or finds a shorter period."""
    period = "vc" if n == 1 else f"vc:{n}"
    if settle_from is not None:
        system = System.make(MODEL, N_BALLS, settle_from, speed_rpm=speed, **LOAD)
        orbit = shoot(system, None, period, settle=0.3)
    else:
        orbit = shoot(MODEL, N_BALLS, period, guess, 0.0, speed_rpm=speed, **LOAD)
    if not orbit.converged:
        return None
    points = section_points(orbit, n)
    size = orbit_size(orbit)
    if n > 1 and np.max(np.abs(points[1] - points[0]) / size) < TOL:
        return None  # fell back onto the period-1 orbit
    return Orbit(speed, n, points, orbit.stability == "stable")


def family(first: Orbit, low: float, high: float) -> list[Orbit]:
    """Orbits of ``first``'s period stepped by ``STEP`` rpm both ways from it, each from
    the previous one, within [low, high] rpm, until none is found."""
    out = [first]
    for sign in (-1.0, 1.0):
        current = first
        while low <= current.speed + sign * STEP <= high:
            nxt = solve(current.speed + sign * STEP, first.period, current.points[0])
            if nxt is None:
                break
            out.append(nxt)
            current = nxt
    return sorted(out, key=lambda o: o.speed)


def period_two(branch: xr.Dataset) -> list[Orbit]:
    """The period-2 family around the middle of the PD interval of ``branch``."""
    pds = [float(branch.speed_rpm[i]) for i in range(branch.sizes["point"])
           if branch.special.values[i] == "PD"]
    middle = round((pds[0] + pds[-1]) / 2 / STEP) * STEP
    one = shoot(MODEL, N_BALLS, "vc", speed_rpm=middle, **LOAD)
    mu, vectors = np.linalg.eig(one.monodromy)
    e = np.real(vectors[:, int(np.argmin(mu.real))])
    size = orbit_size(one)
    kicked = one.z0 + 0.01 * size * e / np.max(np.abs(e / size))
    first = solve(middle, 2, settle_from=kicked)
    return family(first, pds[0], pds[-1]) if first else []


def period_three(cold: xr.Dataset) -> list[Orbit]:
    """The period-3 family through a value of ``cold`` whose points repeat every third."""
    names = cold.attrs["state_names"].split()
    for speed in cold.speed_rpm.values:
        at = cold.sel(direction=cold.direction.values[0], speed_rpm=speed)
        pts = np.stack([at[v].values for v in names], axis=1)
        scale = np.ptp(pts, axis=0) + 1e-30
        if np.max(np.abs(pts[3:] - pts[:-3]) / scale) < TOL < np.max(
                np.abs(pts[1:] - pts[:-1]) / scale):
            first = solve(float(speed), 3, pts[-3])
            if first is not None:
                return family(first, float(cold.speed_rpm[0]), float(cold.speed_rpm[-1]))
    return []


def stable_range(orbits: list[Orbit]) -> str:
    """'a–b rpm' of the stable orbits of a family (grid values)."""
    speeds = [o.speed for o in orbits if o.stable]
    return f"{min(speeds):.0f}–{max(speeds):.0f} rpm" if speeds else "none"


def largest_gap(diagram: xr.Dataset, orbits: list[Orbit]) -> tuple[float, int]:
    """Largest distance (m, in ``VAR``) of a followed section point from the nearest point
    of the orbit of ``orbits`` at the same speed, and the number of speeds compared."""
    index, gap, shared = state_index(VAR), 0.0, 0
    for orbit in orbits:
        if not np.any(np.isclose(diagram.speed_rpm.values, orbit.speed)):
            continue
        shared += 1
        at = diagram[VAR].sel(speed_rpm=orbit.speed).values.ravel()
        gap = max(gap, float(np.max(np.min(np.abs(at[:, None] - orbit.points[None, :, index]),
                                           axis=1))))
    return gap, shared


def draw_branch(ax, branch: xr.Dataset) -> None:
    """The period-1 branch: stable solid, unstable dashed, LP and PD points."""
    lam = branch.speed_rpm.values
    y = branch.z0.sel(state=VAR).values * 1e6
    stable = branch.stable.values
    cuts = np.nonzero(np.diff(stable))[0] + 1
    for run in np.split(np.arange(len(lam)), cuts):
        run = np.append(run, run[-1] + 1) if run[-1] + 1 < len(lam) else run
        ax.plot(lam[run], y[run], "k-" if stable[run[0]] else "k--", lw=1.0, zorder=3)
    for j, kind in enumerate(branch.special.values):
        if kind in ("LP", "PD"):
            ax.plot(lam[j], y[j], "s" if kind == "LP" else "D", color="k", ms=5, mfc="w",
                    zorder=4)


def draw_family(ax, orbits: list[Orbit], color: str) -> None:
    """Each section point of a family as a line over speed (stable solid, else dotted)."""
    index = state_index(VAR)
    for k in range(orbits[0].period if orbits else 0):
        for stable in (True, False):
            speeds = [o.speed if o.stable == stable else np.nan for o in orbits]
            ax.plot(speeds, [o.points[k, index] * 1e6 for o in orbits],
                    "-" if stable else ":", color=color, lw=1.6, zorder=2)


def state_index(name: str) -> int:
    """Position of a state variable of the balanced rotor."""
    return ["x", "y", "vx", "vy"].index(name)


def draw_sweeps(ax, followed: xr.Dataset, cold: xr.Dataset | None) -> None:
    """Section points: followed up (dots), down (rings), not followed (crosses)."""
    style = {"up": dict(marker="o", ms=2.5, color="C0", ls=""),
             "down": dict(marker="o", ms=5, mfc="none", mew=0.7, color="C1", ls="")}
    for direction in followed.direction.values:
        values = followed[VAR].sel(direction=direction)
        grid = np.repeat(followed.speed_rpm.values, values.sizes["k"])
        ax.plot(grid, values.values.ravel() * 1e6, **style[str(direction)], zorder=5)
    if cold is not None:
        values = cold[VAR].isel(direction=0)
        grid = np.repeat(cold.speed_rpm.values, values.sizes["k"])
        ax.plot(grid, values.values.ravel() * 1e6, "x", ms=3, color="0.55", mew=0.6,
                zorder=1)


def legend(fig, ax) -> None:
    """One legend for every panel's symbols, below the panels."""
    handles = [
        ax.plot([], [], "o", ms=3, color="C0")[0], ax.plot([], [], "o", ms=5, mfc="none",
                                                           color="C1")[0],
        ax.plot([], [], "x", ms=4, color="0.55")[0], ax.plot([], [], "k-")[0],
        ax.plot([], [], "k--")[0], ax.plot([], [], "-", color="C2", lw=1.6)[0],
        ax.plot([], [], "-", color="C3", lw=1.6)[0],
        ax.plot([], [], "s", color="k", mfc="w")[0], ax.plot([], [], "D", color="k",
                                                             mfc="w")[0]]
    labels = ["sweep up, followed", "sweep down, followed", "not followed (t = 0, spec's state)",
              "period 1, continuation: stable", "period 1: unstable",
              "period 2, shooting (stable)", "period 3, shooting (stable)",
              "LP (fold)", "PD (period doubling)"]
    fig.legend(handles, labels, fontsize=8, ncol=3, loc="outside lower center")


def figure(diagram: xr.Dataset, cold: xr.Dataset, fold: xr.Dataset, branch: xr.Dataset,
           two: list[Orbit], three: list[Orbit]):
    """Whole range on top; the fold pair and the PD interval below."""
    fig = plt.figure(figsize=(10, 8.6), layout="constrained")
    grid = fig.add_gridspec(2, 2)
    top, left, right = (fig.add_subplot(grid[0, :]), fig.add_subplot(grid[1, 0]),
                        fig.add_subplot(grid[1, 1]))
    for ax, followed, window in ((top, diagram, None), (left, fold, (7300, 7420)),
                                 (right, diagram, (7800, 8500))):
        draw_sweeps(ax, followed, cold if followed is diagram else None)
        draw_branch(ax, branch)
        draw_family(ax, two, "C2")
        draw_family(ax, three, "C3")
        if window:
            ax.set_xlim(*window)
            inside = (diagram.speed_rpm >= window[0]) & (diagram.speed_rpm <= window[1])
            values = np.concatenate([diagram[VAR].sel(speed_rpm=inside).values.ravel(),
                                     cold[VAR].sel(speed_rpm=inside).values.ravel()]) * 1e6
            pad = 0.05 * np.ptp(values)
            ax.set_ylim(values.min() - pad, values.max() + pad)
        ax.set_xlabel("speed_rpm (rpm)")
        ax.set_ylabel(f"{VAR} on the VC section (µm)")
        ax.grid(True, alpha=0.3)
    top.set_xlim(float(diagram.speed_rpm[0]) - 30, float(diagram.speed_rpm[-1]) + 30)
    legend(fig, top)
    left.set_title("fold pair: hysteresis (fine grid)", fontsize=9)
    right.set_title("period doublings; period 3 coexists (reached when not followed)",
                    fontsize=9)
    fig.suptitle(f"{MODEL}, $N_b$ = {N_BALLS}, {LOAD['radial_load']:g} N: brute-force "
                 "diagram against continuation and shooting", fontsize=10)
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name in ("diagram", "cold", "fold", "branch"):
        parser.add_argument(name, type=Path)
    parser.add_argument("-o", "--output", type=Path,
                        default=Path("docs/figures/sweep-diagram-balanced-rotor.png"))
    args = parser.parse_args()
    diagram, cold, fold, branch = (open_result(p) for p in
                                   (args.diagram, args.cold, args.fold, args.branch))
    two, three = period_two(branch), period_three(cold)
    specials = ", ".join(f"{branch.special.values[i]} {float(branch.speed_rpm[i]):.1f}"
                         for i in range(branch.sizes["point"])
                         if branch.special.values[i] in ("LP", "PD"))
    print(f"continuation: {specials} rpm")
    print(f"period 2 (shooting, {STEP:g} rpm steps): stable {stable_range(two)}")
    print(f"period 3 (shooting, {STEP:g} rpm steps): stable {stable_range(three)}, "
          f"found {three[0].speed:.0f}–{three[-1].speed:.0f} rpm" if three else
          "period 3: not found")
    gap, shared = largest_gap(diagram, two)
    print(f"followed sweeps vs the period-2 orbits at {shared} common speeds: every {VAR} "
          f"within {gap * 1e9:.2g} nm")
    fig = figure(diagram, cold, fold, branch, two, three)
    fig.savefig(args.output, dpi=110)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
