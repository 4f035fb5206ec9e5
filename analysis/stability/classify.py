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
   **quasi-periodic** if not. The detail says which of three cases it is, by the interval:
   it contains 0 (a frequency of its own, λ1 ≈ 0); it lies below 0 (a stable response: with
   several forcing frequencies not in a small-integer ratio, X, VC of each bearing, a
   parameter's period, the response follows them, and the verdict reads
   ``quasi-periodic (forced by X, VC, …)``, ``Classification.label``); or it lies above 0
   but below the floor (too weak to call chaotic). "≈ 0" is never said of an exponent whose
   interval excludes 0.

Sections: those of ``analysis.signal.poincare`` (``shaft``, ``cage``, ``vc``,
``vc[<bearing>]``, ``param:NAME`` …), which keep every state variable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from fractions import Fraction

import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.forcing import run_period_parameter, run_unbalance
from analysis.provenance import state_at, state_names, system_of_attrs
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
    forced_by: tuple[str, ...] = ()
    """The forcing frequencies a stable quasi-periodic response follows (``X``, ``VC``,
    ``VC[left]``, ``1/forcing_period``), empty otherwise."""

    @property
    def label(self) -> str:
        """The verdict as a reader sees it: the class, and for a response forced at several
        frequencies, which: ``quasi-periodic (forced by X, VC)``."""
        if self.forced_by:
            return f"{self.nature} (forced by {', '.join(self.forced_by)})"
        return self.nature

    def as_dict(self) -> dict:
        return {**asdict(self), "forced_by": list(self.forced_by), "label": self.label}


# --- the class vocabulary ------------------------------------------------------------------

@dataclass(frozen=True)
class Nature:
    """One class of the chart: its integer ``code`` (a chart file's ``nature_code``), its
    ``key`` (the ``nature`` a point is given; periodic-n stands for every n >= 3), the
    ``label`` of a legend and the ``color`` every figure and the explorer draw it in."""

    code: int
    key: str
    label: str
    color: str


NATURES: tuple[Nature, ...] = (
    Nature(0, "failed", "failed (the run blew up)", "#cccccc"),
    Nature(1, "periodic-1", "periodic-1", "#009e73"),
    Nature(2, "periodic-2", "periodic-2", "#56b4e9"),
    Nature(3, "periodic-n", "periodic-n (n ≥ 3)", "#f0e442"),
    Nature(4, "quasi-periodic", "quasi-periodic", "#0072b2"),
    Nature(5, "chaotic", "chaotic", "#d55e00"),
)
"""The chart classes, once: codes, names and colours (failed: the point's run blew up or its
solver failed, its ``nature`` says how: ``failed: blew up at t = 0.52 s``). The colours are
Okabe and Ito's colour-blind-safe set (and a light grey): every two stay apart for normal vision
and for protanopia, deuteranopia and tritanopia (``tests/reports/test_chart_colours.py``
measures it)."""
NATURE_CODES: dict[str, int] = {n.key: n.code for n in NATURES}
"""Integer code of each class key (``periodic-n``: n >= 3)."""
NATURE_COLORS: dict[int, str] = {n.code: n.color for n in NATURES}
"""Colour (``#rrggbb``) of each class code."""
NATURE_NAMES: dict[int, str] = {n.code: n.label for n in NATURES}
"""Legend label of each class code."""


def nature_code(nature: str) -> int:
    """The code of a point's ``nature``: ``periodic-7`` → periodic-n's, ``failed: …`` →
    failed's."""
    if nature.startswith("failed"):
        return NATURE_CODES["failed"]
    return NATURE_CODES.get(nature, NATURE_CODES["periodic-n"])


def failure_text(exc: SimulationError) -> str:
    """``failed: <what happened>``: the class recorded for a point whose run failed."""
    return "failed: " + str(exc).split(";")[0].replace("the motion ", "")


# --- default sections: one table -----------------------------------------------------------

@dataclass(frozen=True)
class SectionRule:
    """The section (or orbit period) each use takes when none is given, for one kind of
    forcing, and why."""

    classify: str
    """``default_section``: the section a motion is classified on."""
    orbit: str | None
    """``analysis.stability.periodic.default_period``: the period an orbit is sought at
    (None: no default, it must be given)."""
    figure: str
    """``analysis.reports.plots.any_figure``: the Poincaré map of a run's figure."""
    reason: str


SECTION_RULES: dict[str, SectionRule] = {
    "one bearing, no unbalance": SectionRule(
        "vc", "vc", "shaft",
        "the only forcing frequency is VC, so its section reduces a periodic response to "
        "points; the figure shows the shaft section, as every rotor's figure does"),
    "one bearing, unbalance": SectionRule(
        "shaft", "vc", "shaft",
        "two forcings, X and VC: classify tests the two-frequency torus on the shaft "
        "section; an orbit's default stays vc (give shaft or ratio:p/q with unbalance)"),
    "several bearings": SectionRule(
        "shaft", None, "shaft",
        "one VC per bearing: neither shaft nor one bearing's vc is in general a period of "
        "the forcing, so an orbit's period must be named; classify and figures use shaft"),
    "no bearings, forcing_period": SectionRule(
        "param:{forcing}", "param:{forcing}", "param:{forcing}",
        "forced at a parameter's period (mathieu); a figure still shows the shaft section "
        "when the model turns a shaft (shaft_hz > 0)"),
    "no bearings": SectionRule(
        "shaft", "shaft", "shaft", "the shaft speed is the forcing frequency (duffing)"),
}
"""Default sections by kind of forcing (``forcing_case``), one column per use
(``{forcing}``: the parameter that plays the ``forcing_period`` role, ``Model.role``). Where the
columns differ each use keeps the rule it had before they were gathered here."""

GRID_RECORD_SECTION = "shaft"
"""The section whose periods a grid point records (``samples``, ``--revolutions``) when its
setting names none: shaft revolutions. (A chart without a section still classifies each
point on its ``default_section``; its record length stays counted in revolutions.)"""


def forcing_case(bearings: int, unbalanced: bool, forcing_period: bool) -> str:
    """The row of ``SECTION_RULES`` for a model of ``bearings`` bearings, with or without
    unbalance, with or without a ``forcing_period`` parameter."""
    if bearings == 1:
        return "one bearing, unbalance" if unbalanced else "one bearing, no unbalance"
    if bearings > 1:
        return "several bearings"
    return "no bearings, forcing_period" if forcing_period else "no bearings"


def _bearings_of_attrs(attrs: Mapping) -> int:
    if "n_balls" in attrs:
        return 1 if int(attrs["n_balls"]) > 0 else 0
    several = sum(1 for k in attrs if str(k).startswith("n_balls_"))
    return several if several else int(attrs.get("vc_hz", 0.0) > 0)


def default_section(ds: xr.Dataset | Mapping) -> str:
    """The section a motion is classified on when none is given (``SECTION_RULES``,
    column ``classify``): 'vc' for a balanced rotor in one bearing (single forcing
    frequency VC); 'param:forcing_period' for a model without bearings that has that
    parameter (e.g. ``mathieu``); else 'shaft' (unbalance, several bearings, or e.g.
    ``duffing``). ``ds``: a run, or its attrs."""
    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    unbalanced = run_unbalance(attrs) != 0.0
    forcing = run_period_parameter(attrs)  # the forcing_period role
    case = forcing_case(_bearings_of_attrs(attrs), unbalanced, forcing is not None)
    if case == "one bearing, no unbalance" and not attrs.get("vc_hz", 0.0) > 0:
        return "shaft"  # the rotor at rest: no VC period
    return SECTION_RULES[case].classify.format(forcing=forcing)


def default_orbit_section(bearing_names: tuple[str, ...], forcing: str | None) -> str | None:
    """The period an orbit is sought at when none is given (``SECTION_RULES``, column
    ``orbit``; None: it must be given) for a model of these bearings whose forcing period
    parameter (the ``forcing_period`` role) is ``forcing`` (None: it has none)."""
    case = forcing_case(len(bearing_names), False, forcing is not None)
    rule = SECTION_RULES[case].orbit
    return None if rule is None else rule.format(forcing=forcing)


def default_figure_section(ds: xr.Dataset | Mapping) -> str:
    """The section of a run's figure (``SECTION_RULES``, column ``figure``): the shaft
    section whenever the shaft turns, else ``param:forcing_period`` for a model forced at
    a parameter's period (the Mathieu equation), else shaft."""
    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    if float(attrs.get("shaft_hz", 0.0)) > 0:
        return "shaft"
    forcing = run_period_parameter(attrs)  # the forcing_period role
    forced = forcing is not None and float(attrs[forcing]) > 0
    case = "no bearings, forcing_period" if forced else "no bearings"
    return SECTION_RULES[case].figure.format(forcing=forcing)


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


def verdict_points(max_period: int = 16) -> int:
    """Section points a verdict needs: periods up to ``max_period`` must repeat twice."""
    return 2 * max_period + 2


def classify(
    ds: xr.Dataset,
    section: str | None = None,
    exponents: xr.Dataset | None = None,
    *,
    rel_tol: float = 1e-3,
    max_period: int = 16,
    chaos_floor: float = 0.01,
    lyapunov_duration: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Classification:
    """Classify the motion in ``ds`` (a run from ``simulate`` of any model, transient
    dropped) on ``section`` (default: ``default_section``).

    ``exponents`` (from ``analysis.stability.lyapunov.lyapunov``) is computed from the run's
    own model, parameters and final state when needed and not given (``lyapunov_duration``
    seconds, default: the run's length); ``progress(done, total)`` is called meanwhile
    (``lyapunov``'s; never when the points decide alone, in well under a second).
    """
    section = section or default_section(ds)
    pts = poincare_section(ds, section)
    least = verdict_points(max_period)
    found = pts.sizes.get("k", 0)  # section points along k (their times in coordinate t)
    if found < least:
        raise InputError(f"run: {found} point(s) on the {section} section; a verdict "
                         f"needs at least {least} (periods up to {max_period} must repeat "
                         "twice): simulate longer")
    ptp = {v: float(np.ptp(ds[v].values)) for v in state_names(ds)}

    def largest() -> tuple[float, float]:
        found = exponents if exponents is not None else exponents_of_run(
            ds, lyapunov_duration, progress)
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
    two_forcings = run_unbalance(attrs) > 0 and attrs.get("vc_hz", 0) > 0
    if two_forcings and section == "shaft":
        ratio = graph_ratio(points, np.mod(pts.t.values * attrs["vc_hz"], 1.0))
        if ratio < GRAPH_RATIO:
            return Classification("quasi-periodic", "two-frequency torus locked to X and VC "
                                   "(points on a smooth curve of the ball-set phase)",
                                   section, len(points), graph_ratio=ratio,
                                   forced_by=tuple(forcing_frequencies(attrs)))
    lam, ci = largest()
    floor = chaos_floor * 2 * np.pi / attrs["section_period_s"]
    exponent = f"largest Lyapunov exponent {lam:.4g} ± {ci:.2g} 1/s (95 %)"
    found = dict(section=section, n_points=len(points), largest_exponent=lam, ci95=ci,
                 graph_ratio=ratio)
    if lam - ci > 0 and lam > floor:
        return Classification("chaotic", f"{exponent} > 0", **found)
    if lam - ci > 0:
        return Classification("quasi-periodic", f"{exponent} > 0 but below the chaos floor "
                              f"{floor:.3g} 1/s ({chaos_floor:g} of the section's angular "
                              "frequency): too weak to call chaotic", **found)
    if lam + ci < 0:
        forcings = forcing_frequencies(attrs)
        groups = commensurate_groups(forcings)
        if len(groups) > 1:
            named = ", ".join(f"{k} = {v:.4g} Hz" for k, v in forcings.items())
            return Classification("quasi-periodic", f"{exponent} < 0: a stable response "
                                  f"that follows its forcing frequencies ({named}), "
                                  f"{len(groups)} incommensurate groups of them ("
                                  + "; ".join(", ".join(g) for g in groups) +
                                  f": no ratio of integers up to {RATIO_DENOMINATOR} "
                                  "between groups)",
                                  forced_by=tuple(forcings), **found)
        why = ("its forcing frequencies are in a ratio of integers, " +
               ", ".join(groups[0]) + ": " if len(forcings) > 1 else "")
        return Classification("quasi-periodic", f"{exponent} < 0, a stable response, but "
                              f"the {section} section does not repeat within {max_period} "
                              f"samples ({why}a longer period, or a run not yet settled: "
                              "simulate longer)", **found)
    return Classification("quasi-periodic", f"a frequency of its own: {exponent} ≈ 0 (the "
                          "interval contains 0)", **found)


def forcing_frequencies(attrs: Mapping) -> dict[str, float]:
    """The distinct forcing frequencies (Hz) of a run, from its attrs: ``X`` (the shaft,
    with unbalance, or as the forcing of a model without bearings), ``VC`` (one bearing) or
    ``VC[<bearing>]`` (each of several), ``1/<parameter>`` (a model forced at a parameter's
    period). A frequency equal to one already named (two equal bearings) is not repeated."""
    shaft = float(attrs.get("shaft_hz", 0.0))
    forcing = run_period_parameter(attrs)
    period = float(attrs[forcing]) if forcing else 0.0
    vc = {"VC": float(attrs["vc_hz"])} if "vc_hz" in attrs else {
        f"VC[{k.removeprefix('vc_hz_')}]": float(v) for k, v in attrs.items()
        if str(k).startswith("vc_hz_")}
    found: dict[str, float] = {}
    if shaft > 0 and (run_unbalance(attrs) != 0.0
                      or (_bearings_of_attrs(attrs) == 0 and not period > 0)):
        found["X"] = shaft
    found.update({k: v for k, v in vc.items() if v > 0})
    if period > 0:
        found[f"1/{forcing}"] = 1.0 / period
    distinct: dict[str, float] = {}
    for name, f in found.items():
        if not any(abs(f - g) <= 1e-9 * max(f, g) for g in distinct.values()):
            distinct[name] = f
    return distinct


RATIO_DENOMINATOR = 1000
"""Two forcing frequencies are commensurate when their ratio is p/q with q up to this (to
1e-9 relative): a response to them alone is periodic."""


def commensurate_groups(forcings: Mapping[str, float],
                        largest: int = RATIO_DENOMINATOR) -> list[list[str]]:
    """The ``forcings`` (name: Hz) grouped by rational ratio: frequencies in one group are
    in ratios p/q of integers with q up to ``largest`` (to 1e-9 relative), two groups have
    no such ratio. One group: the forcing is periodic; two or more: quasi-periodic (e.g.
    ``[["X"], ["VC[left]", "VC[right]"]]`` for two bearings of 7 and 11 balls on one cage
    frequency)."""
    groups: list[list[str]] = []
    for name, f in forcings.items():
        for group in groups:
            g = forcings[group[0]]
            ratio = Fraction(f / g).limit_denominator(largest)
            if ratio > 0 and abs(float(ratio) - f / g) <= 1e-9 * f / g:
                group.append(name)
                break
        else:
            groups.append([name])
    return groups


def exponents_of_run(ds: xr.Dataset, duration: float | None,
                     progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """λ1 (``lyapunov``) of the run's own model, parameters and final state over
    ``duration`` s (None: the run's length); ``progress``: ``lyapunov``'s."""
    from analysis.stability.lyapunov import lyapunov

    system = system_of_attrs(ds.attrs, state_at(ds, -1))
    length = float(ds.t[-1] - ds.t[0])
    return lyapunov(system, duration=duration or length, transient=0.0,
                    dt=float(ds.attrs["dt"]), progress=progress)
