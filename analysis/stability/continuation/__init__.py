"""Pseudo-arclength continuation: one engine, any branch family, bifurcation detection.

A branch family is a ``BranchProblem`` (``problem``: the Protocol of scaled unknowns
w = (…, λ / s_λ), equations G(w) and the points they make; ``ContinuedRange``, the checked
parameter and ends; Keller's bordered Newton corrector) traced with ``ContinuationOptions``
(``options``: the scaled arclength steps, the point budget, the tolerance, the
``StepGuards`` every step must pass and the tangent method), in the manner of
BifurcationKit.jl's ``continuation(prob, alg, opts)``:

* ``step``: the one predictor–corrector step and the guards' refusal;
* ``trace``: the one engine, ``trace(problem, first, stop, options, hooks=Hooks(…))`` ->
  ``Trace`` (points, status, refused steps, last predictor tried), the one set of status
  texts and the stop report built from a ``Trace``;
* ``shooting``: the periodic orbits' family (``ShootingProblem``) and its starts,
  ``continue_orbits`` (a model and a parameter range), ``continue_from_orbit`` (a solved
  orbit), ``continue_from_branch`` (a point of a stored branch, either direction) and
  ``continue_problem`` (a problem built by hand);
* ``detect``: the special points located by bisection on the arclength: LP (fold: the
  tangent's parameter component changes sign), PD (det(M + I) changes sign), BP (det(M − I)
  changes sign without a fold), NS (the number of complex multipliers outside the unit
  circle changes), and 'grazing?' (a stability change at a kink no test function sees);
* ``dataset``: the branch as a Dataset (``branch_dataset``) and what it says
  (``special_points``, ``special_point_lines``, ``branch_summary``, ``first_point``);
* ``switching``: the period-2 branch at a PD, the asymmetric one at a BP
  (``switch_branch``) and, in one call, ``switch_and_continue``.

Every public name is importable from here: ``from analysis.stability.continuation import
continue_orbits, ContinuationOptions``.
"""

from analysis.stability.continuation.dataset import (
    branch_dataset,
    branch_summary,
    first_point,
    special_point_lines,
    special_points,
)
from analysis.stability.continuation.options import (
    DEFAULT_DS,
    MAX_BRANCH_POINTS,
    TANGENTS,
    ContinuationOptions,
    StepGuards,
    options_with,
)
from analysis.stability.continuation.problem import (
    BranchPoint,
    BranchProblem,
    ContinuedParameter,
    ContinuedRange,
    Newton,
    branch_point,
    correct,
    newton,
    scaled,
    tangent,
)
from analysis.stability.continuation.shooting import (
    ShootingProblem,
    continue_from_branch,
    continue_from_orbit,
    continue_orbits,
    continue_problem,
    orbit_scale,
    start_point,
    trace_branch,
)
from analysis.stability.continuation.step import refusal, start_at, step, step_tangent
from analysis.stability.continuation.switching import (
    SWITCHES,
    Switched,
    switch_and_continue,
    switch_branch,
    switch_branch_point,
    switch_period_doubling,
)
from analysis.stability.continuation.trace import STATUS, Hooks, Trace, stop_report, trace

__all__ = [
    "DEFAULT_DS", "MAX_BRANCH_POINTS", "STATUS", "SWITCHES", "TANGENTS", "BranchPoint",
    "BranchProblem", "ContinuationOptions", "ContinuedParameter", "ContinuedRange", "Hooks",
    "Newton", "ShootingProblem", "StepGuards", "Switched", "Trace", "branch_dataset",
    "branch_point", "branch_summary", "continue_from_branch", "continue_from_orbit",
    "continue_orbits", "continue_problem", "correct", "first_point", "newton",
    "options_with", "orbit_scale", "refusal", "scaled", "special_point_lines",
    "special_points", "start_at", "start_point", "step", "step_tangent", "stop_report",
    "switch_and_continue", "switch_branch", "switch_branch_point", "switch_period_doubling",
    "tangent", "trace", "trace_branch",
]
