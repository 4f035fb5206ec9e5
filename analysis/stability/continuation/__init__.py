"""Pseudo-arclength continuation of periodic orbits, with bifurcation detection.

A branch is a ``BranchProblem`` (``problem``: the model, period, parameter and scales, the
shooting equations G(w) = (Φ_T(z0; λ) − z0) / s_z = 0 in the scaled unknowns
w = (z0 / s_z, λ / s_λ), and Keller's bordered Newton corrector) traced with
``ContinuationOptions`` (``options``: the scaled arclength steps, the point budget, the
tolerance and the ``StepGuards`` every step must pass), in the manner of BifurcationKit.jl's
``continuation(prob, alg, opts)``:

* ``trace``: the guarded stepping loop and its starts, ``continue_orbits`` (a model and a
  parameter range), ``continue_from_orbit`` (a solved orbit), ``continue_from_branch`` (a
  point of a stored branch, either direction) and ``continue_problem`` (a problem built by
  hand);
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
    ContinuationOptions,
    StepGuards,
    options_with,
)
from analysis.stability.continuation.problem import (
    BranchPoint,
    BranchProblem,
    Newton,
    branch_point,
    correct,
    newton,
    orbit_scale,
    scaled,
    tangent,
)
from analysis.stability.continuation.switching import (
    SWITCHES,
    Switched,
    switch_and_continue,
    switch_branch,
    switch_branch_point,
    switch_period_doubling,
)
from analysis.stability.continuation.trace import (
    continue_from_branch,
    continue_from_orbit,
    continue_orbits,
    continue_problem,
    start_point,
    trace_branch,
)

__all__ = [
    "DEFAULT_DS", "MAX_BRANCH_POINTS", "SWITCHES", "BranchPoint", "BranchProblem",
    "ContinuationOptions", "Newton", "StepGuards", "Switched", "branch_dataset",
    "branch_point", "branch_summary", "continue_from_branch", "continue_from_orbit",
    "continue_orbits", "continue_problem", "correct", "first_point", "newton",
    "options_with", "orbit_scale", "scaled", "special_point_lines", "special_points",
    "start_point", "switch_and_continue", "switch_branch", "switch_branch_point",
    "switch_period_doubling", "tangent", "trace_branch",
]
