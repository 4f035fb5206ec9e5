"""The continuation problem of a branch of periodic orbits, and its Newton corrector.

Unknowns w = (z0 / s_z, λ / s_λ), n + 1 of them for a model of n states: the orbit's state at
the section (scaled per component by ``periodic.state_scale``) and the continuation
parameter (scaled by the requested range). Equations: G(w) = (Φ_T(z0; λ) − z0) / s_z = 0
(shooting, ``analysis.integrate.flow``) plus the arclength condition τ·(w − w_pred) = 0 of
Keller's method; the bordered Newton matrix is built from the monodromy matrix and ∂Φ/∂λ,
both by AD (the period's own dependence on λ, e.g. on the speed, included).

``BranchProblem`` (in the manner of BifurcationKit.jl's ``BifurcationProblem``) holds the
model, the period, the parameter and the scales; ``newton``/``correct`` solve the bordered
system from a predictor, ``tangent`` orients the null vector, ``branch_point`` makes a
``BranchPoint`` of a converged w. The problem of ``curves`` extends it with a
second parameter and the augmented equations of a codimension-one point.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from analysis.integrate.flow import Period, evaluate, flow_map, orbit_states, period_seconds
from analysis.model import Model, Structure
from analysis.stability.periodic import state_scale


@dataclass
class BranchPoint:
    """One converged orbit on the branch (λ in the parameter's own unit)."""

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


class ContinuedParameter:
    """What every branch problem shares (periodic orbits here, harmonic balance, tori and
    circles in analysis.frequency): the runtime parameter number
    ``param_index`` of ``model`` varies, the others stay at ``values`` (their units)."""

    model: Model
    param_index: int
    values: dict[str, float]

    @property
    def param_name(self) -> str:
        return self.model.parameter_names[self.param_index]

    def p(self, lam: float) -> np.ndarray:
        """The parameter vector with the continued parameter at ``lam``."""
        p = self.model.parameter_vector(self.values)
        p[self.param_index] = lam
        return p


@dataclass
class BranchProblem(ContinuedParameter):
    """Periodic orbits of ``model`` (with ``structure``) of period ``period`` as the runtime
    parameter number ``param_index`` varies, the others at ``values`` (their units): the
    section at ``t0`` (s), ``n_steps`` RK4 steps per period, the unknowns scaled by ``s_z``
    (per state, its unit) and ``s_lam`` (the parameter's unit). The flow map and the orbit
    sampler are built on construction."""

    model: Model
    structure: Structure
    period: Period
    param_index: int
    values: dict[str, float]
    t0: float
    n_steps: int
    s_z: np.ndarray
    s_lam: float
    flow: object = field(default=None)

    def __post_init__(self):
        self.flow = flow_map(self.model, self.structure, self.period, self.n_steps)
        self.orbit = orbit_states(self.model, self.structure, self.period, self.n_steps)

    @property
    def n(self) -> int:
        return self.model.n_state

    def residual(self, w: np.ndarray):
        """G(w) (n), its Jacobian (n × (n + 1)) and the monodromy matrix."""
        n = self.n
        z, lam = w[:n] * self.s_z, w[n] * self.s_lam
        z_end, mono, dp = evaluate(self.flow, z, self.t0, self.p(lam))
        g = (z_end - z) / self.s_z
        jz = (mono - np.eye(n)) * self.s_z[None, :] / self.s_z[:, None]
        jl = dp[:, self.param_index] * self.s_lam / self.s_z
        return g, np.column_stack([jz, jl]), mono

    def amplitude(self, w: np.ndarray) -> float:
        """Half the peak-to-peak of the first state variable (x, x_rotor …; m) over one
        period."""
        n = self.n
        states = np.asarray(self.orbit(w[:n] * self.s_z, self.t0, self.p(w[n] * self.s_lam)))
        return float(np.ptp(states[0])) / 2


def orbit_scale(prob: BranchProblem, z0: np.ndarray) -> np.ndarray:
    """Per-component scales (``periodic.state_scale``) from the largest |z_i| over one period
    of the orbit through z0 (velocities at least size·2π/T)."""
    states = np.asarray(prob.orbit(z0, prob.t0, prob.p(prob.values[prob.param_name])))
    return state_scale(np.abs(states).max(axis=1),
                       period_seconds(prob.model, prob.structure, prob.period, prob.values),
                       prob.model.module.STATE_UNITS)


def tangent(jac: np.ndarray, previous: np.ndarray | None, direction: float) -> np.ndarray:
    """Unit null vector of the n × (n + 1) Jacobian, oriented along ``previous`` (or by the
    sign of ``direction`` in λ at the start)."""
    tau = np.linalg.svd(jac)[2][-1]
    ref = np.dot(tau, previous) if previous is not None else tau[-1] * direction
    return -tau if ref < 0 else tau


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


def branch_point(prob: BranchProblem, w: np.ndarray, jac: np.ndarray, mono: np.ndarray,
                 previous: np.ndarray | None, direction: float, iterations: int
                 ) -> BranchPoint:
    """The ``BranchPoint`` of the converged unknowns ``w`` (Jacobian ``jac``, monodromy
    ``mono``), its tangent oriented along ``previous`` (None: by ``direction``)."""
    return BranchPoint(lam=w[-1] * prob.s_lam, z0=w[:-1] * prob.s_z,
                       multipliers=np.linalg.eigvals(mono), monodromy=mono,
                       tangent=tangent(jac, previous, direction),
                       amplitude=prob.amplitude(w), newton_iterations=iterations)


def scaled(prob: BranchProblem, point: BranchPoint) -> np.ndarray:
    """The scaled unknowns w = (z0 / s_z, λ / s_λ) of ``point``."""
    return np.concatenate([point.z0 / prob.s_z, [point.lam / prob.s_lam]])
