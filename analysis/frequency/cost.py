"""Costs said before they are paid (issue 32, section 3) for the frequency-domain methods:
the ``analysis.integrate.cost.CostEstimate`` of an ``hb`` or ``torus`` request, from a
short timed probe of the method's own equations.

* **Harmonic balance** (``hb``, ``torus --method hb``): one Newton iteration is a residual
  and Jacobian evaluation and a dense solve of its size; the probe times one of each at the
  request's harmonics (after an untimed call that builds the CasADi function), and the
  estimate is that time × ``NEWTON_ITERATIONS`` per response (``BRANCH_ITERATIONS`` per
  point of a branch, ``max_points`` points at most).
* **Invariant circle** (``torus``, shooting): one Newton iteration integrates the N circle
  points over a shaft period (RK4 steps of the solve, with their tangent); the probe times
  ``PROBE_STEPS`` such steps of two points in a CasADi map like the solve's, and the
  estimate is points × steps per revolution × ``CIRCLE_EVALUATIONS`` shaft-map evaluations
  (the convergence check's 2N points included) per circle.

Left out of both: the guess's settled simulation and λ1 (compiled RK4, seconds at most),
the CasADi builds (seconds) and ``hb``'s two error-estimate solves (each about a first
solve at 2H or 2x samples).
Nothing here prints: the command line renders ``CostEstimate.lines()``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from analysis.integrate.cost import CostEstimate
from analysis.model import System

NEWTON_ITERATIONS = 6
"""Newton iterations expected of one HB response from a simulation's guess."""
BRANCH_ITERATIONS = 3
"""Newton iterations expected per point of a branch (predictor, then corrector)."""
CIRCLE_EVALUATIONS = 4
"""Shaft-map evaluations expected per circle solve (the first residual, about three Newton
steps: measured 2 iterations at vakharia2015 N_b = 10, 5000 rpm, N = 65)."""
PROBE_STEPS = 200
"""RK4 steps of the circle's timed probe (of two points)."""
NEWTON = "Newton iterations"
"""The unit of an HB estimate."""


def probe_newton_seconds(equations) -> float:
    """Seconds of one Newton iteration of ``equations`` (a ``HarmonicSystem`` or
    ``TorusSystem``): a residual and Jacobian evaluation and a dense solve, at zero
    coefficients, after an untimed evaluation (the function built)."""
    x = np.zeros(equations.size)
    p = np.asarray(equations.system.p, dtype=float)
    equations.evaluate(x, p)
    start = time.perf_counter()
    r, jac, _ = equations.evaluate(x, p)
    np.linalg.solve(jac + np.eye(len(r)), r)
    return time.perf_counter() - start


def probe_shaft_step_seconds(shaft_map) -> float:
    """Seconds of one RK4 step of one circle point in a ``ShaftMap`` of two points and
    ``PROBE_STEPS`` steps (its threads as the solve's), after an untimed call."""
    u = np.tile(np.asarray(shaft_map.system.state, dtype=float), (shaft_map.points, 1))
    phi = np.linspace(0, math.pi, shaft_map.points)
    shaft_map(u, phi, shaft_map.system.p)
    start = time.perf_counter()
    shaft_map(u, phi, shaft_map.system.p)
    return (time.perf_counter() - start) / (shaft_map.points * shaft_map.steps)


def hb_cost(system: System, request, torus: bool = False) -> CostEstimate:
    """The cost of ``request`` (``methods.Request``, its inputs checked) by periodic HB, or
    by 2-D HB of a torus (``torus``): probe × iterations × points."""
    if torus:
        from analysis.frequency.torus.equations import TorusSystem
        from analysis.frequency.torus.solve import prepare_torus

        system, freqs, pair = prepare_torus(system, request.frequencies, request.resolution)
        equations = TorusSystem(system, freqs, pair, request.options.get("samples"))
        what = "tori" if request.param else "torus"
    else:
        from analysis.frequency.periodic.harmonic import HarmonicSystem
        from analysis.frequency.periodic.solve import prepare

        system, per = prepare(system, request.period)
        equations = HarmonicSystem(system, per, request.resolution,
                                   request.options.get("samples"))
        what = "responses" if request.param else "response"
    return _newton_estimate(probe_newton_seconds(equations), request, what)


def _newton_estimate(seconds: float, request, what: str) -> CostEstimate:
    branch = request.param is not None
    return CostEstimate(members=request.max_points if branch else 1,
                        steps=BRANCH_ITERATIONS if branch else NEWTON_ITERATIONS, workers=1,
                        step_seconds=seconds, dt=math.nan, what=what, bound=branch,
                        unit=NEWTON)


def circle_cost(system: System, request, convergence: bool = True) -> CostEstimate:
    """The cost of ``request`` by the invariant circle: per circle, (N points, and 2N more
    for the convergence check of one circle; N per circle of a branch, ``max_points``
    circles at most) × steps per shaft period × ``CIRCLE_EVALUATIONS``, at the probed
    seconds per step."""
    from analysis.frequency.circle.solve import SECTION_SAMPLES, ShaftMap, shaft_steps
    from analysis.frequency.torus.equations import omegas_of
    from analysis.frequency.torus.solve import prepare_torus
    from analysis.integrate.plan import RunPlan

    system, freqs, _ = prepare_torus(system, request.frequencies, (1, 1))
    period = 2 * math.pi / omegas_of(system, freqs)[0]
    steps, _ = shaft_steps(period, RunPlan.step(system, request.options.get("dt")).dt,
                           SECTION_SAMPLES)
    seconds = probe_shaft_step_seconds(ShaftMap(system, freqs, PROBE_STEPS, 1, 2))
    points = int(request.resolution)
    branch = request.param is not None
    per_circle = points if branch else points * (3 if convergence else 1)
    return CostEstimate(members=request.max_points if branch else 1,
                        steps=per_circle * steps * CIRCLE_EVALUATIONS, workers=1,
                        step_seconds=seconds, dt=period / steps,
                        what="circles" if branch else "circle", bound=branch)



def torus_hb_cost(system: System, request) -> CostEstimate:
    """``hb_cost`` of a torus by 2-D harmonic balance."""
    return hb_cost(system, request, torus=True)
