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

The rest of the command is said beside them (``CostEstimate.also``, issue 41: `torus
--method hb` said "about 4 s" and took 56 s of CPU): the start-up and probes already spent,
the guess's settled simulations (one per solve), the two error-estimate solves of HB (at
2H: ``DOUBLED_ITERATION`` × the probed iteration, measured 8.2× for a torus 8,4 → 16,8 and
2.5× for a periodic H = 40 → 80, so 8 for a torus and 4 for a periodic response; at twice
the samples: 2×), Hill's stability of each point of a periodic branch (probed), λ1 and
the drift run (RK4 steps of ``lyapunov_duration`` s, the tangent as ``n`` more states), the
invariant circle's integrated amplitude (6N revolutions), the figure's time run and a
``FILE_SECONDS`` per file and figure. RK4 steps are timed by
``analysis.integrate.cost.probe_step_seconds``. The CasADi builds are still left out.
Nothing here prints: the command line renders ``CostEstimate.lines()``.
"""

from __future__ import annotations

import math

import numpy as np

from analysis.integrate.cost import (
    FILE_SECONDS,
    CostEstimate,
    best_seconds,
    steady_seconds,
    with_load,
)
from analysis.model import System

NEWTON_ITERATIONS = 6
"""Newton iterations expected of one HB response from a simulation's guess."""
BRANCH_ITERATIONS = 5
"""Newton iterations expected per point of a branch (predictor, then corrector; 4.7
solves a point measured on a Duffing branch of H = 60 through two folds, 100 points; 3
said half of that)."""
CIRCLE_EVALUATIONS = 4
"""Shaft-map evaluations expected per circle solve (the first residual, about three Newton
steps: measured 2 iterations at vakharia2015 N_b = 10, 5000 rpm, N = 65)."""
PROBE_STEPS = 200
"""RK4 steps of the circle's timed probe (of two points)."""
NEWTON = "Newton iterations"
"""The unit of an HB estimate."""
DOUBLED_ITERATION = {True: 8.0, False: 4.0}
"""A Newton iteration at doubled harmonics over one at H: a torus (True), a periodic
response (False) (module docstring)."""


def rk4_seconds(system: System, seconds: float, dt: float | None, vectors: int = 0) -> float:
    """Expected seconds of ``seconds`` s of RK4 of ``system`` at its step ``dt`` (None: the
    spec's) carrying ``vectors`` tangent columns (each counted as one more state)."""
    from analysis.integrate.cost import probe_step_seconds
    from analysis.integrate.plan import RunPlan

    step = RunPlan.step(system, dt, warn=lambda message: None).dt
    return seconds / step * probe_step_seconds(system, step) * (1 + vectors)


def command_parts(system: System, request, solves: int, extra: float = 0.0
                  ) -> list[tuple[str, float]]:
    """The named parts of a frequency command beyond its Newton iterations or circle steps:
    ``solves`` settled simulations for guesses, λ1 and the drift run, the figure's run
    (``request.figure`` simulated s) and the files; ``extra``: simulated s more."""
    settle = float(system.model.simulation_defaults["transient"])
    dt = request.options.get("dt")
    parts = [("settled simulations for the guesses",
              rk4_seconds(system, solves * (settle + 1.0) + extra, dt))]
    if request.lyapunov_duration > 0 and request.param is None:
        parts.append(("lambda1 and the drift run",
                      rk4_seconds(system, request.lyapunov_duration * 1.1, dt,
                                  system.n_state) +
                      rk4_seconds(system, request.lyapunov_duration, dt)))
    if request.figure is not None:
        run = rk4_seconds(system, settle + request.figure, dt) if request.figure else 0.0
        parts.append(("the figure", run + FILE_SECONDS))
    parts.append(("the file", FILE_SECONDS))
    return parts


def probe_newton_seconds(equations) -> float:
    """Seconds of one Newton iteration of ``equations`` (a ``HarmonicSystem`` or
    ``TorusSystem``): a residual and Jacobian evaluation and a dense solve, at zero
    coefficients, after an untimed evaluation (the function built); the mean of as many as
    fill ``steady_seconds``' 0.05 s. The solve runs in ``blas_threads()`` as the solver's
    do: on a loaded machine OpenBLAS's own threads spin (a 164 × 164 solve took 0.24 s
    instead of 1 ms, and ``hb`` said 45 s for a 6.5 s command)."""
    from analysis.threads import blas_threads

    x = np.zeros(equations.size)
    p = np.asarray(equations.system.p, dtype=float)
    equations.evaluate(x, p)

    def iteration() -> None:
        r, jac, _ = equations.evaluate(x, p)
        np.linalg.solve(jac + np.eye(len(r)), r)

    with blas_threads():
        return steady_seconds(iteration)


def probe_shaft_step_seconds(shaft_map) -> float:
    """Seconds of one RK4 step of one circle point in a ``ShaftMap`` of two points and
    ``PROBE_STEPS`` steps (its threads as the solve's), after an untimed call: the mean of
    as many calls as fill ``steady_seconds``' 0.05 s (one call was 5 ms: under load a
    burst, the torus said half its time)."""
    u = np.tile(np.asarray(shaft_map.system.state, dtype=float), (shaft_map.points, 1))
    phi = np.linspace(0, math.pi, shaft_map.points)
    shaft_map(u, phi, shaft_map.system.p)
    call = steady_seconds(lambda: shaft_map(u, phi, shaft_map.system.p))
    return call / (shaft_map.points * shaft_map.steps)


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
    seconds = probe_newton_seconds(equations)
    estimate = _newton_estimate(seconds, request, what)
    errors = NEWTON_ITERATIONS * seconds * (DOUBLED_ITERATION[torus] + 2.0)
    hill = []
    if not torus and request.param is not None and request.stability["stability"]:
        hill = [("Hill's stability of each point",
                 estimate.members * probe_hill_seconds(equations))]
    return estimate.with_parts(
        ("the two error-estimate solves (2H, 2x samples)", errors), *hill,
        *command_parts(system, request, 3))


def probe_hill_seconds(equations) -> float:
    """Seconds of Hill's multipliers (``hill.hill_stability``: the eigenproblem each
    point of a periodic branch solves, 1.8 s of a 17 s branch of 100 points at H = 60) of
    the Jacobian of ``equations`` (a ``HarmonicSystem``) at zero coefficients, in
    ``blas_threads()`` as the branch's."""
    from analysis.frequency.periodic.hill import hill_stability
    from analysis.threads import blas_threads

    p = np.asarray(equations.system.p, dtype=float)
    _, jac, _ = equations.evaluate(np.zeros(equations.size), p)
    with blas_threads():
        return best_seconds(lambda: hill_stability(jac, equations.n, equations.harmonics,
                                                   equations.period_s(p)), repeat=1)


def _newton_estimate(seconds: float, request, what: str) -> CostEstimate:
    from analysis.integrate.cost import process_seconds

    branch = request.param is not None
    return with_load(CostEstimate(members=request.max_points if branch else 1,
                                  steps=BRANCH_ITERATIONS if branch else NEWTON_ITERATIONS,
                                  workers=1, step_seconds=seconds, dt=math.nan, what=what,
                                  bound=branch, unit=NEWTON, spent=process_seconds()))


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
    from analysis.integrate.cost import process_seconds

    estimate = with_load(CostEstimate(members=request.max_points if branch else 1,
                                      steps=per_circle * steps * CIRCLE_EVALUATIONS,
                                      workers=1, step_seconds=seconds, dt=period / steps,
                                      what="circles" if branch else "circle", bound=branch,
                                      spent=process_seconds()))
    revolutions = 6 * points * period  # the integrated amplitude: 2N and 4N phases
    return estimate.with_parts(
        ("the integrated amplitude and the run's errors",
         rk4_seconds(system, revolutions + 30 * period, request.options.get("dt"))),
        *command_parts(system, request, 1, extra=max(4 * points, 200) * period))



def torus_hb_cost(system: System, request) -> CostEstimate:
    """``hb_cost`` of a torus by 2-D harmonic balance."""
    return hb_cost(system, request, torus=True)
