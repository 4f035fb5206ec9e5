"""Classify a steady response: periodic-n, quasi-periodic or chaotic.

One function, ``classify``, used by every study, for a run of any model (any number of
states). It reads the stroboscopic Poincaré points of all state variables and, when the
points alone cannot decide, the largest Lyapunov exponent:

1. **periodic-n**: the section repeats after n samples, P_{k+n} = P_k within ``rel_tol``
   of the orbit size (n = 1 … ``max_period``).
2. **quasi-periodic, two-frequency torus** (models with one bearing and unbalance only):
   the forcing has two frequencies, X and VC, in general incommensurate, so even the
   simplest response is a closed curve on the shaft section. Such a response is locked to
   both forcings: its state at each shaft section is a smooth function of the ball-set
   phase φ_k = frac(VC·t_k) — the double section (shaft period and cage phase) reduces it
   to points. Test: sorted by φ, successive points are much closer than random pairs.
   With several bearings the forcing has a VC frequency per bearing (three or more
   frequencies), one phase does not reduce it, and this test is skipped.
3. Otherwise **chaotic** if the largest Lyapunov exponent is positive beyond its 95 %
   confidence interval and above ``chaos_floor`` × the section's angular frequency, and
   **quasi-periodic** (a frequency of its own, largest exponent ≈ 0) if not.

Sections: those of ``analysis.signal.poincare`` (``shaft``, ``cage``, ``vc``,
``vc[<bearing>]``, ``param:NAME`` …), which keep every state variable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.forcing import run_period_parameter
from analysis.integrate.simulate import state_at, state_names
from analysis.signal.poincare import poincare_section

GRAPH_RATIO = 0.2
"""Sorted-neighbour / random-pair distance below which points lie on a smooth graph of φ."""


@dataclass(frozen=True)
class Classification:
    nature: str
    """'periodic-n' (n = period in section samples), 'quasi-periodic' or 'chaotic'."""
    detail: str
    section: str
    n_points: int
    period: int | None = None
    largest_exponent: float | None = None
    """Largest Lyapunov exponent, 1/s (None when the section decided alone)."""
    ci95: float | None = None
    graph_ratio: float | None = None

    def as_dict(self) -> dict:
        return asdict(self)


def default_section(ds: xr.Dataset | Mapping) -> str:
    """'vc' for a balanced rotor in one bearing (single forcing frequency VC);
    'param:forcing_period' for a model without bearings that has that parameter (e.g.
    ``mathieu``); else 'shaft' (unbalance, several bearings, or e.g. ``duffing``). ``ds``: a
    run, or its attrs."""
    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    balanced = attrs.get("unbalance_force", 0.0) == 0.0
    if balanced and attrs.get("vc_hz", 0.0) > 0:
        return "vc"
    no_bearings = "n_balls" in attrs and int(attrs["n_balls"]) == 0
    forcing = run_period_parameter(attrs)  # the forcing_period role
    if no_bearings and forcing is not None:
        return f"param:{forcing}"
    return "shaft"


def _pairs(names: tuple[str, ...]) -> list[tuple[str, str]]:
    """(position, velocity) names: each state q with its velocity vq."""
    pairs = [(q, f"v{q}") for q in names if f"v{q}" in names]
    if 2 * len(pairs) != len(names):
        raise InputError(f"dataset: state variables {', '.join(names)} are not positions "
                         "with their velocities (v<name>)")
    return pairs


def _normalised_points(pts: xr.Dataset, ptp: Mapping[str, float]) -> tuple[np.ndarray, float]:
    """Section points of every state variable, with velocities divided by the section's
    angular frequency, and the orbit size: the largest peak-to-peak ``ptp`` of the positions
    over the run (in the first position's unit; positions of another unit, e.g. tilts in
    rad, are rescaled to the same size)."""
    omega = 2 * np.pi / pts.attrs["section_period_s"]
    names = state_names(pts)
    pairs = _pairs(names)
    units = [str(pts[q].attrs.get("units", "")) for q, _ in pairs]
    scale = {u: max(ptp[q] for (q, _), uq in zip(pairs, units, strict=True) if uq == u)
             for u in units}
    size = max(scale[units[0]], 1e-300)
    columns = {}
    for (q, v), u in zip(pairs, units, strict=True):
        factor = size / max(scale[u], 1e-300) if u != units[0] else 1.0
        columns[q] = pts[q].values * factor
        columns[v] = pts[v].values / omega * factor
    p = np.stack([columns[name] for name in names], axis=1)
    return p, size


def repeat_period(points: np.ndarray, size: float, rel_tol: float,
                  max_period: int) -> int | None:
    """Smallest n with |P_{k+n} − P_k| < rel_tol·size for every k, or None."""
    for n in range(1, max_period + 1):
        if len(points) < 2 * n + 2:
            break
        if np.max(np.linalg.norm(points[n:] - points[:-n], axis=1)) < rel_tol * size:
            return n
    return None


def graph_ratio(points: np.ndarray, phase: np.ndarray, seed: int = 0) -> float:
    """Median distance of φ-sorted neighbours over the median distance of random pairs."""
    order = np.argsort(phase)
    neighbours = np.linalg.norm(np.diff(points[order], axis=0), axis=1)
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, len(points), (2, 4 * len(points)))
    pairs = np.linalg.norm(points[i] - points[j], axis=1)
    return float(np.median(neighbours) / max(np.median(pairs[i != j]), 1e-300))


def classify(
    ds: xr.Dataset,
    section: str | None = None,
    exponents: xr.Dataset | None = None,
    *,
    rel_tol: float = 1e-3,
    max_period: int = 16,
    chaos_floor: float = 0.01,
    lyapunov_duration: float | None = None,
) -> Classification:
    """Classify the motion in ``ds`` (a run from ``simulate`` of any model, transient
    dropped) on ``section`` (default: ``default_section``).

    ``exponents`` (from ``analysis.stability.lyapunov.lyapunov``) is computed from the run's
    own model, parameters and final state when needed and not given (``lyapunov_duration``
    seconds, default: the run's length).
    """
    section = section or default_section(ds)
    pts = poincare_section(ds, section)
    least = 2 * max_period + 2
    found = pts.sizes.get("k", 0)  # section points along k (their times in coordinate t)
    if found < least:
        raise InputError(f"run: {found} point(s) on the {section} section; a verdict "
                         f"needs at least {least} (periods up to {max_period} must repeat "
                         "twice): simulate longer")
    ptp = {v: float(np.ptp(ds[v].values)) for v in state_names(ds)}

    def largest() -> tuple[float, float]:
        found = exponents if exponents is not None else _exponents_of_run(ds, lyapunov_duration)
        return float(found.exponents[0]), float(found.ci95[0])

    return classify_section(pts, ptp, largest, rel_tol=rel_tol, max_period=max_period,
                            chaos_floor=chaos_floor)


def classify_section(
    pts: xr.Dataset,
    ptp: Mapping[str, float],
    largest: Callable[[], tuple[float, float]],
    *,
    rel_tol: float = 1e-3,
    max_period: int = 16,
    chaos_floor: float = 0.01,
) -> Classification:
    """Classify a motion from its Poincaré points ``pts`` (``poincare_section`` of a run, or
    the same Dataset built otherwise: the run's attrs with ``section`` and
    ``section_period_s``), the peak-to-peak ``ptp`` of every state variable over the run
    (SI units) and ``largest()``: (λ1, its 95 % half-width) in 1/s, called only when the
    points cannot decide. The steps of ``classify``."""
    section, attrs = pts.attrs["section"], pts.attrs
    points, size = _normalised_points(pts, ptp)
    n = repeat_period(points, size, rel_tol, max_period)
    if n is not None:
        return Classification(f"periodic-{n}", f"{n} distinct point(s) on the {section} "
                              "section", section, len(points), period=n)
    ratio = None
    two_forcings = attrs.get("unbalance_force", 0.0) > 0 and attrs.get("vc_hz", 0) > 0
    if two_forcings and section == "shaft":
        ratio = graph_ratio(points, np.mod(pts.t.values * attrs["vc_hz"], 1.0))
        if ratio < GRAPH_RATIO:
            return Classification("quasi-periodic", "two-frequency torus locked to X and VC "
                                   "(points on a smooth curve of the ball-set phase)",
                                   section, len(points), graph_ratio=ratio)
    lam, ci = largest()
    floor = chaos_floor * 2 * np.pi / attrs["section_period_s"]
    if lam - ci > 0 and lam > floor:
        return Classification("chaotic", f"largest Lyapunov exponent {lam:.4g} ± {ci:.2g} 1/s "
                              "(95 %) > 0", section, len(points), largest_exponent=lam,
                              ci95=ci, graph_ratio=ratio)
    return Classification("quasi-periodic", f"a frequency of its own: largest Lyapunov "
                          f"exponent {lam:.3g} ± {ci:.2g} 1/s ≈ 0", section, len(points),
                          largest_exponent=lam, ci95=ci, graph_ratio=ratio)


def _exponents_of_run(ds: xr.Dataset, duration: float | None) -> xr.Dataset:
    from analysis.stability.lyapunov import lyapunov
    from analysis.stability.periodic import system_of_attrs

    system = system_of_attrs(ds.attrs, state_at(ds, -1))
    length = float(ds.t[-1] - ds.t[0])
    return lyapunov(system, duration=duration or length, transient=0.0,
                    dt=float(ds.attrs["dt"]))
