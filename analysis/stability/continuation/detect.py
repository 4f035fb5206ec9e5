"""Special points of a branch: their test functions and their location by bisection.

Located on the chord between two consecutive points (each trial corrected onto the branch):
  * LP (fold): the parameter component of the tangent changes sign (a multiplier passes +1);
  * PD (period doubling): det(M + I) changes sign (a real multiplier passes −1);
  * BP (branch point): det(M − I) changes sign without a fold (a symmetry-breaking
    pitchfork, say);
  * NS (Neimark–Sacker): the number of complex multipliers outside the unit circle changes.

Non-smoothness: where an orbit starts or stops touching a ball (grazing), the branch has a
kink that no smooth test function sees; continuation passes it, the multipliers jump, and a
stability change there is reported as 'grazing?' (a change of the unstable count without
LP/PD/NS test function sign change).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from analysis.stability.continuation.options import StepGuards
from analysis.stability.continuation.problem import (
    BranchPoint,
    BranchProblem,
    branch_point,
    correct,
    scaled,
)


def lp_test(point: BranchPoint) -> float:
    """Parameter component of the tangent: changes sign at a fold (LP)."""
    return float(point.tangent[-1])


def _bp_test(point: BranchPoint) -> float:
    """det(M − I) = Π(μ − 1): changes sign when a real multiplier passes +1. Without a fold
    (LP) that is a branch point (BP), e.g. the symmetry-breaking pitchfork of the Duffing
    oscillator."""
    return float(np.real(np.prod(point.multipliers - 1)))


def _pd_test(point: BranchPoint) -> float:
    """det(M + I) = Π(μ + 1): changes sign when a real multiplier passes −1 (PD)."""
    return float(np.real(np.prod(point.multipliers + 1)))


def _locate(prob: BranchProblem, a: BranchPoint, b: BranchPoint, kind: str,
            test: Callable[[BranchPoint], float], tol: float, direction: float,
            iterations: int = 12, strict: bool = False) -> BranchPoint | None:
    """Bisection on the chord from a to b (corrected onto the branch) for the sign change of
    ``test``; returns the located point labelled ``kind`` (when no corrector converges: b,
    or None if ``strict``)."""
    wa, wb = scaled(prob, a), scaled(prob, b)
    chord = (wb - wa) / np.linalg.norm(wb - wa)
    sign_a = np.sign(test(a))
    lo, hi, best = 0.0, 1.0, None
    for _ in range(iterations):
        mid = (lo + hi) / 2
        out = correct(prob, wa + mid * (wb - wa), chord, tol)
        if out is None:
            break
        w, jac, mono, it = out
        best = branch_point(prob, w, jac, mono, a.tangent, direction, it)
        if np.sign(test(best)) == sign_a:
            lo = mid
        else:
            hi = mid
    if best is None:  # no corrector converged inside the interval: b is the best estimate
        if strict:
            return None
        best = b
    best.special = kind
    return best


def fold_between(prob: BranchProblem, a: BranchPoint, b: BranchPoint, tol: float,
                 direction: float) -> BranchPoint | None:
    """The fold (LP) between ``a`` and ``b``, whose tangents' parameter components differ
    in sign: located by bisection and checked to be a parameter extremum (beyond both ends,
    up to 1e-3 of the step in λ). None when no corrector converges or the located point is
    not an extremum: then the sign change is no fold of one branch, and the step is
    refused."""
    lp = _locate(prob, a, b, "LP", lp_test, tol, direction, strict=True)
    if lp is None:
        return None
    slack = 1e-3 * abs(b.lam - a.lam) + 1e-12 * prob.s_lam
    beyond_a = (lp.lam - a.lam) * np.sign(a.tangent[-1]) >= -slack
    beyond_b = (lp.lam - b.lam) * np.sign(b.tangent[-1]) <= slack
    return lp if beyond_a and beyond_b else None


def _complex_outside(point: BranchPoint) -> int:
    """Complex multipliers outside the unit circle (beyond 1 + 1e-9, as ``n_unstable``:
    a conservative system's multipliers on the circle are not a Neimark–Sacker point)."""
    mu = point.multipliers
    return int(np.sum((np.abs(mu.imag) > 1e-9) & (np.abs(mu) > 1 + 1e-9)))


def points_between(prob: BranchProblem, a: BranchPoint, b: BranchPoint, tol: float,
                   direction: float, lp: BranchPoint | None = None) -> list[BranchPoint]:
    """LP, PD, BP and NS points between two consecutive branch points, located by
    bisection (``lp``: the fold already located between them)."""
    found = [lp] if lp is not None else []
    for kind, test in (("LP", lp_test), ("PD", _pd_test), ("BP", _bp_test)):
        if kind == "BP" and found and found[0].special == "LP":
            continue  # at a fold det(M − I) changes sign too
        if kind == "LP" and lp is not None:
            continue
        if test(a) != 0 and np.sign(test(a)) != np.sign(test(b)):
            found.append(_locate(prob, a, b, kind, test, tol, direction))
    if _complex_outside(a) != _complex_outside(b):
        level = _complex_outside(a) + 0.5
        found.append(_locate(prob, a, b, "NS", lambda p: _complex_outside(p) - level, tol,
                             direction))
    if not found and a.n_unstable != b.n_unstable:
        b.special = "grazing?"
    return sorted(found, key=lambda p: np.dot(scaled(prob, p) - scaled(prob, a), a.tangent))


def special_between(prob: BranchProblem, a: BranchPoint, b: BranchPoint, tol: float,
                    guards: StepGuards) -> list[BranchPoint] | str:
    """The special points between two accepted points of a one-parameter branch (the
    engine's default ``found_between``): a fold where the tangent's λ component flips
    (with active ``guards``, the step is refused when none is located), then PD, BP, NS."""
    direction = math.copysign(1.0, a.tangent[-1])
    lp = None
    if lp_test(a) != 0 and np.sign(lp_test(a)) != np.sign(lp_test(b)):
        lp = fold_between(prob, a, b, tol, direction)
        if lp is None and guards.active:
            return "the parameter component of the tangent changed sign but no fold was found"
    return points_between(prob, a, b, tol, direction, lp=lp)
