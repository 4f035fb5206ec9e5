"""What each attractor is: its class, period, largest Lyapunov exponent and amplitudes.

An attractor found by the mapper is described by the trajectory that found it, run on past
the time it was recognised with the project's own tools, so an attractor's class means what
it means everywhere else: ``simulate`` from that trajectory's initial state, the transient
being the time it was recognised plus ``settle`` periods, then ``label`` periods classified
by ``analysis.stability.classify.classify_section`` (periodic-n, quasi-periodic, chaotic)
with λ1 and its 95 % interval from ``analysis.stability.lyapunov.lyapunov`` over the same
span. The amplitude of a coordinate is (max − min)/2 over that span, in its unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.signal.poincare import poincare_section
from analysis.stability.attractors.mapper import Found
from analysis.stability.classify import classify_section
from analysis.stability.lyapunov import lyapunov


@dataclass(frozen=True)
class LabelOptions:
    """How long an attractor is run to be described, in forcing periods."""

    settle: int = 100
    """Periods run after it was recognised, before the description starts."""
    span: int = 200
    """Periods described (classified, λ1 averaged, amplitudes measured)."""


@dataclass(frozen=True)
class Attractor:
    """One attractor of a stroboscopic map, described."""

    id: int
    nature: str
    """``periodic-n``, ``quasi-periodic`` or ``chaotic`` (the classes of ``classify``)."""
    period: int | None
    """Forcing periods of a periodic attractor (None otherwise)."""
    lambda1: float
    """Largest Lyapunov exponent, 1/s."""
    lambda1_ci95: float
    """Its 95 % half-width, 1/s."""
    amplitude: dict[str, float]
    """(max − min)/2 of each state over the described span, in its unit."""
    representative: np.ndarray
    """A state on the attractor (SI units) at a section time."""
    points: np.ndarray
    """Its section points as recorded by the mapper (m × n, SI units)."""
    detail: str
    """The classifier's words."""


def describe(system: System, found: Found, label: int, section: str, period_s: float,
             dt: float, options: LabelOptions | None = None) -> Attractor:
    """The ``Attractor`` ``label`` of ``found`` (the mapper's record): ``system`` the
    mapped system, ``section`` the name of the map's section (``vc``, ``shaft``,
    ``param:NAME``), ``period_s`` its period (s) and ``dt`` the map's RK4 step (s)."""
    options = options or LabelOptions()
    start = found.finder_state
    finder = system.replace(state=start[:-1])
    steps_per_period = round(period_s / dt)
    settled_periods = int(np.ceil((found.found_step - start[-1]) / steps_per_period))
    transient = (settled_periods + options.settle) * period_s
    span = options.span * period_s
    run = simulate(finder, duration=transient + span, transient=transient, dt=dt)
    exponents = lyapunov(finder, duration=span, transient=transient, dt=dt, n_exponents=1)
    lam, ci = float(exponents.exponents[0]), float(exponents.ci95[0])
    ranges = {name: float(np.ptp(run[name].values)) for name in system.state_names}
    verdict = classify_section(poincare_section(run, section), ranges, lambda: (lam, ci))
    last = run.isel(t=-1)
    return Attractor(
        id=label, nature=verdict.nature, period=verdict.period, lambda1=lam,
        lambda1_ci95=ci, amplitude={k: v / 2 for k, v in ranges.items()},
        representative=np.array([float(last[name]) for name in system.state_names]),
        points=np.asarray(found.points), detail=verdict.detail)
