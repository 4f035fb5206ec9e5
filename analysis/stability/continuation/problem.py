"""The contract of a branch family, the checked parameter range, and the Newton corrector.

A branch family is a ``BranchProblem`` (in the manner of BifurcationKit.jl's
``BifurcationProblem``): scaled unknowns w whose last entry is the continued parameter,
equations G(w) with their Jacobian (``residual``), and the points it makes of a converged w
(``point``, ``unknowns``, ``value``, ``describe``). The one engine (``step``, ``trace``)
steps any of them: Keller's pseudo-arclength predictor–corrector (``newton``: the bordered
system [G(w); τ·(w − w_pred)] = 0), the tangent by SVD (``tangent``) or a bordered solve.

``ContinuedParameter`` is what the one-parameter families share (the parameter vector with
λ put in, the ``BranchPoint`` of a converged w); ``ContinuedRange`` checks a parameter and
the ends of its range once, for every family. The shooting problem is
``shooting.ShootingProblem``; the harmonic-balance, torus and circle problems live in
``analysis.frequency``, the codimension-one curve problem in ``analysis.stability.curves``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from analysis.errors import InputError
from analysis.model import Model


@dataclass
class BranchPoint:
    """One converged point of a one-parameter branch (λ in the parameter's own unit; z0
    the unknowns besides λ in their units: an orbit's state at the section, Fourier
    coefficients, a circle)."""

    lam: float
    z0: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray
    tangent: np.ndarray
    amplitude: float
    special: str = ""
    newton_iterations: int = 0
    ds: float = 0.0
    """Scaled arclength step planned from this point (what a restart from it uses)."""
    angle: float = 0.0
    """Angle between this point's tangent and the previous point's (deg)."""
    contraction: float = 0.0
    """Largest Newton contraction ratio |Δw_{k+1}| / |Δw_k| of the corrector (0: one
    iteration)."""

    @property
    def n_unstable(self) -> int:
        return int(np.sum(np.abs(self.multipliers) > 1 + 1e-9))

    @property
    def stable(self) -> bool:
        return self.n_unstable == 0


@dataclass
class Newton:
    """A converged corrector: the point, its Jacobian and monodromy matrix, the iterations,
    the largest contraction ratio |Δw_{k+1}| / |Δw_k| and the distance from the predictor
    (scaled variables)."""

    w: np.ndarray
    jac: np.ndarray
    mono: np.ndarray
    iterations: int
    contraction: float
    distance: float


class BranchProblem(Protocol):
    """What the engine (``step.step``, ``trace.trace``) needs of a branch family.

    * ``param_name``: the parameter whose range bounds the branch;
    * ``tangent_method``: ``"svd"`` or ``"bordered"``, the tangent the family prefers
      (``ContinuationOptions.tangent`` overrides it);
    * ``residual(w)``: G(w) (m), its Jacobian (m × (m + 1)) and a matrix whose eigenvalues
      are the point's multipliers (empty when it has none);
    * ``point(corrected, tangent)``: the point of a converged ``Newton`` with that unit
      tangent; ``unknowns(point)``: its scaled w again;
    * ``value(point)``: the parameter value checked against the range (its unit);
    * ``describe(point)``: a few words for a progress line.

    A point has at least ``tangent``, ``newton_iterations``, ``special``, ``ds``, ``angle``
    and ``contraction`` (``BranchPoint``, ``curves.CurvePoint``).
    """

    param_name: str
    tangent_method: str

    def residual(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]: ...

    def point(self, corrected: Newton, tangent: np.ndarray) -> Any: ...

    def unknowns(self, point: Any) -> np.ndarray: ...

    def value(self, point: Any) -> float: ...

    def describe(self, point: Any) -> str: ...


@dataclass(frozen=True)
class ContinuedRange:
    """A runtime parameter ``param`` of ``model`` continued from ``start`` towards ``stop``
    (its unit), checked once for every family (``check``): the parameter exists, the ends
    differ, and ``stop`` is a finite number in the parameter's allowed range."""

    model: Model
    param: str
    start: float
    stop: float

    @classmethod
    def check(cls, model: Model, param: str, start: float, stop: float,
              exclude: str = "") -> ContinuedRange:
        """The range, or ``InputError`` naming the first bad field (``exclude``: a
        parameter that may not be continued here, e.g. a curve's branch parameter)."""
        if param not in model.parameter_names or param == exclude:
            why = "is the branch's own parameter" if param == exclude else \
                f"is not a parameter of '{model.name}'"
            choices = ", ".join(n for n in model.parameter_names if n != exclude)
            raise InputError(f"param: '{param}' {why}; choose one of {choices}")
        if start == stop:
            raise InputError("stop: must differ from start")
        model.parameters({param: stop})  # the range check of the end value (NaN too)
        return cls(model, param, float(start), cls.finite_stop(stop))

    @staticmethod
    def finite_stop(stop: float) -> float:
        """``stop`` as a float, or ``InputError`` when it is not a finite number (the check a
        caller may make before anything else, e.g. before opening a branch file)."""
        if not (isinstance(stop, (int, float)) and math.isfinite(stop)):
            raise InputError(f"stop: must be a finite number, got {stop!r}")
        return float(stop)

    @property
    def index(self) -> int:
        """The parameter's place in the runtime parameter vector."""
        return self.model.parameter_names.index(self.param)

    @property
    def scale(self) -> float:
        """|stop − start|: the parameter's scale in the unknowns (its unit)."""
        return abs(self.stop - self.start)

    @property
    def direction(self) -> float:
        """+1 when the parameter grows towards ``stop``, else −1."""
        return math.copysign(1.0, self.stop - self.start)


class ContinuedParameter:
    """What the one-parameter families share (shooting here, harmonic balance, tori and
    circles in analysis.frequency): the runtime parameter number ``param_index`` of
    ``model`` varies, the others stay at ``values`` (their units); unknowns
    w = (z / s_z, λ / s_λ) and ``BranchPoint`` points. A family adds ``residual(w)`` and
    ``amplitude(w)`` (of the first state, its unit)."""

    model: Model
    param_index: int
    values: dict[str, float]
    s_z: np.ndarray
    s_lam: float
    tangent_method = "svd"

    @property
    def param_name(self) -> str:
        return self.model.parameter_names[self.param_index]

    def p(self, lam: float) -> np.ndarray:
        """The parameter vector with the continued parameter at ``lam``."""
        p = self.model.parameter_vector(self.values)
        p[self.param_index] = lam
        return p

    def point(self, corrected: Newton, tangent: np.ndarray) -> BranchPoint:
        """The ``BranchPoint`` of a converged corrector with unit tangent ``tangent``."""
        w = corrected.w
        return BranchPoint(lam=w[-1] * self.s_lam, z0=w[:-1] * self.s_z,
                           multipliers=np.linalg.eigvals(corrected.mono),
                           monodromy=corrected.mono, tangent=tangent,
                           amplitude=self.amplitude(w),
                           newton_iterations=corrected.iterations)

    def unknowns(self, point: BranchPoint) -> np.ndarray:
        """The scaled unknowns w = (z0 / s_z, λ / s_λ) of ``point``."""
        return np.concatenate([point.z0 / self.s_z, [point.lam / self.s_lam]])

    def value(self, point: BranchPoint) -> float:
        return point.lam

    def describe(self, point: BranchPoint) -> str:
        return f"{self.param_name} = {point.lam:.6g}, " + \
            ("stable" if point.stable else "unstable")


def tangent(jac: np.ndarray, previous: np.ndarray | None, direction: float) -> np.ndarray:
    """Unit null vector of the n × (n + 1) Jacobian, oriented along ``previous`` (or by the
    sign of ``direction`` in λ at the start)."""
    tau = np.linalg.svd(jac)[2][-1]
    ref = np.dot(tau, previous) if previous is not None else tau[-1] * direction
    return -tau if ref < 0 else tau


def newton(prob: BranchProblem, w_pred: np.ndarray, tau: np.ndarray, tol: float,
           max_iter: int = 8) -> Newton | None:
    """Newton on [G(w); τ·(w − w_pred)] = 0 from the predictor ``w_pred``; None when it does
    not converge in ``max_iter`` iterations (or meets a non-finite value or a singular
    matrix). Steps below 100·tol (rounding level) do not count in the contraction ratio.
    ``prob``: any problem with ``residual(w) -> (G, Jacobian, monodromy)``."""
    w = w_pred.copy()
    previous, contraction = None, 0.0
    for it in range(1, max_iter + 1):
        g, jac, mono = prob.residual(w)
        h = np.concatenate([g, [np.dot(tau, w - w_pred)]])
        if not np.all(np.isfinite(h)):
            return None
        try:
            dw = np.linalg.solve(np.vstack([jac, tau]), -h)
        except np.linalg.LinAlgError:
            return None
        w = w + dw
        size = float(np.linalg.norm(dw))
        if previous is not None and previous > 100 * tol:
            contraction = max(contraction, size / previous)
        previous = size
        if size < tol and np.linalg.norm(g) < 1e3 * tol:
            g, jac, mono = prob.residual(w)
            return Newton(w, jac, mono, it, contraction, float(np.linalg.norm(w - w_pred)))
    return None


def correct(prob: BranchProblem, w_pred: np.ndarray, tau: np.ndarray, tol: float,
            max_iter: int = 8):
    """Newton on [G(w); τ·(w − w_pred)] = 0. Returns (w, jac, mono, iterations) or None."""
    out = newton(prob, w_pred, tau, tol, max_iter)
    return None if out is None else (out.w, out.jac, out.mono, out.iterations)


def branch_point(prob: ContinuedParameter, w: np.ndarray, jac: np.ndarray, mono: np.ndarray,
                 previous: np.ndarray | None, direction: float, iterations: int
                 ) -> BranchPoint:
    """The ``BranchPoint`` of the converged unknowns ``w`` (Jacobian ``jac``, monodromy
    ``mono``), its tangent by SVD oriented along ``previous`` (None: by ``direction``)."""
    return prob.point(Newton(w, jac, mono, iterations, 0.0, 0.0),
                      tangent(jac, previous, direction))


def scaled(prob: ContinuedParameter, point: BranchPoint) -> np.ndarray:
    """The scaled unknowns w = (z0 / s_z, λ / s_λ) of ``point``."""
    return prob.unknowns(point)
