"""One predictor–corrector step of any branch problem, and why the guards refuse one.

From a point with unit tangent τ (scaled unknowns w), the predictor is w + ds·τ; Keller's
bordered Newton (``problem.newton``) corrects it on the hyperplane τ·(w − w_pred) = 0; the
new tangent is the Jacobian's null vector by SVD or by one bordered solve
(``ContinuationOptions.tangent``), oriented along τ. The step is then held against the
``StepGuards`` (``refusal``) and the family's ``found_between`` (special points between the
two ends, or a reason to refuse). The engine (``trace``) halves ds after a refusal.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from analysis.stability.continuation.options import ContinuationOptions, StepGuards
from analysis.stability.continuation.problem import BranchProblem, Newton, newton, tangent

NO_CONVERGENCE = "no convergence"
"""The reason of a step whose corrector did not converge (not a guard's refusal)."""

FoundBetween = Callable[[Any, Any], "list | str"]
"""``found_between(prev, point)``: the special points located between two accepted ends
(in order), or the reason the step is refused."""


def angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors (deg)."""
    cos = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))


def step_tangent(jac: np.ndarray, previous: np.ndarray, method: str) -> np.ndarray:
    """The unit null vector of ``jac`` (m × (m + 1)) oriented along ``previous``: by SVD
    (``"svd"``) or by one bordered solve [jac; previous] τ = e_last (``"bordered"``; SVD
    when that matrix is singular)."""
    if method == "bordered":
        rhs = np.zeros(jac.shape[0] + 1)
        rhs[-1] = 1.0
        try:
            tau = np.linalg.solve(np.vstack([jac, previous]), rhs)
        except np.linalg.LinAlgError:
            return tangent(jac, previous, math.copysign(1.0, previous[-1]))
        tau /= np.linalg.norm(tau)
        return -tau if np.dot(tau, previous) < 0 else tau
    return tangent(jac, previous, math.copysign(1.0, previous[-1]))


def refusal(prob: BranchProblem, a: Any, b: Any, corrected: Newton, ds: float,
            guards: StepGuards) -> str:
    """Why ``guards`` refuse the step from ``a`` to ``b`` (corrected by ``corrected`` from a
    predictor ds away); '' when it passes (the fold test is the family's
    ``found_between``)."""
    if not guards.active:
        return ""
    if corrected.contraction > guards.max_contraction:
        return (f"Newton contraction {corrected.contraction:.2f} > "
                f"{guards.max_contraction:g}")
    if corrected.distance > guards.max_correction * ds:
        return (f"the corrector moved {corrected.distance / ds:.2f} ds > "
                f"{guards.max_correction:g} ds from the predictor")
    if b.angle > guards.max_angle:
        return f"the tangent turned {b.angle:.1f}° > {guards.max_angle:g}°"
    secant = prob.unknowns(b) - prob.unknowns(a)
    worst = max(angle(secant, a.tangent), angle(secant, b.tangent))
    if worst > guards.max_angle:
        return f"the secant is {worst:.1f}° > {guards.max_angle:g}° off a tangent"
    same_side = np.sign(a.tangent[-1]) == np.sign(b.tangent[-1])
    if same_side and secant[-1] * a.tangent[-1] < 0 and abs(secant[-1]) > 1e-9 * ds:
        return "the parameter moved against both tangents"
    return ""


def step(prob: BranchProblem, prev: Any, ds: float, options: ContinuationOptions,
         found_between: FoundBetween) -> tuple[list, Any] | str:
    """One predictor–corrector step of ``ds`` from ``prev``: (the special points located
    between, the new point), or why it is refused (``NO_CONVERGENCE``, a guard, or the
    reason ``found_between`` gives)."""
    corrected = newton(prob, prob.unknowns(prev) + ds * prev.tangent, prev.tangent,
                       options.tol)
    if corrected is None:
        return NO_CONVERGENCE
    method = options.tangent or prob.tangent_method
    point = prob.point(corrected, step_tangent(corrected.jac, prev.tangent, method))
    point.angle = angle(prev.tangent, point.tangent)
    point.contraction = corrected.contraction
    reason = refusal(prob, prev, point, corrected, ds, options.guards)
    if reason:
        return reason
    found = found_between(prev, point)
    return found if isinstance(found, str) else (found, point)


def start_at(prob: BranchProblem, w: np.ndarray, direction: float, tol: float,
             tau: np.ndarray | None = None) -> Any:
    """The first point of a branch: ``w`` corrected by Newton with λ held fixed (or along
    ``tau`` when given, which then is the point's tangent; else the tangent by SVD, its λ
    component of the sign of ``direction``). None when it does not converge."""
    out = newton(prob, w, np.eye(len(w))[-1] if tau is None else tau, tol)
    if out is None:
        return None
    return prob.point(out, tangent(out.jac, None, direction) if tau is None else tau)
